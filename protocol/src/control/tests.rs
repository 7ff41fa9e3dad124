//! The control channel's own tests: bounds, framing, the spawn mirror.

use super::*;
use crate::entity::{EntityKind, ShapeDesc};
use crate::token::{mint, ReplayGuard, TokenKey};

fn entity(shape: ShapeDesc) -> EntityDesc {
    EntityDesc {
        id: 3,
        kind: EntityKind::Dynamic,
        shape,
        color: [1, 2, 3, 4],
        owner: Some(9),
        name: "crate".into(),
        position: [1.0, 2.0, 3.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
    }
}

fn round_trip(msg: &ServerControl) -> ServerControl {
    let bytes = encode_frame(msg).unwrap();
    let mut d = FrameDecoder::new();
    d.push(&bytes).unwrap();
    let out = d.next::<ServerControl>().unwrap().unwrap();
    assert!(d.next::<ServerControl>().is_none());
    out
}

#[test]
fn frames_split_anywhere_reassemble() {
    let msgs = vec![
        ServerControl::Despawn { id: 7 },
        ServerControl::Spawn(entity(ShapeDesc::Compound {
            parts: vec![
                (
                    [0.0; 3],
                    [0.0, 0.0, 0.0, 1.0],
                    ShapeDesc::Sphere { radius: 1.0 },
                ),
                ([1.0; 3], [0.0, 0.0, 0.0, 1.0], ShapeDesc::Ground),
            ],
        })),
        ServerControl::Message(b"hello".to_vec()),
    ];
    let stream: Vec<u8> = msgs.iter().flat_map(|m| encode_frame(m).unwrap()).collect();
    for chunk in 1..stream.len() {
        let mut d = FrameDecoder::new();
        let mut got = Vec::new();
        for piece in stream.chunks(chunk) {
            d.push(piece).unwrap();
            while let Some(m) = d.next::<ServerControl>() {
                got.push(m.unwrap());
            }
        }
        assert_eq!(got, msgs, "chunks of {chunk}");
        assert_eq!(d.buffered(), 0);
    }
}

#[test]
fn oversized_frames_are_fatal_and_the_buffer_is_bounded() {
    let mut d = FrameDecoder::new();
    d.push(&(MAX_CONTROL_FRAME as u32 + 1).to_le_bytes())
        .unwrap();
    let e = ControlError::FrameTooLarge {
        len: MAX_CONTROL_FRAME + 1,
        max: MAX_CONTROL_FRAME,
    };
    assert_eq!(d.next::<ClientControl>(), Some(Err(e.clone())));
    assert_eq!(d.next::<ClientControl>(), Some(Err(e.clone())));
    assert_eq!(d.push(&[0]), Err(e));

    let mut d = FrameDecoder::new();
    d.push(&(MAX_CONTROL_FRAME as u32).to_le_bytes()).unwrap();
    d.push(&vec![0; MAX_CONTROL_FRAME - 1]).unwrap();
    assert!(d.next::<ClientControl>().is_none());
    assert!(matches!(
        d.push(&vec![0; MAX_CONTROL_FRAME + 8]),
        Err(ControlError::BufferFull { .. })
    ));
}

#[test]
fn a_bad_frame_is_reported_and_the_next_still_decodes() {
    let mut d = FrameDecoder::new();
    d.push(&[1, 0, 0, 0, 0xFF]).unwrap();
    d.push(&encode_frame(&ClientControl::Goodbye).unwrap())
        .unwrap();
    assert!(matches!(
        d.next::<ClientControl>(),
        Some(Err(ControlError::Decode(_)))
    ));
    assert_eq!(d.next::<ClientControl>(), Some(Ok(ClientControl::Goodbye)));
}

#[test]
fn validation_refuses_what_serde_accepts() {
    let too_many = ShapeDesc::ConvexHull {
        points: vec![[0.0; 3]; ShapeDesc::MAX_POINTS + 1],
    };
    assert!(matches!(
        validate_entity(&entity(too_many)),
        Err(ControlError::TooMany { .. })
    ));
    let nan = ShapeDesc::Sphere { radius: f32::NAN };
    assert!(matches!(
        validate_entity(&entity(nan)),
        Err(ControlError::NotFinite { .. })
    ));
    let bad_index = ShapeDesc::TriMesh {
        vertices: vec![[0.0; 3]; 3],
        triangles: vec![[0, 1, 3]],
    };
    assert_eq!(
        validate_entity(&entity(bad_index)),
        Err(ControlError::BadIndex {
            index: 3,
            vertices: 3
        })
    );
    let mut named = entity(ShapeDesc::Ground);
    named.name = "x".repeat(65);
    assert!(matches!(
        validate_entity(&named),
        Err(ControlError::TooLong { .. })
    ));
    let mut welcome = ServerControl::Welcome {
        client_id: 1,
        tick: 0,
        tick_hz: 0,
        snapshot_hz: 30,
        position_resolution: 0.001,
        position_bound: 1000.0,
        snapshot: SnapshotParams::default(),
        input_bytes: 5,
        server_version: "0.1.0".into(),
        game: "sandbox".into(),
        properties: Default::default(),
    };
    assert!(matches!(
        encode_frame(&welcome),
        Err(ControlError::OutOfRange { .. })
    ));
    let ServerControl::Welcome { tick_hz, .. } = &mut welcome else {
        unreachable!()
    };
    *tick_hz = 60;
    assert!(encode_frame(&welcome).is_ok());
    // A game named past its bound.
    let mut long_named = welcome.clone();
    let ServerControl::Welcome { game, .. } = &mut long_named else {
        unreachable!()
    };
    *game = "g".repeat(MAX_GAME_NAME_BYTES + 1);
    assert!(matches!(
        encode_frame(&long_named),
        Err(ControlError::TooLong { .. })
    ));
    // A grid finer than the snapshot codec's 32 bits an axis.
    let ServerControl::Welcome {
        position_resolution,
        ..
    } = &mut welcome
    else {
        unreachable!()
    };
    *position_resolution = 1e-9;
    assert!(matches!(
        encode_frame(&welcome),
        Err(ControlError::OutOfRange { .. })
    ));
}

#[test]
fn point_sets_are_bounded_and_their_indices_checked() {
    let set = |points: u32, triangles: Vec<[u32; 3]>, lines: Vec<[u32; 2]>| ShapeDesc::PointSet {
        points,
        radius: 0.02,
        triangles,
        lines,
    };
    let ok = entity(set(4, vec![[0, 1, 2], [1, 3, 2]], vec![[0, 3]]));
    assert_eq!(
        round_trip(&ServerControl::Spawn(ok.clone())),
        ServerControl::Spawn(ok.clone())
    );
    assert_eq!(ok.point_id(0), Some(4));
    assert_eq!(ok.point_id(3), Some(7));
    assert_eq!(ok.point_id(4), None, "past the points");
    assert_eq!(ok.point_index(7), Some(3));
    assert_eq!(ok.point_index(3), None, "the set's own id");
    assert_eq!(ok.point_index(8), None);
    assert_eq!(entity(ShapeDesc::Sphere { radius: 1.0 }).point_id(0), None);
    // The largest set whose last point id is u32::MAX is fine; one
    // more point is not.
    let mut last = entity(set(ShapeDesc::MAX_SET_POINTS, vec![], vec![]));
    last.id = u32::MAX - ShapeDesc::MAX_SET_POINTS;
    assert_eq!(validate_entity(&last), Ok(()));
    last.id += 1;
    assert!(matches!(
        validate_entity(&last),
        Err(ControlError::OutOfRange { .. })
    ));
    for bad in [
        set(0, vec![], vec![]),
        set(ShapeDesc::MAX_SET_POINTS + 1, vec![], vec![]),
        ShapeDesc::PointSet {
            points: 3,
            radius: f32::NAN,
            triangles: vec![],
            lines: vec![],
        },
    ] {
        assert!(
            encode_frame(&ServerControl::Spawn(entity(bad.clone()))).is_err(),
            "{bad:?}"
        );
    }
    assert_eq!(
        validate_entity(&entity(set(3, vec![[0, 1, 3]], vec![]))),
        Err(ControlError::BadIndex {
            index: 3,
            vertices: 3
        })
    );
    assert_eq!(
        validate_entity(&entity(set(3, vec![], vec![[2, 5]]))),
        Err(ControlError::BadIndex {
            index: 5,
            vertices: 3
        })
    );
    let inside = ShapeDesc::Compound {
        parts: vec![([0.0; 3], [0.0, 0.0, 0.0, 1.0], set(2, vec![], vec![]))],
    };
    assert!(validate_entity(&entity(inside)).is_err());
    // The largest set fits one control frame.
    let full = entity(ShapeDesc::PointSet {
        points: ShapeDesc::MAX_SET_POINTS,
        radius: 0.01,
        triangles: vec![[16_383, 16_382, 16_381]; ShapeDesc::MAX_SET_TRIANGLES],
        lines: vec![[16_383, 16_382]; ShapeDesc::MAX_SET_LINES],
    });
    let frame = encode_frame(&ServerControl::Spawn(full)).unwrap();
    assert!(
        frame.len() <= MAX_CONTROL_FRAME + 4,
        "{} bytes",
        frame.len()
    );
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
    let msg = ServerControl::Spawn(entity(shape));
    assert_eq!(encode_frame(&msg), Err(ControlError::NestedCompound));
    let bytes = postcard::to_allocvec(&msg).unwrap();
    assert!(matches!(
        decode_payload::<ServerControl>(&bytes),
        Err(ControlError::Decode(_))
    ));
    // An empty compound inside a compound decodes, then fails
    // validation.
    let msg = ServerControl::Spawn(entity(ShapeDesc::Compound {
        parts: vec![(leaf.0, leaf.1, ShapeDesc::Compound { parts: vec![] })],
    }));
    let bytes = postcard::to_allocvec(&msg).unwrap();
    assert_eq!(
        decode_payload::<ServerControl>(&bytes),
        Err(ControlError::NestedCompound)
    );

    // A frame full of nesting: thousands of levels, decoded on a small
    // stack.
    // Spawn (variant 2), id 3, kind Dynamic (1), then compound after
    // compound, each with one part: 30 bytes a level.
    let mut deep = vec![2u8, 3, 1];
    while deep.len() < MAX_CONTROL_FRAME - 30 {
        deep.extend_from_slice(&[6, 1]);
        deep.extend_from_slice(&[0; 28]);
    }
    let handle = std::thread::Builder::new()
        .stack_size(64 * 1024)
        .spawn(move || decode_payload::<ServerControl>(&deep).is_err())
        .unwrap();
    assert!(handle.join().unwrap());
}

#[test]
fn every_message_round_trips() {
    for msg in [
        ServerControl::Welcome {
            client_id: 5,
            tick: 1 << 40,
            tick_hz: 60,
            snapshot_hz: 30,
            position_resolution: 1.0 / 1024.0,
            position_bound: 4096.0,
            snapshot: SnapshotParams::default(),
            input_bytes: 5,
            server_version: "0.1.0".into(),
            game: "sandbox".into(),
            properties: Default::default(),
        },
        ServerControl::Refused(Refusal::VersionMismatch {
            server: 1,
            client: 2,
        }),
        ServerControl::Spawn(entity(ShapeDesc::TriMesh {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
        })),
        ServerControl::Message(vec![1, 2, 3]),
        ServerControl::Goodbye(DisconnectReason::Kicked {
            reason: "afk".into(),
        }),
    ] {
        assert_eq!(round_trip(&msg), msg);
    }
}

#[test]
fn handshake_checks_version_then_token() {
    let key = TokenKey::from_bytes([1; 32]);
    let addr = "127.0.0.1:7777";
    let now = 1_000_000;
    let token = mint(&key, 77, addr, [0; 32], 60, b"", now)
        .unwrap()
        .to_bytes();
    let mut guard = ReplayGuard::new(16);
    let old = ClientControl::Hello {
        version: PROTOCOL_VERSION + 1,
        token: vec![0; 3],
    };
    assert_eq!(
        handshake(&old, now, &key, addr, 1, &mut guard),
        Err(Refusal::VersionMismatch {
            server: PROTOCOL_VERSION,
            client: PROTOCOL_VERSION + 1
        })
    );
    let hello = ClientControl::Hello {
        version: PROTOCOL_VERSION,
        token,
    };
    assert_eq!(
        handshake(&hello, now, &key, addr, 1, &mut guard).map(|o| o.client_id),
        Ok(77)
    );
    assert_eq!(
        handshake(&hello, now, &key, addr, 2, &mut guard),
        Err(Refusal::Token(TokenRefusal::Reused))
    );
    assert_eq!(
        handshake(&ClientControl::Goodbye, now, &key, addr, 3, &mut guard),
        Err(Refusal::Malformed)
    );
    let mut full = ReplayGuard::new(0);
    assert_eq!(
        handshake(&hello, now, &key, addr, 1, &mut full),
        Err(Refusal::ServerFull)
    );
}
