//! The spawn mirror: [`EntityDesc`] and [`ShapeDesc`] as the decoder reads
//! them, with at most one level of compound (see the [module
//! docs](super)).

use serde::{Deserialize, Deserializer};

use crate::entity::{EntityDesc, EntityId, EntityKind, ShapeDesc};

// ---------------------------------------------------------------------------
// The spawn mirror: EntityDesc and ShapeDesc as the decoder reads them, with
// at most one level of compound. Field and variant order must match
// entity.rs exactly (postcard encodes by position); the round-trip tests
// pin that.

/// Reads an [`EntityDesc`] with at most one level of compound in its
/// shape, without recursing further however the bytes nest (for stored
/// entity tables as well as spawns).
pub fn deserialize_entity<'de, D: Deserializer<'de>>(d: D) -> Result<EntityDesc, D::Error> {
    WireEntityDesc::deserialize(d).map(Into::into)
}

/// Reads a [`ShapeDesc`] with at most one level of compound, without
/// recursing further however the bytes nest: for every message that
/// carries a shape (spawns here, the admin channel's live edits).
pub(crate) fn deserialize_shape<'de, D: Deserializer<'de>>(d: D) -> Result<ShapeDesc, D::Error> {
    WireShape::<WireShape<NoNesting>>::deserialize(d).map(Into::into)
}

#[derive(Deserialize)]
struct WireEntityDesc {
    id: EntityId,
    kind: EntityKind,
    shape: WireShape<WireShape<NoNesting>>,
    color: [u8; 4],
    owner: Option<u64>,
    name: String,
    position: [f64; 3],
    rotation: [f64; 4],
}

impl From<WireEntityDesc> for EntityDesc {
    fn from(w: WireEntityDesc) -> Self {
        EntityDesc {
            id: w.id,
            kind: w.kind,
            shape: w.shape.into(),
            color: w.color,
            owner: w.owner,
            name: w.name,
            position: w.position,
            rotation: w.rotation,
        }
    }
}

/// [`ShapeDesc`] with compound parts of type `P`.
#[derive(Deserialize)]
enum WireShape<P> {
    Sphere {
        radius: f32,
    },
    Cuboid {
        half_extents: [f32; 3],
    },
    Capsule {
        half_height: f32,
        radius: f32,
    },
    Cylinder {
        half_height: f32,
        radius: f32,
    },
    ConvexHull {
        points: Vec<[f32; 3]>,
    },
    TriMesh {
        vertices: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
    },
    Compound {
        parts: Vec<([f32; 3], [f32; 4], P)>,
    },
    Particle {
        radius: f32,
    },
    Ground,
    HeightField {
        rows: u32,
        cols: u32,
        size: [f32; 2],
        heights: Vec<f32>,
    },
    PointSet {
        points: u32,
        radius: f32,
        triangles: Vec<[u32; 3]>,
        lines: Vec<[u32; 2]>,
    },
}

impl<P: Into<ShapeDesc>> From<WireShape<P>> for ShapeDesc {
    fn from(w: WireShape<P>) -> Self {
        match w {
            WireShape::Sphere { radius } => ShapeDesc::Sphere { radius },
            WireShape::Cuboid { half_extents } => ShapeDesc::Cuboid { half_extents },
            WireShape::Capsule {
                half_height,
                radius,
            } => ShapeDesc::Capsule {
                half_height,
                radius,
            },
            WireShape::Cylinder {
                half_height,
                radius,
            } => ShapeDesc::Cylinder {
                half_height,
                radius,
            },
            WireShape::ConvexHull { points } => ShapeDesc::ConvexHull { points },
            WireShape::TriMesh {
                vertices,
                triangles,
            } => ShapeDesc::TriMesh {
                vertices,
                triangles,
            },
            WireShape::Compound { parts } => ShapeDesc::Compound {
                parts: parts
                    .into_iter()
                    .map(|(offset, rotation, part)| (offset, rotation, part.into()))
                    .collect(),
            },
            WireShape::Particle { radius } => ShapeDesc::Particle { radius },
            WireShape::Ground => ShapeDesc::Ground,
            WireShape::HeightField {
                rows,
                cols,
                size,
                heights,
            } => ShapeDesc::HeightField {
                rows,
                cols,
                size,
                heights,
            },
            WireShape::PointSet {
                points,
                radius,
                triangles,
                lines,
            } => ShapeDesc::PointSet {
                points,
                radius,
                triangles,
                lines,
            },
        }
    }
}

/// The part of a nested compound: never decodes, so the grammar stops
/// there. (An empty nested compound decodes, holding no parts, and is
/// refused by validation as [`ControlError::NestedCompound`].)
enum NoNesting {}

impl<'de> Deserialize<'de> for NoNesting {
    fn deserialize<D: Deserializer<'de>>(_: D) -> Result<Self, D::Error> {
        Err(serde::de::Error::custom("compound shapes may not nest"))
    }
}

impl From<NoNesting> for ShapeDesc {
    fn from(n: NoNesting) -> Self {
        match n {}
    }
}
