//! The bodies as the wide contact solve reads and writes them: `f32`, 80
//! bytes each, gathered four at a time into lanes by transposing.
//!
//! The solver keeps its `f64` [`SolverBody`] for the joints, the shock
//! pass and the integration; each run of contact passes copies the bodies
//! into this hot state and their new velocities back. The contact passes
//! stream every constraint several times a substep and read both of its
//! bodies each time, so what they read is half the size it was (Box3D's
//! solver body is 56 bytes of `f32`; Box2D's 32 in 2D).

use glam::DVec3;

use super::lanes::{Rot, Sym3, F4, V3};
use super::SolverBody;

/// One body, as five rows of four `f32`:
///
/// | row | contents |
/// |---|---|
/// | 0 | `v.x v.y v.z w.x` |
/// | 1 | `w.y w.z dp.x dp.y` |
/// | 2 | `dp.z dq.x dq.y dq.z` |
/// | 3 | `dq.w inv_mass I⁻¹xx I⁻¹xy` |
/// | 4 | `I⁻¹xz I⁻¹yy I⁻¹yz I⁻¹zz` |
///
/// (velocity m/s, angular velocity rad/s, translation and rotation since
/// the start of the step, inverse mass 1/kg, world inverse inertia
/// 1/(kg·m²), symmetric).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct HotBody {
    rows: [[f32; 4]; 5],
}

impl HotBody {
    /// The hot state of `b`, rounded to `f32`.
    pub(crate) fn of(b: &SolverBody) -> Self {
        let f = |x: f64| x as f32;
        let (v, w, dp, dq, i) = (b.v, b.w, b.dp, b.dq, b.inv_inertia);
        Self {
            rows: [
                [f(v.x), f(v.y), f(v.z), f(w.x)],
                [f(w.y), f(w.z), f(dp.x), f(dp.y)],
                [f(dp.z), f(dq.x), f(dq.y), f(dq.z)],
                [f(dq.w), f(b.inv_mass), f(i.x_axis.x), f(i.y_axis.x)],
                [f(i.z_axis.x), f(i.y_axis.y), f(i.z_axis.y), f(i.z_axis.z)],
            ],
        }
    }

    /// Velocity, m/s.
    pub(crate) fn v(&self) -> DVec3 {
        let r = &self.rows;
        DVec3::new(r[0][0].into(), r[0][1].into(), r[0][2].into())
    }

    /// Angular velocity, rad/s.
    pub(crate) fn w(&self) -> DVec3 {
        let r = &self.rows;
        DVec3::new(r[0][3].into(), r[1][0].into(), r[1][1].into())
    }

    /// The solver body this hot state holds (for tests: the solve never
    /// needs the way back beyond the velocities).
    #[cfg(test)]
    pub(crate) fn solver_body(&self) -> SolverBody {
        let r = &self.rows;
        let d = |x: f32| f64::from(x);
        let (xx, xy, xz, yy, yz, zz) = (
            d(r[3][2]),
            d(r[3][3]),
            d(r[4][0]),
            d(r[4][1]),
            d(r[4][2]),
            d(r[4][3]),
        );
        SolverBody {
            v: self.v(),
            w: self.w(),
            inv_mass: d(r[3][1]),
            inv_inertia: glam::DMat3::from_cols(
                DVec3::new(xx, xy, xz),
                DVec3::new(xy, yy, yz),
                DVec3::new(xz, yz, zz),
            ),
            dp: DVec3::new(d(r[1][2]), d(r[1][3]), d(r[2][0])),
            dq: glam::DQuat::from_xyzw(d(r[2][1]), d(r[2][2]), d(r[2][3]), d(r[3][0])),
        }
    }
}

/// Four bodies, one a lane.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct WideBody {
    pub(crate) v: V3,
    pub(crate) w: V3,
    pub(crate) dp: V3,
    pub(crate) dq: Rot,
    pub(crate) inv_mass: F4,
    pub(crate) inv_inertia: Sym3,
}

/// Row `r` of each of four bodies, transposed: column `j` in lane `l` is
/// `bodies[l].rows[r][j]`.
#[inline]
fn columns(bodies: &[HotBody; 4], r: usize) -> [F4; 4] {
    F4::transpose(std::array::from_fn(|l| F4::from(bodies[l].rows[r])))
}

impl WideBody {
    /// The four bodies in lanes.
    #[inline]
    pub(crate) fn gather(bodies: &[HotBody; 4]) -> Self {
        let [vx, vy, vz, wx] = columns(bodies, 0);
        let [wy, wz, px, py] = columns(bodies, 1);
        let [pz, qx, qy, qz] = columns(bodies, 2);
        let [qw, inv_mass, xx, xy] = columns(bodies, 3);
        let [xz, yy, yz, zz] = columns(bodies, 4);
        Self {
            v: V3 {
                x: vx,
                y: vy,
                z: vz,
            },
            w: V3 {
                x: wx,
                y: wy,
                z: wz,
            },
            dp: V3 {
                x: px,
                y: py,
                z: pz,
            },
            dq: Rot {
                v: V3 {
                    x: qx,
                    y: qy,
                    z: qz,
                },
                w: qw,
            },
            inv_mass,
            inv_inertia: Sym3 {
                xx,
                xy,
                xz,
                yy,
                yz,
                zz,
            },
        }
    }

    /// Writes the lanes' velocities back into `bodies` where `write[l]`
    /// (the rest of each body is what it was gathered from, unchanged).
    #[inline]
    pub(crate) fn scatter(&self, bodies: [Option<&mut HotBody>; 4]) {
        let (v, w, dp) = (self.v, self.w, self.dp);
        let row0 = F4::transpose([v.x, v.y, v.z, w.x]);
        let row1 = F4::transpose([w.y, w.z, dp.x, dp.y]);
        for (l, body) in bodies.into_iter().enumerate() {
            if let Some(body) = body {
                body.rows[0] = row0[l].to_array();
                body.rows[1] = row1[l].to_array();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{DMat3, DQuat};

    use super::*;

    fn body(seed: f64) -> SolverBody {
        let m = DMat3::from_cols(
            DVec3::new(2.0, 0.1, 0.2),
            DVec3::new(0.1, 3.0, 0.3),
            DVec3::new(0.2, 0.3, 4.0),
        ) * seed;
        SolverBody {
            v: DVec3::new(1.0, 2.0, 3.0) * seed,
            w: DVec3::new(-1.0, 0.5, 0.25) * seed,
            inv_mass: 0.5 * seed,
            inv_inertia: m,
            dp: DVec3::new(0.01, 0.02, 0.03) * seed,
            dq: DQuat::from_rotation_y(0.1 * seed),
        }
    }

    #[test]
    fn a_body_goes_into_its_lane_and_its_velocities_come_back() {
        let hot: [HotBody; 4] = std::array::from_fn(|l| HotBody::of(&body(l as f64 + 1.0)));
        let mut wide = WideBody::gather(&hot);
        for (l, h) in hot.iter().enumerate() {
            let b = h.solver_body();
            assert_eq!(wide.v.lane(l), b.v.as_vec3().to_array());
            assert_eq!(wide.w.lane(l), b.w.as_vec3().to_array());
            assert_eq!(wide.dp.lane(l), b.dp.as_vec3().to_array());
            assert_eq!(wide.dq.w.as_array()[l], b.dq.w as f32);
            assert_eq!(wide.inv_mass.as_array()[l], b.inv_mass as f32);
            assert_eq!(
                wide.inv_inertia.yz.as_array()[l],
                b.inv_inertia.z_axis.y as f32
            );
        }
        wide.v = wide.v * F4::splat(2.0);
        wide.w = wide.w * F4::splat(-1.0);
        let mut out = hot;
        let [o0, _, o2, o3] = &mut out;
        wide.scatter([Some(o0), None, Some(o2), Some(o3)]);
        assert_eq!(out[1], hot[1], "a lane not written is left alone");
        for l in [0, 2, 3] {
            let (before, after) = (hot[l].solver_body(), out[l].solver_body());
            assert_eq!(after.v, before.v * 2.0);
            assert_eq!(after.w, -before.w);
            assert_eq!(after.dp, before.dp);
            assert_eq!(after.inv_inertia, before.inv_inertia);
        }
    }
}
