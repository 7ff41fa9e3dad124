//! The hot projections four constraints at a time: a colour's distance
//! constraints and bending hinges are independent (no two share a
//! particle), so four of them run in the lanes of one `f32x4`. The
//! arithmetic is the scalar projection's, operation for operation (plain
//! multiplies and adds, never fused), so a constraint moves its particles
//! by the same amount whichever lane it lands in.

use glam::Vec3;

use crate::rigid::solver::lanes::{F4, V3};

use super::super::scatter::Scatter;
use super::constraints::{Bend, Distance};

#[inline(always)]
fn gather(x: Scatter<'_, Vec3>, idx: [usize; 4]) -> V3 {
    let mut v = V3::ZERO;
    for (l, &i) in idx.iter().enumerate() {
        // SAFETY: the four constraints are of one colour: no other thread
        // touches their particles.
        v.set_lane(l, unsafe { x.get(i) }.to_array());
    }
    v
}

#[inline(always)]
fn scatter(x: Scatter<'_, Vec3>, idx: [usize; 4], v: V3) {
    let (xs, ys, zs) = (v.x.to_array(), v.y.to_array(), v.z.to_array());
    for (l, &i) in idx.iter().enumerate() {
        // SAFETY: as in `gather`.
        unsafe { x.set(i, Vec3::new(xs[l], ys[l], zs[l])) };
    }
}

#[inline(always)]
fn weights(w: &[f32], idx: [usize; 4]) -> F4 {
    F4::from([w[idx[0]], w[idx[1]], w[idx[2]], w[idx[3]]])
}

/// Four distance constraints of one colour.
#[inline]
pub(crate) fn project_distances(c: &[Distance; 4], x: Scatter<'_, Vec3>, w: &[f32], inv_h2: f32) {
    let ia = [c[0].p[0], c[1].p[0], c[2].p[0], c[3].p[0]].map(|i| i as usize);
    let ib = [c[0].p[1], c[1].p[1], c[2].p[1], c[3].p[1]].map(|i| i as usize);
    let (xa, xb) = (gather(x, ia), gather(x, ib));
    let (wa, wb) = (weights(w, ia), weights(w, ib));
    let rest = F4::from([c[0].rest, c[1].rest, c[2].rest, c[3].rest]);
    let alpha = F4::from([
        c[0].compliance,
        c[1].compliance,
        c[2].compliance,
        c[3].compliance,
    ]) * F4::splat(inv_h2);
    let d = xb - xa;
    let len = d.dot(d).sqrt();
    let k = wa + wb + alpha;
    let ok = len.simd_ge(F4::splat(1e-9)) & k.simd_gt(F4::ZERO);
    let safe_len = ok.select(len, F4::ONE);
    let safe_k = ok.select(k, F4::ONE);
    let n = d * (F4::ONE / safe_len);
    let dl = ok.select(-(len - rest) / safe_k, F4::ZERO);
    scatter(x, ia, xa - n * (wa * dl));
    scatter(x, ib, xb + n * (wb * dl));
}

/// `atan2(y, x)` per lane: [`super::constraints::atan2`]'s polynomial.
fn atan2(y: F4, x: F4) -> F4 {
    let (ax, ay) = (x.abs(), y.abs());
    let hi = ax.max(ay);
    let lo = ax.min(ay);
    let zero = hi.simd_eq(F4::ZERO);
    let a = zero.select(F4::ZERO, lo / zero.select(F4::ONE, hi));
    let s = a * a;
    let poly = F4::splat(0.999_866)
        + s * (F4::splat(-0.330_299_5)
            + s * (F4::splat(0.180_141)
                + s * (F4::splat(-0.085_133) + s * F4::splat(0.020_835_1))));
    let mut r = a * poly;
    r = ay
        .simd_gt(ax)
        .select(F4::splat(std::f32::consts::FRAC_PI_2) - r, r);
    r = x
        .simd_lt(F4::ZERO)
        .select(F4::splat(std::f32::consts::PI) - r, r);
    y.simd_lt(F4::ZERO).select(-r, r)
}

/// Four bending hinges of one colour.
#[inline]
pub(crate) fn project_bends(c: &[Bend; 4], x: Scatter<'_, Vec3>, w: &[f32], inv_h2: f32) {
    use std::f32::consts::{PI, TAU};
    let mut idx = [[0usize; 4]; 4];
    for (v, row) in idx.iter_mut().enumerate() {
        *row = [c[0].p[v], c[1].p[v], c[2].p[v], c[3].p[v]].map(|i| i as usize);
    }
    let xs = [
        gather(x, idx[0]),
        gather(x, idx[1]),
        gather(x, idx[2]),
        gather(x, idx[3]),
    ];
    let ws = [
        weights(w, idx[0]),
        weights(w, idx[1]),
        weights(w, idx[2]),
        weights(w, idx[3]),
    ];
    let [x0, x1, x2, x3] = xs;
    let e = x1 - x0;
    let e_len = e.dot(e).sqrt();
    let n1 = e.cross(x2 - x0);
    let n2 = (x3 - x0).cross(e);
    let (l1, l2) = (n1.dot(n1), n2.dot(n2));
    let ok = e_len.simd_ge(F4::splat(1e-9))
        & l1.simd_ge(F4::splat(1e-18))
        & l2.simd_ge(F4::splat(1e-18));
    let one = F4::ONE;
    let e_hat = e * (one / ok.select(e_len, one));
    let il1 = one / ok.select(l1, one);
    let il2 = one / ok.select(l2, one);
    let angle = atan2(n1.cross(n2).dot(e_hat), n1.dot(n2));
    let g2 = -(n1 * (e_len * il1));
    let g3 = -(n2 * (e_len * il2));
    let g0 = -(n1 * ((x2 - x1).dot(e_hat) * il1) + n2 * ((x3 - x1).dot(e_hat) * il2));
    let g1 = n1 * ((x2 - x0).dot(e_hat) * il1) + n2 * ((x3 - x0).dot(e_hat) * il2);
    let grads = [g0, g1, g2, g3];
    let mut c_now = angle - F4::from([c[0].rest, c[1].rest, c[2].rest, c[3].rest]);
    c_now = c_now
        .simd_gt(F4::splat(PI))
        .select(c_now - F4::splat(TAU), c_now);
    c_now = c_now
        .simd_le(F4::splat(-PI))
        .select(c_now + F4::splat(TAU), c_now);
    let mut k = F4::from([
        c[0].compliance,
        c[1].compliance,
        c[2].compliance,
        c[3].compliance,
    ]) * F4::splat(inv_h2);
    for v in 0..4 {
        k += ws[v] * grads[v].dot(grads[v]);
    }
    let ok = ok & k.simd_gt(F4::splat(1e-12));
    let dl = ok.select(-c_now / ok.select(k, one), F4::ZERO);
    for v in 0..4 {
        scatter(x, idx[v], xs[v] + grads[v] * (ws[v] * dl));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sixteen particles in a wobbly sheet; constraints on disjoint ones.
    fn sheet() -> (Vec<Vec3>, Vec<f32>) {
        let x = (0..16)
            .map(|i| {
                let (r, c) = ((i / 4) as f32, (i % 4) as f32);
                Vec3::new(c * 0.1, 0.02 * (r * 1.7 + c).sin(), r * 0.1 + 0.01 * c)
            })
            .collect();
        let w = (0..16)
            .map(|i| if i == 5 { 0.0 } else { 1.0 + i as f32 * 0.1 })
            .collect();
        (x, w)
    }

    #[test]
    fn four_lanes_move_particles_as_the_scalar_projections_do() {
        let (x0, w) = sheet();
        let d = |a: u32, b: u32, rest: f32| Distance {
            p: [a, b],
            rest,
            rest0: rest,
            compliance: 1e-4,
        };
        let ds = [d(0, 1, 0.12), d(2, 3, 0.08), d(4, 5, 0.1), d(6, 7, 0.0999)];
        let (mut a, mut b) = (x0.clone(), x0.clone());
        project_distances(&ds, Scatter::new(&mut a), &w, 3600.0);
        for c in &ds {
            c.project(Scatter::new(&mut b), &w, 3600.0);
        }
        let bend = |p: [u32; 4], rest: f32| Bend {
            p,
            rest,
            compliance: 0.1,
        };
        let bs = [
            bend([0, 1, 4, 12], 0.3),
            bend([2, 3, 6, 13], -0.2),
            bend([5, 8, 9, 14], 0.0),
            bend([10, 11, 7, 15], 3.0),
        ];
        project_bends(&bs, Scatter::new(&mut a), &w, 3600.0);
        for c in &bs {
            c.project(Scatter::new(&mut b), &w, 3600.0);
        }
        for (p, q) in a.iter().zip(&b) {
            assert!((*p - *q).length() < 1e-6, "{p} {q}");
        }
        assert_ne!(a, x0, "the constraints moved something");
    }
}
