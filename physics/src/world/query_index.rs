//! [`QueryIndex`]: the world's shaped bodies in a bounding-volume tree, for
//! many scene queries on one unchanged world (a game's rules casting a
//! few rays per player per tick).
//!
//! [`World::cast_ray`] walks every body, which is exact at any moment but
//! costs O(bodies) a ray: 1000 players casting 5 ground rays each over
//! 2000 bodies is ten million box tests a tick. The index holds each
//! body's tight box at its pose when the index was built, in a
//! [`DynamicTree`] (no fat margin), and answers the same questions with
//! the same answers in O(log bodies) a ray. It is a picture of the world
//! at one moment: build it after the world last changed (stepped, a body
//! added, removed or moved) and drop it at the next change.

use glam::DVec3;

use super::World;
use crate::error::PhysicsError;
use crate::handle::BodyHandle;
use crate::rigid::body::RigidBody;
use crate::rigid::broad_phase::DynamicTree;
use crate::rigid::query::{ray_aabb, ray_cast_shape, RayHit};

/// Boxes in the tree are grown by this much beyond the boxes
/// [`World::cast_ray`] tests, m, so that the tree's own slab test never
/// rejects a body the exact one accepts.
const TREE_SLACK_M: f64 = 1e-6;

/// The world's shaped bodies at their poses of one moment, in a tree, for
/// scene queries (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct QueryIndex {
    /// Bodies whose boxes are in the tree, by the tree's tags.
    indexed: Vec<BodyHandle>,
    /// Bodies too large for the tree (a ground plane's box), tested on
    /// every query.
    unbounded: Vec<BodyHandle>,
    tree: DynamicTree,
    /// Bodies in the world when built, to catch an index used past a change.
    bodies: usize,
}

impl QueryIndex {
    /// Indexes every shaped body of `world` at its pose now.
    pub fn build(world: &World) -> Self {
        let mut index = Self {
            tree: DynamicTree::new(0.0).expect("a zero margin is valid"),
            ..Self::default()
        };
        for (h, b) in world.bodies() {
            index.bodies += 1;
            let Some(shape) = b.shape() else { continue };
            let aabb = shape.aabb(&b.pose()).expanded(1e-9 + TREE_SLACK_M);
            let tag = index.indexed.len() as u32;
            match index.tree.create_proxy(aabb, tag) {
                Ok(_) => index.indexed.push(h),
                Err(_) => index.unbounded.push(h),
            }
        }
        index
    }

    /// Bodies indexed (in the tree or tested every time).
    pub fn len(&self) -> usize {
        self.indexed.len() + self.unbounded.len()
    }

    /// True when no body has a shape.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The nearest hit of the ray `origin + t · dir` (`0 <= t <= max_t`)
    /// on the bodies that `filter` accepts, ties to the lower handle: what
    /// [`World::cast_ray`] answers for the world this index was built
    /// from, which `world` must still be. `filter` is only asked about
    /// bodies whose box the ray crosses.
    ///
    /// # Errors
    /// As [`World::cast_ray`].
    pub fn cast_ray(
        &self,
        world: &World,
        origin: DVec3,
        dir: DVec3,
        max_t: f64,
        mut filter: impl FnMut(BodyHandle, &RigidBody) -> bool,
    ) -> Result<Option<(BodyHandle, RayHit)>, PhysicsError> {
        super::query::check_ray(origin, dir, max_t)?;
        debug_assert_eq!(
            world.bodies().count(),
            self.bodies,
            "a query index used after the world changed"
        );
        let mut best: Option<(BodyHandle, RayHit)> = None;
        let mut consider = |h: BodyHandle, best: &mut Option<(BodyHandle, RayHit)>| {
            let Some(b) = world.body(h) else { return };
            let Some(shape) = b.shape() else { return };
            let pose = b.pose();
            let limit = best.map_or(max_t, |(_, hit)| hit.t);
            let Some(entry) = ray_aabb(origin, dir, limit, &shape.aabb(&pose).expanded(1e-9))
            else {
                return;
            };
            if best.is_some_and(|(_, hit)| entry > hit.t) || !filter(h, b) {
                return;
            }
            if let Some(hit) = ray_cast_shape(shape, &pose, origin, dir, max_t) {
                let better = match *best {
                    None => hit.t <= limit,
                    Some((bh, bhit)) => hit.t < bhit.t || (hit.t == bhit.t && h < bh),
                };
                if better {
                    *best = Some((h, hit));
                }
            }
        };
        for &h in &self.unbounded {
            consider(h, &mut best);
        }
        // The tree's walk: each leaf's answer shortens the ray to the best
        // hit so far (kept long enough to meet ties).
        let walk = self.tree.ray_cast(origin, dir, max_t, |proxy, _| {
            if let Some(h) = self
                .tree
                .user_data(proxy)
                .and_then(|tag| self.indexed.get(tag as usize))
            {
                consider(*h, &mut best);
            }
            best.map_or(max_t, |(_, hit)| hit.t + TREE_SLACK_M)
        });
        // The ray was checked above; the tree accepts every ray that is.
        debug_assert!(walk.is_ok());
        Ok(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rigid::body::RigidBodyDesc;
    use crate::rigid::pose::Pose;
    use crate::rigid::shape::Shape;
    use crate::WorldConfig;
    use glam::DQuat;

    /// A pseudo-random number in [0, 1) from a counter.
    fn unit(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn scattered_world(bodies: usize) -> World {
        let mut world = World::new(WorldConfig::default()).unwrap();
        let mut seed = 7;
        world
            .add_body(&RigidBodyDesc::fixed(
                Shape::cuboid(DVec3::new(200.0, 0.5, 200.0)).unwrap(),
                Pose::from_translation(DVec3::new(0.0, -0.5, 0.0)),
            ))
            .unwrap();
        for i in 0..bodies {
            let mut r = || unit(&mut seed);
            let at = DVec3::new(r() * 40.0 - 20.0, r() * 10.0, r() * 40.0 - 20.0);
            let rotation = DQuat::from_euler(glam::EulerRot::XYZ, r() * 6.0, r() * 6.0, r() * 6.0);
            let shape = match i % 3 {
                0 => Shape::sphere(0.2 + r()).unwrap(),
                1 => Shape::cuboid(DVec3::new(0.2 + r(), 0.2 + r(), 0.2 + r())).unwrap(),
                _ => Shape::capsule(0.2 + r(), 0.1 + r()).unwrap(),
            };
            let pose = Pose::new(at, rotation);
            world
                .add_body(&RigidBodyDesc::dynamic(shape, 1000.0, pose).unwrap())
                .unwrap();
        }
        // Two at the very same place: a tie, to the lower handle.
        for _ in 0..2 {
            world
                .add_body(&RigidBodyDesc::fixed(
                    Shape::sphere(1.0).unwrap(),
                    Pose::from_translation(DVec3::new(30.0, 1.0, 30.0)),
                ))
                .unwrap();
        }
        world
    }

    #[test]
    fn the_index_answers_every_ray_as_the_world_does() {
        let world = scattered_world(300);
        let index = QueryIndex::build(&world);
        assert_eq!(index.len(), 303);
        let mut seed = 11;
        let mut hits = 0;
        for i in 0..2000 {
            let mut r = || unit(&mut seed);
            let origin = DVec3::new(r() * 50.0 - 25.0, r() * 12.0, r() * 50.0 - 25.0);
            let dir = match i % 4 {
                0 => DVec3::NEG_Y,
                1 => DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize_or(DVec3::X),
                2 => DVec3::new(30.0, 1.0, 30.0) - origin,
                _ => DVec3::X,
            };
            let max_t = if i % 5 == 0 { 1.0 } else { 60.0 };
            // Every other body refused, now and then.
            let filter = |h: BodyHandle, _: &RigidBody| i % 7 != 0 || h.index % 2 == 0;
            let want = world.cast_ray(origin, dir, max_t, filter).unwrap();
            let got = index.cast_ray(&world, origin, dir, max_t, filter).unwrap();
            assert_eq!(got.map(|g| g.0), want.map(|w| w.0), "ray {i}");
            if let (Some(g), Some(w)) = (got, want) {
                assert!(
                    (g.1.t - w.1.t).abs() < 1e-9,
                    "ray {i}: {} vs {}",
                    g.1.t,
                    w.1.t
                );
                hits += 1;
            }
        }
        assert!(hits > 1000, "the rays meet something: {hits}");
    }

    #[test]
    fn bad_rays_are_refused_as_the_world_refuses_them() {
        let world = scattered_world(10);
        let index = QueryIndex::build(&world);
        for (origin, dir, max_t) in [
            (DVec3::NAN, DVec3::X, 1.0),
            (DVec3::ZERO, DVec3::ZERO, 1.0),
            (DVec3::ZERO, DVec3::X, -1.0),
        ] {
            let want = world.cast_ray(origin, dir, max_t, |_, _| true);
            let got = index.cast_ray(&world, origin, dir, max_t, |_, _| true);
            assert!(want.is_err() && got.is_err());
        }
    }
}
