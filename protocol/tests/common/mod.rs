//! Property-test strategies shared by the protocol's test files.

#![allow(dead_code)] // each test file uses its own subset

use inertia_protocol::entity::ShapeDesc;
use proptest::collection::vec;
use proptest::prelude::*;

pub fn size() -> impl Strategy<Value = f32> {
    0.0f32..100.0
}

pub fn coord() -> impl Strategy<Value = f32> {
    -1000.0f32..1000.0
}

pub fn point() -> impl Strategy<Value = [f32; 3]> {
    [coord(), coord(), coord()]
}

pub fn leaf_shape() -> impl Strategy<Value = ShapeDesc> {
    prop_oneof![
        size().prop_map(|radius| ShapeDesc::Sphere { radius }),
        [size(), size(), size()].prop_map(|half_extents| ShapeDesc::Cuboid { half_extents }),
        (size(), size()).prop_map(|(half_height, radius)| ShapeDesc::Capsule {
            half_height,
            radius
        }),
        (size(), size()).prop_map(|(half_height, radius)| ShapeDesc::Cylinder {
            half_height,
            radius
        }),
        vec(point(), 0..20).prop_map(|points| ShapeDesc::ConvexHull { points }),
        vec(point(), 1..20).prop_flat_map(|vertices| {
            let n = vertices.len() as u32;
            vec([0..n, 0..n, 0..n], 0..20).prop_map(move |triangles| ShapeDesc::TriMesh {
                vertices: vertices.clone(),
                triangles,
            })
        }),
        size().prop_map(|radius| ShapeDesc::Particle { radius }),
        Just(ShapeDesc::Ground),
    ]
}

pub fn shape() -> impl Strategy<Value = ShapeDesc> {
    prop_oneof![
        3 => leaf_shape(),
        1 => vec(
            (point(), [coord(), coord(), coord(), coord()], leaf_shape()),
            0..6
        )
        .prop_map(|parts| ShapeDesc::Compound { parts }),
        1 => point_set(),
    ]
}

/// A point set (never inside a compound).
pub fn point_set() -> impl Strategy<Value = ShapeDesc> {
    (1u32..200, size()).prop_flat_map(|(points, radius)| {
        (
            vec([0..points, 0..points, 0..points], 0..20),
            vec([0..points, 0..points], 0..20),
        )
            .prop_map(move |(triangles, lines)| ShapeDesc::PointSet {
                points,
                radius,
                triangles,
                lines,
            })
    })
}
