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
//!    `ρ_i / ρ0 = V Σ_j W_poly6(x_i − x_j) + Σ_walls Φ(d)` (with `V` the
//!    particle volume `m / ρ0 = spacing³`, normalised so that a particle
//!    in a cubic lattice at rest reads `ρ0`; itself included in the sum),
//!    `C_i = max(ρ_i / ρ0 − 1, 0)`,
//!    `λ_i = −C_i / (Σ_k |∇_k C_i|² + ε)` with
//!    `∇_i C_i = V Σ_j ∇W_spiky(x_i − x_j) + Σ_walls Ψ(d) n` and
//!    `∇_j C_i = −V ∇W_spiky(x_i − x_j)`; then moves by
//!    `Δx_i = V Σ_j (λ_i + λ_j + s_corr) ∇W_spiky(x_i − x_j) + λ_i Σ_walls Ψ(d) n`,
//!    with the tensile correction `s_corr = −k h² (W(r) / W(Δq))ⁿ`. The
//!    body behind a wall takes `−Δx_wall / (hs (w_p + w_b))` (the pair's
//!    effective mass, as [`Coupling::push_out`] weighs it);
//! 3. particles are kept the collision radius out of the bodies, with
//!    friction ([`Coupling::push_out`]);
//! 4. `v = (x − x_prev) / hs`; a particle gone non-finite goes back to
//!    `x_prev` at rest.
//!
//! After the substeps, vorticity confinement and XSPH viscosity act on the
//! velocities. Every pass is Jacobi (reads old values, writes new ones),
//! runs over fixed chunks of particles in parallel, and each particle
//! gathers from its neighbours in ascending index order and writes only
//! itself: the result is the same on any number of threads. The bodies'
//! impulses are summed per chunk and handed over in chunk order.

use glam::Vec3;

use super::{ChunkScratch, Fluid, WallContact, CHUNK};
use crate::parallel::{for_each_chunk, for_each_chunk2_with, for_each_chunk_with, par_map_chunks3};
use crate::xpbd::coupling::Coupling;

/// Largest position correction a particle takes in one substep, in
/// spacings: a bad configuration settles over a few substeps instead of
/// throwing particles out.
const MAX_CORRECTION: f32 = 0.5;

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

impl Fluid {
    /// Advances the fluid by `dt` seconds under `gravity` (m/s², scaled by
    /// the gravity scale) against the bodies of `coupling` (gathered for
    /// this fluid's particles at the start of the step), adding what the
    /// particles give the bodies to `coupling`'s loads. A `dt` that is not
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

        let hs = dt / self.substeps as f32;
        for _ in 0..self.substeps {
            self.predict(hs, g);
            self.find_densities(coupling, walls);
            self.corrections(hs, coupling);
            std::mem::swap(&mut self.x, &mut self.next);

            self.collide(hs, coupling, walls);
        }
        if self.vorticity > 0.0 {
            self.confine_vorticity(dt);
        }
        if self.viscosity > 0.0 {
            self.xsph();
        }
        if walls {
            for chunk in &self.chunks[..pieces] {
                coupling.add_loads(&chunk.loads);
            }
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
            chunk.loads.clear();
            chunk
                .loads
                .resize(targets, (glam::DVec3::ZERO, glam::DVec3::ZERO));
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

    /// Densities and constraint multipliers at the current positions, and
    /// the walls within a kernel radius of each particle.
    fn find_densities(&mut self, coupling: &Coupling<'_>, walls: bool) {
        let x = &self.x;
        let nb = &self.neighbours;
        let kernels = self.kernels;
        let table = &self.wall;
        let (volume, rest, eps) = (self.volume, self.rest_density, self.relaxation);
        let h = kernels.h;
        let self_weight = kernels.spiky(0.0);
        for_each_chunk2_with(
            &mut self.lambda,
            &mut self.density,
            CHUNK,
            &mut self.chunks,
            |base, lambda, density, scratch| {
                scratch.contacts.clear();
                for k in 0..lambda.len() {
                    let i = base + k;
                    let p = x[i];
                    let mut sum_w = self_weight;
                    let mut grad = Vec3::ZERO;
                    let mut sum_sq = 0.0f32;
                    for &j in nb.of(i) {
                        let d = p - x[j as usize];
                        let r2 = d.length_squared();
                        if r2 >= kernels.h2 {
                            continue;
                        }
                        let r = r2.sqrt();
                        sum_w += kernels.spiky(r);
                        let gw = d * kernels.spiky_grad_over_r(r);
                        grad += gw;
                        sum_sq += gw.length_squared();
                    }
                    let mut frac = volume * sum_w;
                    let mut grad = grad * volume;
                    let sum_sq = sum_sq * volume * volume;
                    if walls {
                        let first = scratch.contacts.len();
                        for &t in coupling.candidates(i) {
                            let Some(s) = coupling.surface(t, p, f64::from(h)) else {
                                continue;
                            };
                            let (phi, psi) = table.at(s.distance as f32);
                            if phi <= 0.0 && psi == 0.0 {
                                continue;
                            }
                            scratch.contacts.push(WallContact {
                                particle: i as u32,
                                target: t,
                                point: s.point,
                                normal: s.normal.as_vec3(),
                                phi,
                                psi,
                                grad: Vec3::ZERO,
                            });
                        }
                        let touching = &mut scratch.contacts[first..];
                        let (phi, wall_grad) = wall_union(touching);
                        frac += phi;
                        grad += wall_grad;
                    }
                    density[k] = rest * frac;
                    let c = frac - 1.0;
                    let denom = grad.length_squared() + sum_sq + eps;
                    let l = if c > 0.0 && denom > 0.0 { -c / denom } else { 0.0 };
                    lambda[k] = if l.is_finite() { l } else { 0.0 };
                }
            },
        );
    }

    /// The Jacobi position corrections: `next = x + Δx`; the walls' share
    /// goes to the bodies' loads.
    fn corrections(&mut self, hs: f32, coupling: &Coupling<'_>) {
        let x = &self.x;
        let lambda = &self.lambda;
        let nb = &self.neighbours;
        let kernels = self.kernels;
        let volume = self.volume;
        let cap = MAX_CORRECTION * self.spacing;
        let tensile = self.tensile_k > 0.0 && self.tensile_inv_w > 0.0;
        let s_scale = -self.tensile_k * kernels.h2;
        let (inv_w, power) = (self.tensile_inv_w, self.tensile_n);
        let w_p = f64::from(1.0 / self.mass);
        let hs = f64::from(hs);
        for_each_chunk_with(&mut self.next, CHUNK, &mut self.chunks, |base, next, scratch| {
            let ChunkScratch { contacts, loads } = scratch;
            let mut c = 0;
            for k in 0..next.len() {
                let i = base + k;
                let p = x[i];
                let li = lambda[i];
                let mut dx = Vec3::ZERO;
                for &j in nb.of(i) {
                    let d = p - x[j as usize];
                    let r2 = d.length_squared();
                    if r2 >= kernels.h2 {
                        continue;
                    }
                    let mut s = li + lambda[j as usize];
                    if tensile {
                        s += s_scale * (kernels.poly6(r2) * inv_w).powi(power);
                    }
                    if s != 0.0 {
                        dx += d * (s * kernels.spiky_grad_over_r(r2.sqrt()));
                    }
                }
                dx *= volume;
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
                next[k] = p + dx * scale;
                if li < 0.0 && scale > 0.0 {
                    for contact in &contacts[first..c] {
                        let target = &coupling.targets[contact.target as usize];
                        if !target.movable() {
                            continue;
                        }
                        let moved = (contact.grad * (li * scale)).as_dvec3();
                        let normal = contact.normal.as_dvec3();
                        let k = w_p + target.inv_mass_along(contact.point, normal);
                        if k > 0.0 {
                            coupling.add_load(loads, contact.target, contact.point, -moved / (hs * k));
                        }
                    }
                }
            }
        });
    }

    /// Keeps the particles out of the bodies and takes the velocities from
    /// the positions; a non-finite particle goes back to where the substep
    /// found it, at rest.
    fn collide(&mut self, hs: f32, coupling: &Coupling<'_>, walls: bool) {
        let prev = &self.prev;
        let w = 1.0 / self.mass;
        let (radius, mu) = (self.collision_radius, self.friction);
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
                    if walls {
                        coupling.push_out(i, &mut p, q, w, radius, mu, hs, &mut scratch.loads);
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
        for_each_chunk(&mut self.next, CHUNK, |base, next| {
            for (k, out) in next.iter_mut().enumerate() {
                let i = base + k;
                let (p, vi) = (x[i], v[i]);
                let mut acc = Vec3::ZERO;
                for &j in nb.of(i) {
                    let j = j as usize;
                    let w = kernels.poly6((p - x[j]).length_squared());
                    if w > 0.0 {
                        acc += (v[j] - vi) * w;
                    }
                }
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
