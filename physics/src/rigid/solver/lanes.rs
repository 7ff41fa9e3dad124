//! Four-wide `f32` arithmetic for the contact solver: one lane per
//! constraint of a batch ([`super::wide`]).
//!
//! Every operation is a plain multiply or add per lane, never a fused
//! multiply-add, so a lane's result is the same bits whichever lane and
//! batch a constraint lands in.

use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

pub(crate) use wide::f32x4 as F4;

/// A vector per lane, stored by component.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct V3 {
    pub(crate) x: F4,
    pub(crate) y: F4,
    pub(crate) z: F4,
}

impl V3 {
    pub(crate) const ZERO: Self = Self {
        x: F4::ZERO,
        y: F4::ZERO,
        z: F4::ZERO,
    };

    #[inline]
    pub(crate) fn dot(self, o: Self) -> F4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline]
    pub(crate) fn cross(self, o: Self) -> Self {
        Self {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }

    /// Lane `l` of each component.
    #[cfg(test)]
    pub(crate) fn lane(&self, l: usize) -> [f32; 3] {
        [
            self.x.as_array()[l],
            self.y.as_array()[l],
            self.z.as_array()[l],
        ]
    }

    /// Sets lane `l` to `v`.
    #[inline]
    pub(crate) fn set_lane(&mut self, l: usize, v: [f32; 3]) {
        self.x.as_mut_array()[l] = v[0];
        self.y.as_mut_array()[l] = v[1];
        self.z.as_mut_array()[l] = v[2];
    }
}

impl Add for V3 {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Self {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl Sub for V3 {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

impl Neg for V3 {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Self {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}

impl AddAssign for V3 {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl SubAssign for V3 {
    #[inline]
    fn sub_assign(&mut self, o: Self) {
        *self = *self - o;
    }
}

impl Mul<F4> for V3 {
    type Output = Self;
    #[inline]
    fn mul(self, s: F4) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

/// A symmetric 3×3 matrix per lane (a world inverse inertia, 1/(kg·m²)).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Sym3 {
    pub(crate) xx: F4,
    pub(crate) xy: F4,
    pub(crate) xz: F4,
    pub(crate) yy: F4,
    pub(crate) yz: F4,
    pub(crate) zz: F4,
}

impl Mul<V3> for Sym3 {
    type Output = V3;
    #[inline]
    fn mul(self, v: V3) -> V3 {
        V3 {
            x: self.xx * v.x + self.xy * v.y + self.xz * v.z,
            y: self.xy * v.x + self.yy * v.y + self.yz * v.z,
            z: self.xz * v.x + self.yz * v.y + self.zz * v.z,
        }
    }
}

/// A rotation per lane, as a unit quaternion `(x, y, z, w)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Rot {
    pub(crate) v: V3,
    pub(crate) w: F4,
}

impl Rot {
    /// `v` turned by the inverse of this rotation.
    #[inline]
    pub(crate) fn inverse_rotate(self, v: V3) -> V3 {
        // q⁻¹ v q for the conjugate `(-u, w)`: t = 2 (-u × v),
        // v' = v + w t + (-u) × t.
        let u = -self.v;
        let c = u.cross(v);
        let two = F4::splat(2.0);
        let t = c * two;
        v + t * self.w + u.cross(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec3};

    fn lanes(v: Vec3) -> V3 {
        V3 {
            x: F4::splat(v.x),
            y: F4::splat(v.y),
            z: F4::splat(v.z),
        }
    }

    #[test]
    fn the_inverse_rotation_matches_glams() {
        let q = Quat::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 0.7);
        let v = Vec3::new(0.3, -1.2, 2.0);
        let rot = Rot {
            v: lanes(Vec3::new(q.x, q.y, q.z)),
            w: F4::splat(q.w),
        };
        let got = rot.inverse_rotate(lanes(v)).lane(2);
        let want = q.inverse() * v;
        for (g, w) in got.iter().zip(want.to_array()) {
            assert!((g - w).abs() < 1e-6, "{got:?} against {want:?}");
        }
    }

    #[test]
    fn the_identity_turns_nothing() {
        let rot = Rot {
            v: V3::ZERO,
            w: F4::ONE,
        };
        let v = lanes(Vec3::new(0.1, 0.2, 0.3));
        assert_eq!(rot.inverse_rotate(v), v);
    }
}
