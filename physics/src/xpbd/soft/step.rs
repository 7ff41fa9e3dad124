//! One step of a soft body: small steps of predict, project, collide,
//! update velocities; then plastic flow and tearing.

use glam::Vec3;

use crate::parallel::{for_each_stage_block, par_map_chunks, par_map_chunks3, CHUNK};

use super::super::coupling::{Coupling, Push};
use super::super::scatter::Scatter;
use super::{lanes, SoftBody, MAX_TEARS_PER_STEP};

/// Steps `body` by `dt` seconds under `gravity` (m/s², the world's), with
/// the rigid bodies of `coupling` as obstacles and anchors. `travel` is
/// how far a particle can go in the step (m, [`SoftBody::travel`]).
pub(crate) fn step(
    body: &mut SoftBody,
    dt: f32,
    gravity: Vec3,
    travel: f32,
    coupling: &mut Coupling<'_>,
) {
    let n = body.material.substeps.max(1);
    let h = dt / n as f32;
    let inv_h2 = 1.0 / (h * h);
    let g = gravity * body.material.gravity_scale as f32;
    let keep = (1.0 - body.material.damping as f32 * h).max(0.0);
    let radius = body.material.collision_radius as f32;
    let friction = body.material.friction as f32;
    // Attachments whose body is a target of the step.
    let attached: Vec<(usize, usize)> = body
        .attachments
        .iter()
        .enumerate()
        .filter_map(|(k, a)| {
            coupling
                .target_of((a.body.index, a.body.generation))
                .map(|t| (k, t))
        })
        .collect();
    let mut grad = Vec::new();
    // The colours stay as they are over the substeps (tearing comes after).
    let stages = Stages::of(body);
    let self_collide = body.material.self_collision && radius > 0.0;
    let mut self_collision = std::mem::take(&mut body.self_collision);
    if self_collide {
        // Both particles of a pair may travel.
        self_collision.prepare(body, 2.0 * radius + 2.0 * travel);
    }
    for k in 0..n {
        if k == 0 {
            predict(body, g, h);
        } else {
            // The last substep's velocities and this one's prediction in
            // one pass over the particles.
            finish_substep(body, h, keep, Some(g));
        }
        project_constraints(body, &stages, inv_h2, &mut grad);
        coupling.advance(f64::from(h));
        coupling.follow(f64::from(k + 1) / f64::from(n));
        for &(k, t) in &attached {
            attach(body, k, t, coupling, h, inv_h2);
        }
        if radius > 0.0 && !coupling.is_empty() {
            collide(body, coupling, radius, friction, h);
        }
        if self_collide {
            self_collision.project(body, radius);
        }
    }
    finish_substep(body, h, keep, None);
    body.self_collision = self_collision;
    if let Some(p) = body.material.plasticity {
        let rate = (p.creep as f32 * dt).min(1.0);
        let (yield_strain, max) = (p.yield_strain as f32, p.max_strain as f32);
        let x = &body.x;
        for d in &mut body.distance.items {
            let len = (x[d.p[1] as usize] - x[d.p[0] as usize]).length();
            let strain = len / d.rest - 1.0;
            if strain.abs() > yield_strain {
                let target = len / (1.0 + yield_strain * strain.signum());
                let rest = d.rest + (target - d.rest) * rate;
                d.rest = rest.clamp(d.rest0 * (1.0 - max).max(0.01), d.rest0 * (1.0 + max));
            }
        }
    }
    if let Some(t) = body.material.tear_strain {
        tear(body, t as f32);
    }
}

/// `prev = x`, then `v += g h` and `x += v h` for a particle that can
/// move (inverse mass `w > 0`); a pinned one keeps no velocity.
#[inline(always)]
fn predict_particle(x: &mut Vec3, v: &mut Vec3, prev: &mut Vec3, w: f32, g: Vec3, h: f32) {
    *prev = *x;
    if w > 0.0 {
        *v += g * h;
        *x += *v * h;
    } else {
        *v = Vec3::ZERO;
    }
}

/// The first substep's prediction, every particle.
fn predict(body: &mut SoftBody, g: Vec3, h: f32) {
    let w = &body.w;
    par_map_chunks3(
        &mut body.x,
        &mut body.v,
        &mut body.prev,
        CHUNK,
        |base, xs, vs, ps| {
            for k in 0..xs.len() {
                predict_particle(&mut xs[k], &mut vs[k], &mut ps[k], w[base + k], g, h);
            }
        },
    );
}

/// The blocks of every colour of every kind, in solve order, for
/// [`for_each_stage_block`]: distance, then bending, volume and tether
/// colours, each kind starting at its own stage.
struct Stages {
    blocks: Vec<usize>,
    bends: usize,
    volumes: usize,
    tethered: usize,
}

impl Stages {
    fn of(body: &SoftBody) -> Self {
        let mut blocks = Vec::new();
        body.distance.stages(&mut blocks);
        let bends = blocks.len();
        body.bend.stages(&mut blocks);
        let volumes = blocks.len();
        body.tets.stages(&mut blocks);
        let tethered = blocks.len();
        body.tethers.stages(&mut blocks);
        Self {
            blocks,
            bends,
            volumes,
            tethered,
        }
    }
}

/// Every constraint once, kind after kind, colour after colour, in one
/// hand-off to the threads.
fn project_constraints(body: &mut SoftBody, stages: &Stages, inv_h2: f32, grad: &mut Vec<Vec3>) {
    let SoftBody {
        x,
        w,
        distance,
        bend,
        tets,
        tethers,
        ..
    } = body;
    let w = &w[..];
    let xs = Scatter::new(x);
    let &Stages {
        ref blocks,
        bends,
        volumes,
        tethered,
    } = stages;
    for_each_stage_block(blocks, |s, b| {
        if s < bends {
            distance.block(s, b).project_lanes(
                |four| lanes::project_distances(four, xs, w, inv_h2),
                |c| c.project(xs, w, inv_h2),
            );
        } else if s < volumes {
            bend.block(s - bends, b).project_lanes(
                |four| lanes::project_bends(four, xs, w, inv_h2),
                |c| c.project(xs, w, inv_h2),
            );
        } else if s < tethered {
            tets.block(s - volumes, b)
                .project(|c| c.project(xs, w, inv_h2));
        } else {
            tethers.block(s - tethered, b).project(|c| c.project(xs, w));
        }
    });
    if let Some(p) = body.pressure {
        project_pressure(body, p.target, p.compliance * inv_h2, grad);
    }
}

/// The enclosed volume kept at `target` m³ (one global constraint).
fn project_pressure(body: &mut SoftBody, target: f32, alpha: f32, grad: &mut Vec<Vec3>) {
    grad.clear();
    grad.resize(body.x.len(), Vec3::ZERO);
    let mut volume = 0.0f32;
    for t in &body.triangles {
        let [a, b, c] = t.map(|i| body.x[i as usize]);
        volume += a.dot(b.cross(c)) / 6.0;
        grad[t[0] as usize] += b.cross(c) / 6.0;
        grad[t[1] as usize] += c.cross(a) / 6.0;
        grad[t[2] as usize] += a.cross(b) / 6.0;
    }
    let mut k = alpha;
    for (g, w) in grad.iter().zip(&body.w) {
        k += w * g.length_squared();
    }
    if k <= 1e-30 {
        return;
    }
    let dl = -(volume - target) / k;
    for ((x, g), w) in body.x.iter_mut().zip(grad.iter()).zip(&body.w) {
        *x += *g * (w * dl);
    }
}

/// Attachment `k` to target `t`: a zero-length compliant constraint from
/// the particle to the body's point, both moved by their shares.
fn attach(
    body: &mut SoftBody,
    k: usize,
    t: usize,
    coupling: &mut Coupling<'_>,
    h: f32,
    inv_h2: f32,
) {
    let a = body.attachments[k];
    let i = a.particle as usize;
    let target = &mut coupling.targets[t];
    let anchor = target.world_point(a.local);
    let d = body.x[i].as_dvec3() - anchor;
    let len = d.length();
    if len < 1e-9 || !len.is_finite() {
        return;
    }
    let n = d / len;
    let wp = f64::from(body.w[i]);
    let k = wp + target.inv_mass_along_now(anchor, n) + f64::from(a.compliance * inv_h2);
    if k <= 0.0 {
        return;
    }
    let dl = -len / k;
    body.x[i] = (body.x[i].as_dvec3() + n * (wp * dl)).as_vec3();
    target.move_by(anchor, -n * dl, f64::from(h));
}

/// Particles kept out of the rigid bodies, each pair sharing its
/// correction; the bodies then move by their shares.
fn collide(body: &mut SoftBody, coupling: &mut Coupling<'_>, radius: f32, mu: f32, h: f32) {
    let (prev, w) = (&body.prev, &body.w);
    let c: &Coupling<'_> = coupling;
    let chunk_pushes = par_map_chunks(&mut body.x, CHUNK, |base, xs| {
        let mut pushes: Option<Vec<Push>> = None;
        for (k, x) in xs.iter_mut().enumerate() {
            let i = base + k;
            if c.candidates(i).is_empty() {
                continue;
            }
            let pushes = pushes.get_or_insert_with(|| c.new_pushes());
            c.press(i, x, prev[i], w[i], radius, mu, h, pushes);
        }
        pushes
    });
    let mut total = coupling.new_pushes();
    for pushes in chunk_pushes.into_iter().flatten() {
        for (sum, p) in total.iter_mut().zip(&pushes) {
            sum.add(p);
        }
    }
    coupling.take_pushes(&total, f64::from(h));
}

/// The velocities of the substep just taken, `v = (x − prev) / h`, damped
/// (a particle gone non-finite goes back to where it stood, at rest);
/// then, given the next substep's gravity, its prediction (`v += g h`,
/// `prev = x`, `x += v h`) in the same pass.
fn finish_substep(body: &mut SoftBody, h: f32, keep: f32, next: Option<Vec3>) {
    let w = &body.w;
    let inv_h = 1.0 / h;
    par_map_chunks3(
        &mut body.x,
        &mut body.v,
        &mut body.prev,
        CHUNK,
        |base, xs, vs, ps| {
            for k in 0..xs.len() {
                let wk = w[base + k];
                if wk > 0.0 {
                    let v = (xs[k] - ps[k]) * inv_h * keep;
                    if v.is_finite() && xs[k].is_finite() {
                        vs[k] = v;
                    } else {
                        xs[k] = ps[k];
                        vs[k] = Vec3::ZERO;
                    }
                }
                match next {
                    Some(g) => predict_particle(&mut xs[k], &mut vs[k], &mut ps[k], wk, g, h),
                    None if wk <= 0.0 => {
                        ps[k] = xs[k];
                        vs[k] = Vec3::ZERO;
                    }
                    None => {}
                }
            }
        },
    );
}

/// The distance constraints stretched past `limit` break, the most
/// strained first, with what lies on their edge; whether any broke.
pub(crate) fn tear(body: &mut SoftBody, limit: f32) -> bool {
    let x = &body.x;
    let mut over: Vec<(f32, [u32; 2])> = body
        .distance
        .items
        .iter()
        .filter_map(|d| {
            let s = (x[d.p[1] as usize] - x[d.p[0] as usize]).length() / d.rest - 1.0;
            (s > limit).then_some((s, d.p))
        })
        .collect();
    if over.is_empty() {
        return false;
    }
    // Most strained first; ties by the edge's particles (a total order).
    over.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    over.truncate(MAX_TEARS_PER_STEP);
    let broken: Vec<[u32; 2]> = over.iter().map(|(_, p)| sorted(*p)).collect();
    let on_edge = |ps: &[u32]| broken.iter().any(|[a, b]| ps.contains(a) && ps.contains(b));
    body.distance.retain(|d| !broken.contains(&sorted(d.p)));
    body.triangles.retain(|t| !on_edge(t));
    body.bend
        .retain(|b| !on_edge(&[b.p[0], b.p[1], b.p[2]]) && !on_edge(&[b.p[0], b.p[1], b.p[3]]));
    body.tets.retain(|t| !on_edge(&t.p));
    true
}

fn sorted([a, b]: [u32; 2]) -> [u32; 2] {
    [a.min(b), a.max(b)]
}
