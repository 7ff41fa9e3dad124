//! The client's half of a game session, without sockets: snapshot
//! datagrams in (decoded, acknowledged), input datagrams out at their
//! rate with the last few inputs repeated against loss. The SDK's driver
//! only moves bytes between the network and a [`ClientSession`] and hands
//! what it decoded to the game's buffers; the tests drive the very same
//! type through simulated links, against a [`crate::ServerSession`].
//!
//! Times are seconds on the client's own monotonic clock, passed in.

use std::collections::VecDeque;

use crate::entity::{buttons, PlayerInput};
use crate::input::{InputDatagram, MAX_REDUNDANT_INPUTS};
use crate::snapshot::{
    ConfigError, DecodedSnapshot, SnapshotConfig, SnapshotDecoder, SnapshotError,
};

/// How a [`ClientSession`] talks to its server.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClientConfig {
    /// How the server codes snapshots (from its welcome).
    pub snapshot: SnapshotConfig,
    /// Input datagrams per second, Hz (at least 1).
    pub input_hz: u32,
    /// Inputs each datagram carries, newest first, 1 to
    /// [`MAX_REDUNDANT_INPUTS`]: an input is lost only when that many
    /// datagrams in a row are.
    pub input_redundancy: usize,
}

/// One client's session: its snapshot decoder (views received, what to
/// acknowledge), the input it sends now and the last few it sent.
#[derive(Debug, Clone)]
pub struct ClientSession {
    config: ClientConfig,
    decoder: SnapshotDecoder,
    input: PlayerInput,
    /// The inputs sent lately, newest first.
    sent: VecDeque<PlayerInput>,
    /// The next input datagram is due at this time, s.
    next_input_at: f64,
    /// The snapshot decoded last (its memory reused for the next).
    decoded: DecodedSnapshot,
}

impl ClientSession {
    /// A session that has received nothing, whose first input is due at
    /// once; `tick` is the server's tick from its welcome.
    pub fn new(config: ClientConfig, tick: u64) -> Result<Self, ConfigError> {
        let config = ClientConfig {
            input_hz: config.input_hz.max(1),
            input_redundancy: config.input_redundancy.clamp(1, MAX_REDUNDANT_INPUTS),
            ..config
        };
        Ok(Self {
            decoder: SnapshotDecoder::new(config.snapshot)?,
            input: PlayerInput {
                tick,
                ..PlayerInput::default()
            },
            sent: VecDeque::new(),
            next_input_at: 0.0,
            decoded: DecodedSnapshot::default(),
            config,
        })
    }

    /// The configuration (rate and redundancy as clamped).
    pub fn config(&self) -> &ClientConfig {
        &self.config
    }

    /// A snapshot datagram: the states it carried (and what left the
    /// view), held until the next datagram; it is acknowledged from the
    /// next input datagram on. On any error nothing changes but the
    /// decoder's counts.
    pub fn on_datagram(&mut self, bytes: &[u8]) -> Result<&DecodedSnapshot, SnapshotError> {
        self.decoder.decode_into(bytes, &mut self.decoded)?;
        Ok(&self.decoded)
    }

    /// What the player wants from now on: movement in the horizontal
    /// plane (each in [−1, 1]), facing angle (rad) and held buttons
    /// (bits outside [`buttons::ALL`] are dropped: the wire has no room
    /// for them).
    pub fn set_input(&mut self, movement: [f32; 2], yaw: f32, buttons: u8) {
        self.input = PlayerInput {
            movement,
            yaw,
            buttons: buttons & buttons::ALL,
            ..self.input
        };
    }

    /// The input as set now.
    pub fn input(&self) -> PlayerInput {
        self.input
    }

    /// When the next input datagram is due, s.
    pub fn next_input_at(&self) -> f64 {
        self.next_input_at
    }

    /// The input datagram due at `now` (s), if one is: the current input
    /// stamped with the next sequence number and `tick` (the server tick
    /// the client believes it is; `None` before it can tell, and the
    /// welcome's tick is used), with the newest acknowledgement and the
    /// last inputs. A datagram that falls behind is skipped, not sent in
    /// a burst.
    pub fn poll_input(&mut self, now: f64, tick: Option<u64>) -> Option<Vec<u8>> {
        // A microsecond early is on time (sums of periods round).
        if now + 1e-6 < self.next_input_at {
            return None;
        }
        let period = 1.0 / f64::from(self.config.input_hz);
        self.next_input_at += period;
        if self.next_input_at <= now {
            // Behind: one now, the next a period on.
            self.next_input_at = now + period;
        }
        let input = PlayerInput {
            sequence: self.input.sequence.wrapping_add(1),
            tick: tick.unwrap_or(self.input.tick),
            ..self.input
        };
        self.input.sequence = input.sequence;
        self.sent.push_front(input);
        self.sent.truncate(self.config.input_redundancy);
        let (ack, ack_bits) = self.decoder.ack_state();
        InputDatagram {
            ack,
            ack_bits,
            inputs: self.sent.iter().copied().collect(),
        }
        .encode()
        .ok()
    }

    /// The snapshot decoder (views held, what it acknowledges, counts).
    pub fn decoder(&self) -> &SnapshotDecoder {
        &self.decoder
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn session(hz: u32, redundancy: usize) -> ClientSession {
        ClientSession::new(
            ClientConfig {
                snapshot: SnapshotConfig::default(),
                input_hz: hz,
                input_redundancy: redundancy,
            },
            100,
        )
        .unwrap()
    }

    #[test]
    fn inputs_go_out_at_their_rate_with_the_last_few_repeated() {
        let mut s = session(30, 3);
        let mut sent = Vec::new();
        // 1 s at 1 ms steps.
        for ms in 0..1000 {
            // Bits beyond the known buttons are dropped, not a lost input.
            s.set_input([0.5, -0.5], 0.1, if ms % 200 < 100 { 0xff } else { 0 });
            if let Some(bytes) = s.poll_input(f64::from(ms) / 1000.0, Some(100 + ms as u64 / 16)) {
                sent.push(InputDatagram::decode(&bytes).unwrap());
            }
        }
        assert_eq!(sent.len(), 30);
        for (k, d) in sent.iter().enumerate() {
            let seqs: Vec<u32> = d.inputs.iter().map(|i| i.sequence).collect();
            let want: Vec<u32> = (1..=k as u32 + 1).rev().take(3).collect();
            assert_eq!(seqs, want, "datagram {k}");
            assert_eq!(d.ack, None, "nothing received, nothing acknowledged");
            assert!(d.inputs.iter().all(|i| i.buttons & !buttons::ALL == 0));
        }
    }

    #[test]
    fn a_late_poll_sends_one_datagram_not_a_burst() {
        let mut s = session(60, 8);
        assert!(s.poll_input(0.0, None).is_some());
        assert!(s.poll_input(0.001, None).is_none());
        // Half a second late: one now, the next a period after.
        assert!(s.poll_input(0.5, None).is_some());
        assert!(s.poll_input(0.5, None).is_none());
        assert!((s.next_input_at() - (0.5 + 1.0 / 60.0)).abs() < 1e-9);
    }

    #[test]
    fn the_configuration_is_clamped() {
        let s = session(0, 99);
        assert_eq!(s.config().input_hz, 1);
        assert_eq!(s.config().input_redundancy, MAX_REDUNDANT_INPUTS);
        assert_eq!(s.input().tick, 100);
    }
}
