//! A player's replay of the recent past, beside the live match: what a
//! client asks, what the server answers, and the datagrams that carry the
//! replayed snapshots and their acknowledgements.
//!
//! A client asks on the control stream ([`ClientControl::Replay`]) for the
//! ticks `from_tick..=to_tick` at a speed, optionally centred on an
//! entity (the one that hit it, the ball). The server answers once
//! ([`ReplayAnswer::Started`] or [`ReplayAnswer::Refused`]) and, while it
//! plays, sends snapshots of the frames it published at those ticks, coded
//! by the same snapshot codec as the live stream but against the
//! replay's own views and sequence numbers, each wrapped in a replay
//! datagram; the client acknowledges each in a replay datagram of its own.
//! The live stream goes on beside it, unchanged: the replay is a second
//! picture, and the player keeps playing (the game's rules decide what a
//! player who watches may do). The replay ends by itself after its last
//! tick ([`ReplayAnswer::Ended`]), or when the client cancels it
//! ([`ClientControl::CancelReplay`]) or asks for another.
//!
//! ## The replay datagram
//!
//! ```text
//! field     bits    meaning
//! tag       8       REPLAY_DATAGRAM_TAG (0x52, 'R')
//! replay    16      the replay's number (little-endian), from its Started
//! then, server to client: a snapshot datagram, the rest of the datagram
//!       client to server: sequence 16, the replay snapshot acknowledged
//! ```
//!
//! Snapshot times: a replayed snapshot's tick is the tick it shows, and
//! its time scale the replay's speed, so a client's interpolation runs
//! through the stretch at that speed exactly as it runs through a live
//! stream in slow motion.
//!
//! [`ClientControl::Replay`]: crate::control::ClientControl::Replay
//! [`ClientControl::CancelReplay`]: crate::control::ClientControl::CancelReplay

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::entity::EntityId;
use crate::message::MessageLimits;

/// The first byte of a replay datagram.
pub const REPLAY_DATAGRAM_TAG: u8 = 0x52;

/// The slowest replay, times real time.
pub const MIN_REPLAY_SPEED: f32 = 0.05;
/// The fastest replay, times real time.
pub const MAX_REPLAY_SPEED: f32 = 8.0;

/// How often a client may ask for a replay (a cancel is free): one a
/// second sustained, three at once.
pub const REPLAY_REQUEST_LIMITS: MessageLimits = MessageLimits {
    per_second: 1,
    burst: 3,
    bytes_per_second: u32::MAX,
    byte_burst: u32::MAX,
};

/// What a client asks to see again.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReplayRequest {
    /// The first tick shown.
    pub from_tick: u64,
    /// The last tick shown (inclusive), after `from_tick`.
    pub to_tick: u64,
    /// Times real time: 1 as it happened, 0.25 in slow motion; within
    /// [`MIN_REPLAY_SPEED`]..=[`MAX_REPLAY_SPEED`].
    pub speed: f32,
    /// The entity the replay centres its interest on (the hitter, the
    /// ball); `None`: the client's own avatar.
    pub focus: Option<EntityId>,
}

impl ReplayRequest {
    /// The last `seconds` before `now_tick` at `tick_hz`, at `speed`,
    /// centred on `focus`: what a kill-cam asks.
    pub fn last_seconds(
        now_tick: u64,
        tick_hz: u32,
        seconds: f32,
        speed: f32,
        focus: Option<EntityId>,
    ) -> Self {
        let back = (f64::from(seconds.max(0.0)) * f64::from(tick_hz)).round() as u64;
        ReplayRequest {
            from_tick: now_tick.saturating_sub(back),
            to_tick: now_tick,
            speed,
            focus,
        }
    }

    /// The stretch's length, ticks.
    pub fn ticks(&self) -> u64 {
        self.to_tick.saturating_sub(self.from_tick)
    }

    /// Checks what any server refuses whatever it holds: an empty or
    /// backwards stretch, a speed not finite or out of range.
    pub fn check(&self) -> Result<(), ReplayRefusal> {
        if self.to_tick <= self.from_tick {
            return Err(ReplayRefusal::Empty);
        }
        if !(self.speed.is_finite() && (MIN_REPLAY_SPEED..=MAX_REPLAY_SPEED).contains(&self.speed))
        {
            return Err(ReplayRefusal::Speed);
        }
        Ok(())
    }
}

/// Why the server will not play a replay: each a typed answer, counted by
/// [`ReplayRefusal::reason`]; nothing of the live match changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Error)]
pub enum ReplayRefusal {
    /// The server keeps no recent past for players (its window is 0).
    #[error("this server keeps no replays")]
    Disabled,
    /// The stretch is empty or backwards.
    #[error("the stretch is empty: its last tick must come after its first")]
    Empty,
    /// The speed is not finite, or out of range.
    #[error("the speed must be within {MIN_REPLAY_SPEED}..={MAX_REPLAY_SPEED} times real time")]
    Speed,
    /// The stretch ends after the newest tick published.
    #[error("the stretch ends in the future: the newest tick is {newest}")]
    Future {
        /// The newest tick the server can show.
        newest: u64,
    },
    /// The stretch starts before the oldest tick still held.
    #[error("the stretch starts before the oldest tick held, {oldest}")]
    TooOld {
        /// The oldest tick the server can show.
        oldest: u64,
    },
    /// The stretch is longer than a replay may be.
    #[error("the stretch is longer than {max_ticks} ticks")]
    TooLong {
        /// The longest stretch, ticks.
        max_ticks: u64,
    },
    /// The client asks faster than a replay a second.
    #[error("too many replays asked for: at most one a second")]
    RateLimited,
    /// As many replays play as the server allows, and this one waited in
    /// the queue until its deadline.
    #[error("the server plays as many replays as it allows; try again")]
    Busy,
    /// The client is not in the game (not welcomed yet, or leaving).
    #[error("not connected")]
    NotJoined,
}

impl ReplayRefusal {
    /// A short label for metrics and logs.
    pub fn reason(&self) -> &'static str {
        match self {
            ReplayRefusal::Disabled => "disabled",
            ReplayRefusal::Empty => "empty",
            ReplayRefusal::Speed => "speed",
            ReplayRefusal::Future { .. } => "future",
            ReplayRefusal::TooOld { .. } => "too_old",
            ReplayRefusal::TooLong { .. } => "too_long",
            ReplayRefusal::RateLimited => "rate",
            ReplayRefusal::Busy => "busy",
            ReplayRefusal::NotJoined => "not_joined",
        }
    }
}

/// Why a replay that played ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ReplayEnd {
    /// Its last tick was shown.
    Finished,
    /// The client cancelled it.
    Cancelled,
    /// The client asked for another.
    Replaced,
    /// The frames it was still to show left the server's window (a replay
    /// slower than real time of a stretch near the window's end).
    WindowPassed,
}

impl ReplayEnd {
    /// A short label for metrics and logs.
    pub fn label(&self) -> &'static str {
        match self {
            ReplayEnd::Finished => "finished",
            ReplayEnd::Cancelled => "cancelled",
            ReplayEnd::Replaced => "replaced",
            ReplayEnd::WindowPassed => "window_passed",
        }
    }
}

/// The server's answer about a replay, on the control stream.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum ReplayAnswer {
    /// The replay plays: its snapshots come in replay datagrams numbered
    /// `replay`.
    Started {
        /// Its number, in every datagram of it.
        replay: u16,
        /// The first tick shown (the asked one, or the first frame
        /// published at or after it).
        from_tick: u64,
        /// The last tick shown.
        to_tick: u64,
        /// Times real time.
        speed: f32,
    },
    /// The replay was refused; nothing plays, and any replay playing goes
    /// on.
    Refused(ReplayRefusal),
    /// Replay `replay` ended; its datagrams stop.
    Ended {
        /// Its number.
        replay: u16,
        /// Why.
        why: ReplayEnd,
    },
}

/// What a client asked of replays, as its connection took it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ReplayAsk {
    /// Play this stretch (its shape checked, within the client's rate).
    Play(ReplayRequest),
    /// Stop the replay playing.
    Cancel,
}

impl ReplayAnswer {
    /// A short label for metrics and logs: `started`, the refusal's
    /// reason, or how the replay ended.
    pub fn label(&self) -> &'static str {
        match self {
            ReplayAnswer::Started { .. } => "started",
            ReplayAnswer::Refused(why) => why.reason(),
            ReplayAnswer::Ended { why, .. } => why.label(),
        }
    }
}

/// One replay datagram, read from untrusted bytes (see the [module
/// docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplayDatagram<'a> {
    /// Server to client: a snapshot of replay `replay`.
    Snapshot {
        /// The replay's number.
        replay: u16,
        /// The snapshot datagram.
        snapshot: &'a [u8],
    },
    /// Client to server: replay `replay`'s snapshot `sequence` arrived.
    Ack {
        /// The replay's number.
        replay: u16,
        /// The snapshot's sequence number.
        sequence: u16,
    },
}

/// A replay datagram that is not one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("not a replay datagram")]
pub struct NotReplayDatagram;

impl ReplayDatagram<'_> {
    /// Whether `datagram` is a replay datagram (by its first byte).
    pub fn is_one(datagram: &[u8]) -> bool {
        datagram.first() == Some(&REPLAY_DATAGRAM_TAG)
    }

    /// The datagram carrying replay `replay`'s `snapshot`.
    pub fn snapshot(replay: u16, snapshot: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(3 + snapshot.len());
        out.push(REPLAY_DATAGRAM_TAG);
        out.extend_from_slice(&replay.to_le_bytes());
        out.extend_from_slice(snapshot);
        out
    }

    /// The datagram acknowledging replay `replay`'s snapshot `sequence`.
    pub fn ack(replay: u16, sequence: u16) -> Vec<u8> {
        let mut out = Vec::with_capacity(5);
        out.push(REPLAY_DATAGRAM_TAG);
        out.extend_from_slice(&replay.to_le_bytes());
        out.extend_from_slice(&sequence.to_le_bytes());
        out
    }

    /// A snapshot datagram from the server.
    pub fn decode_snapshot(datagram: &[u8]) -> Result<ReplayDatagram<'_>, NotReplayDatagram> {
        match datagram {
            [REPLAY_DATAGRAM_TAG, a, b, snapshot @ ..] if !snapshot.is_empty() => {
                Ok(ReplayDatagram::Snapshot {
                    replay: u16::from_le_bytes([*a, *b]),
                    snapshot,
                })
            }
            _ => Err(NotReplayDatagram),
        }
    }

    /// An acknowledgement from the client.
    pub fn decode_ack(datagram: &[u8]) -> Result<ReplayDatagram<'_>, NotReplayDatagram> {
        match datagram {
            [REPLAY_DATAGRAM_TAG, a, b, c, d] => Ok(ReplayDatagram::Ack {
                replay: u16::from_le_bytes([*a, *b]),
                sequence: u16::from_le_bytes([*c, *d]),
            }),
            _ => Err(NotReplayDatagram),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replay_datagrams_round_trip_and_refuse_what_is_not_one() {
        let d = ReplayDatagram::snapshot(7, &[0x53, 1, 2]);
        assert!(ReplayDatagram::is_one(&d));
        assert_eq!(
            ReplayDatagram::decode_snapshot(&d),
            Ok(ReplayDatagram::Snapshot {
                replay: 7,
                snapshot: &[0x53, 1, 2]
            })
        );
        let a = ReplayDatagram::ack(7, 65535);
        assert_eq!(
            ReplayDatagram::decode_ack(&a),
            Ok(ReplayDatagram::Ack {
                replay: 7,
                sequence: 65535
            })
        );
        for bad in [
            &[][..],
            &[0x52],
            &[0x52, 1, 2],
            &[0x53, 1, 2, 3, 4],
            &[0x52, 1, 2, 3, 4, 5],
        ] {
            assert_eq!(
                ReplayDatagram::decode_ack(bad),
                Err(NotReplayDatagram),
                "{bad:?}"
            );
        }
        assert_eq!(
            ReplayDatagram::decode_snapshot(&[0x52, 1, 2]),
            Err(NotReplayDatagram)
        );
    }

    #[test]
    fn a_request_is_checked_for_its_shape() {
        let ok = ReplayRequest::last_seconds(600, 60, 5.0, 1.0, Some(3));
        assert_eq!((ok.from_tick, ok.to_tick, ok.ticks()), (300, 600, 300));
        assert_eq!(ok.check(), Ok(()));
        let at_start = ReplayRequest::last_seconds(100, 60, 5.0, 1.0, None);
        assert_eq!(at_start.from_tick, 0);
        for speed in [0.0, -1.0, f32::NAN, f32::INFINITY, 9.0, 0.01] {
            let r = ReplayRequest { speed, ..ok };
            assert_eq!(r.check(), Err(ReplayRefusal::Speed), "{speed}");
        }
        let backwards = ReplayRequest {
            from_tick: 10,
            to_tick: 10,
            ..ok
        };
        assert_eq!(backwards.check(), Err(ReplayRefusal::Empty));
    }
}
