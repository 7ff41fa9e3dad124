//! One step of a fluid.
//!
//! A step of `dt` finds every particle's neighbours once, on the positions
//! predicted for the whole step (within the kernel radius h), and keeps the
//! lists for its substeps. Each substep of `hs = dt / n` (Macklin et al.,
//! "Small Steps in Physics Simulation", SCA 2019):
//!
//! 1. `v += hs g`, `x_prev = x`, `x += hs v`;
//! 2. one Jacobi iteration of the density constraints (Macklin & Müller,
//!    "Position Based Fluids", SIGGRAPH 2013): every particle finds
//!    `ρ_i / ρ0 = V Σ_j W_spiky(x_i − x_j) + Φ_walls` (with `V` the
//!    particle volume `m / ρ0 = spacing³`, normalised so that a particle
//!    in a cubic lattice at rest reads `ρ0`; itself included in the sum;
//!    spiky rather than the paper's poly6, see [`super::kernels`]; the
//!    walls as in [`super::boundary`], from the planes found at the start
//!    of the step),
//!    `C_i = max(ρ_i / ρ0 − 1, 0)`,
//!    `λ_i = −C_i / (Σ_k |∇_k C_i|² + ε)` with
//!    `∇_i C_i = V Σ_j ∇W_spiky(x_i − x_j) + Σ_walls Ψ(d) n` and
//!    `∇_j C_i = −V ∇W_spiky(x_i − x_j)`; then moves by
//!    `Δx_i = V Σ_j (λ_i + λ_j + s_corr) ∇W_spiky(x_i − x_j) + λ_i Σ_walls Ψ(d) n`,
//!    with the tensile correction `s_corr = −k h² (W_poly6(r) / W_poly6(Δq))ⁿ`
//!    (`λ` is in m², `k` in units of `h²`), each move at most half a
//!    spacing. The
//!    body behind a wall takes the push `−Δx_wall / (w_p + w_b)`
//!    ([`Coupling::push_back`]);
//! 3. particles are kept the collision radius out of the bodies, with
//!    friction, each dynamic body sharing the correction
//!    ([`Coupling::press`]), and the bodies move by the substep's pushes
//!    ([`Coupling::take_pushes`]);
//! 4. `v = (x − x_prev) / hs`; a particle gone non-finite goes back to
//!    `x_prev` at rest.
//!
//! After the substeps, vorticity confinement and XSPH viscosity act on the
//! velocities.
//!
//! `ε` must be about the size of `Σ_k |∇_k C_i|²` itself (1.5 / h² for a
//! particle in a lattice at `h = 2 spacing`): one Jacobi iteration moves
//! every particle for its own constraint and all its neighbours' at once,
//! which overshoots some patterns of compression (on a cubic lattice by up
//! to 2.8 times), and with the velocities taken from the positions an
//! overshoot past 4/3 grows from substep to substep. The price is a fluid a
//! little softer under its own weight: about 1 % compression at the floor
//! of a 1.2 m tank at 4 substeps of 1/60 s (it falls with the square of
//! the substep). Every pass is Jacobi (reads old values, writes new ones),
//! runs over fixed chunks of particles in parallel, and each particle
//! gathers from its neighbours in their list's order (a function of the
//! positions alone) and writes only itself: the result is the same on any
//! number of threads. The bodies' pushes are summed per chunk and handed
//! over in chunk order. Before a substep's corrections the bodies move on
//! along their path over the step ([`Coupling::follow`]).

use glam::Vec3;
use wide::f32x8;

use super::{ChunkScratch, Fluid, WallContact, WallPlane, CHUNK};
use crate::parallel::{
    for_each_chunk, for_each_chunk2_with, for_each_chunk_with, for_each_range_with, par_map_chunks3,
};
use crate::xpbd::coupling::{Coupling, Push};

/// Largest position correction a particle takes in one substep, in
/// spacings: a bad configuration settles over a few substeps instead of
/// throwing particles out.
pub(crate) const MAX_CORRECTION: f32 = 0.5;

/// The walls around one particle together: each wall's half-space holds
/// `Φ_k` of the kernel, and where two meet (a tank's edge) their
/// half-spaces overlap. The union is taken as if the shares were
/// independent, `Φ = 1 − Π_k (1 − Φ_k)` (exact for a Gaussian kernel and
/// walls at right angles; a plain sum would count an edge's overlap twice
/// and crush the particles along it). Each wall's gradient follows from
/// the same product: `∂Φ/∂d_k = Φ'_k Π_{m≠k} (1 − Φ_m)`, with `Ψ_k`
/// standing in for `Φ'_k`. Sets each contact's gradient (1/m) and
/// returns the union `Φ` and the summed gradient.
fn wall_union(contacts: &mut [WallContact]) -> (f32, Vec3) {
    let mut outside = 1.0f32;
    for c in contacts.iter() {
        outside *= (1.0 - c.phi).max(0.0);
    }
    let mut total = Vec3::ZERO;
    for k in 0..contacts.len() {
        let mut others = 1.0f32;
        for (m, c) in contacts.iter().enumerate() {
            if m != k {
                others *= (1.0 - c.phi).max(0.0);
            }
        }
        let c = &mut contacts[k];
        c.grad = c.normal * (c.psi * others);
        total += c.grad;
    }
    (1.0 - outside, total)
}

/// Neighbours a pass takes at a time.
const LANES: usize = 8;

/// The offsets `p − x[j]` (m) of up to eight neighbours `js`, by
/// component; lanes past the end of `js` hold `(pad, 0, 0)`.
#[inline(always)]
fn offsets(p: Vec3, x: &[Vec3], js: &[u32], pad: f32) -> (f32x8, f32x8, f32x8) {
    if let [j0, j1, j2, j3, j4, j5, j6, j7] = *js {
        // A full set, built from registers (no round trip through memory).
        let d0 = p - x[j0 as usize];
        let d1 = p - x[j1 as usize];
        let d2 = p - x[j2 as usize];
        let d3 = p - x[j3 as usize];
        let d4 = p - x[j4 as usize];
        let d5 = p - x[j5 as usize];
        let d6 = p - x[j6 as usize];
        let d7 = p - x[j7 as usize];
        return (
            f32x8::new([d0.x, d1.x, d2.x, d3.x, d4.x, d5.x, d6.x, d7.x]),
            f32x8::new([d0.y, d1.y, d2.y, d3.y, d4.y, d5.y, d6.y, d7.y]),
            f32x8::new([d0.z, d1.z, d2.z, d3.z, d4.z, d5.z, d6.z, d7.z]),
        );
    }
    let mut ox = [pad; LANES];
    let mut oy = [0.0f32; LANES];
    let mut oz = [0.0f32; LANES];
    for (l, &j) in js.iter().enumerate() {
        let d = p - x[j as usize];
        ox[l] = d.x;
        oy[l] = d.y;
        oz[l] = d.z;
    }
    (f32x8::from(ox), f32x8::from(oy), f32x8::from(oz))
}

/// The multipliers `λ_j` of up to eight neighbours `js` and their kernel
/// gradients `gs`; lanes past the end hold zeros.
#[inline(always)]
fn multipliers(lambda: &[f32], js: &[u32], gs: &[f32]) -> (f32x8, f32x8) {
    if let (&[j0, j1, j2, j3, j4, j5, j6, j7], Ok(g)) = (js, <[f32; LANES]>::try_from(gs)) {
        let l = |j: u32| lambda[j as usize];
        return (
            f32x8::new([l(j0), l(j1), l(j2), l(j3), l(j4), l(j5), l(j6), l(j7)]),
            f32x8::new(g),
        );
    }
    let mut lam = [0.0f32; LANES];
    let mut g = [0.0f32; LANES];
    for (l, (&j, &gj)) in js.iter().zip(gs).enumerate() {
        lam[l] = lambda[j as usize];
        g[l] = gj;
    }
    (f32x8::from(lam), f32x8::from(g))
}

/// The sum of the lanes, in lane order (the same bits on any machine).
#[inline(always)]
fn lanes_sum(v: f32x8) -> f32 {
    let a = v.as_array();
    ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))
}

impl Fluid {
    /// Advances the fluid by `dt` seconds under `gravity` (m/s², scaled by
    /// the gravity scale) against the bodies of `coupling` (gathered for
    /// this fluid's particles at the start of the step), which the
    /// particles move by their shares of each substep's contacts. A `dt`
    /// that is not
    /// finite and > 0 does nothing.
    pub(crate) fn step(&mut self, dt: f32, gravity: Vec3, coupling: &mut Coupling<'_>) {
        let n = self.x.len();
        if n == 0 || !(dt.is_finite() && dt > 0.0) {
            return;
        }
        let mut g = gravity * self.gravity_scale;
        if !g.is_finite() {
            g = Vec3::ZERO;
        }
        let walls = !coupling.is_empty() && coupling.covers(n);
        let pieces = self.prepare(if walls { coupling.targets.len() } else { 0 });

        // Neighbours, once, on the positions predicted for the whole step.
        {
            let (x, v) = (&self.x, &self.v);
            for_each_chunk(&mut self.next, CHUNK, |base, next| {
                for (k, q) in next.iter_mut().enumerate() {
                    let i = base + k;
                    let p = x[i] + dt * v[i] + dt * dt * g;
                    *q = if p.is_finite() { p } else { x[i] };
                }
            });
        }
        self.neighbours
            .build(&mut self.grid, &self.next, self.kernels.h);

        if walls {
            self.find_walls(dt, g, coupling);
        }

        let hs = dt / self.substeps as f32;
        for k in 0..self.substeps {
            self.predict(hs, g);
            if walls {
                coupling.advance(f64::from(hs));
                coupling.follow(f64::from(k + 1) / f64::from(self.substeps));
            }
            self.find_densities(walls, coupling);
            self.corrections(coupling);
            std::mem::swap(&mut self.x, &mut self.next);
            self.collide(hs, coupling, walls);
            if walls {
                let mut total = coupling.new_pushes();
                for chunk in &mut self.chunks[..pieces] {
                    for (sum, p) in total.iter_mut().zip(&chunk.pushes) {
                        sum.add(p);
                    }
                    chunk.pushes.fill(Push::default());
                }
                coupling.take_pushes(&total, f64::from(hs));
            }
        }
        if self.vorticity > 0.0 {
            self.confine_vorticity(dt);
        }
        if self.viscosity > 0.0 {
            self.xsph();
        }
    }

    /// Sizes the scratch for the particles and `targets` bodies; returns
    /// the number of chunks.
    fn prepare(&mut self, targets: usize) -> usize {
        let n = self.x.len();
        self.prev.resize(n, Vec3::ZERO);
        self.next.resize(n, Vec3::ZERO);
        self.lambda.resize(n, 0.0);
        self.density.resize(n, 0.0);
        self.omega.resize(n, Vec3::ZERO);
        self.inv_mass.resize(n, 1.0 / self.mass);
        let pieces = n.div_ceil(CHUNK);
        if self.chunks.len() < pieces {
            self.chunks.resize_with(pieces, ChunkScratch::default);
        }
        for chunk in &mut self.chunks[..pieces] {
            chunk.contacts.clear();
            chunk.pushes.clear();
            chunk.pushes.resize(targets, Push::default());
        }
        pieces
    }

    /// `v += hs g`, `x_prev = x`, `x += hs v`.
    fn predict(&mut self, hs: f32, g: Vec3) {
        par_map_chunks3(
            &mut self.x,
            &mut self.v,
            &mut self.prev,
            CHUNK,
            |_, x, v, prev| {
                for ((x, v), prev) in x.iter_mut().zip(v.iter_mut()).zip(prev.iter_mut()) {
                    *v += hs * g;
                    *prev = *x;
                    *x += hs * *v;
                }
            },
        );
    }

    /// The surfaces each particle may come within a kernel radius of over
    /// the step, from the positions at its start.
    fn find_walls(&mut self, dt: f32, g: Vec3, coupling: &Coupling<'_>) {
        let (x, v) = (&self.x, &self.v);
        let base_reach = self.kernels.h + self.spacing;
        let fall = g.length() * dt * dt;
        for_each_range_with(x.len(), CHUNK, &mut self.chunks, |base, len, scratch| {
            scratch.planes.clear();
            for i in base..base + len {
                let candidates = coupling.candidates(i);
                if candidates.is_empty() {
                    continue;
                }
                let within = f64::from(base_reach + v[i].length() * dt + fall);
                for &target in candidates {
                    if let Some(s) = coupling.surface(target, x[i], within) {
                        let (point, normal) = coupling.to_body(target, s.point, s.normal);
                        scratch.planes.push(WallPlane {
                            particle: i as u32,
                            target,
                            point,
                            normal,
                            bounds: s.distance >= 0.0 && coupling.is_convex(target),
                        });
                    }
                }
            }
        });
    }

    /// Densities and constraint multipliers at the current positions, and
    /// the walls within a kernel radius of each particle.
    fn find_densities(&mut self, walls: bool, coupling: &Coupling<'_>) {
        let x = &self.x;
        let nb = &self.neighbours;
        let kernels = self.kernels;
        let table = &self.wall;
        let (volume, rest, eps) = (self.volume, self.rest_density, self.relaxation);
        let h = kernels.h;
        let self_weight = kernels.spiky(0.0);
        // Where the lanes past a list's end stand: out of the kernel's reach.
        let far = 2.0 * h;
        for_each_chunk2_with(
            &mut self.lambda,
            &mut self.density,
            CHUNK,
            &mut self.chunks,
            |base, lambda, density, scratch| {
                let ChunkScratch {
                    contacts,
                    pair,
                    gap: gaps,
                    planes,
                    ..
                } = scratch;
                contacts.clear();
                pair.clear();
                gaps.clear();
                let mut next_plane = 0;
                for k in 0..lambda.len() {
                    let i = base + k;
                    let p = x[i];
                    let mut sum_w = self_weight;
                    let mut grad = Vec3::ZERO;
                    let mut sum_sq = 0.0f32;
                    let list = nb.of(i);
                    let at = pair.len();
                    pair.resize(at + list.len(), 0.0);
                    // Eight neighbours at a time, each lane summing its own
                    // and the lanes added in order at the end.
                    let (mut w8, mut sq8) = (f32x8::ZERO, f32x8::ZERO);
                    let (mut gx8, mut gy8, mut gz8) = (f32x8::ZERO, f32x8::ZERO, f32x8::ZERO);
                    for (js, out) in list.chunks(LANES).zip(pair[at..].chunks_mut(LANES)) {
                        let (dx, dy, dz) = offsets(p, x, js, far);
                        let (w, g) = kernels.spiky_pair_x8(dx, dy, dz);
                        let (gx, gy, gz) = (dx * g, dy * g, dz * g);
                        w8 += w;
                        gx8 += gx;
                        gy8 += gy;
                        gz8 += gz;
                        sq8 += gx * gx + gy * gy + gz * gz;
                        if let Ok(out) = <&mut [f32; LANES]>::try_from(&mut *out) {
                            *out = *g.as_array();
                        } else {
                            for (o, &gl) in out.iter_mut().zip(g.as_array()) {
                                *o = gl;
                            }
                        }
                    }
                    sum_w += lanes_sum(w8);
                    grad += Vec3::new(lanes_sum(gx8), lanes_sum(gy8), lanes_sum(gz8));
                    sum_sq += lanes_sum(sq8);
                    let mut frac = volume * sum_w;
                    let mut grad = grad * volume;
                    let sum_sq = sum_sq * volume * volume;
                    let mut gap = h;
                    if walls {
                        let first = contacts.len();
                        while next_plane < planes.len() && planes[next_plane].particle as usize == i
                        {
                            let plane = planes[next_plane];
                            next_plane += 1;
                            let (point, normal) =
                                coupling.to_world(plane.target, plane.point, plane.normal);
                            let d = (p.as_dvec3() - point).dot(normal);
                            let d = d as f32;
                            gap = gap.min(if plane.bounds { d } else { f32::NEG_INFINITY });
                            if d.is_nan() || d >= h {
                                continue;
                            }
                            let (phi, psi) = table.at(d);
                            if phi <= 0.0 && psi == 0.0 {
                                continue;
                            }
                            contacts.push(WallContact {
                                particle: i as u32,
                                target: plane.target,
                                point: p.as_dvec3() - normal * f64::from(d),
                                normal: normal.as_vec3(),
                                phi,
                                psi,
                                grad: Vec3::ZERO,
                            });
                        }
                        let (phi, wall_grad) = wall_union(&mut contacts[first..]);
                        frac += phi;
                        grad += wall_grad;
                    }
                    gaps.push(gap);
                    density[k] = rest * frac;
                    let c = frac - 1.0;
                    let denom = grad.length_squared() + sum_sq + eps;
                    let l = if c > 0.0 && denom > 0.0 {
                        -c / denom
                    } else {
                        0.0
                    };
                    lambda[k] = if l.is_finite() { l } else { 0.0 };
                }
            },
        );
    }

    /// The Jacobi position corrections: `next = x + Δx`; the bodies behind
    /// the walls take the walls' share as pushes.
    fn corrections(&mut self, coupling: &Coupling<'_>) {
        let x = &self.x;
        let lambda = &self.lambda;
        let nb = &self.neighbours;
        let kernels = self.kernels;
        let volume = self.volume;
        let cap = MAX_CORRECTION * self.spacing;
        let tensile = self.tensile_k > 0.0 && self.tensile_inv_w > 0.0;
        let s_scale = -self.tensile_k * kernels.h2;
        let (inv_w, power) = (self.tensile_inv_w, self.tensile_n.max(1));
        let w_p = f64::from(1.0 / self.mass);
        for_each_chunk_with(
            &mut self.next,
            CHUNK,
            &mut self.chunks,
            |base, next, scratch| {
                let ChunkScratch {
                    contacts,
                    pushes,
                    pair,
                    ..
                } = scratch;
                let mut c = 0;
                let mut at = 0;
                for (k, out) in next.iter_mut().enumerate() {
                    let i = base + k;
                    let p = x[i];
                    let li = lambda[i];
                    let list = nb.of(i);
                    // The kernel gradients the density pass found, pair by pair.
                    let grads = &pair[at..at + list.len()];
                    at += list.len();
                    let (mut cx, mut cy, mut cz) = (f32x8::ZERO, f32x8::ZERO, f32x8::ZERO);
                    for (js, gs) in list.chunks(LANES).zip(grads.chunks(LANES)) {
                        let (ox, oy, oz) = offsets(p, x, js, 0.0);
                        let (lam, g) = multipliers(lambda, js, gs);
                        let mut s = f32x8::splat(li) + lam;
                        if tensile {
                            let ratio =
                                kernels.poly6_x8(ox * ox + oy * oy + oz * oz) * f32x8::splat(inv_w);
                            let mut pow = ratio;
                            for _ in 1..power {
                                pow *= ratio;
                            }
                            s += f32x8::splat(s_scale) * pow;
                        }
                        let f = s * g;
                        cx += ox * f;
                        cy += oy * f;
                        cz += oz * f;
                    }
                    let mut dx = Vec3::new(lanes_sum(cx), lanes_sum(cy), lanes_sum(cz)) * volume;
                    let first = c;
                    while c < contacts.len() && contacts[c].particle as usize == i {
                        dx += contacts[c].grad * li;
                        c += 1;
                    }
                    let len = dx.length();
                    let scale = if !len.is_finite() {
                        0.0
                    } else if len > cap {
                        cap / len
                    } else {
                        1.0
                    };
                    *out = p + dx * scale;
                    if li < 0.0 && scale > 0.0 {
                        for contact in &contacts[first..c] {
                            let moved = (contact.grad * (li * scale)).as_dvec3();
                            coupling.push_back(
                                pushes,
                                contact.target,
                                contact.point,
                                contact.normal.as_dvec3(),
                                moved,
                                w_p,
                            );
                        }
                    }
                }
            },
        );
    }

    /// Keeps the particles out of the bodies and takes the velocities from
    /// the positions; a non-finite particle goes back to where the substep
    /// found it, at rest.
    fn collide(&mut self, hs: f32, coupling: &Coupling<'_>, walls: bool) {
        let prev = &self.prev;
        // The positions before the corrections (swapped out of `x`).
        let before = &self.next;
        let w = 1.0 / self.mass;
        let (radius, mu) = (self.collision_radius, self.friction);
        let moving = coupling.moving();
        for_each_chunk2_with(
            &mut self.x,
            &mut self.v,
            CHUNK,
            &mut self.chunks,
            |base, x, v, scratch| {
                for k in 0..x.len() {
                    let i = base + k;
                    let q = prev[i];
                    let mut p = x[k];
                    // A particle that stood farther from every surface than
                    // the collision radius and its correction together
                    // cannot be within it, while the bodies hold still.
                    if walls && (moving || scratch.gap[k] - (p - before[i]).length() < radius) {
                        coupling.press(i, &mut p, q, w, radius, mu, hs, &mut scratch.pushes);
                    }
                    let mut vel = (p - q) / hs;
                    if !(p.is_finite() && vel.is_finite()) {
                        p = q;
                        vel = Vec3::ZERO;
                    }
                    x[k] = p;
                    v[k] = vel;
                }
            },
        );
    }

    /// XSPH viscosity: `v_i += c V Σ_j (v_j − v_i) W_poly6(x_i − x_j)`.
    fn xsph(&mut self) {
        let (x, v, nb) = (&self.x, &self.v, &self.neighbours);
        let kernels = self.kernels;
        let scale = self.viscosity * self.volume;
        let far = 2.0 * kernels.h;
        for_each_chunk(&mut self.next, CHUNK, |base, next| {
            for (k, out) in next.iter_mut().enumerate() {
                let i = base + k;
                let (p, vi) = (x[i], v[i]);
                let (mut ax, mut ay, mut az) = (f32x8::ZERO, f32x8::ZERO, f32x8::ZERO);
                for js in nb.of(i).chunks(LANES) {
                    let (dx, dy, dz) = offsets(p, x, js, far);
                    let w = kernels.poly6_x8(dx * dx + dy * dy + dz * dz);
                    // `v_i − v_j`, so the sum is taken with the sign turned.
                    let (ux, uy, uz) = offsets(vi, v, js, 0.0);
                    ax -= ux * w;
                    ay -= uy * w;
                    az -= uz * w;
                }
                let acc = Vec3::new(lanes_sum(ax), lanes_sum(ay), lanes_sum(az));
                let nv = vi + acc * scale;
                *out = if nv.is_finite() { nv } else { vi };
            }
        });
        std::mem::swap(&mut self.v, &mut self.next);
    }

    /// Vorticity confinement over a step of `dt`: the vorticity
    /// `ω_i = V Σ_j ∇W(x_i − x_j) × (v_j − v_i)`, its gradient's direction
    /// `N = η / |η|` with `η = V Σ_j (|ω_j| − |ω_i|) ∇W(x_i − x_j)`, and
    /// `v_i += dt ε (N × ω_i)`.
    fn confine_vorticity(&mut self, dt: f32) {
        let (x, v, nb) = (&self.x, &self.v, &self.neighbours);
        let kernels = self.kernels;
        let volume = self.volume;
        for_each_chunk(&mut self.omega, CHUNK, |base, omega| {
            for (k, out) in omega.iter_mut().enumerate() {
                let i = base + k;
                let (p, vi) = (x[i], v[i]);
                let mut w = Vec3::ZERO;
                for &j in nb.of(i) {
                    let j = j as usize;
                    let d = p - x[j];
                    let g = d * kernels.spiky_grad_over_r(d.length());
                    w += g.cross(v[j] - vi);
                }
                let w = w * volume;
                *out = if w.is_finite() { w } else { Vec3::ZERO };
            }
        });
        let omega = &self.omega;
        let strength = self.vorticity * dt;
        for_each_chunk(&mut self.next, CHUNK, |base, next| {
            for (k, out) in next.iter_mut().enumerate() {
                let i = base + k;
                let p = x[i];
                let wi = omega[i].length();
                let mut eta = Vec3::ZERO;
                for &j in nb.of(i) {
                    let j = j as usize;
                    let d = p - x[j];
                    eta += d * (kernels.spiky_grad_over_r(d.length()) * (omega[j].length() - wi));
                }
                let len = eta.length();
                let mut nv = v[i];
                if len > 1e-12 && len.is_finite() {
                    let dir = eta / len;
                    nv += dir.cross(omega[i]) * strength;
                }
                *out = if nv.is_finite() { nv } else { v[i] };
            }
        });
        std::mem::swap(&mut self.v, &mut self.next);
    }
}
