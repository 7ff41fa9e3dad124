//! Control messages on their way to the peer: whole frames in order,
//! written as the peer's flow-control window allows, with the time the
//! stream last moved so that a peer that stops reading is noticed.

use std::time::{Duration, Instant};

use crate::control::{encode_frame, ControlError, ServerControl};

/// Bytes of a control stream not yet written, oldest first.
#[derive(Debug, Clone)]
pub struct Outbox {
    bytes: Vec<u8>,
    /// Where the unwritten bytes start.
    start: usize,
    /// When the stream last moved, or the first bytes came to wait.
    moved: Instant,
}

impl Outbox {
    /// An empty outbox at `now`.
    pub fn new(now: Instant) -> Outbox {
        Outbox {
            bytes: Vec::new(),
            start: 0,
            moved: now,
        }
    }

    /// Queues `msg` at `now`; its framed length, bytes.
    pub fn push(&mut self, msg: &ServerControl, now: Instant) -> Result<usize, ControlError> {
        let frame = encode_frame(msg)?;
        Ok(self.push_coded(&frame, now))
    }

    /// Queues bytes already coded as control frames at `now`; how many.
    pub fn push_coded(&mut self, frames: &[u8], now: Instant) -> usize {
        if self.is_empty() {
            self.moved = now;
        }
        self.bytes.extend_from_slice(frames);
        frames.len()
    }

    /// The bytes still to write.
    pub fn pending(&self) -> &[u8] {
        &self.bytes[self.start..]
    }

    /// How many bytes wait.
    pub fn len(&self) -> usize {
        self.bytes.len() - self.start
    }

    /// True when nothing waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `n` of the pending bytes were written at `now`.
    pub fn advance(&mut self, n: usize, now: Instant) {
        self.start = (self.start + n).min(self.bytes.len());
        if self.start == self.bytes.len() {
            self.bytes.clear();
            self.start = 0;
        } else if self.start > (64 << 10) && self.start * 2 > self.bytes.len() {
            self.bytes.drain(..self.start);
            self.start = 0;
        }
        self.moved = now;
    }

    /// When the peer will have left the stream unread for `stall`, while
    /// something waits for it.
    pub fn stall_deadline(&self, stall: Duration) -> Option<Instant> {
        (!self.is_empty()).then(|| self.moved + stall)
    }

    /// Drops everything that waits (the stream is gone).
    pub fn clear(&mut self) {
        self.bytes.clear();
        self.start = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn despawn(id: u32) -> ServerControl {
        ServerControl::Despawn { id }
    }

    #[test]
    fn the_outbox_keeps_frames_in_order_and_knows_when_it_stalled() {
        let t0 = Instant::now();
        let stall = Duration::from_secs(10);
        let mut outbox = Outbox::new(t0);
        assert!(outbox.is_empty());
        assert_eq!(
            outbox.stall_deadline(stall),
            None,
            "nothing waits: no stall"
        );
        let mut expected = Vec::new();
        let queued_at = t0 + Duration::from_secs(3);
        for id in 0..20_000 {
            let n = outbox.push(&despawn(id), queued_at).expect("encodes");
            expected.extend(encode_frame(&despawn(id)).expect("encodes"));
            assert!(n > 4);
        }
        assert_eq!(outbox.stall_deadline(stall), Some(queued_at + stall));
        // Written a little at a time, compacted on the way: the same
        // bytes in the same order, and each write moves the deadline on.
        let mut written = Vec::new();
        let mut at = queued_at;
        while !outbox.is_empty() {
            let n = outbox.pending().len().min(7_001);
            written.extend_from_slice(&outbox.pending()[..n]);
            at += Duration::from_millis(1);
            outbox.advance(n, at);
            if !outbox.is_empty() {
                assert_eq!(outbox.stall_deadline(stall), Some(at + stall));
            }
        }
        assert_eq!(written, expected);
        assert_eq!(outbox.stall_deadline(stall), None);
        assert!(outbox.bytes.is_empty(), "nothing kept once written");
    }
}
