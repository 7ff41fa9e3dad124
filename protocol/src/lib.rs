//! Inertia's wire protocol, free of I/O: everything here turns values into
//! bytes and untrusted bytes back into values, and is tested without
//! sockets.
//!
//! - [`entity`]: what an entity is, looks like and where it is; player input.
//! - [`credentials`]: the dev-mode credentials file.
//! - [`bits`]: the bit packer every message is written with.
//! - [`quantize`]: positions on a grid and orientations as smallest three.
//! - [`link`]: a simulated lossy link on a virtual clock, for tests.
//! - [`snapshot`]: the snapshot datagram, delta-coded against acknowledged
//!   views and fitted to a budget by [`priority`] and [`interest`].

pub mod bits;
pub mod credentials;
pub mod entity;
pub mod interest;
pub mod link;
pub mod priority;
pub mod quantize;
pub mod rng;
pub mod snapshot;

pub use bits::{BitError, BitReader, BitWriter};
pub use link::{LinkConfig, LinkError, LinkStats, SimLink};
pub use quantize::{read_rotation, write_rotation, PositionGrid};
pub use entity::{EntityDesc, EntityId, EntityKind, EntityState, PlayerInput, ShapeDesc};
pub use interest::Interest;
pub use priority::{PriorityAccumulator, PriorityWeights};
pub use snapshot::{
    DecodedSnapshot, SnapshotConfig, SnapshotDecoder, SnapshotEncoder, SnapshotError, View,
    ViewEntity,
};
