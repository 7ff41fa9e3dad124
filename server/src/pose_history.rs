//! [`PoseHistory`]: where every moving body was over the last few ticks,
//! so that game rules can answer a player's shot against the world the
//! player saw (lag compensation).
//!
//! # Design note
//!
//! A client draws the world interpolated some way behind the server: half
//! a round trip for the snapshot to arrive, plus its interpolation delay.
//! A player who aims at a moving target aims where the target was on its
//! screen, and the input saying "fire" arrives another half round trip
//! later. Answered against the world as it is when the input is applied,
//! the shot misses a target crossing at 5 m/s by 0.5–1 m at 100 ms RTT.
//! Each input says which (fractional) tick the player was drawing
//! ([`PlayerInput::view_tick`](inertia_protocol::PlayerInput::view_tick));
//! the server keeps the poses of every body that can move for a bounded
//! window of recent ticks, and a rule may cast its ray against the poses at
//! that tick, interpolated between the two ticks around it as the client
//! interpolated them.
//!
//! **What is kept.** After every tick, for each entity whose body is not
//! static: its id and its body's pose (m, world). Shapes are not copied:
//! they are read from the world when asked (a body removed since cannot be
//! hit, and a body whose shape changed is tested with its present shape).
//! Static bodies are not kept and are answered as they are now: they do
//! not move. The window holds at most `capacity` ticks: as many as the
//! game rules ask for ([`crate::rules::GameRules::rewind_window_ms`], none
//! by default, up to [`crate::sim::SimConfig::max_rewind_ms`]; a player's view
//! lags its input's tick by the input's lead, a round trip and a margin,
//! plus the client's interpolation delay, about 250 ms at a 100 ms round
//! trip, so rules that compensate ask for about 500 ms). Keeping a window
//! costs state size too: it travels in every keyframe and checkpoint, so
//! rules that never look back get a window of one tick, which keeps
//! nothing ([`PoseHistory::record`]). Memory is bounded by
//! `capacity × moving bodies × 60` bytes (about 1.8 MB for 1000 moving
//! bodies at 60 Hz: 30 ticks of 60 bytes each), and the buffers of the
//! oldest tick are reused for the newest.
//!
//! **The rewind cap.** A view older than the oldest tick kept is answered
//! at the oldest tick kept (and the answer says it was clamped: the
//! server counts these); a view ahead of the newest tick is answered at the
//! newest. A player with a long round trip therefore cannot reach further
//! back than the window, which bounds how far behind cover a victim can be
//! hit.
//!
//! **Determinism.** The window is part of what a simulation carries on
//! from: it is saved with [`SimState`](crate::replay::SimState) (state
//! format version 2) and restored with it, so a seek, reverse play, `load`
//! or `--resume` that re-simulates from a keyframe has exactly the window
//! the live run had at that tick, and the same shots hit. It is filled by
//! [`Simulation::tick`](crate::sim::Simulation::tick), the one path every
//! tick takes, live or re-simulated. Poses are interpolated in `f64`
//! (`lerp` of translations, `slerp` of rotations) by the same code in
//! both, so the answers agree bit for bit.

use std::collections::VecDeque;

use inertia_codec::{ByteReader, ByteWriter, CodecError};
use inertia_physics::rigid::body::BodyKind;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::World;
use inertia_protocol::EntityId;

use crate::scene::{EntitySource, EntityTable};

/// The most rules may look back by default, ms (what they ask for is
/// [`crate::rules::GameRules::rewind_window_ms`]).
pub const DEFAULT_MAX_REWIND_MS: u32 = 1000;
/// The most ticks a window may keep (about 4 s at 60 Hz): the decoder of a
/// saved window refuses more.
pub const MAX_REWIND_TICKS: usize = 256;

/// Ticks of a window `max_rewind_ms` long at `tick_hz`, rounded up, plus
/// the tick now: 1 (no rewind, and nothing kept) to [`MAX_REWIND_TICKS`].
pub fn rewind_ticks(max_rewind_ms: u32, tick_hz: u32) -> usize {
    let ticks = (u64::from(max_rewind_ms) * u64::from(tick_hz)).div_ceil(1000);
    (ticks as usize + 1).clamp(1, MAX_REWIND_TICKS)
}

/// Bytes of one saved [`KeptPose`]: entity, translation, rotation.
const POSE_BYTES: usize = 4 + 7 * 8;

/// One moving body at one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeptPose {
    /// Its entity.
    pub entity: EntityId,
    /// Its body's pose (origin and orientation of the body frame), m,
    /// world.
    pub pose: Pose,
}

/// Every moving body at one tick, by entity id.
#[derive(Debug, Clone, PartialEq)]
struct TickPoses {
    tick: u64,
    bodies: Vec<KeptPose>,
}

/// Where a view tick was answered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rewound {
    /// The tick asked for, ticks.
    pub asked: f64,
    /// The tick answered at, ticks: `asked` within the window.
    pub used: f64,
    /// `asked` was older than the oldest tick kept (the rewind cap).
    pub clamped: bool,
}

/// Why a rewound query could not be answered.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum RewindError {
    /// The view tick was NaN or infinite.
    #[error("view tick {0} is not a finite number")]
    NotFinite(f64),
}

/// The poses of every moving body over the last ticks (see the module
/// notes).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseHistory {
    capacity: usize,
    /// Oldest first; ticks increase.
    ticks: VecDeque<TickPoses>,
}

impl PoseHistory {
    /// An empty window of at most `capacity` ticks (at least 1, at most
    /// [`MAX_REWIND_TICKS`]).
    pub fn new(capacity: usize) -> Self {
        let capacity = capacity.clamp(1, MAX_REWIND_TICKS);
        Self {
            capacity,
            ticks: VecDeque::with_capacity(capacity),
        }
    }

    /// The most ticks kept.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Ticks kept now.
    pub fn len(&self) -> usize {
        self.ticks.len()
    }

    /// True before the first tick is kept.
    pub fn is_empty(&self) -> bool {
        self.ticks.is_empty()
    }

    /// The oldest and newest ticks kept.
    pub fn span(&self) -> Option<(u64, u64)> {
        Some((self.ticks.front()?.tick, self.ticks.back()?.tick))
    }

    /// Keeps the poses of every entity's non-static body as they stand at
    /// `tick`. A tick at or before the newest kept replaces it and drops
    /// what came after (the world was set back). A window of one tick
    /// keeps nothing: it would only repeat the world as it is, which
    /// queries then answer, so rules that never look back cost the tick
    /// nothing and their saved states carry no poses.
    pub fn record(&mut self, tick: u64, world: &World, entities: &EntityTable) {
        if self.capacity < 2 {
            return;
        }
        while self.ticks.back().is_some_and(|t| t.tick >= tick) {
            self.ticks.pop_back();
        }
        let mut bodies = if self.ticks.len() >= self.capacity {
            self.ticks.pop_front().map(|t| t.bodies).unwrap_or_default()
        } else {
            Vec::new()
        };
        bodies.clear();
        // The table iterates by id, so the list is sorted by entity.
        for (entity, e) in entities.iter() {
            let EntitySource::Body(h) = e.source else {
                continue;
            };
            if let Some(b) = world.body(h).filter(|b| b.kind() != BodyKind::Static) {
                bodies.push(KeptPose {
                    entity,
                    pose: b.pose(),
                });
            }
        }
        self.ticks.push_back(TickPoses { tick, bodies });
    }

    /// Forgets every tick kept.
    pub fn clear(&mut self) {
        self.ticks.clear();
    }

    /// Where the view tick `view` is answered: within the window, clamped
    /// to its ends. `None` when nothing is kept.
    pub fn rewound(&self, view: f64) -> Result<Option<Rewound>, RewindError> {
        if !view.is_finite() {
            return Err(RewindError::NotFinite(view));
        }
        let Some((oldest, newest)) = self.span() else {
            return Ok(None);
        };
        let (oldest, newest) = (oldest as f64, newest as f64);
        Ok(Some(Rewound {
            asked: view,
            used: view.clamp(oldest, newest),
            clamped: view < oldest,
        }))
    }

    /// The moving bodies as they stood at the (fractional) tick `view`,
    /// sorted by entity, into `out` (cleared first); see
    /// [`Self::rewound`] for the clamping. Between two kept ticks a body
    /// kept at both is interpolated (translation linearly, rotation by
    /// slerp), as a client interpolates snapshots; a body kept at only one
    /// of them (spawned or removed in between) is there only when that
    /// tick is the nearer. `None` when nothing is kept.
    pub fn poses_at(
        &self,
        view: f64,
        out: &mut Vec<KeptPose>,
    ) -> Result<Option<Rewound>, RewindError> {
        out.clear();
        let Some(rewound) = self.rewound(view)? else {
            return Ok(None);
        };
        let at = rewound.used;
        // The last tick kept at or before `at`, and the one after it.
        let i0 = self.ticks.partition_point(|t| (t.tick as f64) <= at) - 1;
        let a = &self.ticks[i0];
        let Some(b) = self.ticks.get(i0 + 1) else {
            out.extend_from_slice(&a.bodies);
            return Ok(Some(rewound));
        };
        let s = (at - a.tick as f64) / (b.tick - a.tick) as f64;
        let (mut i, mut j) = (0, 0);
        while i < a.bodies.len() || j < b.bodies.len() {
            let (pa, pb) = (a.bodies.get(i), b.bodies.get(j));
            match (pa, pb) {
                (Some(pa), Some(pb)) if pa.entity == pb.entity => {
                    out.push(KeptPose {
                        entity: pa.entity,
                        pose: Pose {
                            translation: pa.pose.translation.lerp(pb.pose.translation, s),
                            rotation: pa.pose.rotation.slerp(pb.pose.rotation, s),
                        },
                    });
                    i += 1;
                    j += 1;
                }
                (Some(pa), pb) if pb.is_none_or(|pb| pa.entity < pb.entity) => {
                    if s < 0.5 {
                        out.push(*pa);
                    }
                    i += 1;
                }
                (_, Some(pb)) => {
                    if s >= 0.5 {
                        out.push(*pb);
                    }
                    j += 1;
                }
                (_, None) => break,
            }
        }
        Ok(Some(rewound))
    }

    /// The window as bytes, for [`SimState`](crate::replay::SimState):
    ///
    /// ```text
    /// u32 capacity, u32 ticks, then per tick (oldest first):
    ///   u64 tick, u32 n, n × (u32 entity, 3 × f64 translation m,
    ///                         4 × f64 rotation x y z w)
    /// ```
    pub fn to_bytes(&self) -> Vec<u8> {
        let n: usize = self
            .ticks
            .iter()
            .map(|t| 12 + t.bodies.len() * POSE_BYTES)
            .sum();
        let mut out = Vec::with_capacity(8 + n);
        let mut w = ByteWriter::new(&mut out);
        w.u32(self.capacity as u32);
        w.u32(self.ticks.len() as u32);
        for t in &self.ticks {
            w.u64(t.tick);
            w.u32(t.bodies.len() as u32);
            for k in &t.bodies {
                w.u32(k.entity);
                let p = k.pose;
                for v in p
                    .translation
                    .to_array()
                    .into_iter()
                    .chain(p.rotation.to_array())
                {
                    w.f64(v);
                }
            }
        }
        out
    }

    /// A window from [`Self::to_bytes`]. Untrusted: counts are bounded by
    /// the bytes left and [`MAX_REWIND_TICKS`], ticks must increase and
    /// entities within a tick too, poses must be finite; trailing bytes
    /// are refused.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let mut r = ByteReader::new(bytes);
        let capacity = r.u32().map_err(short)? as usize;
        if capacity == 0 || capacity > MAX_REWIND_TICKS {
            return Err(format!("pose window of {capacity} ticks"));
        }
        let count = r.u32().map_err(short)? as usize;
        if count > capacity {
            return Err(format!("{count} ticks in a window of {capacity}"));
        }
        let mut history = Self::new(capacity);
        for _ in 0..count {
            let tick = r.u64().map_err(short)?;
            if history.ticks.back().is_some_and(|t| t.tick >= tick) {
                return Err(format!("pose window tick {tick} does not increase"));
            }
            let n = r.u32().map_err(short)? as usize;
            if n.saturating_mul(POSE_BYTES) > r.remaining() {
                return Err(format!("{n} poses cannot fit"));
            }
            let mut bodies = Vec::with_capacity(n);
            for _ in 0..n {
                let entity = r.u32().map_err(short)?;
                let mut v = [0.0f64; 7];
                for x in &mut v {
                    *x = r.f64().map_err(short)?;
                }
                if !v.iter().all(|x| x.is_finite()) {
                    return Err(format!("pose of entity {entity} is not finite"));
                }
                if bodies.last().is_some_and(|k: &KeptPose| k.entity >= entity) {
                    return Err(format!("pose window entity {entity} out of order"));
                }
                let pose = Pose {
                    translation: inertia_physics::glam::DVec3::new(v[0], v[1], v[2]),
                    rotation: inertia_physics::glam::DQuat::from_xyzw(v[3], v[4], v[5], v[6]),
                };
                bodies.push(KeptPose { entity, pose });
            }
            history.ticks.push_back(TickPoses { tick, bodies });
        }
        if !r.is_empty() {
            return Err(format!(
                "{} trailing bytes after the pose window",
                r.remaining()
            ));
        }
        Ok(history)
    }
}

/// A field of a saved window runs past its end.
fn short(e: CodecError) -> String {
    format!("pose window {e}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use inertia_physics::glam::{DQuat, DVec3};
    use inertia_physics::rigid::body::RigidBodyDesc;
    use inertia_physics::rigid::shape::Shape;
    use inertia_physics::{BodyHandle, WorldConfig};
    use inertia_protocol::{EntityDesc, EntityKind, ShapeDesc};

    fn entity(entities: &mut EntityTable, h: BodyHandle) -> EntityId {
        entities.insert(
            EntitySource::Body(h),
            EntityDesc {
                id: 0,
                kind: EntityKind::Kinematic,
                shape: ShapeDesc::Sphere { radius: 0.5 },
                color: [0; 4],
                owner: None,
                name: String::new(),
                position: [0.0; 3],
                rotation: [0.0, 0.0, 0.0, 1.0],
            },
        )
    }

    /// A world with one static and one kinematic ball, the kinematic one
    /// at x = tick m and turned tick × 0.1 rad about Y, kept for ticks
    /// 0..n.
    fn history(capacity: usize, n: u64) -> (PoseHistory, World, EntityTable, EntityId) {
        let mut world = World::new(WorldConfig::default()).unwrap();
        let mut entities = EntityTable::new();
        let ball = Shape::sphere(0.5).unwrap();
        let still = world
            .add_body(&RigidBodyDesc::fixed(ball.clone(), Pose::default()))
            .unwrap();
        entity(&mut entities, still);
        let h = world
            .add_body(&RigidBodyDesc::kinematic(ball, Pose::default()))
            .unwrap();
        let id = entity(&mut entities, h);
        let mut poses = PoseHistory::new(capacity);
        for tick in 0..n {
            let pose = Pose {
                translation: DVec3::new(tick as f64, 0.0, 0.0),
                rotation: DQuat::from_rotation_y(tick as f64 * 0.1),
            };
            world.set_body_pose(h, pose).unwrap();
            poses.record(tick, &world, &entities);
        }
        (poses, world, entities, id)
    }

    #[test]
    fn the_window_is_bounded_and_keeps_only_moving_bodies() {
        let (poses, ..) = history(4, 100);
        assert_eq!((poses.len(), poses.span()), (4, Some((96, 99))));
        assert!(poses.ticks.iter().all(|t| t.bodies.len() == 1));
        assert_eq!(rewind_ticks(250, 60), 16);
        assert_eq!(rewind_ticks(0, 60), 1);
        assert_eq!(rewind_ticks(u32::MAX, 60), MAX_REWIND_TICKS);
    }

    #[test]
    fn poses_between_ticks_are_interpolated() {
        let (poses, _, _, id) = history(16, 20);
        let mut out = Vec::new();
        let r = poses.poses_at(12.25, &mut out).unwrap().unwrap();
        assert_eq!((r.used, r.clamped), (12.25, false));
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].entity, id);
        assert!((out[0].pose.translation.x - 12.25).abs() < 1e-12);
        let (_, angle) = out[0].pose.rotation.to_axis_angle();
        assert!((angle - 1.225).abs() < 1e-9, "{angle}");
        // On a tick: exactly that tick's pose.
        poses.poses_at(15.0, &mut out).unwrap();
        assert_eq!(out[0].pose.translation.x, 15.0);
    }

    #[test]
    fn the_rewind_is_capped_at_the_window() {
        let (poses, _, _, _) = history(5, 20);
        let mut out = Vec::new();
        // Older than the oldest kept (15): answered there, and said so.
        let r = poses.poses_at(3.5, &mut out).unwrap().unwrap();
        assert_eq!((r.asked, r.used, r.clamped), (3.5, 15.0, true));
        assert_eq!(out[0].pose.translation.x, 15.0);
        // Ahead of the newest: the newest, not clamped.
        let r = poses.poses_at(25.0, &mut out).unwrap().unwrap();
        assert_eq!((r.used, r.clamped), (19.0, false));
        assert!(matches!(
            poses.poses_at(f64::NAN, &mut out),
            Err(RewindError::NotFinite(v)) if v.is_nan()
        ));
        assert!(matches!(
            poses.rewound(f64::INFINITY),
            Err(RewindError::NotFinite(_))
        ));
        assert_eq!(PoseHistory::new(3).rewound(1.0), Ok(None));
    }

    #[test]
    fn bodies_that_did_not_exist_then_are_not_there() {
        let (mut poses, mut world, mut entities, old) = history(16, 10);
        let late = world
            .add_body(&RigidBodyDesc::kinematic(
                Shape::sphere(0.5).unwrap(),
                Pose::default(),
            ))
            .unwrap();
        let late = entity(&mut entities, late);
        poses.record(10, &world, &entities);
        let mut out = Vec::new();
        poses.poses_at(9.25, &mut out).unwrap();
        assert_eq!(out.iter().map(|k| k.entity).collect::<Vec<_>>(), vec![old]);
        poses.poses_at(9.75, &mut out).unwrap();
        assert_eq!(
            out.iter().map(|k| k.entity).collect::<Vec<_>>(),
            vec![old, late]
        );
        // Setting the world back drops what came after.
        poses.record(5, &world, &entities);
        assert_eq!(poses.span(), Some((0, 5)));
    }

    #[test]
    fn the_window_round_trips_through_bytes_and_refuses_garbage() {
        let (poses, ..) = history(6, 9);
        let bytes = poses.to_bytes();
        assert_eq!(PoseHistory::from_bytes(&bytes), Ok(poses));
        for cut in 0..bytes.len() {
            assert!(PoseHistory::from_bytes(&bytes[..cut]).is_err(), "cut {cut}");
        }
        let mut extra = bytes.clone();
        extra.push(0);
        assert!(PoseHistory::from_bytes(&extra).is_err());
        let mut nan = bytes.clone();
        let at = 8 + 12 + 4;
        nan[at..at + 8].copy_from_slice(&f64::NAN.to_bits().to_le_bytes());
        assert!(PoseHistory::from_bytes(&nan).is_err());
        assert!(PoseHistory::from_bytes(&[0; 8]).is_err());
    }
}
