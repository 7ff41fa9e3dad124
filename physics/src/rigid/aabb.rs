//! Axis-aligned bounding boxes: the broad phase's view of a shape.
//!
//! An [`Aabb`] is the set `min <= x <= max` (componentwise, closed). Shapes
//! produce them for a pose ([`Shape::aabb`](super::shape::Shape::aabb));
//! the broad phase fattens them with [`Aabb::expanded`] and ranks tree
//! nodes by [`Aabb::surface_area`] (the surface-area heuristic).

use glam::DVec3;

/// A closed axis-aligned box, `min <= max` componentwise, in m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lowest corner, m.
    pub min: DVec3,
    /// Highest corner, m.
    pub max: DVec3,
}

impl Aabb {
    /// A box from its corners (m). The caller keeps `min <= max`.
    #[inline]
    pub const fn new(min: DVec3, max: DVec3) -> Self {
        Self { min, max }
    }

    /// A box from its centre and half extents (m, >= 0).
    #[inline]
    pub fn from_center_half_extents(center: DVec3, half_extents: DVec3) -> Self {
        Self {
            min: center - half_extents,
            max: center + half_extents,
        }
    }

    /// The smallest box holding every point (m), or `None` for no points.
    pub fn from_points(points: &[DVec3]) -> Option<Aabb> {
        let (first, rest) = points.split_first()?;
        let mut b = Aabb::new(*first, *first);
        for p in rest {
            b.min = b.min.min(*p);
            b.max = b.max.max(*p);
        }
        Some(b)
    }

    /// The smallest box holding both boxes.
    #[inline]
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// True when `other` lies entirely inside `self` (touching counts).
    #[inline]
    pub fn contains(&self, other: &Aabb) -> bool {
        self.min.cmple(other.min).all() && other.max.cmple(self.max).all()
    }

    /// True when the point `p` (m) lies inside or on the box.
    #[inline]
    pub fn contains_point(&self, p: DVec3) -> bool {
        self.min.cmple(p).all() && p.cmple(self.max).all()
    }

    /// True when the boxes overlap or touch.
    #[inline]
    pub fn intersects(&self, other: &Aabb) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }

    /// The box grown by `margin` m on every side (a negative margin shrinks it;
    /// the caller keeps the result non-inverted).
    #[inline]
    pub fn expanded(&self, margin: f64) -> Aabb {
        let m = DVec3::splat(margin);
        Aabb {
            min: self.min - m,
            max: self.max + m,
        }
    }

    /// Total area of the six faces, m²: `2 (xy + yz + zx)` of the extents.
    #[inline]
    pub fn surface_area(&self) -> f64 {
        let e = self.max - self.min;
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Enclosed volume, m³.
    #[inline]
    pub fn volume(&self) -> f64 {
        let e = self.max - self.min;
        e.x * e.y * e.z
    }

    /// Centre of the box, m.
    #[inline]
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the extent along each axis, m.
    #[inline]
    pub fn half_extents(&self) -> DVec3 {
        (self.max - self.min) * 0.5
    }
}
