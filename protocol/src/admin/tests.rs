//! The admin protocol's own tests.

use super::*;
use crate::control::{decode_payload, encode_frame, MAX_CONTROL_FRAME};

/// Fails to compile when [`ShapeDesc`] gains a variant the mirror
/// lacks.
#[allow(dead_code)]
fn mirror_is_complete(s: ShapeDesc) {
    match s {
        ShapeDesc::Sphere { .. }
        | ShapeDesc::Cuboid { .. }
        | ShapeDesc::Capsule { .. }
        | ShapeDesc::Cylinder { .. }
        | ShapeDesc::ConvexHull { .. }
        | ShapeDesc::TriMesh { .. }
        | ShapeDesc::Compound { .. }
        | ShapeDesc::Particle { .. }
        | ShapeDesc::Ground
        | ShapeDesc::HeightField { .. }
        | ShapeDesc::PointSet { .. } => {}
    }
}

fn spawn(shape: ShapeDesc) -> AdminCall {
    AdminCall {
        id: 1,
        request: AdminRequest::Spawn {
            desc: SpawnDesc {
                kind: EntityKind::Dynamic,
                shape,
                mass: MassSpec::Density(1000.0),
                position: [0.0, 5.0, 0.0],
                rotation: [0.0, 0.0, 0.0, 1.0],
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
                color: [255; 4],
                name: "crate".into(),
            },
        },
    }
}

#[test]
fn nested_compounds_are_refused_without_recursing() {
    let leaf = ([0.0f32; 3], [0.0f32, 0.0, 0.0, 1.0]);
    let mut shape = ShapeDesc::Sphere { radius: 1.0 };
    for _ in 0..3 {
        shape = ShapeDesc::Compound {
            parts: vec![(leaf.0, leaf.1, shape)],
        };
    }
    let msg = spawn(shape);
    assert_eq!(encode_frame(&msg), Err(ControlError::NestedCompound));
    let bytes = postcard::to_allocvec(&msg).unwrap();
    assert!(matches!(
        decode_payload::<AdminCall>(&bytes),
        Err(ControlError::Decode(_))
    ));
    let msg = spawn(ShapeDesc::Compound {
        parts: vec![(leaf.0, leaf.1, ShapeDesc::Compound { parts: vec![] })],
    });
    let bytes = postcard::to_allocvec(&msg).unwrap();
    assert_eq!(
        decode_payload::<AdminCall>(&bytes),
        Err(ControlError::NestedCompound)
    );

    // A frame full of nesting, decoded on a small stack: call id 1,
    // Spawn (variant 12), kind Dynamic (1), then compound after
    // compound, each with one part: 30 bytes a level.
    let mut deep = vec![1u8, 12, 1];
    while deep.len() < MAX_CONTROL_FRAME - 30 {
        deep.extend_from_slice(&[6, 1]);
        deep.extend_from_slice(&[0; 28]);
    }
    let handle = std::thread::Builder::new()
        .stack_size(64 * 1024)
        .spawn(move || decode_payload::<AdminCall>(&deep).is_err())
        .unwrap();
    assert!(handle.join().unwrap());
}

#[test]
fn validation_errors_become_invalid_admin_errors() {
    let e = AdminError::from(AdminValidationError::EmptyName);
    assert_eq!(e.kind, AdminErrorKind::Invalid);
    assert_eq!(e.message, "the checkpoint name is empty");
    let long = AdminError::new(AdminErrorKind::Io, "é".repeat(MAX_ADMIN_ERROR_BYTES));
    assert!(long.message.len() <= MAX_ADMIN_ERROR_BYTES);
    assert!(AdminResponse::Error(long).check().is_ok());
}
