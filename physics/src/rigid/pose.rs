//! A rigid transform: a rotation followed by a translation.
//!
//! `x_parent = rotation * x_local + translation`. Poses place bodies in the
//! world, and shapes inside bodies and compounds. There is no scale: rigid
//! bodies do not stretch, and a scaled shape is a different shape (build it
//! with the scaled sizes instead).

use glam::{DQuat, DVec3};

/// Position and orientation of a local frame in its parent frame.
///
/// Maps a point given in the local frame to the parent frame by
/// `rotation * p + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Origin of the local frame in the parent frame, m.
    pub translation: DVec3,
    /// Orientation of the local frame in the parent frame; a unit quaternion.
    pub rotation: DQuat,
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// The pose that maps every point to itself.
    pub const IDENTITY: Pose = Pose {
        translation: DVec3::ZERO,
        rotation: DQuat::IDENTITY,
    };

    /// A pose from a translation (m) and a unit-quaternion rotation.
    ///
    /// The rotation is stored as given; callers that build it from
    /// accumulated products should renormalise it first.
    #[inline]
    pub const fn new(translation: DVec3, rotation: DQuat) -> Self {
        Self {
            translation,
            rotation,
        }
    }

    /// A pure translation (m).
    #[inline]
    pub const fn from_translation(translation: DVec3) -> Self {
        Self::new(translation, DQuat::IDENTITY)
    }

    /// A pure rotation about the local origin.
    #[inline]
    pub const fn from_rotation(rotation: DQuat) -> Self {
        Self::new(DVec3::ZERO, rotation)
    }

    /// Maps a point (m) from the local frame to the parent frame.
    #[inline]
    pub fn transform_point(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    /// Maps a direction or displacement from the local frame to the parent
    /// frame (rotation only; the translation does not apply to vectors).
    #[inline]
    pub fn transform_vector(&self, v: DVec3) -> DVec3 {
        self.rotation * v
    }

    /// Maps a point (m) from the parent frame back to the local frame.
    #[inline]
    pub fn inverse_transform_point(&self, p: DVec3) -> DVec3 {
        self.rotation.conjugate() * (p - self.translation)
    }

    /// Maps a direction from the parent frame back to the local frame.
    #[inline]
    pub fn inverse_transform_vector(&self, v: DVec3) -> DVec3 {
        self.rotation.conjugate() * v
    }

    /// The pose that undoes this one: `p.inverse().mul(&p) == IDENTITY`
    /// (up to rounding). Uses the conjugate, so the rotation must be unit.
    #[inline]
    pub fn inverse(&self) -> Pose {
        let rotation = self.rotation.conjugate();
        Pose {
            translation: -(rotation * self.translation),
            rotation,
        }
    }

    /// Composition `self * other`: first `other`, then `self`.
    ///
    /// If `other` places a shape in a body and `self` places the body in the
    /// world, the result places the shape in the world.
    #[inline]
    pub fn mul(&self, other: &Pose) -> Pose {
        Pose {
            translation: self.rotation * other.translation + self.translation,
            rotation: self.rotation * other.rotation,
        }
    }

    /// True when translation and rotation are finite and the rotation is a
    /// unit quaternion to within `1e-6` in length.
    pub fn is_valid(&self) -> bool {
        self.translation.is_finite()
            && self.rotation.is_finite()
            && (self.rotation.length() - 1.0).abs() <= 1e-6
    }
}
