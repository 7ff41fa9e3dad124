//! Control messages as frames on a stream: a `u32` little-endian length,
//! then that many postcard bytes. [`FrameDecoder`] is sans-IO: stream
//! bytes go in as they arrive, whole messages come out.

use super::{ControlError, ControlMessage, MAX_CONTROL_FRAME, MAX_DECODER_BUFFER};

/// Validates `msg` and encodes it as one frame: its postcard length as a
/// `u32` little-endian, then the postcard bytes. Refuses messages that
/// fail validation or exceed [`MAX_CONTROL_FRAME`] (a triangle mesh near
/// [`ShapeDesc::MAX_POINTS`] can), since the peer would refuse them.
pub fn encode_frame<T: ControlMessage>(msg: &T) -> Result<Vec<u8>, ControlError> {
    msg.validate()?;
    let mut out = postcard::to_extend(msg, vec![0u8; 4]).map_err(ControlError::Encode)?;
    let len = out.len() - 4;
    if len > MAX_CONTROL_FRAME {
        return Err(ControlError::FrameTooLarge {
            len,
            max: MAX_CONTROL_FRAME,
        });
    }
    out[..4].copy_from_slice(&(len as u32).to_le_bytes());
    Ok(out)
}

/// Decodes one frame's payload (without its length prefix) and validates
/// the message.
pub fn decode_payload<T: ControlMessage>(payload: &[u8]) -> Result<T, ControlError> {
    if payload.len() > MAX_CONTROL_FRAME {
        return Err(ControlError::FrameTooLarge {
            len: payload.len(),
            max: MAX_CONTROL_FRAME,
        });
    }
    let (msg, rest) = postcard::take_from_bytes::<T>(payload).map_err(ControlError::Decode)?;
    if !rest.is_empty() {
        return Err(ControlError::TrailingBytes { extra: rest.len() });
    }
    msg.validate()?;
    Ok(msg)
}

/// Splits a control stream into messages, without I/O: [`Self::push`] the
/// bytes as they arrive, then call [`Self::next`] until it returns `None`.
///
/// A frame that fails to decode or validate is consumed and reported; the
/// stream stays in step and the caller decides whether to go on (usually
/// it closes with [`DisconnectReason::ProtocolError`]). A frame whose
/// length passes [`MAX_CONTROL_FRAME`] leaves the stream out of step, so
/// the decoder reports that error from then on.
#[derive(Debug, Default, Clone)]
pub struct FrameDecoder {
    buf: Vec<u8>,
    /// Bytes of `buf` already consumed.
    start: usize,
    /// The fatal error, once one happened.
    failed: Option<ControlError>,
}

impl FrameDecoder {
    /// An empty decoder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Bytes held and not yet decoded.
    pub fn buffered(&self) -> usize {
        self.buf.len() - self.start
    }

    /// Appends stream bytes. Refuses (keeping nothing of `bytes`) a push
    /// that would hold more than [`MAX_DECODER_BUFFER`]; a push of at most
    /// [`MAX_CONTROL_FRAME`] bytes after draining with [`Self::next`]
    /// always fits.
    pub fn push(&mut self, bytes: &[u8]) -> Result<(), ControlError> {
        if let Some(e) = &self.failed {
            return Err(e.clone());
        }
        let buffered = self.buffered();
        if buffered + bytes.len() > MAX_DECODER_BUFFER {
            return Err(ControlError::BufferFull {
                buffered,
                pushed: bytes.len(),
                max: MAX_DECODER_BUFFER,
            });
        }
        if self.start > 0 {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
        Ok(())
    }

    /// The next whole message, if one has arrived: `None` while a frame is
    /// incomplete.
    #[allow(clippy::should_implement_trait)]
    pub fn next<T: ControlMessage>(&mut self) -> Option<Result<T, ControlError>> {
        if let Some(e) = &self.failed {
            return Some(Err(e.clone()));
        }
        let held = &self.buf[self.start..];
        let header: [u8; 4] = held.get(..4)?.try_into().ok()?;
        let len = u32::from_le_bytes(header) as usize;
        if len > MAX_CONTROL_FRAME {
            let e = ControlError::FrameTooLarge {
                len,
                max: MAX_CONTROL_FRAME,
            };
            self.failed = Some(e.clone());
            self.buf = Vec::new();
            self.start = 0;
            return Some(Err(e));
        }
        let payload = held.get(4..4 + len)?;
        let result = decode_payload(payload);
        self.start += 4 + len;
        if self.start == self.buf.len() {
            self.buf.clear();
            self.start = 0;
        }
        Some(result)
    }
}
