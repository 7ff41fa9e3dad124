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
fn check_ray(origin: DVec3, dir: DVec3, max_t: f64) -> Result<(), PhysicsError> {
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
        for (h, b, shape, pose) in self.shaped_bodies() {
            let limit = best.map_or(max_t, |(_, hit)| hit.t);
            let Some(entry) = ray_aabb(origin, dir, limit, &shape.aabb(&pose).expanded(1e-9))
            else {
                continue;
            };
            if best.is_some_and(|(_, hit)| entry > hit.t) || !filter(h, b) {
                continue;
            }
            if let Some(hit) = ray_cast_shape(shape, &pose, origin, dir, limit) {
                if best.is_none_or(|(_, b)| hit.t < b.t) {
                    best = Some((h, hit));
                }
            }
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
