//! Hooke springs with damping between two particles of one system.
//!
//! Force on particle `a` (and its opposite on `b`), with `d = x_a - x_b`,
//! `L = |d|`, `n = d / L`:
//!
//! `F_a = -(k (L - L0) + c (v_a - v_b) · n) n`
//!
//! where `L0` is the rest length (m), `k` the stiffness (N/m) and `c` the
//! damping (N·s/m). Potential energy: `½ k (L - L0)²`.
//!
//! Determinism under threads: each spring's force is computed independently
//! (in parallel, into its own slot), then each particle *gathers* the forces
//! of its springs in a fixed order from a CSR adjacency. No particle is ever
//! written by two threads, and the sum order never depends on the thread count.

use glam::DVec3;

use crate::error::{non_negative, positive, PhysicsError};
use crate::parallel::{par_map_chunks, CHUNK};

/// Parameters of one spring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringParams {
    /// Rest length `L0`, m; must be > 0.
    pub rest_length: f64,
    /// Stiffness `k`, N/m; must be >= 0.
    pub stiffness: f64,
    /// Damping `c`, N·s/m, along the spring; must be >= 0.
    pub damping: f64,
}

impl SpringParams {
    pub(crate) fn validate(&self) -> Result<(), PhysicsError> {
        if self.rest_length == 0.0 {
            return Err(PhysicsError::DegenerateSpring("rest length is zero"));
        }
        positive("spring rest length", self.rest_length)?;
        non_negative("spring stiffness", self.stiffness)?;
        non_negative("spring damping", self.damping)?;
        Ok(())
    }
}

/// A spring as stored: endpoints are particle *slots* (stable across removals).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Spring {
    pub(crate) a: u32,
    pub(crate) b: u32,
    pub(crate) params: SpringParams,
}

/// Springs compiled to dense arrays plus a CSR particle → springs adjacency.
/// Derived from the springs and the slot table; rebuilt when `dirty`.
#[derive(Debug, Clone, Default)]
pub(crate) struct SpringTopology {
    pub(crate) dirty: bool,
    /// Dense endpoint indices.
    pub(crate) a: Vec<u32>,
    pub(crate) b: Vec<u32>,
    pub(crate) params: Vec<SpringParams>,
    /// `adj[offsets[i]..offsets[i+1]]` are `(spring << 1) | is_b` for particle `i`.
    pub(crate) offsets: Vec<u32>,
    pub(crate) adj: Vec<u32>,
    /// Scratch: force on endpoint `a` of each spring, N.
    pub(crate) force: Vec<DVec3>,
    /// Upper bound on the squared highest natural frequency of the spring
    /// network, rad²/s² (Gershgorin bound on `M^-1 K`).
    pub(crate) omega2_max: f64,
    /// Upper bound on the damping rate `Σ c / m` of any particle, 1/s.
    pub(crate) damping_rate_max: f64,
    /// Factors on every spring's stiffness and damping for the current step:
    /// 1 unless even the most substeps allowed cannot keep the network stable
    /// (see [`SpringTopology::plan`]).
    pub(crate) stiffness_scale: f64,
    pub(crate) damping_scale: f64,
}

impl SpringTopology {
    /// Rebuilds from springs (in arena order) and the slot table.
    pub(crate) fn rebuild<'a>(
        &mut self,
        springs: impl Iterator<Item = &'a Spring>,
        slot_to_dense: impl Fn(u32) -> u32,
        inv_mass: &[f64],
        movable: impl Fn(usize) -> bool,
    ) {
        let particle_count = inv_mass.len();
        self.a.clear();
        self.b.clear();
        self.params.clear();
        for s in springs {
            self.a.push(slot_to_dense(s.a));
            self.b.push(slot_to_dense(s.b));
            self.params.push(s.params);
        }
        let mut counts = vec![0u32; particle_count + 1];
        for (&a, &b) in self.a.iter().zip(&self.b) {
            counts[a as usize + 1] += 1;
            counts[b as usize + 1] += 1;
        }
        for i in 0..particle_count {
            counts[i + 1] += counts[i];
        }
        self.offsets = counts.clone();
        self.adj = vec![0; self.a.len() * 2];
        let mut cursor = counts;
        for (s, (&a, &b)) in self.a.iter().zip(&self.b).enumerate() {
            let s = s as u32;
            self.adj[cursor[a as usize] as usize] = s << 1;
            cursor[a as usize] += 1;
            self.adj[cursor[b as usize] as usize] = (s << 1) | 1;
            cursor[b as usize] += 1;
        }
        self.force.resize(self.a.len(), DVec3::ZERO);
        // Stability: per movable particle, Σ k (1/m_i + 1/sqrt(m_i m_j)) bounds
        // the row sum of M^-1/2 K M^-1/2 (Gershgorin), hence ω².
        let (mut w2, mut g) = (0.0f64, 0.0f64);
        for i in 0..particle_count {
            if !movable(i) {
                continue;
            }
            let (mut row, mut damp) = (0.0, 0.0);
            for &e in &self.adj[self.offsets[i] as usize..self.offsets[i + 1] as usize] {
                let s = (e >> 1) as usize;
                let j = if e & 1 == 0 { self.b[s] } else { self.a[s] } as usize;
                let p = &self.params[s];
                let other = if movable(j) {
                    (inv_mass[i] * inv_mass[j]).sqrt()
                } else {
                    0.0
                };
                row += p.stiffness * (inv_mass[i] + other);
                damp += p.damping * (inv_mass[i] + other);
            }
            w2 = w2.max(row);
            g = g.max(damp);
        }
        self.omega2_max = w2;
        self.damping_rate_max = g;
        self.stiffness_scale = 1.0;
        self.damping_scale = 1.0;
        self.dirty = false;
    }

    /// Plans a world step of `dt`: the substeps that keep an explicit step
    /// stable for this network (`ω_max h <= 1` and `damping_rate h <= 1` with
    /// `h = dt / n`), at most `max`. If `max` is not enough, the springs are
    /// softened for this step just enough to be stable at `max` substeps
    /// (stiffness by `(n / ω dt)²`, damping by `n / (rate dt)`): the network
    /// gets stretchier instead of exploding. Returns the substep count.
    pub(crate) fn plan(&mut self, dt: f64, max: u32) -> u32 {
        let max = max.max(1);
        let (w, r) = (self.omega2_max.sqrt() * dt, self.damping_rate_max * dt);
        let need = w.max(r);
        let n = if need.is_finite() {
            (need.ceil() as u32).clamp(1, max)
        } else {
            max
        };
        let nf = f64::from(n);
        self.stiffness_scale = if w > nf { (nf / w) * (nf / w) } else { 1.0 };
        self.damping_scale = if r > nf { nf / r } else { 1.0 };
        n
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.a.is_empty()
    }

    /// Computes every spring's force into `self.force`, then adds each
    /// particle's gathered spring force into `out` (N). Springs touching a
    /// particle with `skip` flags set exert nothing.
    pub(crate) fn accumulate(
        &mut self,
        x: &[DVec3],
        v: &[DVec3],
        flags: &[u32],
        skip: u32,
        out: &mut [DVec3],
    ) {
        let (a, b, params) = (&self.a, &self.b, &self.params);
        let (ks, cs) = (self.stiffness_scale, self.damping_scale);
        let scaled = ks != 1.0 || cs != 1.0;
        par_map_chunks(&mut self.force, CHUNK, |base, chunk| {
            for (k, f) in chunk.iter_mut().enumerate() {
                let s = base + k;
                let (ia, ib) = (a[s] as usize, b[s] as usize);
                *f = if (flags[ia] | flags[ib]) & skip != 0 {
                    DVec3::ZERO
                } else {
                    let p = if scaled {
                        SpringParams {
                            stiffness: params[s].stiffness * ks,
                            damping: params[s].damping * cs,
                            ..params[s]
                        }
                    } else {
                        params[s]
                    };
                    spring_force(x[ia] - x[ib], v[ia] - v[ib], &p)
                };
            }
        });
        let (offsets, adj, force) = (&self.offsets, &self.adj, &self.force);
        par_map_chunks(out, CHUNK, |base, chunk| {
            for (k, o) in chunk.iter_mut().enumerate() {
                let i = base + k;
                let mut sum = DVec3::ZERO;
                for &e in &adj[offsets[i] as usize..offsets[i + 1] as usize] {
                    let f = force[(e >> 1) as usize];
                    sum += if e & 1 == 0 { f } else { -f };
                }
                *o += sum;
            }
        });
    }

    /// Total elastic potential energy, J, summed in spring order.
    pub(crate) fn potential(&self, x: &[DVec3], flags: &[u32], skip: u32) -> f64 {
        let mut e = 0.0;
        for s in 0..self.a.len() {
            let (ia, ib) = (self.a[s] as usize, self.b[s] as usize);
            if (flags[ia] | flags[ib]) & skip != 0 {
                continue;
            }
            let p = &self.params[s];
            let stretch = (x[ia] - x[ib]).length() - p.rest_length;
            e += 0.5 * p.stiffness * self.stiffness_scale * stretch * stretch;
        }
        e
    }
}

/// Force on endpoint `a`, N, given `d = x_a - x_b` and `dv = v_a - v_b`.
#[inline]
pub(crate) fn spring_force(d: DVec3, dv: DVec3, p: &SpringParams) -> DVec3 {
    let len = d.length();
    if len <= f64::MIN_POSITIVE || !len.is_finite() {
        // Coincident endpoints: the direction is undefined, exert nothing
        // rather than a NaN.
        return DVec3::ZERO;
    }
    let n = d / len;
    -(p.stiffness * (len - p.rest_length) + p.damping * dv.dot(n)) * n
}
