//! One step of the rigid bodies, as named, timed stages (each in its own
//! file):
//!
//! 1. **forces** ([`bodies`]) — body force generators (wind, buoyancy, ...)
//!    are evaluated once, at the start of the step; bodies touching awake
//!    ones wake.
//! 2. **broad phase** ([`pairs`]) — each body's box, grown by how far it can
//!    move this step plus the speculative margin, is updated in the dynamic
//!    AABB tree; the overlapping pairs come out sorted.
//! 3. **narrow phase** ([`manifolds`]) — each pair (each pair of child
//!    shapes for compounds) whose tight boxes meet gives a manifold, in
//!    parallel; its points take the impulses they had last step (matched
//!    by feature id) for warm starting. A pair the last step found apart
//!    is first projected on the axis that showed it ([`apart`]).
//! 4. **colouring** ([`colouring`](super::solver::colouring)) — the contact
//!    constraints are grouped so that no two of a group move the same
//!    body, and stored colour by colour (the order they are solved in).
//! 5. **solve** ([`substeps`]) — [`solver`](super::solver) substeps:
//!    integrate velocities, warm start, solve with bias, integrate positions
//!    (with the gyroscopic splitting of [`motion`](super::motion)), relax;
//!    then restitution. Each colour's contacts are solved in parallel.
//! 6. **finish** ([`finish`]) — joints break, contact and force events, the
//!    contact cache; bodies get their new velocities, or are quarantined if
//!    their state is not finite.
//! 7. **islands** — resting islands fall asleep.
//!
//! A world where nothing can move skips every stage, and remembers the
//! bodies' revision (see `Arena::revision`) so the next step needs no look
//! at a body either while nothing changed them.
//!
//! Everything iterates in body-handle order, pair order and colour order,
//! none of which depends on the number of threads, so the result does not
//! either; nor does it depend on history the state does not record.

mod apart;
mod bodies;
mod cache;
mod finish;
mod manifolds;
mod pairs;
mod shock;
mod substeps;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use glam::{DQuat, DVec3, Quat, Vec3};

use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::profile::RigidProfile;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::body_index::BodyIndex;
use crate::rigid::broad_phase::BroadPhase;
use crate::rigid::forces::BodyField;
use crate::rigid::joint::Joint;
use crate::rigid::solver::SolverConfig;
pub(crate) use cache::{pair_contacts, ContactCache};

/// Contacts closer than this are kept as speculative points, m.
pub const SPECULATIVE_DISTANCE: f64 = 0.02;
/// Margin of the broad phase's fat boxes, m.
const AABB_MARGIN: f64 = 0.1;

/// Which manifold: the two bodies (handle order) and the child shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct ContactKey {
    pub(crate) a: (u32, u32),
    pub(crate) b: (u32, u32),
    pub(crate) child_a: u32,
    pub(crate) child_b: u32,
}

/// One point of a manifold as the narrow phase found it, with the
/// impulses it ended the step with, N·s (for warm starting); its anchors
/// let the pair's manifold be used again while the bodies barely move
/// (see [`CachedManifold::reference`]).
///
/// What the cache keeps is in single precision, as rapier3d and Box2D keep
/// all their contact data: warm starts need no more, and a body-frame
/// anchor 100 m from its centre of mass is still kept to 8 µm. It is most
/// of a saved world, and changes every step: in f64 a 1000-body pile's
/// save held 1.3 MB, of which 0.8 MB was its contacts.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct CachedPoint {
    pub(crate) id: u32,
    /// The point on A, in A's body frame, m (also for matching when
    /// feature ids change).
    pub(crate) anchor_a: Vec3,
    /// The point on B, in B's body frame, m.
    pub(crate) anchor_b: Vec3,
    /// The point's separation less `n · (point on B - point on A)` (world),
    /// m: 0 for points on the two surfaces along the normal.
    pub(crate) gap: f32,
    /// Accumulated normal impulse, N·s.
    pub(crate) normal: f32,
    /// The point's share of the friction impulse, along the two tangents,
    /// N·s.
    pub(crate) tangent: [f32; 2],
}

/// A manifold kept from one step to the next (world state: saved and
/// hashed): its points with their impulses, and what lets the narrow
/// phase use it again instead of colliding the shapes.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct CachedManifold {
    /// The unit normal from A to B, in A's body frame.
    pub(crate) normal_a: Vec3,
    /// The bodies' relative pose when the shapes were last collided;
    /// `None` for a manifold that is not used again (a compound's child,
    /// or one read from a state written before manifolds were).
    pub(crate) reference: Option<Reference>,
    pub(crate) points: Vec<CachedPoint>,
    /// The normal impulse over the step that last solved it (every
    /// substep and restitution), N·s.
    pub(crate) impulse: f32,
    /// The smallest separation of its points at the start of that step,
    /// m.
    pub(crate) separation: f32,
}

/// Where two bodies stood, relative to each other, when their shapes were
/// last collided, and how far apart the manifold's points were looked for.
///
/// The pose is that of the smaller body (by radius about its centre of
/// mass) in the frame of the larger, whose points stay put in it. The
/// manifold is used again while `drift + speculative ≤ reach` and `drift ≤
/// RECYCLE_DRIFT` ([`Reference::holds`]): `drift` bounds how far any point
/// of the smaller body has moved in the larger's frame since (the change
/// of the relative translation, plus the chord of the relative rotation
/// times the smaller radius), so no separation between the two has changed
/// by more; `speculative` is this step's speculative distance. Every
/// feature pair within this step's speculative distance was then within
/// `reach`, so it is among the manifold's points; each point's separation
/// is measured again from the bodies' poses, along the kept normal (turned
/// with A). The shapes are collided with [`RECYCLE_DRIFT`] more than the
/// speculative distance, which is the room drift has; the cap on drift
/// bounds how stale the normal and the points may grow when the
/// speculative distance was large (a fast body that has since stopped).
/// Kept in single precision like the points: the pose is off by at most
/// a micrometre within 10 m, against the 2 mm of drift it is tested for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Reference {
    /// Whether A is the larger body, whose frame the pose is in.
    pub(crate) in_a: bool,
    /// The smaller body's centre of mass from the larger's, in the
    /// larger's body frame, m.
    pub(crate) translation: Vec3,
    /// The smaller body's rotation relative to the larger's.
    pub(crate) rotation: Quat,
    /// How far apart points were kept, m (the distance the shapes were
    /// collided with: see [`Reference::reach`]).
    pub(crate) reach: f32,
}

/// How far the points of two bodies in contact may drift relative to each
/// other before their shapes are collided again, m. Jolt keeps a body
/// pair's contacts while it moves less than 1 mm and turns less than 2°;
/// rapier3d keeps them within 5 cm of drift. A resting stack drifts
/// micrometres a step, so it is collided again every few hundred steps.
pub(crate) const RECYCLE_DRIFT: f64 = 0.002;

impl Reference {
    /// The distance to collide two bodies' shapes with, m, when their
    /// speculative distance is `speculative`: that with room for
    /// [`RECYCLE_DRIFT`], as the reference keeps it, so that the points
    /// were looked for exactly as far as it says.
    pub(crate) fn reach(speculative: f64) -> f64 {
        f64::from((speculative + RECYCLE_DRIFT) as f32)
    }

    /// The relative pose of `a` and `b` (centres of mass, body rotations),
    /// with points kept up to `reach` (from [`Reference::reach`]).
    pub(crate) fn between(a: &RigidBody, b: &RigidBody, reach: f64) -> Reference {
        let (in_a, translation, rotation) = Reference::pose(a, b);
        Reference {
            in_a,
            translation: translation.as_vec3(),
            rotation: rotation.as_quat(),
            reach: reach as f32,
        }
    }

    /// Whether A is the larger of `a` and `b`, and the smaller's pose in
    /// the larger's frame (translation, m, and rotation), in full.
    fn pose(a: &RigidBody, b: &RigidBody) -> (bool, DVec3, DQuat) {
        let in_a = a.shape_radius() >= b.shape_radius();
        let (large, small) = if in_a { (a, b) } else { (b, a) };
        let inverse = large.rotation.inverse();
        (
            in_a,
            inverse * (small.com - large.com),
            inverse * small.rotation,
        )
    }

    /// Whether the manifold kept with this reference still serves `a` and
    /// `b` this step, with `speculative` its speculative distance, m.
    pub(crate) fn holds(&self, a: &RigidBody, b: &RigidBody, speculative: f64) -> bool {
        let drift = self.drift(a, b);
        drift <= RECYCLE_DRIFT && drift + speculative <= f64::from(self.reach)
    }

    /// How far any point of the smaller of `a` and `b` has moved in the
    /// larger's frame since this reference, at most, m (infinite if they
    /// changed roles).
    pub(crate) fn drift(&self, a: &RigidBody, b: &RigidBody) -> f64 {
        let (in_a, translation, rotation) = Reference::pose(a, b);
        if in_a != self.in_a {
            return f64::INFINITY;
        }
        let small = if self.in_a { b } else { a };
        let turn = rotation * self.rotation.as_dquat().inverse();
        // The chord of the turn: |q_xyz| = sin(θ/2), chord = 2 sin(θ/2).
        let chord = 2.0 * DVec3::new(turn.x, turn.y, turn.z).length();
        (translation - self.translation.as_dvec3()).length() + chord * small.shape_radius()
    }
}

/// A new point with no cached id takes the impulses of a cached point whose
/// anchor on A lies within this distance, m. (Two parallel faces in contact
/// may swap which one is the reference face from one step to the next,
/// which renames every feature id though the contact has not changed.)
const ANCHOR_MATCH_DISTANCE: f64 = 0.02;

/// Whether a pair of bodies started or stopped touching.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactEventKind {
    /// The bodies touch now and did not at the end of the last step.
    Begin,
    /// The bodies touched at the end of the last step and no longer do.
    End,
}

/// A change of contact between two bodies (`a` before `b` in handle order).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ContactEvent {
    /// Began or ended.
    pub kind: ContactEventKind,
    /// First body.
    pub a: BodyHandle,
    /// Second body.
    pub b: BodyHandle,
    /// Whether either body is a sensor (an overlap, not a collision).
    pub sensor: bool,
}

/// Two bodies pressed together harder than one of their thresholds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactForceEvent {
    /// First body.
    pub a: BodyHandle,
    /// Second body.
    pub b: BodyHandle,
    /// Average normal force over the step: the normal impulse of every
    /// substep (and of restitution) divided by the step, N. Impacts count.
    pub force: f64,
    /// Its direction, from `a` to `b`, of the largest manifold.
    pub normal: DVec3,
}

/// Two bodies in contact at the last step, as a game's rules ask of it
/// (standing on the ground, pressed against a wall, how hard). Read from
/// the pair's manifolds in the contact cache, so it is kept to the cache's
/// single precision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairContact {
    /// The first body (the lower handle).
    pub a: BodyHandle,
    /// The second body.
    pub b: BodyHandle,
    /// Unit normal from `a` to `b` of the manifold that pushed hardest (of
    /// the deepest one when none pushed), turned with `a` to where it is
    /// now.
    pub normal: DVec3,
    /// The smallest separation of their points at the start of the step,
    /// m: negative where they overlapped, up to the speculative distance
    /// where they were about to touch.
    pub separation: f64,
    /// The normal impulse between them over the step (every substep and
    /// restitution), N·s; divided by the step, the average contact force.
    pub impulse: f64,
    /// Contact points, over every manifold of the pair.
    pub points: usize,
}

/// What the rigid step reports.
#[derive(Debug, Default)]
pub(crate) struct RigidStepOut {
    pub(crate) quarantined: Vec<BodyHandle>,
    pub(crate) broken_joints: Vec<crate::handle::JointHandle>,
    pub(crate) events: Vec<ContactEvent>,
    pub(crate) forces: Vec<ContactForceEvent>,
    /// Each body's centre of mass and principal rotation at the start of
    /// the step, by slot: how far it moved over the step (push-out
    /// included, which its velocity does not show) for the rest test.
    pub(crate) start: Vec<(DVec3, glam::DQuat)>,
    /// Wall time of each stage.
    pub(crate) profile: RigidProfile,
    /// Shape pairs collided and manifolds used again.
    pub(crate) manifolds: crate::rigid::contact::ManifoldCount,
}

/// The largest vectors a step fills, kept empty between steps so that
/// each step uses their room again instead of mapping fresh pages (scratch:
/// nothing in them is read across steps).
#[derive(Debug, Default)]
pub(crate) struct StepMemory {
    /// Contact constraints.
    pub(crate) constraints: Vec<crate::rigid::solver::ContactConstraint>,
    /// Joint rows with their joint's arena index and generation.
    pub(crate) joint_rows: Vec<(u32, u32, crate::rigid::joint::JointConstraint)>,
    /// Solver bodies.
    pub(crate) solver_bodies: Vec<crate::rigid::solver::SolverBody>,
    /// The narrow phase's lists of manifolds found, one a run of pairs.
    pub(crate) found: Vec<Vec<manifolds::FoundManifold>>,
    /// The contact constraints in batches, and the bodies' hot state.
    pub(crate) wide: crate::rigid::solver::WideContacts,
}

/// Contact state carried from step to step.
#[derive(Debug, Default)]
pub(crate) struct Contacts {
    /// Each manifold of the last step, with its impulses (world state:
    /// saved and hashed).
    pub(crate) cache: ContactCache,
    /// Pairs touching at the end of the last step, for begin/end events
    /// (world state: saved and hashed).
    pub(crate) touching: std::collections::BTreeSet<(BodyHandle, BodyHandle)>,
    /// The broad phase; derived from the bodies and rebuilt after a restore.
    broad: Option<BroadPhase>,
    /// The axes that showed pairs apart at the last step (derived: nothing
    /// found depends on them; forgotten with the broad phase).
    apart: apart::SeparatingAxes,
    /// The bodies' revision when the last step found nothing could move
    /// (derived): while it stands, no body needs a look to know it.
    resting: Option<crate::arena::Revision>,
    /// The step's largest vectors, emptied, for the next step.
    pub(crate) memory: StepMemory,
    /// Deepest overlap the last step's narrow phase found between two
    /// bodies (not sensors), m; 0 when nothing overlapped. A diagnostic,
    /// derived: not saved.
    pub(crate) deepest_penetration: f64,
}

impl Contacts {
    /// Forgets the broad phase and the separating axes (after a restore or
    /// a removal the broad phase is rebuilt).
    pub(crate) fn reset_broad_phase(&mut self) {
        self.broad = None;
        self.apart.clear();
    }

    /// Drops everything about a removed body.
    pub(crate) fn forget(&mut self, h: BodyHandle) {
        let id = (h.index, h.generation);
        self.cache.retain(|k| k.a != id && k.b != id);
        self.touching.retain(|(a, b)| *a != h && *b != h);
        self.reset_broad_phase();
    }

    /// Number of manifolds touching last step.
    pub(crate) fn manifold_count(&self) -> usize {
        self.cache.len()
    }
}

/// What the rigid step reads besides the bodies, joints and contacts.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepInputs<'a> {
    /// Body force generators, compiled.
    pub(crate) field: &'a BodyField,
    /// Uniform gravity, m/s².
    pub(crate) gravity: DVec3,
    /// Solver settings.
    pub(crate) cfg: &'a SolverConfig,
    /// Extra force (N) and torque (N·m) per body, e.g. from attachments.
    pub(crate) extra: &'a BTreeMap<BodyHandle, (DVec3, DVec3)>,
    /// The step, s.
    pub(crate) dt: f64,
}

/// Times consecutive stages.
struct Stopwatch(Instant);

impl Stopwatch {
    /// Time since the last lap (or the start).
    fn lap(&mut self) -> Duration {
        let now = Instant::now();
        let d = now - self.0;
        self.0 = now;
        d
    }
}

/// Whether no body can move this step: no dynamic body is awake (sleeping
/// and quarantined ones ignore forces) and no kinematic body has a velocity.
fn at_rest(bodies: &Arena<RigidBody>) -> bool {
    bodies.iter().all(|(_, _, b)| match b.kind {
        BodyKind::Dynamic => b.sleeping || b.quarantined,
        BodyKind::Kinematic => b.linvel == DVec3::ZERO && b.angvel == DVec3::ZERO,
        BodyKind::Static => true,
    })
}

/// Advances every body by `dt`: contacts, joints, motion, events.
pub(crate) fn step(
    bodies: &mut Arena<RigidBody>,
    joints: &mut Arena<Joint>,
    contacts: &mut Contacts,
    inputs: StepInputs<'_>,
) -> RigidStepOut {
    let mut clock = Stopwatch(Instant::now());
    let mut profile = RigidProfile::default();
    if contacts.resting == Some(bodies.revision()) || at_rest(bodies) {
        // Everything asleep or still: nothing can move, touch or wake, so
        // the step changes nothing (contacts, impulses and sleep carry
        // over as they are). A settled world costs one look at each body,
        // and none again until something changes a body.
        contacts.resting = Some(bodies.revision());
        profile.forces = clock.lap();
        return RigidStepOut {
            profile,
            ..RigidStepOut::default()
        };
    }

    contacts.resting = None;
    let index = BodyIndex::new(bodies);
    let external = bodies::external_loads(bodies, &inputs);
    let links = bodies::Links::new(joints, &contacts.touching);
    links.wake(bodies);
    profile.forces = clock.lap();

    let broad = pairs::update(bodies, &index, &mut contacts.broad, inputs.dt);
    if pairs::wake_before_contact(bodies, &index, broad, inputs.dt, &inputs.cfg.sleep) {
        links.wake(bodies);
    }
    profile.broad_phase = clock.lap();

    let mut memory = std::mem::take(&mut contacts.memory);
    let spare_axes = contacts.apart.take_spare();
    let mut narrow = manifolds::find(
        bodies,
        &index,
        &links,
        broad,
        &contacts.cache,
        &contacts.apart,
        &contacts.touching,
        inputs.dt,
        &mut memory.found,
        spare_axes,
    );
    contacts.apart.replace(std::mem::take(&mut narrow.apart));
    manifolds::joint_rows(bodies, &index, joints, &mut memory.joint_rows);
    profile.narrow_phase = clock.lap();

    let mut solve = substeps::Solve::new(
        bodies,
        &narrow.constraints,
        memory,
        &inputs,
        &external,
        &crate::rigid::solver::ContactPass::new(
            inputs.cfg,
            inputs.dt / f64::from(inputs.cfg.substeps.max(1)),
            true,
        ),
    );
    profile.colouring = clock.lap();

    let quarantined = solve.run(bodies, &index, &external, &inputs);
    profile.solve = clock.lap();

    let mut out = finish::finish(
        bodies,
        joints,
        contacts,
        &index,
        solve,
        finish::Found {
            manifolds: narrow.constraints,
            touching: narrow.touching,
            carried: narrow.carried,
            deepest: narrow.deepest,
            quarantined,
        },
        &inputs,
    );
    out.manifolds = narrow.count;
    profile.finish = clock.lap();

    let links = bodies::Links::new(joints, &contacts.touching);
    crate::rigid::island::update(
        bodies,
        &index,
        links.all(),
        &out.start,
        &inputs.cfg.sleep,
        inputs.dt,
    );
    profile.islands = clock.lap();
    out.profile = profile;
    out
}
