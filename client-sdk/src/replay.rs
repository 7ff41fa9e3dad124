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
    /// The replay whose datagrams are taken (the one playing, or the last
    /// one until another is asked for).
    current: Option<u16>,
    /// The newest replay number begun: a replay's first datagrams may
    /// come before its answer, and are taken when the number is newer.
    begun: Option<u16>,
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
        let decoder = fresh_decoder(config, &properties);
        Self {
            config,
            tick_hz: f64::from(tick_hz),
            known: KnownProperties::new(properties.clone()),
            properties,
            status: ReplayStatus::Idle,
            current: None,
            begun: None,
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

    /// The player asked for a replay: the last one's datagrams still on
    /// their way are no longer taken, and the newest tick is the new
    /// one's once it comes.
    pub fn asked(&mut self) {
        self.status = ReplayStatus::Asked;
        self.current = None;
        self.newest_tick = None;
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
                if self.current != Some(replay) && self.begun.is_none_or(|b| replay > b) {
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
                if self.current == Some(replay) && self.status != ReplayStatus::Asked {
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
        self.begun = Some(replay);
        self.decoder = fresh_decoder(self.config, &self.properties);
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
            let newer = self.status == ReplayStatus::Asked && self.begun.is_none_or(|b| replay > b);
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

/// A decoder that has received nothing, for a replay's own views.
fn fresh_decoder(config: SnapshotConfig, properties: &Arc<PropertySchema>) -> SnapshotDecoder {
    SnapshotDecoder::new(config)
        .expect("the welcome's snapshot settings were checked")
        .with_properties(properties.clone())
}

#[cfg(test)]
mod tests {
    use glam::{DQuat, DVec3};
    use inertia_protocol::snapshot::SnapshotEncoder;
    use inertia_protocol::{EntityState, PriorityAccumulator};

    use super::*;

    fn snapshot(encoder: &mut SnapshotEncoder, tick: u64, x: f64) -> Vec<u8> {
        let state = EntityState {
            id: 4,
            position: DVec3::new(x, 1.0, 0.0),
            rotation: DQuat::IDENTITY,
            linear_velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            asleep: false,
        };
        let mut priorities = PriorityAccumulator::default();
        encoder.encode(tick, 1.0, false, &[state], &mut priorities, 1200)
    }

    fn view() -> ReplayView {
        ReplayView::new(SnapshotConfig::default(), 60, Default::default())
    }

    #[test]
    fn a_replay_is_taken_before_its_answer_and_the_last_ones_stragglers_are_not() {
        let mut v = view();
        let mut e = SnapshotEncoder::new(SnapshotConfig::default()).unwrap();
        // Nothing asked: a replay datagram is nobody's.
        let d0 = ReplayDatagram::snapshot(0, &snapshot(&mut e, 100, 1.0));
        assert_eq!(v.on_datagram(0.0, &d0), None);
        v.asked();
        // Its first snapshot before the answer is taken and acknowledged.
        let ack = v.on_datagram(0.0, &d0).expect("taken");
        assert_eq!(
            ReplayDatagram::decode_ack(&ack),
            Ok(ReplayDatagram::Ack {
                replay: 0,
                sequence: 0
            })
        );
        assert_eq!(v.newest_tick(), Some(100));
        let started = v.on_answer(ReplayAnswer::Started {
            replay: 0,
            from_tick: 100,
            to_tick: 200,
            speed: 1.0,
        });
        assert!(matches!(started, ReplayEvent::Started { .. }));
        assert_eq!(v.newest_tick(), Some(100), "the answer keeps what came");
        let d1 = ReplayDatagram::snapshot(0, &snapshot(&mut e, 102, 1.1));
        assert!(v.on_datagram(1.0 / 30.0, &d1).is_some());
        assert_eq!(v.newest_tick(), Some(102));
        assert!(v.sample(0.5).is_some_and(|s| s.get(4).is_some()));

        // Another is asked for: the first one's datagrams still on their
        // way change nothing, the second one's are taken.
        v.asked();
        assert_eq!(v.newest_tick(), None);
        let late = ReplayDatagram::snapshot(0, &snapshot(&mut e, 104, 1.2));
        assert_eq!(v.on_datagram(0.1, &late), None);
        assert_eq!(v.newest_tick(), None);
        let mut e2 = SnapshotEncoder::new(SnapshotConfig::default()).unwrap();
        let second = ReplayDatagram::snapshot(1, &snapshot(&mut e2, 50, 3.0));
        assert!(v.on_datagram(0.2, &second).is_some());
        assert_eq!(v.newest_tick(), Some(50));
        // The first one's end does not end the second.
        v.on_answer(ReplayAnswer::Ended {
            replay: 0,
            why: ReplayEnd::Replaced,
        });
        assert_eq!(v.status(), ReplayStatus::Asked);
        v.on_answer(ReplayAnswer::Started {
            replay: 1,
            from_tick: 50,
            to_tick: 80,
            speed: 0.5,
        });
        v.on_answer(ReplayAnswer::Ended {
            replay: 1,
            why: ReplayEnd::Finished,
        });
        assert_eq!(v.status(), ReplayStatus::Ended(ReplayEnd::Finished));
        // Bytes that are not a replay snapshot change nothing.
        assert_eq!(v.on_datagram(0.3, &[0x52, 1]), None);
        assert_eq!(v.on_datagram(0.3, &ReplayDatagram::ack(1, 3)), None);
    }

    #[test]
    fn a_refusal_leaves_a_replay_playing_as_it_was() {
        let mut v = view();
        v.asked();
        v.on_answer(ReplayAnswer::Started {
            replay: 0,
            from_tick: 1,
            to_tick: 9,
            speed: 1.0,
        });
        v.on_answer(ReplayAnswer::Refused(ReplayRefusal::RateLimited));
        assert!(matches!(
            v.status(),
            ReplayStatus::Playing { replay: 0, .. }
        ));
        let mut idle = view();
        idle.asked();
        idle.on_answer(ReplayAnswer::Refused(ReplayRefusal::Busy));
        assert_eq!(idle.status(), ReplayStatus::Refused(ReplayRefusal::Busy));
    }
}
