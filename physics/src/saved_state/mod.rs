//! Save and restore of the complete world state in a compact binary form,
//! and the state hash (`hash.rs`): both come from one walk over the state.
//!
//! Layout (little-endian, through [`inertia_codec`]): magic `INRTWRLD`,
//! format version (u32), the state, and a 64-bit checksum of everything
//! before it. The state is written by one walk (`encode_world`) that the
//! [state hash](hash) also uses, so the hash covers exactly what is
//! saved. Everything the step reads is in it — including the Verlet
//! history, the slot tables and free lists (which decide future handles) —
//! so restore-then-step gives the same bits as never-saved-then-step.
//! Derived data (spring adjacency, scratch buffers, GPU buffers) is
//! rebuilt.
//!
//! Decoding treats the bytes as untrusted: every count is bounded by the bytes
//! left, every value is validated as if it came through the public API, and
//! nothing is applied unless the whole file decodes.

mod fluid;
pub mod hash;
mod rigid;
mod soft;

use std::collections::{BTreeMap, BTreeSet};

use crate::handle::BodyHandle;
use crate::rigid::aabb::Aabb;

use glam::DVec3;
use inertia_codec::{ByteReader, ByteWriter, CodecError};

use crate::arena::{Arena, Entry};
use crate::forces::{
    Buoyancy, Drag, Explosion, Force, ForceEntry, GravityMethod, MutualGravity, UniformGravity,
    Wind,
};
use crate::handle::SystemHandle;
use crate::integrator::Integrator;
use crate::particle_system::{
    Backend, ParticleSystem, Slot, FLAG_PINNED, FLAG_QUARANTINED, FREE, MAX_GROUPS,
};
use crate::rigid::body::RigidBody;
use crate::rigid::pipeline::{CachedManifold, ContactCache, ContactKey};
use crate::rigid::solver::SolverConfig;
use crate::spring::{Spring, SpringParams};
use hash::hash_bytes;

const MAGIC: &[u8; 8] = b"INRTWRLD";
/// The format version this build writes and reads.
pub const FORMAT_VERSION: u32 = 9;
/// The oldest format version this build reads. Version 3 kept each
/// manifold's impulses only: its manifolds are collided afresh on the
/// first step after a restore. Version 4 had no world gravity on
/// particles (its systems restore with a gravity scale of 0, as their own
/// forces carried their gravity), no push-out velocities and no contact
/// pairs (the queries report none until the world steps). Versions 4 and
/// 5 kept the contact cache in double precision, which is rounded to the
/// single precision it is now kept in. Versions before 7 had no soft
/// bodies, before 8 no fluids, and before 9 no fluid emitters (a fluid of
/// version 8 restores with none).
pub const OLDEST_FORMAT_VERSION: u32 = 3;

/// Why a saved state could not be restored. The world is unchanged.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SavedStateError {
    /// The bytes do not start with the `INRTWRLD` magic.
    #[error("not an Inertia world state (bad magic)")]
    BadMagic,
    /// Written by a format version this build does not read.
    #[error(
        "unsupported world state format version {0} (this build reads {OLDEST_FORMAT_VERSION} to {FORMAT_VERSION})"
    )]
    UnsupportedVersion(u32),
    /// The data ended early.
    #[error("world state truncated at byte {0}")]
    Truncated(usize),
    /// The checksum does not match: the bytes were corrupted.
    #[error("world state checksum mismatch (stored {stored:#018x}, computed {computed:#018x})")]
    Checksum {
        /// Checksum in the file.
        stored: u64,
        /// Checksum of the bytes read.
        computed: u64,
    },
    /// A value is out of range or inconsistent.
    #[error("invalid world state: {0}")]
    Invalid(String),
    /// Bytes left over after the state.
    #[error("{0} unexpected trailing bytes after the world state")]
    Trailing(usize),
}

/// Where the state walk writes: bytes, or the hasher.
pub(crate) trait StateSink {
    fn u8(&mut self, v: u8);
    fn u32(&mut self, v: u32);
    fn u64(&mut self, v: u64);
    fn f32(&mut self, v: f32);
    fn f64(&mut self, v: f64);
    fn vec3(&mut self, v: DVec3) {
        self.f64(v.x);
        self.f64(v.y);
        self.f64(v.z);
    }
}

/// Writes into a byte buffer.
#[derive(Debug, Default)]
pub(crate) struct ByteSink(pub(crate) Vec<u8>);

impl StateSink for ByteSink {
    fn u8(&mut self, v: u8) {
        ByteWriter::new(&mut self.0).u8(v);
    }
    fn u32(&mut self, v: u32) {
        ByteWriter::new(&mut self.0).u32(v);
    }
    fn u64(&mut self, v: u64) {
        ByteWriter::new(&mut self.0).u64(v);
    }
    fn f32(&mut self, v: f32) {
        ByteWriter::new(&mut self.0).f32(v);
    }
    fn f64(&mut self, v: f64) {
        ByteWriter::new(&mut self.0).f64(v);
    }
}

fn len<S: StateSink>(s: &mut S, n: usize) {
    s.u64(n as u64);
}

/// An optional number: a tag byte, then the number when present.
fn option_f64<S: StateSink>(s: &mut S, v: Option<f64>) {
    match v {
        None => s.u8(0),
        Some(x) => {
            s.u8(1);
            s.f64(x);
        }
    }
}

fn vec3s<S: StateSink>(s: &mut S, v: &[DVec3]) {
    len(s, v.len());
    for &x in v {
        s.vec3(x);
    }
}

fn f64s<S: StateSink>(s: &mut S, v: &[f64]) {
    len(s, v.len());
    for &x in v {
        s.f64(x);
    }
}

fn u32s<S: StateSink>(s: &mut S, v: &[u32]) {
    len(s, v.len());
    for &x in v {
        s.u32(x);
    }
}

fn arena<S: StateSink, T>(s: &mut S, a: &Arena<T>, mut item: impl FnMut(&mut S, &T)) {
    len(s, a.entries.len());
    for e in &a.entries {
        match e {
            Entry::Vacant { generation } => {
                s.u8(0);
                s.u32(*generation);
            }
            Entry::Occupied { generation, value } => {
                s.u8(1);
                s.u32(*generation);
                item(s, value);
            }
        }
    }
    u32s(s, &a.free);
}

fn force<S: StateSink>(s: &mut S, f: &Force) {
    match f {
        Force::UniformGravity(g) => {
            s.u8(0);
            s.f64(g.g);
            s.vec3(g.direction);
        }
        Force::MutualGravity(g) => {
            s.u8(1);
            s.f64(g.g_constant);
            s.f64(g.softening);
            match g.method {
                GravityMethod::Exact => s.u8(0),
                GravityMethod::BarnesHut { theta } => {
                    s.u8(1);
                    s.f64(theta);
                }
            }
        }
        Force::Drag(d) => {
            s.u8(2);
            s.f64(d.linear_scale);
            s.f64(d.quadratic_scale);
        }
        Force::Wind(w) => {
            s.u8(3);
            s.vec3(w.velocity);
            s.f64(w.air_density);
            s.f64(w.pressure_coefficient);
        }
        Force::Buoyancy(b) => {
            s.u8(4);
            s.f64(b.surface_height);
            s.vec3(b.up);
            s.f64(b.fluid_density);
            s.f64(b.gravity);
            s.f64(b.fluid_drag);
        }
        Force::Explosion(e) => {
            s.u8(5);
            s.vec3(e.center);
            s.f64(e.start_time);
            s.f64(e.front_speed);
            s.f64(e.front_thickness);
            s.f64(e.peak_pressure);
            s.f64(e.reference_radius);
            s.f64(e.max_radius);
        }
    }
}

fn system<S: StateSink>(s: &mut S, p: &ParticleSystem) {
    s.u8(p.integrator.code());
    s.u8(match p.backend {
        Backend::Cpu => 0,
        Backend::Gpu => 1,
    });
    s.f64(p.verlet_dt);
    s.u32(p.max_substeps);
    s.f64(p.collision_radius);
    s.f64(p.collision_friction);
    s.f64(p.gravity_scale);
    vec3s(s, &p.position);
    vec3s(s, &p.velocity);
    vec3s(s, &p.prev_position);
    f64s(s, &p.inv_mass);
    f64s(s, &p.drag_linear);
    f64s(s, &p.drag_quadratic);
    f64s(s, &p.area);
    f64s(s, &p.volume);
    u32s(s, &p.flags);
    u32s(s, &p.group);
    s.u8(u8::from(p.control_active));
    vec3s(s, &p.control);
    len(s, p.slots.len());
    for slot in &p.slots {
        s.u32(slot.generation);
        s.u32(slot.dense);
    }
    u32s(s, &p.free_slots);
    vec3s(s, &p.group_control);
    arena(s, &p.springs, |s, sp| {
        s.u32(sp.a);
        s.u32(sp.b);
        s.f64(sp.params.rest_length);
        s.f64(sp.params.stiffness);
        s.f64(sp.params.damping);
    });
    arena(s, &p.forces, |s, f| force(s, &f.force));
}

/// The one walk over the world state, shared by save and hash.
/// Everything that is world state, borrowed for one walk.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StateRef<'a> {
    pub(crate) tick: u64,
    pub(crate) time: f64,
    pub(crate) systems: &'a Arena<ParticleSystem>,
    pub(crate) bodies: &'a Arena<RigidBody>,
    pub(crate) gravity: DVec3,
    pub(crate) body_forces: &'a Arena<ForceEntry>,
    pub(crate) solver: &'a SolverConfig,
    pub(crate) contacts: &'a ContactCache,
    pub(crate) touching: &'a BTreeSet<(BodyHandle, BodyHandle)>,
    pub(crate) body_bounds: Option<Aabb>,
    pub(crate) joints: &'a Arena<crate::rigid::joint::Joint>,
    pub(crate) attachments: &'a Arena<crate::rigid::attachment::Attachment>,
    pub(crate) soft_bodies: &'a Arena<crate::xpbd::soft::SoftBody>,
    pub(crate) fluids: &'a Arena<crate::xpbd::fluid::Fluid>,
}

/// The one walk over the world state, shared by save and hash.
pub(crate) fn encode_world<S: StateSink>(s: &mut S, w: &StateRef<'_>) {
    s.u64(w.tick);
    s.f64(w.time);
    arena(s, w.systems, system);
    s.vec3(w.gravity);
    arena(s, w.bodies, rigid::body);
    arena(s, w.body_forces, |s, f| force(s, &f.force));
    rigid::solver(s, w.solver);
    rigid::contacts(s, w.contacts);
    rigid::touching(s, w.touching);
    rigid::bounds(s, w.body_bounds);
    arena(s, w.joints, rigid::joint);
    arena(s, w.attachments, rigid::attachment);
    arena(s, w.soft_bodies, soft::soft_body);
    arena(s, w.fluids, fluid::fluid);
}

/// The complete saved file for a state.
pub(crate) fn save_world(w: &StateRef<'_>) -> Vec<u8> {
    let particles: usize = w.systems.iter().map(|(_, _, p)| p.len()).sum();
    let mut sink = ByteSink(Vec::with_capacity(
        64 + particles * 140 + w.bodies.len() * 256,
    ));
    sink.0.extend_from_slice(MAGIC);
    sink.u32(FORMAT_VERSION);
    encode_world(&mut sink, w);
    let sum = hash_bytes(&sink.0);
    sink.u64(sum);
    sink.0
}

/// A decoded world state, validated, ready to swap in.
#[derive(Debug)]
pub(crate) struct DecodedWorld {
    pub(crate) tick: u64,
    pub(crate) time: f64,
    pub(crate) systems: Arena<ParticleSystem>,
    pub(crate) bodies: Arena<RigidBody>,
    pub(crate) gravity: DVec3,
    pub(crate) body_forces: Arena<ForceEntry>,
    pub(crate) solver: SolverConfig,
    pub(crate) contacts: BTreeMap<ContactKey, CachedManifold>,
    pub(crate) touching: BTreeSet<(BodyHandle, BodyHandle)>,
    pub(crate) body_bounds: Option<Aabb>,
    pub(crate) joints: Arena<crate::rigid::joint::Joint>,
    pub(crate) attachments: Arena<crate::rigid::attachment::Attachment>,
    pub(crate) soft_bodies: Arena<crate::xpbd::soft::SoftBody>,
    pub(crate) fluids: Arena<crate::xpbd::fluid::Fluid>,
}

/// Reads the state's values off the file's bytes: the byte fields come
/// from [`ByteReader`], their meaning and bounds from here.
struct Reader<'a> {
    bytes: ByteReader<'a>,
    /// The format version being read.
    version: u32,
}

fn invalid<T>(msg: impl Into<String>) -> Result<T, SavedStateError> {
    Err(SavedStateError::Invalid(msg.into()))
}

/// A short read: the state ends at byte `at + remaining`, before what it
/// claims to hold.
fn truncated(e: CodecError) -> SavedStateError {
    match e {
        CodecError::Truncated { at, remaining, .. } => SavedStateError::Truncated(at + remaining),
        // The state has no varints.
        other => SavedStateError::Invalid(other.to_string()),
    }
}

impl Reader<'_> {
    /// Where the state's bytes end (the checksum follows).
    fn end(&self) -> usize {
        self.bytes.position() + self.bytes.remaining()
    }
    fn u8(&mut self) -> Result<u8, SavedStateError> {
        self.bytes.u8().map_err(truncated)
    }
    fn u32(&mut self) -> Result<u32, SavedStateError> {
        self.bytes.u32().map_err(truncated)
    }
    fn u64(&mut self) -> Result<u64, SavedStateError> {
        self.bytes.u64().map_err(truncated)
    }
    fn f64(&mut self) -> Result<f64, SavedStateError> {
        self.bytes.f64().map_err(truncated)
    }
    fn finite(&mut self, what: &str) -> Result<f64, SavedStateError> {
        let v = self.f64()?;
        if v.is_finite() {
            Ok(v)
        } else {
            invalid(format!("{what} is not finite"))
        }
    }
    fn finite32(&mut self, what: &str) -> Result<f32, SavedStateError> {
        let v = self.bytes.f32().map_err(truncated)?;
        if v.is_finite() {
            Ok(v)
        } else {
            invalid(format!("{what} is not finite"))
        }
    }
    fn vec3(&mut self, what: &str) -> Result<DVec3, SavedStateError> {
        Ok(DVec3::new(
            self.finite(what)?,
            self.finite(what)?,
            self.finite(what)?,
        ))
    }
    /// A count of items at least `min_size` bytes each, bounded by the bytes left.
    fn count(&mut self, min_size: usize) -> Result<usize, SavedStateError> {
        let n = self.u64()?;
        let left = self.bytes.remaining() as u64;
        if n > left / min_size.max(1) as u64 {
            return Err(SavedStateError::Truncated(self.end()));
        }
        Ok(n as usize)
    }
    /// What [`option_f64`] wrote; a present number must be finite.
    fn option_f64(&mut self, what: &str) -> Result<Option<f64>, SavedStateError> {
        match self.u8()? {
            0 => Ok(None),
            1 => Ok(Some(self.finite(what)?)),
            t => invalid(format!("{what} tag {t}")),
        }
    }
    fn vec3s(&mut self, what: &str) -> Result<Vec<DVec3>, SavedStateError> {
        let n = self.count(24)?;
        (0..n).map(|_| self.vec3(what)).collect()
    }
    fn f64s(&mut self, what: &str) -> Result<Vec<f64>, SavedStateError> {
        let n = self.count(8)?;
        (0..n).map(|_| self.finite(what)).collect()
    }
    fn u32s(&mut self) -> Result<Vec<u32>, SavedStateError> {
        let n = self.count(4)?;
        (0..n).map(|_| self.u32()).collect()
    }
    fn arena<T>(
        &mut self,
        mut item: impl FnMut(&mut Self) -> Result<T, SavedStateError>,
    ) -> Result<Arena<T>, SavedStateError> {
        let n = self.count(5)?;
        let mut entries = Vec::with_capacity(n);
        for _ in 0..n {
            let tag = self.u8()?;
            let generation = self.u32()?;
            entries.push(match tag {
                0 => Entry::Vacant { generation },
                1 => Entry::Occupied {
                    generation,
                    value: item(self)?,
                },
                t => return invalid(format!("arena entry tag {t}")),
            });
        }
        let free = self.u32s()?;
        Arena::from_parts(entries, free)
            .ok_or_else(|| SavedStateError::Invalid("arena free list is inconsistent".into()))
    }

    fn force(&mut self) -> Result<Force, SavedStateError> {
        let f = match self.u8()? {
            0 => Force::UniformGravity(UniformGravity {
                g: self.f64()?,
                direction: self.vec3("gravity direction")?,
            }),
            1 => {
                let g_constant = self.f64()?;
                let softening = self.f64()?;
                let method = match self.u8()? {
                    0 => GravityMethod::Exact,
                    1 => GravityMethod::BarnesHut { theta: self.f64()? },
                    t => return invalid(format!("gravity method {t}")),
                };
                Force::MutualGravity(MutualGravity {
                    g_constant,
                    softening,
                    method,
                })
            }
            2 => Force::Drag(Drag {
                linear_scale: self.f64()?,
                quadratic_scale: self.f64()?,
            }),
            3 => Force::Wind(Wind {
                velocity: self.vec3("wind velocity")?,
                air_density: self.f64()?,
                pressure_coefficient: self.f64()?,
            }),
            4 => Force::Buoyancy(Buoyancy {
                surface_height: self.f64()?,
                up: self.vec3("buoyancy up")?,
                fluid_density: self.f64()?,
                gravity: self.f64()?,
                fluid_drag: self.f64()?,
            }),
            5 => Force::Explosion(Explosion {
                center: self.vec3("explosion center")?,
                start_time: self.f64()?,
                front_speed: self.f64()?,
                front_thickness: self.f64()?,
                peak_pressure: self.f64()?,
                reference_radius: self.f64()?,
                max_radius: self.f64()?,
            }),
            t => return invalid(format!("force kind {t}")),
        };
        f.validate()
            .map_err(|e| SavedStateError::Invalid(e.to_string()))?;
        Ok(f)
    }

    fn system(&mut self, handle: SystemHandle) -> Result<ParticleSystem, SavedStateError> {
        let integrator = Integrator::from_code(self.u8()?)
            .ok_or_else(|| SavedStateError::Invalid("unknown integrator".into()))?;
        let mut p = ParticleSystem::new(handle, crate::SystemDesc::with_integrator(integrator));
        p.backend = match self.u8()? {
            0 => Backend::Cpu,
            1 => Backend::Gpu,
            t => return invalid(format!("backend {t}")),
        };
        p.verlet_dt = self.finite("verlet dt")?;
        p.max_substeps = self.u32()?;
        p.collision_radius = self.finite("collision radius")?;
        p.collision_friction = self.finite("collision friction")?;
        if p.collision_radius < 0.0 || p.collision_friction < 0.0 {
            return invalid("negative collision radius or friction");
        }
        if p.max_substeps == 0 {
            return invalid("max substeps is zero");
        }
        // Before version 5 the world's gravity did not reach particles.
        p.gravity_scale = if self.version >= 5 {
            self.finite("system gravity scale")?
        } else {
            0.0
        };
        p.position = self.vec3s("position")?;
        p.velocity = self.vec3s("velocity")?;
        p.prev_position = self.vec3s("previous position")?;
        p.inv_mass = self.f64s("inverse mass")?;
        p.drag_linear = self.f64s("linear drag")?;
        p.drag_quadratic = self.f64s("quadratic drag")?;
        p.area = self.f64s("area")?;
        p.volume = self.f64s("volume")?;
        p.flags = self.u32s()?;
        p.group = self.u32s()?;
        p.control_active = match self.u8()? {
            0 => false,
            1 => true,
            t => return invalid(format!("control flag {t}")),
        };
        p.control = self.vec3s("control force")?;
        let n_slots = self.count(8)?;
        p.slots = (0..n_slots)
            .map(|_| {
                Ok(Slot {
                    generation: self.u32()?,
                    dense: self.u32()?,
                })
            })
            .collect::<Result<_, SavedStateError>>()?;
        p.free_slots = self.u32s()?;
        p.group_control = self.vec3s("group control force")?;
        p.springs = self.arena(|r| {
            let a = r.u32()?;
            let b = r.u32()?;
            let params = SpringParams {
                rest_length: r.f64()?,
                stiffness: r.f64()?,
                damping: r.f64()?,
            };
            params
                .validate()
                .map_err(|e| SavedStateError::Invalid(e.to_string()))?;
            Ok(Spring { a, b, params })
        })?;
        p.forces = self.arena(|r| Ok(ForceEntry { force: r.force()? }))?;
        validate_system(&mut p)?;
        p.topology.dirty = true;
        Ok(p)
    }
}

/// Cross-checks one decoded system and rebuilds `dense_to_slot`.
fn validate_system(p: &mut ParticleSystem) -> Result<(), SavedStateError> {
    let n = p.position.len();
    let same = [
        p.velocity.len(),
        p.inv_mass.len(),
        p.drag_linear.len(),
        p.drag_quadratic.len(),
        p.area.len(),
        p.volume.len(),
        p.flags.len(),
        p.group.len(),
    ];
    if same.iter().any(|&l| l != n) {
        return invalid("particle arrays differ in length");
    }
    if !(p.prev_position.is_empty() || p.prev_position.len() == n) {
        return invalid("previous-position array has the wrong length");
    }
    let control_ok = if p.control_active {
        p.control.len() == n
    } else {
        p.control.is_empty()
    };
    if !control_ok {
        return invalid("control array has the wrong length");
    }
    if p.inv_mass.iter().any(|&m| m <= 0.0) {
        return invalid("inverse mass must be > 0");
    }
    for v in [&p.drag_linear, &p.drag_quadratic, &p.area, &p.volume] {
        if v.iter().any(|&x| x < 0.0) {
            return invalid("negative drag, area or volume");
        }
    }
    if p.flags
        .iter()
        .any(|&f| f & !(FLAG_PINNED | FLAG_QUARANTINED) != 0)
    {
        return invalid("unknown particle flag");
    }
    if p.group.iter().any(|&g| g >= MAX_GROUPS) || p.group_control.len() > MAX_GROUPS as usize {
        return invalid("group id out of range");
    }
    let mut dense_to_slot = vec![FREE; n];
    for (s, slot) in p.slots.iter().enumerate() {
        if slot.dense == FREE {
            continue;
        }
        let d = slot.dense as usize;
        if d >= n || dense_to_slot[d] != FREE {
            return invalid("slot table is inconsistent");
        }
        dense_to_slot[d] = s as u32;
    }
    if dense_to_slot.contains(&FREE) {
        return invalid("a particle has no slot");
    }
    let free_count = p.slots.iter().filter(|s| s.dense == FREE).count();
    let mut seen = vec![false; p.slots.len()];
    for &f in &p.free_slots {
        let f = f as usize;
        if f >= p.slots.len() || p.slots[f].dense != FREE || seen[f] {
            return invalid("free slot list is inconsistent");
        }
        seen[f] = true;
    }
    if p.free_slots.len() != free_count {
        return invalid("free slot list is incomplete");
    }
    p.dense_to_slot = dense_to_slot;
    let live = |slot: u32| p.slots.get(slot as usize).is_some_and(|s| s.dense != FREE);
    for (_, _, s) in p.springs.iter() {
        if !live(s.a) || !live(s.b) || s.a == s.b {
            return invalid("spring joins a missing particle");
        }
    }
    Ok(())
}

/// Decodes and validates a saved file.
/// Rewrites the checksum at the end of a saved world's bytes so that it
/// matches what precedes it; false (and nothing changed) when `bytes` is
/// too short to hold one. For tools that edit saved states, and for the
/// fuzz targets, which would otherwise never get past the checksum.
pub fn reseal(bytes: &mut [u8]) -> bool {
    let Some(body_end) = bytes.len().checked_sub(8) else {
        return false;
    };
    let sum = hash_bytes(&bytes[..body_end]);
    bytes[body_end..].copy_from_slice(&sum.to_le_bytes());
    true
}

pub(crate) fn load_world(bytes: &[u8]) -> Result<DecodedWorld, SavedStateError> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(SavedStateError::BadMagic);
    }
    if bytes.len() < MAGIC.len() + 4 + 8 {
        return Err(SavedStateError::Truncated(bytes.len()));
    }
    let body_end = bytes.len() - 8;
    let stored = ByteReader::new(&bytes[body_end..])
        .u64()
        .map_err(truncated)?;
    let mut state = ByteReader::new(&bytes[..body_end]);
    // Past the magic, checked above.
    state.bytes(MAGIC.len()).map_err(truncated)?;
    let mut r = Reader {
        bytes: state,
        version: FORMAT_VERSION,
    };
    let version = r.u32()?;
    if !(OLDEST_FORMAT_VERSION..=FORMAT_VERSION).contains(&version) {
        return Err(SavedStateError::UnsupportedVersion(version));
    }
    r.version = version;
    let computed = hash_bytes(&bytes[..body_end]);
    if stored != computed {
        return Err(SavedStateError::Checksum { stored, computed });
    }
    let tick = r.u64()?;
    if tick > crate::limits::MAX_TICK {
        return invalid(format!(
            "tick {tick} is past the last a world reaches ({})",
            crate::limits::MAX_TICK
        ));
    }
    let time = r.finite("time")?;
    if !(0.0..=crate::limits::MAX_TIME).contains(&time) {
        return invalid(format!(
            "time {time} s is outside 0..={} s",
            crate::limits::MAX_TIME
        ));
    }
    let n = r.count(5)?;
    let mut entries = Vec::with_capacity(n);
    for index in 0..n {
        let tag = r.u8()?;
        let generation = r.u32()?;
        entries.push(match tag {
            0 => Entry::Vacant { generation },
            1 => Entry::Occupied {
                generation,
                value: r.system(SystemHandle {
                    index: index as u32,
                    generation,
                })?,
            },
            t => return invalid(format!("system entry tag {t}")),
        });
    }
    let free = r.u32s()?;
    let systems = Arena::from_parts(entries, free)
        .ok_or_else(|| SavedStateError::Invalid("system free list is inconsistent".into()))?;
    let gravity = r.vec3("gravity")?;
    let bodies = r.arena(|r| r.body())?;
    let body_forces = r.arena(|r| Ok(ForceEntry { force: r.force()? }))?;
    let solver = r.solver()?;
    let mut contacts = r.contacts()?;
    let touching = r.touching()?;
    if version == 5 {
        r.pairs_into(&mut contacts)?;
    }
    let body_bounds = r.bounds()?;
    let joints = r.arena(|r| r.joint())?;
    let attachments = r.arena(|r| r.attachment())?;
    let soft_bodies = if version >= 7 {
        r.arena(|r| r.soft_body())?
    } else {
        Arena::default()
    };
    let fluids = if version >= 8 {
        r.arena(|r| r.fluid())?
    } else {
        Arena::default()
    };
    if !r.bytes.is_empty() {
        return Err(SavedStateError::Trailing(r.bytes.remaining()));
    }
    Ok(DecodedWorld {
        tick,
        time,
        systems,
        bodies,
        gravity,
        body_forces,
        solver,
        contacts,
        touching,
        body_bounds,
        joints,
        attachments,
        soft_bodies,
        fluids,
    })
}
