//! Islands and sleeping.
//!
//! Bodies resting on each other form an *island*: the connected components
//! of the graph whose nodes are the dynamic bodies and whose edges are the
//! pairs that touched this step (static and kinematic bodies do not join
//! islands — a floor under a thousand boxes must not fuse them into one).
//! A body's `sleep_time` grows while it moves slower than the tolerances
//! and resets when it moves faster. When every body of an island has slept
//! for [`SleepConfig::time_to_sleep`], the island goes to sleep: velocities
//! zeroed, no integration, no solving — a settled pile costs nothing.
//!
//! A sleeping body wakes when the game touches it (velocity, impulse,
//! control, pose) or when an awake body comes into contact with it; waking
//! spreads through everything touching it. Components are found with a
//! union–find over body slots in handle order, so the result is
//! deterministic.

use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::body_index::BodyIndex;

/// When bodies fall asleep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SleepConfig {
    /// Whether islands may sleep at all.
    pub enabled: bool,
    /// Speed of the centre of mass below which a body counts as resting, m/s.
    pub linear_tolerance: f64,
    /// Angular speed below which a body counts as resting, rad/s.
    pub angular_tolerance: f64,
    /// How long every body of an island must rest before it sleeps, s.
    pub time_to_sleep: f64,
}

impl Default for SleepConfig {
    fn default() -> Self {
        // Box2D's tolerances: 5 cm/s, 2°/s, half a second.
        Self {
            enabled: true,
            linear_tolerance: 0.05,
            angular_tolerance: 2f64.to_radians(),
            time_to_sleep: 0.5,
        }
    }
}

impl SleepConfig {
    /// Whether a body moving at `linear` m/s and turning at `angular`
    /// rad/s moves as slowly as a resting one.
    pub(crate) fn slow(&self, linear: f64, angular: f64) -> bool {
        linear < self.linear_tolerance && angular < self.angular_tolerance
    }
}

/// Wakes every sleeping dynamic body connected through `touching` to an
/// awake, moving dynamic body (or that the caller already woke). Returns
/// whether anything woke.
pub(crate) fn wake_touched(
    bodies: &mut Arena<RigidBody>,
    touching: impl Iterator<Item = (BodyHandle, BodyHandle)> + Clone,
) -> bool {
    let mut any = false;
    loop {
        let mut woke = false;
        for (a, b) in touching.clone() {
            let state = |h: BodyHandle| {
                bodies
                    .get(h.index, h.generation)
                    .map(|x| (x.kind == BodyKind::Dynamic, x.sleeping))
            };
            let (Some((da, sa)), Some((db, sb))) = (state(a), state(b)) else {
                continue;
            };
            // An awake dynamic body touching a sleeping one wakes it.
            let wake = if da && db && sa != sb {
                Some(if sa { a } else { b })
            } else {
                None
            };
            if let Some(h) = wake {
                if let Some(x) = bodies.get_mut(h.index, h.generation) {
                    x.sleeping = false;
                    x.sleep_time = 0.0;
                    woke = true;
                }
            }
        }
        if !woke {
            return any;
        }
        any = true;
    }
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Advances sleep timers by `dt` and puts to sleep every island whose
/// bodies have all rested long enough. A body rests when both its
/// velocity and how fast it moved over the step (from `start`, each
/// body's centre of mass and principal rotation at the start of the step,
/// by slot) are under the tolerances: push-out moves a body out of an
/// overlap without giving it velocity, and a body still being pushed out
/// of the ground is not resting.
///
/// Each pair costs two slot lookups (`index`); only awake bodies are timed.
pub(crate) fn update(
    bodies: &mut Arena<RigidBody>,
    index: &BodyIndex,
    touching: impl Iterator<Item = (BodyHandle, BodyHandle)>,
    start: &[(glam::DVec3, glam::DQuat)],
    cfg: &SleepConfig,
    dt: f64,
) {
    if !cfg.enabled {
        return;
    }
    // Awake dynamic bodies by slot; with none, nothing to time or put to
    // sleep (a settled world costs nothing here). Islands join dynamic
    // bodies, asleep or not (a sleeping body touched this step can bridge
    // two awake ones).
    let awake: Vec<bool> = bodies
        .iter()
        .map(|(_, _, b)| b.kind == BodyKind::Dynamic && !b.sleeping && !b.quarantined)
        .collect();
    if !awake.contains(&true) {
        return;
    }
    let dynamic: Vec<bool> = bodies
        .iter()
        .map(|(_, _, b)| b.kind == BodyKind::Dynamic)
        .collect();
    let mut parent: Vec<usize> = (0..awake.len()).collect();
    for (a, b) in touching {
        if let (Some(i), Some(j)) = (index.slot(a), index.slot(b)) {
            if dynamic[i] && dynamic[j] {
                let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
                if ri != rj {
                    parent[ri.max(rj)] = ri.min(rj);
                }
            }
        }
    }
    // Timers, and the least rested body of each island.
    let mut island_min = vec![f64::INFINITY; awake.len()];
    let mut can_sleep = vec![true; awake.len()];
    for (k, (_, _, b)) in bodies.iter_mut().enumerate() {
        if !awake[k] {
            continue;
        }
        // A body the game is pushing (scripted force or torque) never rests.
        let pushed = b.control_force != glam::DVec3::ZERO || b.control_torque != glam::DVec3::ZERO;
        let (speed, spin) = start.get(k).map_or((0.0, 0.0), |(com, principal)| {
            let turned = principal.angle_between(b.rotation * b.principal);
            ((b.com - *com).length() / dt, turned / dt)
        });
        let resting =
            !pushed && cfg.slow(b.linvel.length().max(speed), b.angvel.length().max(spin));
        b.sleep_time = if resting && b.can_sleep {
            b.sleep_time + dt
        } else {
            0.0
        };
        let root = find(&mut parent, k);
        island_min[root] = island_min[root].min(b.sleep_time);
        can_sleep[root] &= b.can_sleep;
    }
    for (k, (_, _, b)) in bodies.iter_mut().enumerate() {
        if !awake[k] {
            continue;
        }
        let root = find(&mut parent, k);
        if can_sleep[root] && island_min[root] >= cfg.time_to_sleep {
            b.sleeping = true;
            b.linvel = glam::DVec3::ZERO;
            b.angvel = glam::DVec3::ZERO;
        }
    }
}
