//! [`QueryIndex`]: the world's shaped bodies in a bounding-volume
//! hierarchy, for many scene queries on one unchanged world (a game's
//! rules casting a few rays per player per tick).
//!
//! [`World::cast_ray`] walks every body, which is exact at any moment but
//! costs O(bodies) a ray: 1000 players casting 5 ground rays each over
//! 2000 bodies is ten million box tests a tick. The index holds each
//! body's tight box at its pose when the index was built, in a hierarchy
//! built top down (split at the median of the box centres along the
//! widest axis, at most [`LEAF_SIZE`] bodies to a leaf: O(n log n) to
//! build, balanced whatever the layout), and answers the same questions
//! with the same answers in O(log bodies) a ray. It is a picture of the
//! world at one moment: build it after the world last changed (stepped,
//! a body added, removed or moved) and drop it at the next change.

use glam::DVec3;

use super::World;
use crate::error::PhysicsError;
use crate::handle::BodyHandle;
use crate::rigid::aabb::Aabb;
use crate::rigid::body::RigidBody;
use crate::rigid::query::{ray_aabb, RayHit};

/// Boxes in the hierarchy are grown by this much beyond the boxes
/// [`World::cast_ray`] tests, m, so that no rounding in a node's test
/// rejects a body the exact test accepts.
const SLACK_M: f64 = 1e-6;
/// The most bodies in one leaf of the hierarchy.
pub const LEAF_SIZE: usize = 4;

/// One node: its box, and either two children or a run of bodies.
#[derive(Debug, Clone, Copy)]
struct Node {
    aabb: Aabb,
    /// Leaf: the first of its bodies in `order`; inner: the second child
    /// (the first is the next node).
    at: u32,
    /// Bodies in the leaf; 0 for an inner node.
    count: u32,
}

/// The world's shaped bodies at their poses of one moment, in a
/// hierarchy, for scene queries (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct QueryIndex {
    /// Bodies, in the order the leaves take them.
    order: Vec<BodyHandle>,
    nodes: Vec<Node>,
    /// Bodies in the world when built, to catch an index used past a change.
    bodies: usize,
}

impl QueryIndex {
    /// Indexes every shaped body of `world` at its pose now.
    pub fn build(world: &World) -> Self {
        let mut bodies = 0;
        let mut items: Vec<(Aabb, DVec3, BodyHandle)> = Vec::new();
        for (h, b) in world.bodies() {
            bodies += 1;
            let Some(shape) = b.shape() else { continue };
            let aabb = shape.aabb(&b.pose()).expanded(1e-9 + SLACK_M);
            // A box too large to have a finite centre (a ground plane)
            // is placed at the origin: it still bounds itself.
            let centre = Some(aabb.center())
                .filter(|c| c.is_finite())
                .unwrap_or(DVec3::ZERO);
            items.push((aabb, centre, h));
        }
        let mut index = Self {
            order: Vec::with_capacity(items.len()),
            nodes: Vec::with_capacity(2 * items.len().div_ceil(LEAF_SIZE)),
            bodies,
        };
        if !items.is_empty() {
            index.split(&mut items);
        }
        index
    }

    /// Adds the subtree over `items` (not empty) and returns its node.
    fn split(&mut self, items: &mut [(Aabb, DVec3, BodyHandle)]) -> usize {
        let aabb = items[1..]
            .iter()
            .fold(items[0].0, |acc, (b, _, _)| acc.union(b));
        let node = self.nodes.len();
        self.nodes.push(Node {
            aabb,
            at: self.order.len() as u32,
            count: items.len() as u32,
        });
        if items.len() <= LEAF_SIZE {
            self.order.extend(items.iter().map(|(_, _, h)| *h));
            return node;
        }
        let (lo, hi) = items[1..]
            .iter()
            .fold((items[0].1, items[0].1), |(lo, hi), (_, c, _)| {
                (lo.min(*c), hi.max(*c))
            });
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = items.len() / 2;
        // Ties by handle, so the same world builds the same hierarchy.
        items.select_nth_unstable_by(mid, |a, b| {
            a.1[axis].total_cmp(&b.1[axis]).then(a.2.cmp(&b.2))
        });
        let (left, right) = items.split_at_mut(mid);
        self.split(left);
        let second = self.split(right);
        self.nodes[node].at = second as u32;
        self.nodes[node].count = 0;
        node
    }

    /// Bodies indexed.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// True when no body has a shape.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
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
        let mut stack: Vec<usize> = Vec::with_capacity(64);
        if !self.nodes.is_empty() {
            stack.push(0);
        }
        while let Some(n) = stack.pop() {
            let node = self.nodes[n];
            // Kept long enough to meet a tie with the best hit so far.
            let reach = best.map_or(max_t, |(_, hit)| hit.t + SLACK_M);
            if ray_aabb(origin, dir, reach, &node.aabb).is_none() {
                continue;
            }
            if node.count == 0 {
                stack.push(node.at as usize);
                stack.push(n + 1);
                continue;
            }
            let run = node.at as usize..(node.at + node.count) as usize;
            for &h in &self.order[run] {
                if let Some(b) = world.body(h) {
                    super::query::offer_to_ray(&mut best, h, b, (origin, dir, max_t), &mut filter);
                }
            }
        }
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
