//! Generational handles. A handle is an index plus the generation of the slot
//! it was issued for; when the slot is reused its generation moves on, so a
//! stale handle is detected and every lookup with it returns `None`.

/// A particle system in a [`World`](crate::World).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SystemHandle {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

/// A particle inside one particle system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParticleHandle {
    pub(crate) system: SystemHandle,
    pub(crate) slot: u32,
    pub(crate) generation: u32,
}

/// A Hooke spring inside one particle system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SpringHandle {
    pub(crate) system: SystemHandle,
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

/// A force generator attached to one particle system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ForceHandle {
    pub(crate) system: SystemHandle,
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

impl ParticleHandle {
    /// The system this particle lives in.
    pub fn system(self) -> SystemHandle {
        self.system
    }

    /// The handle as `[system index, system generation, slot, generation]`,
    /// for storing beside a saved world.
    pub fn to_raw(self) -> [u32; 4] {
        [
            self.system.index,
            self.system.generation,
            self.slot,
            self.generation,
        ]
    }

    /// A handle from [`ParticleHandle::to_raw`]'s numbers. A made-up one is
    /// harmless: it looks up to `None`.
    pub fn from_raw([index, system_generation, slot, generation]: [u32; 4]) -> Self {
        Self {
            system: SystemHandle {
                index,
                generation: system_generation,
            },
            slot,
            generation,
        }
    }
}

impl SpringHandle {
    /// The system this spring lives in.
    pub fn system(self) -> SystemHandle {
        self.system
    }
}

impl ForceHandle {
    /// The system this force acts on.
    pub fn system(self) -> SystemHandle {
        self.system
    }
}

/// A force generator acting on every rigid body of a [`World`](crate::World).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BodyForceHandle {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

/// A spring from a particle to a rigid body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AttachmentHandle {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

/// A joint between two rigid bodies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointHandle {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

/// A rigid body in a [`World`](crate::World).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BodyHandle {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

impl BodyHandle {
    /// The handle as `[slot index, generation]`, for storing beside a
    /// saved world ([`World::save`](crate::World::save) keeps both).
    pub fn to_raw(self) -> [u32; 2] {
        [self.index, self.generation]
    }

    /// A handle from [`BodyHandle::to_raw`]'s numbers. A made-up one is
    /// harmless: it looks up to `None`.
    pub fn from_raw([index, generation]: [u32; 2]) -> Self {
        Self { index, generation }
    }
}

/// A soft body in a [`World`](crate::World).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SoftBodyHandle {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

impl SoftBodyHandle {
    /// The handle as `[slot index, generation]`.
    pub fn to_raw(self) -> [u32; 2] {
        [self.index, self.generation]
    }

    /// A handle from [`SoftBodyHandle::to_raw`]'s numbers. A made-up one is
    /// harmless: it looks up to `None`.
    pub fn from_raw([index, generation]: [u32; 2]) -> Self {
        Self { index, generation }
    }
}

/// A fluid in a [`World`](crate::World).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FluidHandle {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

impl FluidHandle {
    /// The handle as `[slot index, generation]`.
    pub fn to_raw(self) -> [u32; 2] {
        [self.index, self.generation]
    }

    /// A handle from [`FluidHandle::to_raw`]'s numbers. A made-up one is
    /// harmless: it looks up to `None`.
    pub fn from_raw([index, generation]: [u32; 2]) -> Self {
        Self { index, generation }
    }
}
