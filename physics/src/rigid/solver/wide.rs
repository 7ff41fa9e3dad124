//! The contact passes four constraints at a time: lanes across
//! constraints, not across one manifold's points.
//!
//! The constraints of one colour share no movable body, so any four of them
//! can be solved at once, one a lane: their bodies are gathered into lanes
//! ([`WideBody::gather`]), the passes run as four-wide `f32` arithmetic,
//! and the new velocities are scattered back. Box2D v3 (`contact_solver.c`)
//! and Box3D solve their colours this way, rapier its
//! `ContactWithCoulombFriction<SimdReal>`, PhysX its
//! `SolverContactBatchPointDynamic4`.
//!
//! Within a colour the constraints are batched by point count, so a batch
//! of sphere contacts carries one point a lane and one of face contacts
//! four; the order of constraints within a colour changes nothing, as they
//! share no body. The overflow constraints (which do share bodies) are
//! batched one a batch and solved in order on one thread.
//!
//! The constraints are prepared in `f64` ([`ContactConstraint::prepare`])
//! and packed here once a step; the passes are the same as the scalar
//! [`ContactConstraint::solve`] and `ContactConstraint::warm_start` (kept
//! in test builds), lane by lane, with the manifold's points solved in
//! turn within a lane. What
//! the rest of the step reads back (the impulses) is unpacked into the
//! constraints ([`WideContacts::unpack`]).

use std::ops::Range;

use super::hot::{HotBody, WideBody};
use super::lanes::{F4, V3};
use super::{ContactConstraint, ContactPass, SolverBody, MAX_POINTS};
use crate::rigid::solver::colouring::{Groups, Shared, MAX_COLOURS};

/// Lanes of a batch.
pub(crate) const LANES: usize = 4;

/// Batches per parallel work item; a colour with fewer than two items' worth
/// runs on the calling thread.
const ITEM: usize = 16;

/// Bodies per parallel work item when loading and storing the hot state.
const BODY_ITEM: usize = 2048;

/// Batches per parallel work item when packing them.
const PACK_ITEM: usize = 64;

/// Entries of a packed lower-triangular 4×4 factor.
const TRIANGLE: usize = MAX_POINTS * (MAX_POINTS + 1) / 2;

/// Where entry `(i, j)`, `j ≤ i`, of a lower triangle is packed.
#[inline]
const fn tri(i: usize, j: usize) -> usize {
    i * (i + 1) / 2 + j
}

/// A friction or twist row of four constraints (see [`super::Row`]).
#[derive(Debug, Clone, Copy, Default)]
struct WideRow {
    ang_a: V3,
    ang_b: V3,
    mass: F4,
    impulse: F4,
}

/// Point `i` of the four constraints of a batch (see [`super::NormalRows`]).
#[derive(Debug, Clone, Copy, Default)]
struct WidePoint {
    ra: V3,
    rb: V3,
    /// Inverse effective mass, 1/kg, and its inverse, kg (0 where 0).
    k: F4,
    mass: F4,
    base: F4,
    impulse: F4,
    carried: F4,
    max_impulse: F4,
    total_impulse: F4,
}

/// The factors of the normal blocks of a batch, lower triangles packed
/// ([`tri`]); lanes without a block hold the identity.
#[derive(Debug, Clone, Copy)]
struct WideBlock {
    solve: [F4; TRIANGLE],
    relax: [F4; TRIANGLE],
}

/// Four constraints of one colour.
#[derive(Debug, Clone, Copy)]
struct Batch {
    /// The bodies of each lane (slots in the hot state), and whether the
    /// lane writes them back (movable; padding lanes read a body at rest
    /// and write nothing).
    a: [u32; LANES],
    b: [u32; LANES],
    write_a: [bool; LANES],
    write_b: [bool; LANES],
    /// Points used by the lane with most, and where they start in
    /// [`WideContacts::points`].
    count: u32,
    first: u32,
    /// Points each lane uses.
    len: F4,
    /// Where the batch's normal blocks are in [`WideContacts::blocks`], and
    /// which lanes have one (a mask).
    block: u32,
    has_block: F4,
    normal: V3,
    /// The friction coefficient for the step (static while the centre
    /// sticks at the start of the step, else dynamic).
    mu: F4,
    twist_radius: F4,
    centre_a: V3,
    centre_b: V3,
    t1: V3,
    t2: V3,
    friction: [WideRow; 2],
    twist: WideRow,
}

/// A contact pass's constants in lanes (see [`ContactPass`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct WidePass {
    use_bias: bool,
    h: F4,
    bias_rate: F4,
    mass_scale: F4,
    impulse_scale: F4,
    /// `impulse_scale / mass_scale`: the softness of the normal block.
    block_soft: F4,
    push_out: F4,
}

impl WidePass {
    pub(crate) fn new(pass: &ContactPass) -> Self {
        let f = |x: f64| F4::splat(x as f32);
        Self {
            use_bias: pass.use_bias,
            h: f(pass.h),
            bias_rate: f(pass.bias_rate),
            mass_scale: f(pass.mass_scale),
            impulse_scale: f(pass.impulse_scale),
            block_soft: f(pass.impulse_scale / pass.mass_scale),
            push_out: f(pass.push_out),
        }
    }
}

/// The contact constraints of a step in batches, and the bodies' hot state.
#[derive(Debug, Default)]
pub(crate) struct WideContacts {
    batches: Vec<Batch>,
    points: Vec<WidePoint>,
    blocks: Vec<WideBlock>,
    /// The batches of each colour, and whether it is the overflow.
    colours: Vec<(Range<usize>, bool)>,
    /// Where each stored constraint is: its batch and lane.
    lanes: Vec<(u32, u8)>,
    /// The bodies by slot, then one at rest that padding lanes read; only
    /// those in `used` are loaded (the others are never read).
    hot: Vec<HotBody>,
    /// The slots of the bodies the constraints join, in order: all that
    /// the passes load and store, so bodies no contact touches (a sleeping
    /// crowd beside a few moving ones) cost nothing in them.
    used: Vec<u32>,
}

/// `x` as `f32` lanes of a vector.
fn f32s(v: glam::DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

impl WideContacts {
    /// Batches of the prepared `constraints` (stored colour by colour, as
    /// `groups` and `colours` say), between `bodies` whose `movable` flags
    /// are given by slot, each with the normal block of its points
    /// factored for the `solve` pass's softness (and the relax pass's); in
    /// the room of `self`, whatever it held.
    pub(crate) fn pack(
        &mut self,
        constraints: &[ContactConstraint],
        groups: &Groups,
        colours: &[u8],
        movable: &[bool],
        bodies: &[SolverBody],
        solve: &ContactPass,
    ) {
        let rest = movable.len() as u32;
        // The layout, in order: which constraints each batch takes (a
        // counting sort by point count within each colour), where its
        // points and block go.
        let mut members: Vec<[u32; LANES]> = Vec::new();
        let (mut points, mut blocks) = (0u32, 0u32);
        let mut new_batch = |ks: &[u32], batches: &mut Vec<Batch>| {
            let count = ks
                .iter()
                .map(|&k| constraints[k as usize].len.min(MAX_POINTS))
                .max()
                .unwrap_or(0) as u32;
            let mut lanes = [u32::MAX; LANES];
            lanes[..ks.len()].copy_from_slice(ks);
            members.push(lanes);
            let block = if count >= 2 {
                blocks += 1;
                blocks - 1
            } else {
                u32::MAX
            };
            batches.push(Batch::empty(rest, count, points, block));
            points += count;
        };
        self.batches.clear();
        self.colours.clear();
        let mut by_len: [Vec<u32>; MAX_POINTS + 1] = Default::default();
        for range in &groups.ranges {
            let ks = &groups.order[range.clone()];
            let overflow = colours[ks[0] as usize] as usize == MAX_COLOURS;
            let start = self.batches.len();
            if overflow {
                for k in ks {
                    new_batch(std::slice::from_ref(k), &mut self.batches);
                }
            } else {
                by_len.iter_mut().for_each(Vec::clear);
                for &k in ks {
                    by_len[constraints[k as usize].len.min(MAX_POINTS)].push(k);
                }
                for same in &by_len {
                    for four in same.chunks(LANES) {
                        new_batch(four, &mut self.batches);
                    }
                }
            }
            self.colours.push((start..self.batches.len(), overflow));
        }
        // The bodies the constraints join.
        let mut seen = vec![false; movable.len()];
        for c in constraints {
            seen[c.a] = true;
            seen[c.b] = true;
        }
        self.used.clear();
        self.used
            .extend((0..movable.len() as u32).filter(|&k| seen[k as usize]));
        // The contents, batch by batch in parallel.
        self.points.clear();
        self.points.resize(points as usize, WidePoint::default());
        self.blocks.clear();
        self.blocks.resize(
            blocks as usize,
            WideBlock {
                solve: identity(),
                relax: identity(),
            },
        );
        self.lanes.clear();
        self.lanes.resize(constraints.len(), (0, 0));
        let (wide_points, wide_blocks, lanes) = (
            Shared::new(&mut self.points),
            Shared::new(&mut self.blocks),
            Shared::new(&mut self.lanes),
        );
        crate::parallel::par_map_chunks(&mut self.batches, PACK_ITEM, |base, chunk| {
            for (j, batch) in chunk.iter_mut().enumerate() {
                let at = base + j;
                // SAFETY: each batch has its own range of points and its
                // own block (the layout above), and each constraint is in
                // one batch.
                let pts =
                    unsafe { wide_points.get_range(batch.first as usize, batch.count as usize) };
                let mut block = (batch.block != u32::MAX).then(|| {
                    // SAFETY: as above.
                    unsafe { wide_blocks.get(batch.block as usize) }
                });
                for (l, &k) in members[at].iter().enumerate() {
                    if k == u32::MAX {
                        break;
                    }
                    // SAFETY: as above.
                    unsafe { *lanes.get(k as usize) = (at as u32, l as u8) };
                    let c = &constraints[k as usize];
                    batch.set_lane(l, c, movable, pts);
                    let Some(wide) = &mut block else { continue };
                    if let Some(factors) = c.factor_block(&bodies[c.a], &bodies[c.b], solve) {
                        wide.set_lane(l, &factors, batch.count as usize);
                        batch.has_block.as_mut_array()[l] = f32::from_bits(u32::MAX);
                    }
                }
            }
        });
    }

    /// Copies the bodies the constraints join into the hot state (all of
    /// each: the integration moves them and may freeze one between passes).
    pub(crate) fn load(&mut self, bodies: &[SolverBody]) {
        self.hot.resize(bodies.len() + 1, HotBody::default());
        self.hot[bodies.len()] = HotBody::default();
        if self.used.len() == bodies.len() {
            // Every body: straight through.
            let hot = &mut self.hot[..bodies.len()];
            crate::parallel::par_map_chunks(hot, BODY_ITEM, |base, chunk| {
                for (h, b) in chunk.iter_mut().zip(&bodies[base..]) {
                    *h = HotBody::of(b);
                }
            });
            return;
        }
        let hot = Shared::new(&mut self.hot);
        crate::parallel::for_each_item(&self.used, BODY_ITEM, |chunk| {
            for &k in chunk {
                // SAFETY: each slot is once in `used`.
                unsafe { *hot.get(k as usize) = HotBody::of(&bodies[k as usize]) };
            }
        });
    }

    /// Copies the hot state's velocities into the `movable` bodies the
    /// constraints join.
    pub(crate) fn store(&self, bodies: &mut [SolverBody], movable: &[bool]) {
        let hot = &self.hot;
        if self.used.len() == bodies.len() {
            crate::parallel::par_map_chunks(bodies, BODY_ITEM, |base, chunk| {
                for ((b, h), &m) in chunk.iter_mut().zip(&hot[base..]).zip(&movable[base..]) {
                    if m {
                        b.v = h.v();
                        b.w = h.w();
                    }
                }
            });
            return;
        }
        let out = Shared::new(bodies);
        crate::parallel::for_each_item(&self.used, BODY_ITEM, |chunk| {
            for &k in chunk {
                if movable[k as usize] {
                    // SAFETY: each slot is once in `used`.
                    let b = unsafe { out.get(k as usize) };
                    b.v = hot[k as usize].v();
                    b.w = hot[k as usize].w();
                }
            }
        });
    }

    /// Whether there is nothing to solve.
    pub(crate) fn is_empty(&self) -> bool {
        self.batches.is_empty()
    }

    /// Re-applies the impulses of the last substep.
    pub(crate) fn warm_start(&mut self) {
        self.run(|batch, pts, _, a, b| batch.warm_start(pts, a, b));
    }

    /// One solve (`pass.use_bias`) or relax pass.
    pub(crate) fn solve(&mut self, pass: &WidePass) {
        self.run(|batch, pts, block, a, b| batch.solve(pts, block, a, b, pass));
    }

    /// Runs `f(batch, its points, its blocks, body A lanes, body B lanes)`
    /// over every batch, colour by colour, each colour's batches in
    /// parallel (the overflow in order on the calling thread), on the hot
    /// state.
    fn run<F>(&mut self, f: F)
    where
        F: Fn(&mut Batch, &mut [WidePoint], Option<&WideBlock>, &mut WideBody, &mut WideBody)
            + Sync,
    {
        let hot = Shared::new(&mut self.hot);
        let points = Shared::new(&mut self.points);
        let blocks = &self.blocks;
        let one = |batch: &mut Batch| {
            let gather = |ends: &[u32; LANES]| {
                WideBody::gather(&std::array::from_fn(|l| hot.read(ends[l] as usize)))
            };
            let (mut a, mut b) = (gather(&batch.a), gather(&batch.b));
            // SAFETY: each batch's points are its own range of `points`
            // (`push_batch`), so no two batches hold the same point.
            let pts = unsafe { points.get_range(batch.first as usize, batch.count as usize) };
            let block = blocks.get(batch.block as usize);
            f(batch, pts, block, &mut a, &mut b);
            let writes = |body: &WideBody, ends: &[u32; LANES], write: &[bool; LANES]| {
                body.scatter(std::array::from_fn(|l| {
                    write[l].then(|| {
                        // SAFETY: within a colour a movable body is in one
                        // lane of one batch only (the colouring), and a
                        // lane's two bodies differ; the overflow runs one
                        // batch at a time.
                        unsafe { hot.get(ends[l] as usize) }
                    })
                }));
            };
            writes(&a, &batch.a, &batch.write_a);
            writes(&b, &batch.b, &batch.write_b);
        };
        for (range, overflow) in &self.colours {
            let batches = &mut self.batches[range.clone()];
            if *overflow || batches.len() < 2 * ITEM {
                batches.iter_mut().for_each(one);
            } else {
                crate::parallel::par_map_chunks(batches, ITEM, |_, chunk| {
                    chunk.iter_mut().for_each(one);
                });
            }
        }
    }

    /// Copies the impulses of constraint `k` (as stored) back into `c`.
    pub(crate) fn unpack_one(&self, k: usize, c: &mut ContactConstraint) {
        let (at, l) = self.lanes[k];
        let (batch, l) = (&self.batches[at as usize], l as usize);
        let pts = &self.points[batch.first as usize..][..batch.count as usize];
        let lane = |x: &F4| f64::from(x.as_array()[l]);
        for (i, p) in pts.iter().enumerate().take(c.len) {
            c.rows.impulse[i] = lane(&p.impulse);
            c.rows.max_impulse[i] = lane(&p.max_impulse);
            c.rows.total_impulse[i] = lane(&p.total_impulse);
        }
        c.friction[0].impulse = lane(&batch.friction[0].impulse);
        c.friction[1].impulse = lane(&batch.friction[1].impulse);
        c.twist.impulse = lane(&batch.twist.impulse);
    }

    /// Copies every constraint's impulses back.
    pub(crate) fn unpack(&self, constraints: &mut [ContactConstraint]) {
        for (k, c) in constraints.iter_mut().enumerate() {
            self.unpack_one(k, c);
        }
    }
}

/// The identity, packed.
fn identity() -> [F4; TRIANGLE] {
    std::array::from_fn(|e| {
        let diagonal = (0..MAX_POINTS).any(|i| tri(i, i) == e);
        if diagonal {
            F4::ONE
        } else {
            F4::ZERO
        }
    })
}

/// Solves `L Lᵀ x = rhs` over the first `n` points, with `L` packed and its
/// diagonal holding `1 / L_ii` (see `super::cholesky`).
#[inline]
fn cholesky_solve(l: &[F4; TRIANGLE], rhs: &[F4; MAX_POINTS], n: usize) -> [F4; MAX_POINTS] {
    let mut y = [F4::ZERO; MAX_POINTS];
    for i in 0..n {
        let mut sum = rhs[i];
        for m in 0..i {
            sum -= l[tri(i, m)] * y[m];
        }
        y[i] = sum * l[tri(i, i)];
    }
    let mut x = [F4::ZERO; MAX_POINTS];
    for i in (0..n).rev() {
        let mut sum = y[i];
        for m in i + 1..n {
            sum -= l[tri(m, i)] * x[m];
        }
        x[i] = sum * l[tri(i, i)];
    }
    x
}

/// Applies `lambda` (N·s) along `d` with the row's angular parts: `-` on
/// A, `+` on B.
#[inline]
fn apply_row(row: &WideRow, d: V3, lambda: F4, a: &mut WideBody, b: &mut WideBody) {
    a.v -= d * (lambda * a.inv_mass);
    a.w -= row.ang_a * lambda;
    b.v += d * (lambda * b.inv_mass);
    b.w += row.ang_b * lambda;
}

impl WideBlock {
    /// Lane `l` holds the factors of a constraint's block (solve and
    /// relax), over its first `count` points.
    fn set_lane(&mut self, l: usize, factors: &[super::BlockMatrix; 2], count: usize) {
        for (into, from) in [
            (&mut self.solve, &factors[0]),
            (&mut self.relax, &factors[1]),
        ] {
            for i in 0..count {
                for j in 0..=i {
                    into[tri(i, j)].as_mut_array()[l] = from[i][j] as f32;
                }
            }
        }
    }
}

impl Batch {
    /// A batch of no constraints yet: every lane padding, reading the body
    /// at rest `rest`; its `count` points start at `first`, its block (if
    /// `count ≥ 2`) is `block`.
    fn empty(rest: u32, count: u32, first: u32, block: u32) -> Self {
        Self {
            a: [rest; LANES],
            b: [rest; LANES],
            write_a: [false; LANES],
            write_b: [false; LANES],
            count,
            first,
            len: F4::ZERO,
            block,
            has_block: F4::ZERO,
            normal: V3::ZERO,
            mu: F4::ZERO,
            twist_radius: F4::ZERO,
            centre_a: V3::ZERO,
            centre_b: V3::ZERO,
            t1: V3::ZERO,
            t2: V3::ZERO,
            friction: [WideRow::default(); 2],
            twist: WideRow::default(),
        }
    }

    /// Lane `l` (and its points, in `pts`) holds the prepared constraint
    /// `c`, between bodies whose `movable` flags are given by slot.
    fn set_lane(
        &mut self,
        l: usize,
        c: &ContactConstraint,
        movable: &[bool],
        pts: &mut [WidePoint],
    ) {
        self.a[l] = c.a as u32;
        self.b[l] = c.b as u32;
        self.write_a[l] = movable[c.a];
        self.write_b[l] = movable[c.b];
        let len = c.len.min(MAX_POINTS);
        self.len.as_mut_array()[l] = len as f32;
        self.normal.set_lane(l, f32s(c.normal));
        let mu = if c.sticking {
            c.friction_static
        } else {
            c.friction_dynamic
        };
        self.mu.as_mut_array()[l] = mu as f32;
        self.twist_radius.as_mut_array()[l] = c.twist_radius as f32;
        let (ca, cb) = c.centres();
        self.centre_a.set_lane(l, f32s(ca));
        self.centre_b.set_lane(l, f32s(cb));
        let [t1, t2] = c.tangents();
        self.t1.set_lane(l, f32s(t1));
        self.t2.set_lane(l, f32s(t2));
        let [f1, f2] = &mut self.friction;
        for (wide, row) in [
            (f1, &c.friction[0]),
            (f2, &c.friction[1]),
            (&mut self.twist, &c.twist),
        ] {
            wide.ang_a.set_lane(l, f32s(row.ang_a));
            wide.ang_b.set_lane(l, f32s(row.ang_b));
            wide.mass.as_mut_array()[l] = row.mass as f32;
            wide.impulse.as_mut_array()[l] = row.impulse as f32;
        }
        let rows = &c.rows;
        for (i, p) in pts.iter_mut().enumerate().take(len) {
            let lane = |x: &mut F4, v: f64| x.as_mut_array()[l] = v as f32;
            p.ra.set_lane(l, f32s(rows.ra.get(i)));
            p.rb.set_lane(l, f32s(rows.rb.get(i)));
            let k = rows.k[i];
            lane(&mut p.k, k);
            lane(&mut p.mass, if k > 0.0 { 1.0 / k } else { 0.0 });
            lane(&mut p.base, rows.base[i]);
            lane(&mut p.impulse, rows.impulse[i]);
            lane(&mut p.carried, rows.carried[i]);
            lane(&mut p.max_impulse, rows.max_impulse[i]);
            lane(&mut p.total_impulse, rows.total_impulse[i]);
        }
    }

    /// Whether point `i` is used, per lane (a mask).
    #[inline]
    fn used(&self, i: usize) -> F4 {
        self.len.simd_gt(F4::splat(i as f32))
    }

    /// Normal speed of point `p`, m/s (positive: separating).
    #[inline]
    fn normal_speed(&self, p: &WidePoint, a: &WideBody, b: &WideBody) -> F4 {
        let n = self.normal;
        n.dot(b.v - a.v) + p.rb.dot(n.cross(b.w)) - p.ra.dot(n.cross(a.w))
    }

    /// Applies the normal impulse `x` at point `p`.
    #[inline]
    fn push_one(&self, p: &WidePoint, x: F4, a: &mut WideBody, b: &mut WideBody) {
        let n = self.normal;
        a.v -= n * (x * a.inv_mass);
        b.v += n * (x * b.inv_mass);
        a.w -= a.inv_inertia * (p.ra.cross(n) * x);
        b.w += b.inv_inertia * (p.rb.cross(n) * x);
    }

    /// Applies the normal impulses `x` at every point at once.
    #[inline]
    fn push(&self, pts: &[WidePoint], x: &[F4; MAX_POINTS], a: &mut WideBody, b: &mut WideBody) {
        let n = self.normal;
        let (mut sum, mut ra, mut rb) = (F4::ZERO, V3::ZERO, V3::ZERO);
        for (p, &x) in pts.iter().zip(x) {
            sum += x;
            ra += p.ra * x;
            rb += p.rb * x;
        }
        a.v -= n * (sum * a.inv_mass);
        b.v += n * (sum * b.inv_mass);
        a.w -= a.inv_inertia * ra.cross(n);
        b.w += b.inv_inertia * rb.cross(n);
    }

    /// The points' separations now, m, from how far the bodies moved since
    /// the start of the step.
    #[inline]
    fn separations(&self, pts: &[WidePoint], a: &WideBody, b: &WideBody) -> [F4; MAX_POINTS] {
        let n = self.normal;
        let (na, nb) = (a.dq.inverse_rotate(n), b.dq.inverse_rotate(n));
        let moved = n.dot(b.dp - a.dp);
        let mut s = [F4::ZERO; MAX_POINTS];
        for (s, p) in s.iter_mut().zip(pts) {
            *s = moved + p.rb.dot(nb) - p.ra.dot(na) + p.base;
        }
        s
    }

    /// Re-applies the impulses of the last substep.
    fn warm_start(&self, pts: &[WidePoint], a: &mut WideBody, b: &mut WideBody) {
        let x = std::array::from_fn(|i| pts.get(i).map_or(F4::ZERO, |p| p.impulse));
        self.push(pts, &x, a, b);
        let [f1, f2] = &self.friction;
        let tw = &self.twist;
        let linear = self.t1 * f1.impulse + self.t2 * f2.impulse;
        a.v -= linear * a.inv_mass;
        b.v += linear * b.inv_mass;
        a.w -= f1.ang_a * f1.impulse + f2.ang_a * f2.impulse + tw.ang_a * tw.impulse;
        b.w += f1.ang_b * f1.impulse + f2.ang_b * f2.impulse + tw.ang_b * tw.impulse;
    }

    /// One pass: friction at the centre, the twist, then the normals (the
    /// block where it applies, else point by point), as
    /// [`ContactConstraint::solve`] does for one constraint.
    fn solve(
        &mut self,
        pts: &mut [WidePoint],
        block: Option<&WideBlock>,
        a: &mut WideBody,
        b: &mut WideBody,
        pass: &WidePass,
    ) {
        let n = self.normal;
        let pressed = pts.iter().fold(F4::ZERO, |s, p| s + p.impulse);
        let limit = self.mu * pressed;
        let dv = b.v + b.w.cross(self.centre_b) - a.v - a.w.cross(self.centre_a);
        let (t1, t2) = (self.t1, self.t2);
        let [f1, f2] = &mut self.friction;
        let new1 = f1.impulse - f1.mass * t1.dot(dv);
        let new2 = f2.impulse - f2.mass * t2.dot(dv);
        let size = (new1 * new1 + new2 * new2).sqrt();
        let over = size.simd_gt(limit);
        let scale = size.simd_gt(F4::ZERO).select(limit / size, F4::ZERO);
        let new1 = over.select(new1 * scale, new1);
        let new2 = over.select(new2 * scale, new2);
        let (d1, d2) = (new1 - f1.impulse, new2 - f2.impulse);
        f1.impulse = new1;
        f2.impulse = new2;
        apply_row(f1, t1, d1, a, b);
        apply_row(f2, t2, d2, a, b);
        let twist_limit = limit * self.twist_radius;
        let tw = &mut self.twist;
        let spin = n.dot(b.w - a.w);
        let total = (tw.impulse - tw.mass * spin)
            .max(-twist_limit)
            .min(twist_limit);
        let applied = total - tw.impulse;
        tw.impulse = total;
        a.w -= tw.ang_a * applied;
        b.w += tw.ang_b * applied;

        let separations = self.separations(pts, a, b);
        let done = match block {
            Some(block) => self.solve_block(pts, block, a, b, pass, &separations),
            None => F4::ZERO,
        };
        if done.all() {
            return;
        }
        for (i, p) in pts.iter_mut().enumerate() {
            let todo = self.used(i) & !done;
            if todo.none() {
                continue;
            }
            let s = separations[i];
            let (bias, ms, is) = if pass.use_bias {
                (
                    (pass.bias_rate * s).max(-pass.push_out),
                    pass.mass_scale,
                    pass.impulse_scale,
                )
            } else {
                (F4::ZERO, F4::ONE, F4::ZERO)
            };
            // Speculative: just do not close the gap.
            let apart = s.simd_gt(F4::ZERO);
            let bias = apart.select(s / pass.h, bias);
            let ms = apart.select(F4::ONE, ms);
            let is = apart.select(F4::ZERO, is);
            let vn = self.normal_speed(p, a, b);
            let give = p.impulse - p.carried;
            let impulse = -p.mass * ms * (vn + bias) - is * give;
            let total = (p.impulse + impulse).max(F4::ZERO);
            let applied = todo.select(total - p.impulse, F4::ZERO);
            p.impulse = todo.select(total, p.impulse);
            p.max_impulse = p.max_impulse.max(applied);
            if !pass.use_bias {
                p.total_impulse += todo.select(total, F4::ZERO);
            }
            self.push_one(p, applied, a, b);
        }
    }

    /// The points of each lane with a block solved together (see
    /// `ContactConstraint::solve_normals_block`) where all of them touch
    /// and the result pushes at every point; returns the lanes solved so
    /// (a mask).
    fn solve_block(
        &self,
        pts: &mut [WidePoint],
        block: &WideBlock,
        a: &mut WideBody,
        b: &mut WideBody,
        pass: &WidePass,
        separations: &[F4; MAX_POINTS],
    ) -> F4 {
        let count = pts.len();
        let mut touching = self.has_block;
        for (i, &s) in separations.iter().enumerate().take(count) {
            touching &= !(self.used(i) & s.simd_gt(F4::ZERO));
        }
        if touching.none() {
            return touching;
        }
        let (l, soft) = if pass.use_bias {
            (&block.solve, pass.block_soft)
        } else {
            (&block.relax, F4::ZERO)
        };
        let mut rhs = [F4::ZERO; MAX_POINTS];
        for (i, p) in pts.iter().enumerate() {
            let bias = if pass.use_bias {
                (pass.bias_rate * separations[i]).max(-pass.push_out)
            } else {
                F4::ZERO
            };
            let vn = self.normal_speed(p, a, b);
            let r = -(vn + bias + soft * p.k * (p.impulse - p.carried));
            rhs[i] = self.used(i).select(r, F4::ZERO);
        }
        let x = cholesky_solve(l, &rhs, count);
        let mut done = touching;
        for (p, &x) in pts.iter().zip(&x) {
            let total = p.impulse + x;
            done &= total.is_finite() & total.simd_ge(F4::ZERO);
        }
        if done.none() {
            return done;
        }
        let x: [F4; MAX_POINTS] = std::array::from_fn(|i| done.select(x[i], F4::ZERO));
        for (p, &x) in pts.iter_mut().zip(&x) {
            p.impulse += x;
            p.max_impulse = p.max_impulse.max(x);
            if !pass.use_bias {
                p.total_impulse += done.select(p.impulse, F4::ZERO);
            }
        }
        self.push(pts, &x, a, b);
        done
    }
}

#[cfg(test)]
mod tests {
    use glam::{DMat3, DQuat, DVec3};

    use super::*;
    use crate::rigid::solver::colouring;
    use crate::rigid::solver::{ContactSource, PointConstraint, SolverConfig};

    /// A small xorshift generator: numbers in `[-1, 1)`.
    struct Numbers(u64);

    impl Numbers {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }

        fn vec(&mut self) -> DVec3 {
            DVec3::new(self.next(), self.next(), self.next())
        }
    }

    /// Bodies (0 static, the rest moving), and constraints between them
    /// of one to four points, some overlapping and some apart, prepared
    /// for the solve pass and stored colour by colour.
    fn world(
        pass: &ContactPass,
    ) -> (
        Vec<SolverBody>,
        Vec<bool>,
        Vec<ContactConstraint>,
        colouring::Groups,
        Vec<u8>,
    ) {
        let mut r = Numbers(0x9E37_79B9_7F4A_7C15);
        let bodies: Vec<SolverBody> = (0..14)
            .map(|i| {
                if i == 0 {
                    return SolverBody {
                        v: DVec3::ZERO,
                        w: DVec3::ZERO,
                        inv_mass: 0.0,
                        inv_inertia: DMat3::ZERO,
                        dp: DVec3::ZERO,
                        dq: DQuat::IDENTITY,
                    };
                }
                let inertia = DMat3::from_diagonal(DVec3::new(2.0, 3.0, 4.0) + r.vec());
                let turn = DQuat::from_rotation_y(0.5 * r.next());
                SolverBody {
                    v: r.vec(),
                    w: r.vec(),
                    inv_mass: 0.6 + 0.4 * r.next(),
                    inv_inertia: DMat3::from_quat(turn)
                        * inertia
                        * DMat3::from_quat(turn.inverse()),
                    dp: r.vec() * 0.01,
                    dq: DQuat::from_scaled_axis(r.vec() * 0.01),
                }
            })
            .collect();
        let movable: Vec<bool> = (0..bodies.len()).map(|i| i != 0).collect();
        let cfg = SolverConfig::default();
        let constraints: Vec<ContactConstraint> = (0..40)
            .map(|k| {
                let a = if k % 3 == 0 { 0 } else { 1 + (k * 5) % 13 };
                let b = 1 + (k * 7 + 3) % 13;
                let b = if a == b { 1 + b % 13 } else { b };
                let len = 1 + k % MAX_POINTS;
                let mut points = [PointConstraint::default(); MAX_POINTS];
                for p in &mut points[..len] {
                    let tangent = [0.1 * r.next(), 0.1 * r.next()];
                    *p =
                        PointConstraint::new(r.vec() * 0.5, r.vec() * 0.5, r.next().abs(), tangent);
                    p.base_separation = 0.01 * r.next();
                }
                let mut c = ContactConstraint::new(&ContactSource {
                    ends: (a, b),
                    normal: r.vec().normalize(),
                    materials: (0.6, 0.5, 0.0),
                    points,
                    len,
                });
                c.prepare(&bodies[a], &bodies[b], r.vec(), cfg.stick_speed, pass);
                c
            })
            .collect();
        let ends: Vec<(usize, usize)> = constraints.iter().map(|c| (c.a, c.b)).collect();
        let colours = colouring::colour(&ends, &movable);
        let groups = colouring::group(&colours);
        let stored: Vec<ContactConstraint> = groups
            .order
            .iter()
            .map(|&k| constraints[k as usize].clone())
            .collect();
        let colours: Vec<u8> = groups.order.iter().map(|&k| colours[k as usize]).collect();
        let groups = colouring::Groups {
            order: (0..stored.len() as u32).collect(),
            ranges: groups.ranges,
        };
        (bodies, movable, stored, groups, colours)
    }

    #[test]
    fn the_wide_passes_match_the_scalar_ones() {
        let cfg = SolverConfig::default();
        let h = 1.0 / 240.0;
        let (solve, relax) = (
            ContactPass::new(&cfg, h, true),
            ContactPass::new(&cfg, h, false),
        );
        let (bodies, movable, constraints, groups, colours) = world(&solve);
        assert!(
            constraints.iter().filter(|c| c.block.is_some()).count() > 5,
            "some constraints use the normal block"
        );
        let (mut scalar_bodies, mut scalar) = (bodies.clone(), constraints.clone());
        let run = |cs: &mut Vec<ContactConstraint>,
                   bs: &mut Vec<SolverBody>,
                   f: &(dyn Fn(&mut ContactConstraint, &mut SolverBody, &mut SolverBody)
                         + Sync)| {
            colouring::solve_coloured(cs, &groups, &colours, |c| (c.a, c.b), bs, &movable, f);
        };
        run(&mut scalar, &mut scalar_bodies, &|c, a, b| {
            c.warm_start(a, b)
        });
        run(&mut scalar, &mut scalar_bodies, &|c, a, b| {
            c.solve(a, b, &solve)
        });
        run(&mut scalar, &mut scalar_bodies, &|c, a, b| {
            c.solve(a, b, &relax)
        });

        let (mut wide_bodies, mut unpacked) = (bodies.clone(), constraints.clone());
        let mut wide = WideContacts::default();
        wide.pack(&constraints, &groups, &colours, &movable, &bodies, &solve);
        wide.load(&wide_bodies);
        wide.warm_start();
        wide.solve(&WidePass::new(&solve));
        wide.solve(&WidePass::new(&relax));
        wide.store(&mut wide_bodies, &movable);
        wide.unpack(&mut unpacked);

        let close = |x: f64, y: f64| (x - y).abs() <= 2e-4 * (1.0 + x.abs().max(y.abs()));
        for (i, (s, w)) in scalar_bodies.iter().zip(&wide_bodies).enumerate() {
            for (x, y) in
                s.v.to_array()
                    .into_iter()
                    .chain(s.w.to_array())
                    .zip(w.v.to_array().into_iter().chain(w.w.to_array()))
            {
                assert!(close(x, y), "body {i}: scalar {s:?}, wide {w:?}");
            }
        }
        for (k, (s, w)) in scalar.iter().zip(&unpacked).enumerate() {
            for i in 0..s.len {
                let (x, y) = (s.rows.impulse[i], w.rows.impulse[i]);
                assert!(close(x, y), "constraint {k} point {i}: {x} against {y}");
                let (x, y) = (s.rows.total_impulse[i], w.rows.total_impulse[i]);
                assert!(
                    close(x, y),
                    "constraint {k} point {i} total: {x} against {y}"
                );
            }
            for (x, y) in [
                (s.friction[0].impulse, w.friction[0].impulse),
                (s.friction[1].impulse, w.friction[1].impulse),
                (s.twist.impulse, w.twist.impulse),
            ] {
                assert!(close(x, y), "constraint {k} friction: {x} against {y}");
            }
        }
        assert_eq!(wide_bodies[0].v, DVec3::ZERO, "the static body never moves");
    }
}
