//! Rigid bodies as the particles of a soft body or a fluid see them over
//! one step: the surfaces they are kept out of, with friction, and how
//! the particles move the dynamic ones.
//!
//! The soft stage runs after the rigid stage, so the bodies stand at their
//! new poses with their new velocities. Friction holds a particle to a
//! body's motion over the whole step ([`StepStart`]), not to the velocity
//! the rigid stage ended with: a crate floating at rest ends every rigid
//! stage sinking at its last substep's speed (the fluid lifts it again
//! after), and particles held to that speed would lift it a tenth more
//! than its weight (measured: 0.446 of it submerged instead of 0.48 at
//! 10 cm).
//!
//! Contacts share each correction with the body within the stage, as an
//! XPBD contact between two bodies does ([`Coupling::press`]): the particle
//! moves by `w_p / (w_p + w_b)` of it and the body by the rest, where
//! `w_b = 1/M + (r × n) · I⁻¹ (r × n)` is the body's inverse mass along
//! the normal, with the velocity that move takes over the substep
//! ([`Coupling::take_pushes`], after each pass: every contact of the pass
//! takes its share as though the body were its alone, and the body takes
//! their sum, so momentum is exchanged exactly). A fluid particle's
//! density constraint treats a body as a wall and moves the particle
//! alone; the body takes the push back ([`Coupling::push_back`]). Later
//! substeps meet the body where it was pushed and, before that, where the
//! rigid stage's move puts it at that substep's end ([`Coupling::follow`]):
//! the rigid stage has already moved the body for the whole step, and a
//! particle that met it there in the first substep was pushed the whole
//! step's sink deep in one substep, leaving at the number of substeps
//! times the body's speed. Held still for the stage, a body gave the
//! particles that (and took back as much): a crate dropped into a pool flew
//! 3.5 m out of it, and one dropped into a hammock bounced back higher than
//! it fell from. Attachments meet and move their bodies the same way
//! ([`CouplingBody::move_by`]): held to a body standing a whole step ahead, a
//! board hung from one rope's edge spun up until it left the world. At
//! the end of the stage each body takes its moves and the velocities that
//! came with them ([`apply_changes`]), and wakes.
//!
//! Candidates are found once a step: every body whose bounding box,
//! widened by how far a particle can reach over the step, holds the
//! particle. Bodies are taken in handle order and particles in index order,
//! and pushes are summed per chunk of particles, chunk after chunk, so the
//! result does not depend on the thread count.

use glam::{DMat3, DVec3, Vec3};

use crate::arena::Arena;
use crate::parallel::{map_chunks, CHUNK};
use crate::rigid::aabb::Aabb;
use crate::rigid::body::{BodyKind, RigidBody};
use crate::rigid::pose::Pose;
use crate::rigid::query::project_point_shape;
use crate::rigid::shape::Shape;

/// Where every body stood as the step began (derived, per step): the soft
/// stage takes a body's velocity over the step as its move since then.
#[derive(Debug, Default)]
pub(crate) struct StepStart {
    /// By arena slot: the generation, centre of mass (m) and rotation.
    poses: Vec<Option<(u32, DVec3, glam::DQuat)>>,
    /// The step, s.
    dt: f64,
}

impl StepStart {
    /// Notes where `bodies` stand before a step of `dt` seconds.
    pub(crate) fn record(&mut self, bodies: &Arena<RigidBody>, dt: f64) {
        self.poses.clear();
        self.dt = dt;
        for (index, generation, b) in bodies.iter() {
            let slot = index as usize;
            if self.poses.len() <= slot {
                self.poses.resize(slot + 1, None);
            }
            self.poses[slot] = Some((generation, b.com, b.rotation));
        }
    }

    /// The mean linear (m/s) and angular (rad/s) velocity of the body
    /// `key`, now at `com` turned by `rotation`, since the step began;
    /// `None` for a body added since, or before any record.
    pub(crate) fn mean_velocity(
        &self,
        key: (u32, u32),
        com: DVec3,
        rotation: glam::DQuat,
    ) -> Option<(DVec3, DVec3)> {
        let &(generation, com0, rotation0) = self.poses.get(key.0 as usize)?.as_ref()?;
        if generation != key.1 || self.dt <= 0.0 {
            return None;
        }
        let mut turn = rotation * rotation0.conjugate();
        if turn.w < 0.0 {
            turn = -turn;
        }
        let v = (com - com0) / self.dt;
        let w = turn.to_scaled_axis() / self.dt;
        (v.is_finite() && w.is_finite()).then_some((v, w))
    }

    /// Where body `key` stood as the step began: its centre of mass (m)
    /// and rotation.
    pub(crate) fn pose_of(&self, key: (u32, u32)) -> Option<(DVec3, glam::DQuat)> {
        let &(generation, com, rotation) = self.poses.get(key.0 as usize)?.as_ref()?;
        (generation == key.1).then_some((com, rotation))
    }
}

/// A body as the particles see it.
pub(crate) struct CouplingBody<'a> {
    /// Arena index and generation.
    pub(crate) key: (u32, u32),
    pub(crate) shape: &'a Shape,
    pub(crate) pose: Pose,
    /// The shape's box, widened by the reach.
    pub(crate) aabb: Aabb,
    com: DVec3,
    /// The body's rotation (as [`StepStart`] notes it).
    rotation: glam::DQuat,
    /// m/s.
    linvel: DVec3,
    /// rad/s.
    angvel: DVec3,
    /// 1/kg; 0 for bodies that particles cannot move (static, kinematic).
    inv_mass: f64,
    inv_inertia: DMat3,
    /// The body's dynamic friction coefficient (the pair takes the larger
    /// of the body's and the particles').
    pub(crate) friction: f64,
    /// How far attachments and a soft body's contacts moved the body
    /// within the stage: translation (m) and rotation vector (rad), and
    /// the velocities that came with it (m/s, rad/s).
    moved: Motion,
    /// The pose with `moved` applied: where particles meet the body now.
    now: Pose,
    /// The body's centre of mass in its own frame, m.
    local_com: DVec3,
    /// Where the body stood as the step began (centre of mass, m, and
    /// rotation), when known ([`Coupling::over_step`]).
    start: Option<(DVec3, glam::DQuat)>,
    /// Whether the body moves within the stage ([`CouplingBody::finds_moves`],
    /// kept with `start`).
    moves: bool,
    /// Where the body stands along its path over the step, before
    /// `moved`: centre of mass (m) and rotation ([`Coupling::follow`]).
    path: (DVec3, glam::DQuat),
}

/// What attachments did to a body within the stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Motion {
    /// Translation of the centre of mass, m.
    dx: DVec3,
    /// Rotation about the centre of mass, applied after the body's own.
    dq: glam::DQuat,
    /// Change of linear velocity, m/s.
    dv: DVec3,
    /// Change of angular velocity, rad/s.
    dw: DVec3,
}

impl Motion {
    /// A move `dx` (m) and turn `dq`, and the velocities that came with
    /// them (m/s, rad/s).
    #[cfg(feature = "gpu")]
    pub(crate) fn new(dx: DVec3, dq: glam::DQuat, dv: DVec3, dw: DVec3) -> Self {
        Self { dx, dq, dv, dw }
    }
}

impl Default for Motion {
    fn default() -> Self {
        Self {
            dx: DVec3::ZERO,
            dq: glam::DQuat::IDENTITY,
            dv: DVec3::ZERO,
            dw: DVec3::ZERO,
        }
    }
}

/// `q` turned by the rotation vector `theta` (rad), to first order and
/// normalised.
fn turned(q: glam::DQuat, theta: DVec3) -> glam::DQuat {
    let t = glam::DQuat::from_xyzw(theta.x, theta.y, theta.z, 0.0) * q;
    (q + t * 0.5).normalize()
}

impl<'a> CouplingBody<'a> {
    /// Body `b` (arena key `key`) as particles see it, its box widened by
    /// `reach` (m); `None` for sensors and bodies without a shape.
    pub(crate) fn of(key: (u32, u32), b: &'a RigidBody, reach: f64) -> Option<Self> {
        if b.sensor {
            return None;
        }
        let shape = b.shape.as_ref()?;
        let pose = b.pose();
        let movable = b.kind == BodyKind::Dynamic && !b.quarantined;
        let mut target = CouplingBody {
            key,
            shape,
            aabb: shape.aabb(&pose).expanded(reach),
            pose,
            com: b.com,
            rotation: b.rotation,
            linvel: b.linvel,
            angvel: b.angvel,
            inv_mass: if movable { b.inv_mass } else { 0.0 },
            inv_inertia: if movable {
                b.inverse_inertia_world()
            } else {
                DMat3::ZERO
            },
            friction: b.friction_dynamic,
            moved: Motion::default(),
            now: pose,
            local_com: b.local_com,
            start: None,
            moves: false,
            path: (b.com, b.rotation),
        };
        target.moves = target.finds_moves();
        Some(target)
    }

    /// Velocity of the body's material at `p`, m/s: its motion over the
    /// step and what the stage gave it since.
    pub(crate) fn velocity_at(&self, p: DVec3) -> DVec3 {
        let m = &self.moved;
        (self.linvel + m.dv) + (self.angvel + m.dw).cross(p - self.path.0 - m.dx)
    }

    /// `1/M + (r × d) · I⁻¹ (r × d)`, 1/kg, with `r` from the centre of
    /// mass as the step left it.
    pub(crate) fn inv_mass_along(&self, p: DVec3, d: DVec3) -> f64 {
        self.inv_mass_about(self.com, p, d)
    }

    /// The same with `r` from the centre of mass as the stage moved it.
    pub(crate) fn inv_mass_along_now(&self, p: DVec3, d: DVec3) -> f64 {
        self.inv_mass_about(self.path.0 + self.moved.dx, p, d)
    }

    fn inv_mass_about(&self, com: DVec3, p: DVec3, d: DVec3) -> f64 {
        if self.inv_mass == 0.0 {
            return 0.0;
        }
        let c = (p - com).cross(d);
        self.inv_mass + c.dot(self.inv_inertia * c)
    }

    /// Whether particles can move the body.
    pub(crate) fn movable(&self) -> bool {
        self.inv_mass > 0.0
    }

    /// Whether the body moves within the stage: particles can move it, or
    /// the rigid stage moved it over the step.
    fn finds_moves(&self) -> bool {
        self.movable()
            || self
                .start
                .is_some_and(|(com, rotation)| com != self.com || rotation != self.rotation)
    }

    /// A point given in the body's frame, in the world, m: where the body
    /// stands along its path and as the stage moved it.
    pub(crate) fn world_point(&self, local: DVec3) -> DVec3 {
        self.now.transform_point(local)
    }

    /// Starts a substep of `h` seconds: the velocity the stage gave the
    /// body moves it on (the rigid stage already moved it by the velocity
    /// it had, along the path [`CouplingBody::follow`] takes).
    pub(crate) fn advance(&mut self, h: f64) {
        if self.moved == Motion::default() {
            return;
        }
        self.moved.dx += self.moved.dv * h;
        self.moved.dq = turned(self.moved.dq, self.moved.dw * h);
        self.refresh();
    }

    /// `now` from the path and `moved`.
    fn refresh(&mut self) {
        let m = &self.moved;
        let (com, rotation) = self.path;
        let rotation = (m.dq * rotation).normalize();
        self.now = Pose {
            translation: com + m.dx - rotation * self.local_com,
            rotation,
        };
    }

    /// Puts the body at fraction `t` of its path over the step.
    fn follow(&mut self, t: f64) {
        let Some((com0, rotation0)) = self.start else {
            return;
        };
        self.path = (
            com0.lerp(self.com, t),
            rotation0.slerp(self.rotation, t).normalize(),
        );
        self.refresh();
    }

    /// Moves the body by a positional impulse `p` (N·s·s: impulse times
    /// the substep) at `point`, over a substep of `h` seconds (XPBD: the
    /// move is the body's share of a constraint's correction, and its
    /// velocity changes by the move over the substep).
    pub(crate) fn move_by(&mut self, point: DVec3, p: DVec3, h: f64) {
        let arm = point - self.path.0 - self.moved.dx;
        self.shift(
            Push {
                p,
                moment: arm.cross(p),
            },
            h,
        );
    }

    /// Moves the body by `push` over a substep of `h` seconds, as
    /// [`CouplingBody::move_by`].
    fn shift(&mut self, push: Push, h: f64) {
        if !(self.movable() && push.p.is_finite() && push.moment.is_finite()) {
            return;
        }
        let dx = push.p * self.inv_mass;
        let dtheta = self.inv_inertia * push.moment;
        self.moved.dx += dx;
        self.moved.dq = turned(self.moved.dq, dtheta);
        self.moved.dv += dx / h;
        self.moved.dw += dtheta / h;
        self.refresh();
    }
}

/// The surface of a body nearest a particle.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NearestSurface {
    /// The nearest point of the body's surface, m.
    pub(crate) point: DVec3,
    /// Unit normal out of the body, towards the particle.
    pub(crate) normal: DVec3,
    /// Signed distance of the particle from the surface, m (negative
    /// inside the solid).
    pub(crate) distance: f64,
}

/// What one pass of contacts gave one target ([`Coupling::press`],
/// [`Coupling::push_back`]): a positional impulse (N·s·s) and its moment
/// about the body's centre of mass as it then stood (N·m·s·s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Push {
    pub(crate) p: DVec3,
    pub(crate) moment: DVec3,
}

impl Push {
    /// Adds `other` (sums are taken chunk by chunk, in order).
    pub(crate) fn add(&mut self, other: &Push) {
        self.p += other.p;
        self.moment += other.moment;
    }
}

/// The bodies near one soft body or fluid over one step.
#[derive(Default)]
pub(crate) struct Coupling<'a> {
    pub(crate) targets: Vec<CouplingBody<'a>>,
    /// Per particle, where its candidates start in `candidates`; one more
    /// entry than particles.
    start: Vec<u32>,
    /// Indices into `targets`.
    candidates: Vec<u32>,
}

impl<'a> Coupling<'a> {
    /// The bodies within `reach` (m) of the particles `x` that can move
    /// (inverse mass `w > 0`), with every body in `always` (attachments) as
    /// a target whether near or not.
    pub(crate) fn gather(
        bodies: &'a Arena<RigidBody>,
        x: &[Vec3],
        w: &[f32],
        reach: f32,
        always: &[(u32, u32)],
    ) -> Self {
        if bodies.len() == 0 || x.is_empty() {
            return Self::default();
        }
        let Some(bounds) = particle_bounds(x) else {
            return Self::default();
        };
        let reach = f64::from(reach);
        let bounds = bounds.expanded(reach);
        let targets: Vec<CouplingBody<'a>> = bodies
            .iter()
            .filter_map(|(index, generation, b)| {
                let t = CouplingBody::of((index, generation), b, reach)?;
                let wanted = always.contains(&(index, generation));
                (wanted || t.aabb.intersects(&bounds)).then_some(t)
            })
            .collect();
        let mut start = Vec::with_capacity(x.len() + 1);
        let mut candidates = Vec::new();
        if !targets.is_empty() {
            let found = map_chunks(x, CHUNK, |base, xs| {
                let mut counts = Vec::with_capacity(xs.len());
                let mut list = Vec::new();
                for (k, p) in xs.iter().enumerate() {
                    let before = list.len();
                    if w[base + k] > 0.0 {
                        let p = p.as_dvec3();
                        for (t, target) in targets.iter().enumerate() {
                            if target.aabb.contains_point(p) {
                                list.push(t as u32);
                            }
                        }
                    }
                    counts.push((list.len() - before) as u32);
                }
                (counts, list)
            });
            let mut at = 0u32;
            for (counts, list) in found {
                for n in counts {
                    start.push(at);
                    at += n;
                }
                candidates.extend(list);
            }
            start.push(at);
        }
        Self {
            targets,
            start,
            candidates,
        }
    }

    /// Whether no particle has a body near it.
    pub(crate) fn is_empty(&self) -> bool {
        self.candidates.is_empty()
    }

    /// The index of the target for body `key`, if it is one.
    pub(crate) fn target_of(&self, key: (u32, u32)) -> Option<usize> {
        self.targets.iter().position(|t| t.key == key)
    }

    /// The candidate bodies of particle `i`.
    pub(crate) fn candidates(&self, i: usize) -> &[u32] {
        if self.start.is_empty() {
            return &[];
        }
        &self.candidates[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// The surface of candidate `target` nearest `x`, if the particle is
    /// within `within` (m) of it or inside.
    pub(crate) fn surface(&self, target: u32, x: Vec3, within: f64) -> Option<NearestSurface> {
        let t = &self.targets[target as usize];
        let x = x.as_dvec3();
        let p = project_point_shape(t.shape, &t.now, x)?;
        if !p.inside && p.distance >= within {
            return None;
        }
        let to = x - p.point;
        let len = to.length();
        if len <= 1e-12 || !len.is_finite() {
            return None;
        }
        let normal = if p.inside { -to / len } else { to / len };
        Some(NearestSurface {
            point: p.point,
            normal,
            distance: if p.inside { -p.distance } else { p.distance },
        })
    }

    /// The correction (m) that keeps a particle at `x`, where it stood at
    /// `prev` at the start of a substep of `h` seconds, `radius` out of
    /// target `target` whose surface `s` is nearest it, with Coulomb
    /// friction `mu` (the larger of it and the body's): the slide relative
    /// to the surface over the substep, undone up to `mu` times the normal
    /// correction.
    #[allow(clippy::too_many_arguments)]
    fn correction(
        &self,
        target: u32,
        s: &NearestSurface,
        x: Vec3,
        prev: Vec3,
        radius: f32,
        mu: f32,
        h: f32,
    ) -> DVec3 {
        let t = &self.targets[target as usize];
        let depth = f64::from(radius) - s.distance;
        let mut dx = s.normal * depth;
        let mu = f64::from(mu).max(t.friction);
        if mu > 0.0 {
            let moved = (x - prev).as_dvec3() + dx - t.velocity_at(s.point) * f64::from(h);
            let slide = moved - s.normal * moved.dot(s.normal);
            let len = slide.length();
            if len > 1e-12 {
                let cap = mu * depth;
                dx -= slide * (cap / len).min(1.0);
            }
        }
        dx
    }

    /// Keeps particle `i` (at `x`, where it stood at `prev` at the start of
    /// the substep of `h` seconds, inverse mass `w`) `radius` out of every
    /// candidate body, with Coulomb friction `mu` (the larger of it and the
    /// body's) against the body's motion. The pair shares each correction
    /// as an XPBD contact between two bodies does: the particle takes
    /// `w / (w + w_b)` of it, and the body's goes to
    /// `pushes` as a positional impulse `−Δx / (w + w_b)` (N·s·s, with its
    /// moment), for [`Coupling::take_pushes`] after the pass.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn press(
        &self,
        i: usize,
        x: &mut Vec3,
        prev: Vec3,
        w: f32,
        radius: f32,
        mu: f32,
        h: f32,
        pushes: &mut [Push],
    ) {
        for &target in self.candidates(i) {
            let Some(s) = self.surface(target, *x, f64::from(radius)) else {
                continue;
            };
            let dx = self.correction(target, &s, *x, prev, radius, mu, h);
            let t = &self.targets[target as usize];
            let n = dx.normalize_or_zero();
            let w_b = t.inv_mass_along_now(s.point, n);
            let k = f64::from(w) + w_b;
            if k <= 0.0 {
                continue;
            }
            let new = (x.as_dvec3() + dx * (f64::from(w) / k)).as_vec3();
            if !new.is_finite() {
                continue;
            }
            *x = new;
            if w_b > 0.0 {
                self.give(pushes, target, s.point, -dx / k);
            }
        }
    }

    /// The push a fluid particle of inverse mass `w` gives the body of
    /// target `target` when the wall term of its density constraint moved
    /// it by `moved` (m) off the plane through `point` with `normal`: the
    /// positional impulse `−moved / (w + w_b)`, added to `pushes` (the
    /// particle's own move is not shared: the density constraint takes the
    /// body as a wall).
    pub(crate) fn push_back(
        &self,
        pushes: &mut [Push],
        target: u32,
        point: DVec3,
        normal: DVec3,
        moved: DVec3,
        w: f64,
    ) {
        let w_b = self.targets[target as usize].inv_mass_along_now(point, normal);
        let k = w + w_b;
        if w_b > 0.0 && k > 0.0 {
            self.give(pushes, target, point, -moved / k);
        }
    }

    /// Adds the positional impulse `p` (N·s·s) at `point` (m) on target
    /// `target` to `pushes`.
    fn give(&self, pushes: &mut [Push], target: u32, point: DVec3, p: DVec3) {
        let t = &self.targets[target as usize];
        if !p.is_finite() {
            return;
        }
        let push = &mut pushes[target as usize];
        push.p += p;
        push.moment += (point - t.path.0 - t.moved.dx).cross(p);
    }

    /// Moves every body by what a pass of [`Coupling::press`] and
    /// [`Coupling::push_back`] gave it (`pushes`, summed over the pass's
    /// chunks in order) over a substep of `h` seconds.
    pub(crate) fn take_pushes(&mut self, pushes: &[Push], h: f64) {
        for (t, push) in self.targets.iter_mut().zip(pushes) {
            if *push != Push::default() {
                t.shift(*push, h);
            }
        }
    }

    /// A fresh accumulator of [`Push`]es, one per target.
    pub(crate) fn new_pushes(&self) -> Vec<Push> {
        vec![Push::default(); self.targets.len()]
    }

    /// Starts a substep of `h` seconds for every target: the velocity the
    /// stage gave it moves it on.
    pub(crate) fn advance(&mut self, h: f64) {
        for t in &mut self.targets {
            t.advance(h);
        }
    }

    /// Puts every target where it stood at fraction `t` (0 to 1) of the
    /// step along its path, for the contacts and attachments of a substep
    /// ending there.
    pub(crate) fn follow(&mut self, t: f64) {
        for target in &mut self.targets {
            target.follow(t);
        }
    }

    /// Takes each target's velocity as its mean over the step that
    /// `start` saw begin (bodies it did not see keep theirs).
    pub(crate) fn over_step(&mut self, start: &StepStart) {
        for t in &mut self.targets {
            if let Some((v, w)) = start.mean_velocity(t.key, t.com, t.rotation) {
                t.linvel = v;
                t.angvel = w;
                t.start = start.pose_of(t.key);
                t.moves = t.finds_moves();
            }
        }
    }

    /// Whether any target moves within the stage: one particles can move,
    /// or one the rigid stage moved over the step (so the planes found at
    /// its start no longer bound where it stands).
    pub(crate) fn moving(&self) -> bool {
        self.targets.iter().any(|t| t.moves)
    }

    /// A point and a normal (m, unit) given at the start of the stage in
    /// the world, in target `target`'s frame as it then stood: a frame that
    /// moves with the body within the stage (unchanged for a body that
    /// keeps still).
    pub(crate) fn to_body(&self, target: u32, point: DVec3, normal: DVec3) -> (DVec3, DVec3) {
        let t = &self.targets[target as usize];
        if !t.moves {
            return (point, normal);
        }
        (
            t.now.inverse_transform_point(point),
            t.now.rotation.inverse() * normal,
        )
    }

    /// A point and a normal in target `target`'s frame ([`Coupling::to_body`])
    /// where the body now stands.
    pub(crate) fn to_world(&self, target: u32, point: DVec3, normal: DVec3) -> (DVec3, DVec3) {
        let t = &self.targets[target as usize];
        if !t.moves {
            return (point, normal);
        }
        (t.now.transform_point(point), t.now.rotation * normal)
    }

    /// Whether the candidate lists were gathered for `n` particles (or
    /// hold none at all).
    pub(crate) fn covers(&self, n: usize) -> bool {
        self.start.is_empty() || self.start.len() == n + 1
    }

    /// Whether target `target`'s shape is convex (its nearest surface
    /// point moves smoothly, and the plane there bounds the whole body).
    pub(crate) fn is_convex(&self, target: u32) -> bool {
        self.targets[target as usize].shape.is_convex()
    }

    /// What the particles did to each movable body, by body key.
    pub(crate) fn finish(self) -> Vec<BodyChange> {
        self.targets
            .iter()
            .filter(|t| t.movable() && t.moved != Motion::default())
            .map(|t| BodyChange {
                key: t.key,
                moved: t.moved,
            })
            .collect()
    }
}

/// What the particles did to one body over the stage.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BodyChange {
    key: (u32, u32),
    /// Its moves by contacts and attachments.
    moved: Motion,
}

impl BodyChange {
    /// The moves `moved` of body `key` within the stage (particles on the
    /// GPU make them there).
    #[cfg(feature = "gpu")]
    pub(crate) fn of_motion(key: (u32, u32), moved: Motion) -> Self {
        Self { key, moved }
    }
}

/// Gives every body what the particles did to it ([`Coupling::finish`]):
/// its moves, and the velocities that came with them; and wakes it (its
/// rest timer starts again). A change that is not finite is dropped.
pub(crate) fn apply_changes(bodies: &mut Arena<RigidBody>, changes: &[BodyChange]) {
    for c in changes {
        let m = c.moved;
        let finite = [m.dx, m.dv, m.dw].iter().all(|v| v.is_finite()) && m.dq.is_finite();
        if !finite {
            continue;
        }
        if let Some(b) = bodies.get_mut(c.key.0, c.key.1) {
            // A body the particles push is not at rest: its rest timer
            // starts again, so it does not fall asleep between two
            // steps' pushes (asleep, it would skip its weight in the
            // rigid stage and still take the push).
            b.wake();
            b.linvel += m.dv;
            b.angvel += m.dw;
            b.com += m.dx;
            b.rotation = (m.dq * b.rotation).normalize();
        }
    }
}

/// The box around `x`, m.
pub(crate) fn particle_bounds(x: &[Vec3]) -> Option<Aabb> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in x {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo.is_finite() && hi.is_finite()).then(|| Aabb {
        min: lo.as_dvec3(),
        max: hi.as_dvec3(),
    })
}

#[cfg(test)]
mod tests {
    use glam::{DQuat, DVec3, Vec3};

    use super::*;
    use crate::rigid::body::RigidBodyDesc;

    /// A body moved 3 cm along x and turned 0.1 rad about y over a step of
    /// 0.05 s is seen moving at 0.6 m/s and turning at 2 rad/s, whatever
    /// velocity the rigid stage left it with; a body added since the
    /// record keeps its own.
    #[test]
    fn a_body_moves_at_its_mean_velocity_over_the_step() {
        let mut bodies = Arena::default();
        let desc = RigidBodyDesc::dynamic(
            Shape::cuboid(DVec3::splat(0.5)).unwrap(),
            100.0,
            Pose::default(),
        )
        .unwrap();
        let key = bodies.insert(desc.build().unwrap());
        let mut start = StepStart::default();
        start.record(&bodies, 0.05);
        let b = bodies.get_mut(key.0, key.1).unwrap();
        b.com += DVec3::new(0.03, 0.0, 0.0);
        b.rotation = DQuat::from_rotation_y(0.1) * b.rotation;
        b.linvel = DVec3::new(0.0, -1.0, 0.0);
        let late = bodies.insert(desc.build().unwrap());
        bodies.get_mut(late.0, late.1).unwrap().linvel = DVec3::new(0.0, -1.0, 0.0);

        let x = [Vec3::ZERO];
        let mut coupling = Coupling::gather(&bodies, &x, &[1.0], 1.0, &[]);
        coupling.over_step(&start);
        let t = &coupling.targets[coupling.target_of(key).unwrap()];
        assert!(
            (t.linvel - DVec3::new(0.6, 0.0, 0.0)).length() < 1e-9,
            "{}",
            t.linvel
        );
        assert!(
            (t.angvel - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-9,
            "{}",
            t.angvel
        );
        let t = &coupling.targets[coupling.target_of(late).unwrap()];
        assert_eq!(t.linvel, DVec3::new(0.0, -1.0, 0.0));
    }
}
