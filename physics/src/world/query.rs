//! Scene queries on the world's rigid bodies: ray casts, overlap, point
//! projection and shape casts.
//!
//! Each query walks the bodies in handle order, skips those without a
//! shape or whose box (`shape.aabb(&body.pose())`) cannot be involved,
//! and asks [`rigid::query`](crate::rigid::query) for the exact answer.
//! The walk is linear in the number of bodies; it reads the bodies' current
//! poses, so it is exact between steps even after teleports, when the
//! broad phase's fat boxes would be stale. Ties are broken by body handle,
//! so every result is deterministic.

use glam::DVec3;

use super::World;
use crate::error::{direction, finite3, non_negative, PhysicsError};
use crate::handle::BodyHandle;
use crate::rigid::body::RigidBody;
use crate::rigid::pose::Pose;
use crate::rigid::query::{
    self, cast_shape, overlap, project_point_shape, ray_aabb, ray_cast_shape, CastError,
    PointProjection, RayHit,
};
use crate::rigid::shape::Shape;

/// Checks a ray's input: finite origin, finite non-zero direction,
/// finite `max_t >= 0`.
pub(super) fn check_ray(origin: DVec3, dir: DVec3, max_t: f64) -> Result<(), PhysicsError> {
    finite3("ray origin", origin)?;
    direction("ray direction", dir)?;
    non_negative("ray max_t", max_t)?;
    Ok(())
}

/// A finite pose with its rotation renormalised (as bodies' are).
fn check_pose(what: &'static str, pose: Pose) -> Result<Pose, PhysicsError> {
    finite3(what, pose.translation)?;
    let rotation = crate::rigid::body::checked_rotation(pose.rotation)?;
    Ok(Pose::new(pose.translation, rotation))
}

/// Offers body `h` to a nearest-hit search along the ray `(origin, dir,
/// max_t)`: `best` becomes it when its shape is hit nearer than the best
/// so far, ties to the lower handle whatever order bodies come in.
/// `filter` is only asked about bodies whose box the ray crosses before
/// the best hit so far.
pub(super) fn offer_to_ray(
    best: &mut Option<(BodyHandle, RayHit)>,
    h: BodyHandle,
    b: &RigidBody,
    (origin, dir, max_t): (DVec3, DVec3, f64),
    filter: &mut impl FnMut(BodyHandle, &RigidBody) -> bool,
) {
    let Some(shape) = b.shape() else { return };
    let pose = b.pose();
    let limit = best.map_or(max_t, |(_, hit)| hit.t);
    let Some(entry) = ray_aabb(origin, dir, limit, &shape.aabb(&pose).expanded(1e-9)) else {
        return;
    };
    if best.is_some_and(|(_, hit)| entry > hit.t) || !filter(h, b) {
        return;
    }
    if let Some(hit) = ray_cast_shape(shape, &pose, origin, dir, limit) {
        let nearer = match *best {
            None => true,
            Some((bh, bhit)) => hit.t < bhit.t || (hit.t == bhit.t && h < bh),
        };
        if nearer {
            *best = Some((h, hit));
        }
    }
}

impl World {
    /// The bodies with a shape, in handle order, with that shape and the
    /// body's pose.
    fn shaped_bodies(&self) -> impl Iterator<Item = (BodyHandle, &RigidBody, &Shape, Pose)> {
        self.bodies()
            .filter_map(|(h, b)| b.shape().map(|s| (h, b, s, b.pose())))
    }

    /// Every hit of the ray `origin + t · dir` (`0 <= t <= max_t`, `t` in
    /// units of `|dir|`, so m for a unit `dir`) on bodies that `filter`
    /// accepts, one per body (its first hit), sorted by `t` then handle.
    ///
    /// A ray that starts inside a solid shape hits it at `t = 0` with normal
    /// `−dir` (see [`rigid::query`](crate::rigid::query)).
    ///
    /// # Errors
    /// [`PhysicsError::NonFinite`] for a non-finite origin, direction or
    /// `max_t`, [`PhysicsError::ZeroDirection`] for a zero direction,
    /// [`PhysicsError::Negative`] for `max_t < 0`.
    pub fn cast_ray_all(
        &self,
        origin: DVec3,
        dir: DVec3,
        max_t: f64,
        mut filter: impl FnMut(BodyHandle, &RigidBody) -> bool,
    ) -> Result<Vec<(BodyHandle, RayHit)>, PhysicsError> {
        check_ray(origin, dir, max_t)?;
        let mut hits = Vec::new();
        for (h, b, shape, pose) in self.shaped_bodies() {
            if ray_aabb(origin, dir, max_t, &shape.aabb(&pose).expanded(1e-9)).is_none()
                || !filter(h, b)
            {
                continue;
            }
            if let Some(hit) = ray_cast_shape(shape, &pose, origin, dir, max_t) {
                hits.push((h, hit));
            }
        }
        hits.sort_by(|a, b| a.1.t.total_cmp(&b.1.t).then(a.0.cmp(&b.0)));
        Ok(hits)
    }

    /// The nearest hit of the ray `origin + t · dir` (`0 <= t <= max_t`)
    /// on the bodies that `filter` accepts; ties go to the lower handle.
    /// See [`World::cast_ray_all`] for units and conventions. `filter` is
    /// only asked about bodies whose box the ray crosses.
    ///
    /// ```
    /// use inertia_physics::glam::DVec3;
    /// use inertia_physics::rigid::body::RigidBodyDesc;
    /// use inertia_physics::rigid::pose::Pose;
    /// use inertia_physics::rigid::shape::Shape;
    /// use inertia_physics::{World, WorldConfig};
    ///
    /// let mut world = World::new(WorldConfig::default()).unwrap();
    /// let ball = Shape::sphere(1.0).unwrap();
    /// let pose = Pose::from_translation(DVec3::new(5.0, 0.0, 0.0));
    /// let h = world.add_body(&RigidBodyDesc::fixed(ball, pose)).unwrap();
    /// let (hit_body, hit) = world
    ///     .cast_ray(DVec3::ZERO, DVec3::X, 100.0, |_, _| true)
    ///     .unwrap()
    ///     .expect("the ray meets the ball");
    /// assert_eq!(hit_body, h);
    /// assert!((hit.t - 4.0).abs() < 1e-12); // m, since dir is a unit vector
    /// assert!((hit.normal + DVec3::X).length() < 1e-12);
    /// ```
    ///
    /// # Errors
    /// As [`World::cast_ray_all`].
    pub fn cast_ray(
        &self,
        origin: DVec3,
        dir: DVec3,
        max_t: f64,
        mut filter: impl FnMut(BodyHandle, &RigidBody) -> bool,
    ) -> Result<Option<(BodyHandle, RayHit)>, PhysicsError> {
        check_ray(origin, dir, max_t)?;
        let mut best: Option<(BodyHandle, RayHit)> = None;
        for (h, b) in self.bodies() {
            offer_to_ray(&mut best, h, b, (origin, dir, max_t), &mut filter);
        }
        Ok(best)
    }

    /// The bodies whose shapes touch or overlap `shape` placed at `pose`
    /// (world), sorted by handle.
    ///
    /// # Errors
    /// [`PhysicsError::NonFinite`] for a non-finite translation or rotation,
    /// [`PhysicsError::ZeroDirection`] for a zero rotation quaternion
    /// (others are renormalised), [`PhysicsError::Invalid`] when `shape` and
    /// a body's shape are both triangle meshes or heightfields (no test
    /// exists between two surfaces).
    pub fn overlap_shape(
        &self,
        shape: &Shape,
        pose: Pose,
    ) -> Result<Vec<BodyHandle>, PhysicsError> {
        let pose = check_pose("query pose", pose)?;
        let bounds = shape.aabb(&pose);
        let mut out = Vec::new();
        for (h, _, body_shape, body_pose) in self.shaped_bodies() {
            if !body_shape.aabb(&body_pose).intersects(&bounds) {
                continue;
            }
            let hit = overlap(shape, &pose, body_shape, &body_pose).map_err(|e| {
                PhysicsError::Invalid {
                    what: "overlap query",
                    why: e.to_string(),
                }
            })?;
            if hit {
                out.push(h);
            }
        }
        Ok(out)
    }

    /// The body nearest to `point` (m, world) and the projection onto its
    /// surface; bodies containing the point come first (deepest first), then
    /// the nearest outside; ties go to the lower handle. `None` when no
    /// body has a shape.
    ///
    /// # Errors
    /// [`PhysicsError::NonFinite`] for a non-finite point.
    pub fn project_point(
        &self,
        point: DVec3,
    ) -> Result<Option<(BodyHandle, PointProjection)>, PhysicsError> {
        finite3("query point", point)?;
        let mut best: Option<(BodyHandle, PointProjection)> = None;
        for (h, _, shape, pose) in self.shaped_bodies() {
            if let Some((_, b)) = best {
                // The box is no farther than the shape: skip bodies whose
                // box is farther than the best outside distance (or, once a
                // body holds the point, any body whose box does not).
                let bounds = shape.aabb(&pose);
                let gap = (bounds.min - point)
                    .max(point - bounds.max)
                    .max(DVec3::ZERO);
                if gap.length() > b.signed_distance().max(0.0) {
                    continue;
                }
            }
            let Some(p) = project_point_shape(shape, &pose, point) else {
                continue;
            };
            if best.is_none_or(|(_, b)| p.signed_distance() < b.signed_distance()) {
                best = Some((h, p));
            }
        }
        Ok(best)
    }

    /// Sweeps the convex `shape` from `pose` along `dir` without turning
    /// and returns the first body it touches with the time of impact `t`
    /// (in units of `|dir|`, `0 <= t <= max_t`: the shape then sits at
    /// `pose.translation + t · dir`). Found by conservative advancement,
    /// accurate to [`query::CAST_TOLERANCE`] of gap and never past the
    /// true time; a shape already touching a body gives `t = 0`. Ties go
    /// to the lower handle.
    ///
    /// # Errors
    /// [`PhysicsError::NonFinite`] for non-finite input,
    /// [`PhysicsError::ZeroDirection`] for a zero `dir`,
    /// [`PhysicsError::Negative`] for `max_t < 0`,
    /// [`PhysicsError::ZeroDirection`] also for a zero rotation quaternion
    /// (others are renormalised), and [`PhysicsError::Invalid`] for a shape
    /// that is not convex (cast a compound's children one by one).
    pub fn cast_shape(
        &self,
        shape: &Shape,
        pose: Pose,
        dir: DVec3,
        max_t: f64,
    ) -> Result<Option<(BodyHandle, f64)>, PhysicsError> {
        let pose = check_pose("cast pose", pose)?;
        direction("cast direction", dir)?;
        non_negative("cast max_t", max_t)?;
        if !shape.is_convex() {
            return Err(PhysicsError::Invalid {
                what: "cast shape",
                why: "must be convex (sphere, cuboid, capsule, cylinder or hull)".into(),
            });
        }
        let end = Pose::new(pose.translation + dir * max_t, pose.rotation);
        let swept = shape.aabb(&pose).union(&shape.aabb(&end));
        let mut best: Option<(BodyHandle, f64)> = None;
        for (h, _, body_shape, body_pose) in self.shaped_bodies() {
            if !body_shape
                .aabb(&body_pose)
                .intersects(&swept.expanded(query::CAST_TOLERANCE))
            {
                continue;
            }
            let limit = best.map_or(max_t, |b| b.1);
            let toi = cast_shape(shape, &pose, dir, limit, body_shape, &body_pose).map_err(
                |e: CastError| PhysicsError::Invalid {
                    what: "shape cast",
                    why: e.to_string(),
                },
            )?;
            if let Some(t) = toi {
                if best.is_none_or(|b| t < b.1) {
                    best = Some((h, t));
                }
            }
        }
        Ok(best)
    }
}

// ------------------------------------------------------ landing prediction

use glam::DQuat;

use crate::error::positive;
use crate::rigid::aabb::Aabb;
use crate::rigid::ballistic::{
    Landing, Trajectory, LANDING_FINE_SAGITTA, LANDING_MAX_CHORDS, LANDING_SAGITTA,
};
use crate::rigid::body::BodyKind;
use crate::rigid::narrow::collide;

/// Contacts at the landing pose are looked for this far apart, m (the
/// cast stops within [`query::CAST_TOLERANCE`]).
const LANDING_CONTACT_MARGIN: f64 = 10.0 * query::CAST_TOLERANCE;

/// The most halvings of a hit chord.
const LANDING_MAX_DEPTH: u32 = 40;

/// A convex piece of the moving body: its pose in the body frame and its
/// shape.
type Part<'a> = (Pose, &'a Shape);

/// The convex pieces of `shape` placed by `local` (compounds are opened).
fn convex_parts<'a>(
    shape: &'a Shape,
    local: Pose,
    out: &mut Vec<Part<'a>>,
) -> Result<(), PhysicsError> {
    match shape {
        Shape::Compound(children) => {
            for (p, child) in children.iter() {
                convex_parts(child, local.mul(p), out)?;
            }
            Ok(())
        }
        s if s.is_convex() => {
            out.push((local, s));
            Ok(())
        }
        _ => Err(PhysicsError::Invalid {
            what: "landing prediction",
            why: "the body's shape must be convex or a compound of convex parts \
                  (a triangle mesh or heightfield cannot be swept)"
                .into(),
        }),
    }
}

/// The pieces `collide` accepts of a target at `pose`: compounds opened,
/// everything else as it is.
fn target_leaves<'a>(shape: &'a Shape, pose: Pose, out: &mut Vec<Part<'a>>) {
    if let Shape::Compound(children) = shape {
        for (p, child) in children.iter() {
            target_leaves(child, pose.mul(p), out);
        }
    } else {
        out.push((pose, shape));
    }
}

/// A body the swept path may meet.
struct SweepTarget<'a> {
    handle: BodyHandle,
    shape: &'a Shape,
    pose: Pose,
    bounds: Aabb,
}

/// The first hit along one chord: which target, where along the chord
/// (0..=1), and the ray hit when the body has no shape.
#[derive(Clone, Copy)]
struct ChordHit {
    target: usize,
    fraction: f64,
    ray: Option<RayHit>,
}

/// The nearest contact between the moving parts at `frame` and a target,
/// within `margin`: point on the target (m, world), unit normal out of the
/// target, separation (m).
fn nearest_contact(
    parts: &[Part<'_>],
    frame: Pose,
    target: &SweepTarget<'_>,
    margin: f64,
) -> Result<Option<(DVec3, DVec3, f64)>, PhysicsError> {
    let mut leaves = Vec::new();
    target_leaves(target.shape, target.pose, &mut leaves);
    let mut best: Option<(DVec3, DVec3, f64)> = None;
    for (local, part) in parts {
        let pose = frame.mul(local);
        for (leaf_pose, leaf) in &leaves {
            let m = collide(part, &pose, leaf, leaf_pose, margin).map_err(|e| {
                PhysicsError::Invalid {
                    what: "landing prediction",
                    why: e.to_string(),
                }
            })?;
            let Some(min) = m.min_separation() else {
                continue;
            };
            if best.is_some_and(|b| min >= b.2) {
                continue;
            }
            let near: Vec<DVec3> = m
                .points
                .iter()
                .filter(|p| p.separation <= min + query::CAST_TOLERANCE)
                .map(|p| leaf_pose.transform_point(p.local_b))
                .collect();
            let point = near.iter().copied().sum::<DVec3>() / near.len() as f64;
            best = Some((point, -m.normal, min));
        }
    }
    Ok(best)
}

/// The body's path and the bodies near it.
struct Sweep<'a> {
    path: Trajectory,
    rotation: DQuat,
    local_com: DVec3,
    /// Bounding radius about the centre of mass, m (0 without a shape).
    radius: f64,
    /// Convex pieces of the body; empty: a ray from the centre of mass.
    parts: Vec<Part<'a>>,
    targets: Vec<SweepTarget<'a>>,
    /// Targets the body touches at the start and moves away from: ignored
    /// until it has left them.
    leaving: Vec<bool>,
    /// Largest acceleration on the path, m/s².
    accel: f64,
}

impl Sweep<'_> {
    /// The body frame when the centre of mass is at `com`.
    fn frame(&self, com: DVec3) -> Pose {
        Pose::new(com - self.rotation * self.local_com, self.rotation)
    }

    /// How far a chord of `dt` seconds can bulge off the path, m.
    fn sagitta(&self, dt: f64) -> f64 {
        self.accel * dt * dt / 8.0
    }

    /// The first target the body (or its centre of mass) meets moving
    /// along the chord from `path(t0)` to `path(t1)`; ties go to the lower
    /// handle.
    fn cast_chord(&self, t0: f64, t1: f64) -> Result<Option<ChordHit>, PhysicsError> {
        let c0 = self.path.position(t0);
        let dir = self.path.position(t1) - c0;
        if dir == DVec3::ZERO || !dir.is_finite() {
            return Ok(None);
        }
        let reach = Aabb::new(c0.min(c0 + dir), c0.max(c0 + dir))
            .expanded(self.radius + 2.0 * query::CAST_TOLERANCE);
        let frame = self.frame(c0);
        let mut best: Option<ChordHit> = None;
        for (i, target) in self.targets.iter().enumerate() {
            if self.leaving[i] || !target.bounds.intersects(&reach) {
                continue;
            }
            if self.parts.is_empty() {
                let limit = best.map_or(1.0, |b| b.fraction);
                if let Some(hit) = ray_cast_shape(target.shape, &target.pose, c0, dir, limit) {
                    if best.is_none_or(|b| hit.t < b.fraction) {
                        best = Some(ChordHit {
                            target: i,
                            fraction: hit.t,
                            ray: Some(hit),
                        });
                    }
                }
                continue;
            }
            for (local, part) in &self.parts {
                let limit = best.map_or(1.0, |b| b.fraction);
                let toi = cast_shape(
                    part,
                    &frame.mul(local),
                    dir,
                    limit,
                    target.shape,
                    &target.pose,
                )
                .map_err(|e: CastError| PhysicsError::Invalid {
                    what: "landing prediction",
                    why: e.to_string(),
                })?;
                if let Some(s) = toi {
                    if best.is_none_or(|b| s < b.fraction) {
                        best = Some(ChordHit {
                            target: i,
                            fraction: s,
                            ray: None,
                        });
                    }
                }
            }
        }
        Ok(best)
    }

    /// Halves the hit chord `[t0, t1]`, keeping the first half that still
    /// hits, until it hugs the path; returns the hit and its chord. A chord
    /// whose halves both miss (the path grazes past) keeps its own hit.
    fn refine(
        &self,
        mut t0: f64,
        mut t1: f64,
        mut hit: ChordHit,
    ) -> Result<(ChordHit, f64, f64), PhysicsError> {
        for _ in 0..LANDING_MAX_DEPTH {
            if self.sagitta(t1 - t0) <= LANDING_FINE_SAGITTA {
                break;
            }
            let tm = 0.5 * (t0 + t1);
            if let Some(h) = self.cast_chord(t0, tm)? {
                (hit, t1) = (h, tm);
            } else if let Some(h) = self.cast_chord(tm, t1)? {
                (hit, t0) = (h, tm);
            } else {
                break;
            }
        }
        Ok((hit, t0, t1))
    }

    /// Whether the body, at `path(t)`, still touches target `i`.
    fn still_touching(&self, t: f64, i: usize) -> Result<bool, PhysicsError> {
        let frame = self.frame(self.path.position(t));
        Ok(nearest_contact(
            &self.parts,
            frame,
            &self.targets[i],
            2.0 * query::CAST_TOLERANCE,
        )?
        .is_some())
    }

    /// The landing for a hit at time `t`.
    fn landing(&self, hit: ChordHit, time: f64) -> Result<Landing, PhysicsError> {
        let com = self.path.position(time);
        let velocity = self.path.velocity(time);
        let target = &self.targets[hit.target];
        let (point, normal) = match hit.ray {
            Some(ray) => (ray.point, ray.normal),
            None => {
                match nearest_contact(&self.parts, self.frame(com), target, LANDING_CONTACT_MARGIN)?
                {
                    Some((point, normal, _)) => (point, normal),
                    None => {
                        // Not expected (the cast stops within its tolerance):
                        // the nearest surface point to the centre of mass.
                        let fallback = -velocity.normalize_or_zero();
                        match project_point_shape(target.shape, &target.pose, com) {
                            Some(p) => {
                                (p.point, (com - p.point).try_normalize().unwrap_or(fallback))
                            }
                            None => (com, fallback),
                        }
                    }
                }
            }
        };
        Ok(Landing {
            time,
            point,
            normal,
            center_of_mass: com,
            velocity,
            body: target.handle,
        })
    }
}

impl World {
    /// The analytic path of a body's centre of mass from its current state
    /// (see [`ballistic`](crate::rigid::ballistic)): for a dynamic body the
    /// world's gravity times its gravity scale, with its linear damping
    /// as the drag rate (the continuous form of the per-substep
    /// `v / (1 + c h)`); kinematic bodies keep their velocity and static
    /// ones stay put. Force generators, scripted forces, contacts and
    /// joints are not part of it.
    ///
    /// # Errors
    /// [`PhysicsError::UnknownBody`] for a stale handle.
    pub fn body_trajectory(&self, body: BodyHandle) -> Result<Trajectory, PhysicsError> {
        let b = self.body(body).ok_or(PhysicsError::UnknownBody(body))?;
        let (gravity, drag) = match b.kind {
            BodyKind::Dynamic => (self.gravity * b.gravity_scale, b.linear_damping),
            BodyKind::Kinematic | BodyKind::Static => (DVec3::ZERO, 0.0),
        };
        let velocity = if b.kind == BodyKind::Static {
            DVec3::ZERO
        } else {
            b.linvel
        };
        Trajectory::new(b.com, velocity, gravity, drag)
    }

    /// Where `body` will first hit another body within `max_time` seconds
    /// if it flies freely from its current state along
    /// [`World::body_trajectory`]: gravity and linear damping only — force
    /// generators (drag, wind, buoyancy, blasts), scripted forces and
    /// joints are ignored, and the shape keeps its current orientation
    /// (spin is ignored). `None` when nothing is hit in time.
    ///
    /// The shape (each convex part of a compound) is swept with shape casts
    /// along chords of the path, each bulging off it by at most
    /// [`LANDING_SAGITTA`] (longer when the flight would need more than
    /// [`LANDING_MAX_CHORDS`]); the first chord that hits is halved down
    /// to [`LANDING_FINE_SAGITTA`], so the time and point are those of the
    /// true path to about the cast tolerance (0.1 mm of gap). A body with
    /// no shape traces its centre of mass with rays. Every other body with
    /// a shape can be hit, whatever its kind or sleep state, except
    /// sensors and quarantined bodies (which stop nothing); bodies the body
    /// touches at the start and moves away from are ignored until it has
    /// left them. A path that could only graze past an obstacle by less
    /// than a chord's bulge may miss or hit it. Deterministic: bodies are
    /// visited in handle order and ties go to the lower handle.
    ///
    /// ```
    /// use inertia_physics::glam::DVec3;
    /// use inertia_physics::rigid::body::RigidBodyDesc;
    /// use inertia_physics::rigid::pose::Pose;
    /// use inertia_physics::rigid::shape::Shape;
    /// use inertia_physics::{World, WorldConfig};
    ///
    /// let mut world = World::new(WorldConfig::default()).unwrap();
    /// world.set_gravity(DVec3::new(0.0, -10.0, 0.0)).unwrap();
    /// let slab = Shape::cuboid(DVec3::new(50.0, 0.5, 50.0)).unwrap();
    /// let ground = world
    ///     .add_body(&RigidBodyDesc::fixed(slab, Pose::from_translation(-0.5 * DVec3::Y)))
    ///     .unwrap();
    /// let ball = RigidBodyDesc::dynamic(
    ///     Shape::sphere(0.5).unwrap(),
    ///     1000.0,
    ///     Pose::from_translation(DVec3::new(0.0, 0.5, 0.0)),
    /// )
    /// .unwrap()
    /// .with_velocity(DVec3::new(3.0, 5.0, 0.0), DVec3::ZERO);
    /// let ball = world.add_body(&ball).unwrap();
    /// // Thrown from the ground, it comes down after 2 · 5 / 10 = 1 s, 3 m on.
    /// let landing = world.predict_landing(ball, 5.0).unwrap().unwrap();
    /// assert_eq!(landing.body, ground);
    /// assert!((landing.time - 1.0).abs() < 1e-3);
    /// assert!(landing.point.distance(DVec3::new(3.0, 0.0, 0.0)) < 1e-3);
    /// assert!((landing.normal - DVec3::Y).length() < 1e-9);
    /// ```
    ///
    /// # Errors
    /// [`PhysicsError::NonFinite`] or [`PhysicsError::NotPositive`] unless
    /// `max_time` is finite and > 0, [`PhysicsError::UnknownBody`] for a
    /// stale handle, [`PhysicsError::Invalid`] for a body whose shape is a
    /// triangle mesh or heightfield (or a compound holding one).
    pub fn predict_landing(
        &self,
        body: BodyHandle,
        max_time: f64,
    ) -> Result<Option<Landing>, PhysicsError> {
        positive("landing max_time", max_time)?;
        let path = self.body_trajectory(body)?;
        let b = self.body(body).ok_or(PhysicsError::UnknownBody(body))?;
        let mut parts = Vec::new();
        if let Some(shape) = b.shape() {
            convex_parts(shape, Pose::IDENTITY, &mut parts)?;
        }
        let accel = path.max_acceleration();
        let chords = if accel > 0.0 {
            let dt = (8.0 * LANDING_SAGITTA / accel).sqrt();
            (max_time / dt).ceil().clamp(1.0, LANDING_MAX_CHORDS as f64) as usize
        } else {
            1
        };
        let mut times: Vec<f64> = (0..=chords)
            .map(|i| max_time * i as f64 / chords as f64)
            .collect();
        let mut points: Vec<DVec3> = times.iter().map(|&t| path.position(t)).collect();
        // A path that overflows ends where it still is finite.
        if let Some(end) = points.iter().position(|p| !p.is_finite()) {
            times.truncate(end);
            points.truncate(end);
        }
        let mut sweep = Sweep {
            path,
            rotation: b.rotation,
            local_com: b.local_com,
            radius: if parts.is_empty() { 0.0 } else { b.radius },
            parts,
            targets: Vec::new(),
            leaving: Vec::new(),
            accel,
        };
        let Some(bounds) = Aabb::from_points(&points) else {
            return Ok(None);
        };
        let bounds = bounds.expanded(
            sweep.radius + sweep.sagitta(max_time / chords as f64) + 2.0 * query::CAST_TOLERANCE,
        );
        sweep.targets = self
            .shaped_bodies()
            .filter(|(h, other, _, _)| *h != body && !other.sensor && !other.quarantined)
            .map(|(handle, _, shape, pose)| SweepTarget {
                handle,
                shape,
                pose,
                bounds: shape.aabb(&pose),
            })
            .filter(|t| t.bounds.intersects(&bounds))
            .collect();
        // Bodies touched at the start and moved away from (by the velocity,
        // or by the acceleration when at rest along the normal).
        let (v0, a0) = (sweep.path.velocity(0.0), sweep.path.acceleration(0.0));
        let start = sweep.frame(points[0]);
        for t in &sweep.targets {
            let leaving = !sweep.parts.is_empty()
                && nearest_contact(&sweep.parts, start, t, 2.0 * query::CAST_TOLERANCE)?
                    .is_some_and(|(_, n, _)| {
                        let away = v0.dot(n);
                        away > 0.0 || (away == 0.0 && a0.dot(n) > 0.0)
                    });
            sweep.leaving.push(leaving);
        }
        for w in times.windows(2) {
            let (t0, t1) = (w[0], w[1]);
            for i in 0..sweep.targets.len() {
                if sweep.leaving[i] && t0 > 0.0 && !sweep.still_touching(t0, i)? {
                    sweep.leaving[i] = false;
                }
            }
            if let Some(hit) = sweep.cast_chord(t0, t1)? {
                let (hit, ta, tb) = sweep.refine(t0, t1, hit)?;
                return sweep.landing(hit, ta + hit.fraction * (tb - ta)).map(Some);
            }
        }
        Ok(None)
    }
}
