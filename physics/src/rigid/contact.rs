//! Contact manifolds: what the narrow phase hands the solver.
//!
//! A [`Manifold`] is one contact normal (world space, from A to B) and up
//! to four [`ContactPoint`]s. Points are stored in each shape's local
//! frame, so the solver can re-evaluate the separation after the bodies
//! move within a step without running collision again, and each carries a
//! feature id that stays the same while the same pair of features (face,
//! edge, vertex) touch, so last frame's impulses can be matched to this
//! frame's points (warm starting).

use glam::DVec3;

/// Most points a manifold holds: four well spread points hold a resting
/// box as well as all the clipped points would, and keep the solver small.
pub const MAX_POINTS: usize = 4;

/// One point of contact between shapes A and B.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPoint {
    /// Contact point on A, in A's shape-local frame, m.
    pub local_a: DVec3,
    /// Contact point on B, in B's shape-local frame, m.
    pub local_b: DVec3,
    /// Signed distance along the normal, m: negative = penetration,
    /// positive = gap (speculative). In world space,
    /// `point_b ≈ point_a + separation · normal`.
    pub separation: f64,
    /// Feature id, stable across frames while the same features touch
    /// (for warm starting). Unique within one manifold.
    pub id: u32,
}

/// The contact between two shapes: one normal and 0 to [`MAX_POINTS`]
/// points.
///
/// `points` is a `Vec` (at most [`MAX_POINTS`] long) rather than a fixed
/// array, so an empty manifold costs no allocation and callers can
/// iterate it directly.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Manifold {
    /// Unit normal in world space pointing from A to B (zero when there
    /// are no points).
    pub normal: DVec3,
    /// 0..=4 points.
    pub points: Vec<ContactPoint>,
}

impl Manifold {
    /// A manifold with no points: the shapes are farther apart than the
    /// speculative distance.
    pub fn empty() -> Manifold {
        Manifold::default()
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The smallest separation among the points, m (`None` if empty).
    pub fn min_separation(&self) -> Option<f64> {
        self.points.iter().map(|p| p.separation).reduce(f64::min)
    }

    /// The same contact seen from B: normal flipped, `local_a` and
    /// `local_b` swapped; separations and ids unchanged.
    pub fn flipped(&self) -> Manifold {
        Manifold {
            normal: -self.normal,
            points: self
                .points
                .iter()
                .map(|p| ContactPoint {
                    local_a: p.local_b,
                    local_b: p.local_a,
                    ..*p
                })
                .collect(),
        }
    }
}

/// How the manifolds of one step were found.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ManifoldCount {
    /// Shape pairs collided (a compound counts once per pair of children).
    pub collided: u64,
    /// Manifolds used again from the last step, their bodies having barely
    /// moved relative to each other (see ARCHITECTURE.md, contact
    /// recycling).
    pub recycled: u64,
}

impl std::ops::AddAssign for ManifoldCount {
    fn add_assign(&mut self, other: Self) {
        self.collided += other.collided;
        self.recycled += other.recycled;
    }
}

/// Why two shapes could not be collided.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContactError {
    /// A pose has a non-finite translation or a rotation that is not a
    /// unit quaternion (to 1e-6). Fix the body's state; nothing was computed.
    #[error("pose of shape {which} is not finite or its rotation is not unit")]
    BadPose {
        /// "a" or "b".
        which: &'static str,
    },
    /// Neither shape is convex (mesh or heightfield against mesh or
    /// heightfield): static geometry does not collide with itself.
    #[error("no narrow phase for {a} against {b}: at least one shape must be convex")]
    Unsupported {
        /// Kind of shape A.
        a: &'static str,
        /// Kind of shape B.
        b: &'static str,
    },
    /// Compounds are split by the caller, one child shape at a time.
    #[error("compound shapes must be collided per child by the caller")]
    Compound,
    /// The speculative distance was negative or not finite.
    #[error("speculative distance must be finite and >= 0, got {0}")]
    BadSpeculative(f64),
}
