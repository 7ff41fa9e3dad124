//! A replay of the recent past the player asked for, kept apart from the
//! live stream (see [`inertia_protocol::replay`]): its own snapshot
//! decoder, interpolation buffer and properties, fed only by replay
//! datagrams. The live stream, its buffer and the prediction go on beside
//! it untouched, so when the replay ends the game simply draws the live
//! sample again: nothing to reconnect, nothing to catch up.
//!
//! Sans-IO: replay datagrams and the server's answers go in with the
//! client's time; acknowledgements to send come out.

use std::sync::Arc;

use inertia_protocol::property::{PropertySchema, PropertyValue};
use inertia_protocol::replay::{ReplayAnswer, ReplayDatagram, ReplayEnd, ReplayRefusal};
use inertia_protocol::snapshot::{SnapshotConfig, SnapshotDecoder};
use inertia_protocol::{DecodedSnapshot, EntityId};

use crate::clock::SnapshotMeta;
use crate::interp::{InterpolationBuffer, Sample};
use crate::properties::KnownProperties;

/// Where the player's replay stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ReplayStatus {
    /// None asked, or the last one is over and was seen out.
    Idle,
    /// Asked; the server has not answered yet.
    Asked,
    /// Playing: its snapshots arrive.
    Playing {
        /// Its number.
        replay: u16,
        /// The first tick shown.
        from_tick: u64,
        /// The last tick shown.
        to_tick: u64,
        /// Times real time.
        speed: f32,
    },
    /// The server refused it.
    Refused(ReplayRefusal),
    /// It ended (all its snapshots came, or it was cancelled).
    Ended(ReplayEnd),
}

/// Something that happened to the player's replay, for the game.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ReplayEvent {
    /// It plays: draw [`crate::Client::replay_sample`].
    Started {
        /// The first tick shown.
        from_tick: u64,
        /// The last tick shown.
        to_tick: u64,
        /// Times real time.
        speed: f32,
    },
    /// The server refused it, saying why.
    Refused(ReplayRefusal),
    /// It ended: draw the live sample again.
    Ended(ReplayEnd),
}

/// The replay the player watches (see the [module docs](self)).
#[derive(Debug)]
pub struct ReplayView {
    config: SnapshotConfig,
    tick_hz: f64,
    properties: Arc<PropertySchema>,
    status: ReplayStatus,
    /// The replay whose datagrams are taken: the one playing, or the
    /// next one after those that ended (its datagrams may come before
    /// its answer).
    current: Option<u16>,
    /// The newest replay number that ended.
    ended: Option<u16>,
    decoder: SnapshotDecoder,
    decoded: DecodedSnapshot,
    interp: InterpolationBuffer,
    known: KnownProperties,
    /// The newest replayed tick decoded.
    newest_tick: Option<u64>,
}

impl ReplayView {
    /// No replay yet; replays are coded as `config` says (the welcome's),
    /// at `tick_hz`, carrying `properties`.
    pub fn new(config: SnapshotConfig, tick_hz: u32, properties: Arc<PropertySchema>) -> Self {
        let decoder = SnapshotDecoder::new(config)
            .expect("the welcome's snapshot settings were checked")
            .with_properties(properties.clone());
        Self {
            config,
            tick_hz: f64::from(tick_hz),
            known: KnownProperties::new(properties.clone()),
            properties,
            status: ReplayStatus::Idle,
            current: None,
            ended: None,
            decoder,
            decoded: DecodedSnapshot::default(),
            interp: InterpolationBuffer::new(f64::from(tick_hz)),
            newest_tick: None,
        }
    }

    /// Where the replay stands.
    pub fn status(&self) -> ReplayStatus {
        self.status
    }

    /// The player asked for a replay.
    pub fn asked(&mut self) {
        self.status = ReplayStatus::Asked;
    }

    /// The server's answer: what to tell the game.
    pub fn on_answer(&mut self, answer: ReplayAnswer) -> ReplayEvent {
        match answer {
            ReplayAnswer::Started {
                replay,
                from_tick,
                to_tick,
                speed,
            } => {
                if self.current != Some(replay) {
                    self.begin(replay);
                }
                self.status = ReplayStatus::Playing {
                    replay,
                    from_tick,
                    to_tick,
                    speed,
                };
                ReplayEvent::Started {
                    from_tick,
                    to_tick,
                    speed,
                }
            }
            ReplayAnswer::Refused(why) => {
                // A refusal leaves a replay playing as it was.
                if !matches!(self.status, ReplayStatus::Playing { .. }) {
                    self.status = ReplayStatus::Refused(why);
                }
                ReplayEvent::Refused(why)
            }
            ReplayAnswer::Ended { replay, why } => {
                self.ended = Some(self.ended.map_or(replay, |e| e.max(replay)));
                if self.current == Some(replay) {
                    self.current = None;
                    self.status = ReplayStatus::Ended(why);
                }
                ReplayEvent::Ended(why)
            }
        }
    }

    /// Starts taking replay `replay`'s datagrams, on fresh views and a
    /// fresh buffer.
    fn begin(&mut self, replay: u16) {
        self.current = Some(replay);
        self.decoder = SnapshotDecoder::new(self.config)
            .expect("checked at start")
            .with_properties(self.properties.clone());
        self.interp = InterpolationBuffer::new(self.tick_hz);
        self.known = KnownProperties::new(self.properties.clone());
        self.newest_tick = None;
    }

    /// A replay datagram at `now` (s): the acknowledgement to send back,
    /// when it was one of the replay's snapshots. Datagrams of a replay
    /// that ended, and any that do not decode, change nothing.
    pub fn on_datagram(&mut self, now: f64, bytes: &[u8]) -> Option<Vec<u8>> {
        let Ok(ReplayDatagram::Snapshot { replay, snapshot }) =
            ReplayDatagram::decode_snapshot(bytes)
        else {
            return None;
        };
        if self.current != Some(replay) {
            // A newer replay's first datagrams may come before its answer.
            let newer = self.ended.is_none_or(|e| replay > e)
                && self.current.is_none_or(|c| replay > c)
                && self.status == ReplayStatus::Asked;
            if !newer {
                return None;
            }
            self.begin(replay);
        }
        self.decoder.decode_into(snapshot, &mut self.decoded).ok()?;
        let snap = &self.decoded;
        let meta = SnapshotMeta {
            seq: Some(snap.sequence),
            tick: snap.tick,
            time_scale: snap.time_scale,
            paused: snap.paused,
        };
        for &id in &snap.removed {
            self.interp.remove(id);
        }
        self.interp.push_states(now, meta, &snap.updated);
        while self.interp.poll_event().is_some() {}
        if snap.newest {
            self.newest_tick = Some(snap.tick);
            if let Some(view) = self.decoder.view(snap.sequence) {
                if !self.properties.is_empty() {
                    self.known.on_view(snap.tick, view);
                }
            }
        }
        Some(ReplayDatagram::ack(replay, snap.sequence))
    }

    /// The replayed world as it should be drawn at `local_time` (s): the
    /// replay playing, or the last one's last frames once it ended (its
    /// buffer plays on to its end, behind by the interpolation delay);
    /// `None` before any replayed state came.
    pub fn sample(&mut self, local_time: f64) -> Option<Sample> {
        let sample = self.interp.sample(local_time);
        (!sample.entities.is_empty()).then(|| sample.clone())
    }

    /// The newest replayed tick decoded.
    pub fn newest_tick(&self) -> Option<u64> {
        self.newest_tick
    }

    /// An entity's properties as the replay shows them now.
    pub fn properties(&self, entity: EntityId) -> Option<Vec<PropertyValue>> {
        self.known.entity(entity)
    }

    /// The match's properties as the replay shows them now.
    pub fn match_state(&self) -> Vec<PropertyValue> {
        self.known.match_state()
    }
}
