//! The shared vocabulary of server, protocol and client: what an entity is,
//! what it looks like, where it is, and what a player asks of it.
//!
//! These are plain values. The snapshot codec turns [`EntityState`]s into
//! datagrams; the control channel carries [`EntityDesc`]s (on spawn) and
//! [`PlayerInput`](crate::input::PlayerInput)s travel in the client's datagrams.

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

/// A server-assigned entity id, stable for the entity's life and never
/// reused within one server run.
pub type EntityId = u32;

/// The most entities one snapshot view may hold (and so one datagram may
/// list).
pub const MAX_ENTITIES: usize = 16_384;

/// Where one entity is and how it moves, as the server knows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntityState {
    /// The entity.
    pub id: EntityId,
    /// Position of the body's origin in the world, m.
    pub position: DVec3,
    /// Orientation (unit quaternion).
    pub rotation: DQuat,
    /// Linear velocity of the origin, m/s.
    pub linear_velocity: DVec3,
    /// Angular velocity, rad/s (world frame).
    pub angular_velocity: DVec3,
    /// True while the body sleeps (it will not move until woken).
    pub asleep: bool,
}

/// The look of an entity's shape, enough for a client to draw it. Sizes in
/// m, in the entity's own frame (capsules and cylinders along +Y).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ShapeDesc {
    /// A ball.
    Sphere {
        /// Radius, m.
        radius: f32,
    },
    /// A box.
    Cuboid {
        /// Half the size along x, y, z, m.
        half_extents: [f32; 3],
    },
    /// A capsule along Y.
    Capsule {
        /// Half the inner segment's length, m.
        half_height: f32,
        /// Radius, m.
        radius: f32,
    },
    /// A cylinder along Y.
    Cylinder {
        /// Half the height, m.
        half_height: f32,
        /// Radius, m.
        radius: f32,
    },
    /// A convex polyhedron given by its points (at most
    /// [`ShapeDesc::MAX_POINTS`]).
    ConvexHull {
        /// The hull's points, m.
        points: Vec<[f32; 3]>,
    },
    /// A triangle mesh (static scenery).
    TriMesh {
        /// Vertices, m (at most [`ShapeDesc::MAX_POINTS`]).
        vertices: Vec<[f32; 3]>,
        /// Triangles as vertex indices (at most [`ShapeDesc::MAX_POINTS`]).
        triangles: Vec<[u32; 3]>,
    },
    /// Several shapes placed in the entity's frame (at most
    /// [`ShapeDesc::MAX_PARTS`], not nested).
    Compound {
        /// Each part with its offset (m) and rotation (x, y, z, w).
        parts: Vec<([f32; 3], [f32; 4], ShapeDesc)>,
    },
    /// A particle drawn as a ball (cloth and rope vertices, fluid).
    Particle {
        /// Drawing radius, m.
        radius: f32,
    },
    /// An infinite ground plane through the origin, normal +Y.
    Ground,
    /// Terrain: heights on a regular grid centred on the origin, rows
    /// along Z and columns along X (as the engine's heightfields), at most
    /// [`ShapeDesc::MAX_POINTS`] samples (a server thins a larger field).
    HeightField {
        /// Samples along Z (at least 2).
        rows: u32,
        /// Samples along X (at least 2).
        cols: u32,
        /// The whole field's size along X and Z, m.
        size: [f32; 2],
        /// Heights, m, row after row (`rows × cols`).
        heights: Vec<f32>,
    },
    /// A set of points that move on their own: the vertices of a soft body
    /// (rope, cloth, jelly) or the particles of a fluid. Point `i` travels
    /// in snapshots as the entity `id + 1 + i` (see
    /// [`EntityDesc::point_id`]), an ordinary entity state whose rotation
    /// is always the identity, so points are quantized, delta-coded,
    /// budgeted and culled by interest one by one like any entity. Those
    /// ids are the set's: no other entity has them. A point no snapshot
    /// has placed yet (a fluid's particle not emitted, or one out of the
    /// client's view) is not drawn, nor are the triangles and lines that
    /// use it.
    PointSet {
        /// Points in the set (at most [`ShapeDesc::MAX_SET_POINTS`]; a
        /// fluid's capacity, of which some may not exist yet).
        points: u32,
        /// Drawing radius of a point (a fluid particle, a rope's
        /// thickness), m.
        radius: f32,
        /// Surface triangles as point indices, counter-clockwise seen from
        /// outside (at most [`ShapeDesc::MAX_SET_TRIANGLES`]; none for a
        /// fluid or a rope).
        triangles: Vec<[u32; 3]>,
        /// Segments drawn as lines between points (a rope's; at most
        /// [`ShapeDesc::MAX_SET_LINES`]).
        lines: Vec<[u32; 2]>,
    },
}

impl ShapeDesc {
    /// The most points, vertices or triangles a shape description may hold.
    pub const MAX_POINTS: usize = 4096;
    /// The most parts a compound may hold.
    pub const MAX_PARTS: usize = 64;
    /// The most points a point set may hold: as many as a snapshot view
    /// ([`MAX_ENTITIES`]).
    pub const MAX_SET_POINTS: u32 = MAX_ENTITIES as u32;
    /// The most triangles a point set may list (with
    /// [`Self::MAX_SET_LINES`] lines, its spawn fits one control frame).
    pub const MAX_SET_TRIANGLES: usize = 6144;
    /// The most lines a point set may list.
    pub const MAX_SET_LINES: usize = 4096;
}

/// What kind of thing an entity is, for the client's drawing and logic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum EntityKind {
    /// Never moves (ground, walls, scenery).
    Static,
    /// Moved by the simulation.
    Dynamic,
    /// Moved by a script or by its owner's inputs, not by contacts.
    Kinematic,
    /// A player's avatar.
    Avatar,
    /// A volume of water (drawn, not collided).
    Water,
    /// A soft body: a rope, a cloth or a deformable solid, drawn from its
    /// points ([`ShapeDesc::PointSet`]).
    SoftBody,
    /// A fluid, drawn from its particles ([`ShapeDesc::PointSet`]).
    Fluid,
}

/// Everything a client needs to draw an entity, sent reliably once when the
/// entity enters the client's view.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EntityDesc {
    /// The entity.
    pub id: EntityId,
    /// What it is.
    pub kind: EntityKind,
    /// Its shape.
    pub shape: ShapeDesc,
    /// RGBA colour.
    pub color: [u8; 4],
    /// The client that owns it (its avatar), if any.
    pub owner: Option<u64>,
    /// A name for debugging and tools (at most 64 bytes).
    pub name: String,
    /// Position when sent, m.
    pub position: [f64; 3],
    /// Orientation when sent (x, y, z, w).
    pub rotation: [f64; 4],
}

impl EntityDesc {
    /// The entity id under which point `index` of this entity's point set
    /// travels in snapshots: `id + 1 + index`. `None` when the shape is not
    /// a point set, the index is past its points, or the id would pass
    /// `u32::MAX`.
    pub fn point_id(&self, index: u32) -> Option<EntityId> {
        match self.shape {
            ShapeDesc::PointSet { points, .. } if index < points => {
                self.id.checked_add(1)?.checked_add(index)
            }
            _ => None,
        }
    }

    /// The point of this entity's set that entity `id` stands for, if any
    /// (the inverse of [`Self::point_id`]).
    pub fn point_index(&self, id: EntityId) -> Option<u32> {
        match self.shape {
            ShapeDesc::PointSet { points, .. } => {
                let index = id.checked_sub(self.id)?.checked_sub(1)?;
                (index < points).then_some(index)
            }
            _ => None,
        }
    }

    /// Ids this entity takes: 1, and the points of a point set.
    pub fn ids_taken(&self) -> u64 {
        match self.shape {
            ShapeDesc::PointSet { points, .. } => 1 + u64::from(points),
            _ => 1,
        }
    }
}
