//! The client's half of a game session, without sockets: snapshot
//! datagrams in (decoded, acknowledged), input datagrams out at their
//! rate with the last few inputs repeated against loss. The SDK's driver
//! only moves bytes between the network and a [`ClientSession`] and hands
//! what it decoded to the game's buffers; the tests drive the very same
//! type through simulated links, against a [`crate::ServerSession`].
//!
//! Times are seconds on the client's own monotonic clock, passed in.

use std::collections::VecDeque;

use crate::input::{
    InputDatagram, InputPayload, PlayerInput, MAX_REDUNDANT_INPUTS, MAX_VIEW_BEHIND,
};
use crate::snapshot::{
    DecodedSnapshot, SnapshotConfig, SnapshotConfigError, SnapshotDecoder, SnapshotError,
};

/// How a [`ClientSession`] talks to its server.
#[derive(Debug, Clone, PartialEq)]
pub struct ClientConfig {
    /// How the server codes snapshots (from its welcome).
    pub snapshot: SnapshotConfig,
    /// Input datagrams per second, Hz (at least 1).
    pub input_hz: u32,
    /// Inputs each datagram carries, newest first, 1 to
    /// [`MAX_REDUNDANT_INPUTS`]: an input is lost only when that many
    /// datagrams in a row are.
    pub input_redundancy: usize,
    /// The game's properties every snapshot carries (from the welcome:
    /// [`ServerInfo::properties`](crate::connection::ServerInfo::properties)).
    pub properties: std::sync::Arc<crate::property::PropertySchema>,
}

/// One client's session: its snapshot decoder (views received, what to
/// acknowledge), the input it sends now and the last few it sent.
#[derive(Debug, Clone)]
pub struct ClientSession {
    config: ClientConfig,
    decoder: SnapshotDecoder,
    input: PlayerInput,
    /// Whether the game has set its input yet: no input is made before
    /// (datagrams carry the acknowledgements alone), since only the game
    /// knows what its players want by default.
    input_set: bool,
    /// The render tick of the last frame the game drew, ticks; `None`
    /// before the first.
    view_tick: Option<f64>,
    /// The inputs sent lately, newest first.
    sent: VecDeque<PlayerInput>,
    /// The tick of the newest input made, once one is.
    stamped: Option<u64>,
    /// The next input datagram is due at this time, s.
    next_input_at: f64,
    /// The snapshot decoded last (its memory reused for the next).
    decoded: DecodedSnapshot,
}

impl ClientSession {
    /// A session that has received nothing, whose first input is due at
    /// once; `tick` is the server's tick from its welcome.
    pub fn new(config: ClientConfig, tick: u64) -> Result<Self, SnapshotConfigError> {
        let config = ClientConfig {
            input_hz: config.input_hz.max(1),
            input_redundancy: config.input_redundancy.clamp(1, MAX_REDUNDANT_INPUTS),
            ..config
        };
        Ok(Self {
            decoder: SnapshotDecoder::new(config.snapshot)?
                .with_properties(config.properties.clone()),
            input: PlayerInput {
                tick,
                ..PlayerInput::default()
            },
            input_set: false,
            view_tick: None,
            sent: VecDeque::new(),
            stamped: None,
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

    /// What the player wants from now on: the game's input, as its bytes
    /// ([`GameInput::to_payload`](crate::input::GameInput::to_payload)).
    /// Every input stamped from now on carries it; none is made before
    /// the first call.
    pub fn set_input(&mut self, payload: InputPayload) {
        self.input = PlayerInput {
            payload,
            ..self.input
        };
        self.input_set = true;
    }

    /// The (fractional) server tick of the world the game drew last: the
    /// interpolation render tick of its last sampled frame. Each input
    /// sent from now on says how far behind its own tick that was
    /// ([`PlayerInput::view_behind`]), so that the server can answer the
    /// player's shots against the world it saw. Not finite is ignored.
    pub fn set_view_tick(&mut self, render_tick: f64) {
        if render_tick.is_finite() {
            self.view_tick = Some(render_tick);
        }
    }

    /// The view tick set last ([`Self::set_view_tick`]).
    pub fn view_tick(&self) -> Option<f64> {
        self.view_tick
    }

    /// The input as set now.
    pub fn input(&self) -> PlayerInput {
        self.input
    }

    /// When the next input datagram is due, s.
    pub fn next_input_at(&self) -> f64 {
        self.next_input_at
    }

    /// The input datagram due at `now` (s), if one is. `tick` is the tick
    /// the client wants its input applied at now (the SDK runs it ahead of
    /// the server; `None` before it can tell, and the welcome's tick is
    /// used). Every tick after the newest one stamped, up to `tick`, gets
    /// one input (the current one, with the next sequence number; at most
    /// the redundancy's worth when the tick leaps), so the server has an
    /// input for each tick, each saying how far behind its tick the view
    /// set last was (0 before any, or when the view is ahead of it; capped
    /// at [`MAX_VIEW_BEHIND`]); a `tick` that has not moved on makes none,
    /// and the datagram then carries the acknowledgement and the last
    /// inputs again. A datagram that falls behind is skipped, not sent in
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
        let target = tick.unwrap_or(self.input.tick);
        let first = self.stamped.map_or(target, |last| last.saturating_add(1));
        if target >= first && self.input_set {
            let most = self.config.input_redundancy as u64;
            let from = first.max(target.saturating_sub(most - 1));
            for t in from..=target {
                let view_behind = self.view_tick.map_or(0.0, |v| {
                    ((t as f64 - v).clamp(0.0, f64::from(MAX_VIEW_BEHIND))) as f32
                });
                let input = PlayerInput {
                    sequence: self.input.sequence.wrapping_add(1),
                    tick: t,
                    view_behind,
                    ..self.input
                };
                self.input.sequence = input.sequence;
                self.sent.push_front(input);
            }
            self.stamped = Some(target);
        }
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

    /// The tick of the newest input made, once one is.
    pub fn stamped_tick(&self) -> Option<u64> {
        self.stamped
    }

    /// The inputs sent lately (the last datagram's), newest first.
    pub fn sent(&self) -> impl Iterator<Item = &PlayerInput> + '_ {
        self.sent.iter()
    }

    /// server's, from its welcome) in every snapshot.
    pub fn with_properties(
        mut self,
        schema: std::sync::Arc<crate::property::PropertySchema>,
    ) -> Self {
        self.decoder = self.decoder.with_properties(schema);
        self
    }

    /// The snapshot decoder (views held, what it acknowledges, counts).
    pub fn decoder(&self) -> &SnapshotDecoder {
        &self.decoder
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A session whose game has set its input (three bytes).
    fn session(hz: u32, redundancy: usize) -> ClientSession {
        let mut s = ClientSession::new(
            ClientConfig {
                snapshot: SnapshotConfig::default(),
                input_hz: hz,
                input_redundancy: redundancy,
                properties: Default::default(),
            },
            100,
        )
        .unwrap();
        s.set_input(InputPayload::new(&[1, 2, 3]).unwrap());
        s
    }

    #[test]
    fn issue_43_no_input_is_made_before_the_game_sets_one() {
        let mut s = ClientSession::new(
            ClientConfig {
                snapshot: SnapshotConfig::default(),
                input_hz: 60,
                input_redundancy: 4,
                properties: Default::default(),
            },
            100,
        )
        .unwrap();
        // Only the game knows what its players want by default: until it
        // says, datagrams carry the acknowledgements alone.
        let bytes = s.poll_input(0.0, Some(100)).unwrap();
        assert!(InputDatagram::decode(&bytes).unwrap().inputs.is_empty());
        assert_eq!(s.stamped_tick(), None);
        s.set_input(InputPayload::new(&[9]).unwrap());
        let bytes = s.poll_input(1.0 / 60.0, Some(101)).unwrap();
        let d = InputDatagram::decode(&bytes).unwrap();
        assert_eq!(d.inputs.len(), 1);
        assert_eq!(
            (d.inputs[0].tick, d.inputs[0].payload.as_bytes()),
            (101, &[9u8][..])
        );
    }

    #[test]
    fn inputs_go_out_at_their_rate_with_the_last_few_repeated() {
        let mut s = session(30, 3);
        let mut sent = Vec::new();
        // 1 s at 1 ms steps, the wanted tick moving at 62.5 Hz: two new
        // ticks (sometimes three) per datagram.
        for ms in 0..1000 {
            let held = if ms % 200 < 100 { 0xff } else { 0 };
            s.set_input(InputPayload::new(&[0x40, held]).unwrap());
            if let Some(bytes) = s.poll_input(f64::from(ms) / 1000.0, Some(100 + ms as u64 / 16)) {
                sent.push(InputDatagram::decode(&bytes).unwrap());
            }
        }
        assert_eq!(sent.len(), 30);
        let mut ticks = Vec::new();
        for (k, d) in sent.iter().enumerate() {
            assert!(d.inputs.len() <= 3, "datagram {k}");
            assert_eq!(d.ack, None, "nothing received, nothing acknowledged");
            assert!(d.inputs.iter().all(|i| i.payload.len() == 2));
            // Newest first, one sequence and one tick apart.
            for pair in d.inputs.windows(2) {
                assert_eq!(pair[0].sequence, pair[1].sequence + 1, "datagram {k}");
                assert_eq!(pair[0].tick, pair[1].tick + 1, "datagram {k}");
            }
            let newest = d.inputs[0].tick;
            if ticks.last() != Some(&newest) {
                ticks.push(newest);
            }
        }
        // Every tick from the first to the last got its input.
        let all: Vec<u64> = sent
            .iter()
            .flat_map(|d| d.inputs.iter().map(|i| i.tick))
            .collect();
        for t in 100..=*ticks.last().unwrap() {
            assert!(all.contains(&t), "tick {t} has no input");
        }
        assert_eq!(s.stamped_tick(), Some(100 + 967 / 16));
    }

    #[test]
    fn a_tick_that_stands_still_makes_no_new_input_and_a_leap_is_capped() {
        let mut s = session(60, 4);
        let bytes = s.poll_input(0.0, Some(500)).unwrap();
        let first = InputDatagram::decode(&bytes).unwrap();
        assert_eq!(first.inputs.len(), 1);
        assert_eq!((first.inputs[0].sequence, first.inputs[0].tick), (1, 500));
        // The same tick (a paused server): the same input again.
        let again = InputDatagram::decode(&s.poll_input(1.0, Some(500)).unwrap()).unwrap();
        assert_eq!(again.inputs, first.inputs);
        // An earlier one (the estimate slewed back): nothing new either.
        let back = InputDatagram::decode(&s.poll_input(2.0, Some(498)).unwrap()).unwrap();
        assert_eq!(back.inputs, first.inputs);
        // A leap of 100 ticks: the last four get inputs.
        let leap = InputDatagram::decode(&s.poll_input(3.0, Some(600)).unwrap()).unwrap();
        let ticks: Vec<u64> = leap.inputs.iter().map(|i| i.tick).collect();
        assert_eq!(ticks, [600, 599, 598, 597]);
        assert_eq!(s.sent().next().map(|i| i.sequence), Some(5));
    }

    #[test]
    fn inputs_say_how_far_behind_their_tick_the_view_was() {
        let mut s = session(60, 2);
        let newest = |bytes: Vec<u8>| InputDatagram::decode(&bytes).unwrap().inputs[0];
        assert_eq!(
            newest(s.poll_input(0.0, Some(200)).unwrap()).view_behind,
            0.0
        );
        s.set_view_tick(192.25);
        s.set_view_tick(f64::NAN);
        assert_eq!(s.view_tick(), Some(192.25));
        let i = newest(s.poll_input(0.1, Some(201)).unwrap());
        assert_eq!((i.tick, i.view_behind, i.view_tick()), (201, 8.75, 192.25));
        // A view ahead of the input's tick is no rewind; far behind, the cap.
        s.set_view_tick(203.0);
        assert_eq!(
            newest(s.poll_input(0.2, Some(202)).unwrap()).view_behind,
            0.0
        );
        s.set_view_tick(-1e6);
        assert_eq!(
            newest(s.poll_input(0.3, Some(203)).unwrap()).view_behind,
            MAX_VIEW_BEHIND
        );
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
