//! Property tests of the admin protocol: every request and response
//! round-trips through the control framing, the decoder survives any
//! bytes, what operators may not ask is refused with its reason, and the
//! credential comparison admits exactly the credential.

use inertia_protocol::admin::{
    admin_handshake, credential_matches, AdminCall, AdminError, AdminErrorKind, AdminHandshake,
    AdminHello, AdminRefusal, AdminReply, AdminRequest, AdminResponse, AdminValidationError,
    AdminWelcome, CheckpointName, MassSpec, SpawnDesc, StatusReport, TimeMode,
    ADMIN_PROTOCOL_VERSION, MAX_ADMIN_ERROR_BYTES, MAX_CHECKPOINT_NAME_BYTES, MAX_CREDENTIAL_BYTES,
    MAX_KICK_REASON_BYTES, MAX_OPERATOR_BYTES, MAX_TIME_SCALE, MIN_TIME_SCALE,
};
use inertia_protocol::control::{
    decode_payload, encode_frame, ControlError, ControlMessage, FrameDecoder,
};
use inertia_protocol::entity::{EntityKind, ShapeDesc};
use proptest::collection::vec;
use proptest::prelude::*;

use crate::common;
use common::shape;

fn kind() -> impl Strategy<Value = EntityKind> {
    prop_oneof![
        Just(EntityKind::Static),
        Just(EntityKind::Dynamic),
        Just(EntityKind::Kinematic),
        Just(EntityKind::Avatar),
        Just(EntityKind::Water),
    ]
}

fn vec3(bound: f64) -> impl Strategy<Value = [f64; 3]> {
    [-bound..bound, -bound..bound, -bound..bound]
}

/// A quaternion that is not zero.
fn rotation() -> impl Strategy<Value = [f64; 4]> {
    [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, 0.1f64..1.0]
}

fn time_scale() -> impl Strategy<Value = f64> {
    prop_oneof![
        MIN_TIME_SCALE..=MAX_TIME_SCALE,
        Just(MAX_TIME_SCALE),
        Just(MIN_TIME_SCALE),
    ]
}

fn spawn_desc() -> impl Strategy<Value = SpawnDesc> {
    (
        kind(),
        shape(),
        prop_oneof![
            (1e-3f64..1e5).prop_map(MassSpec::Density),
            (1e-3f64..1e6).prop_map(MassSpec::Mass),
        ],
        vec3(1e6),
        rotation(),
        vec3(1e3),
        vec3(1e3),
        any::<[u8; 4]>(),
        "\\PC{0,16}",
    )
        .prop_map(
            |(kind, shape, mass, position, rotation, velocity, angular_velocity, color, name)| {
                SpawnDesc {
                    kind,
                    shape,
                    mass,
                    position,
                    rotation,
                    velocity,
                    angular_velocity,
                    color,
                    name,
                }
            },
        )
}

fn checkpoint_name() -> impl Strategy<Value = CheckpointName> {
    "[A-Za-z0-9_-][A-Za-z0-9._-]{0,127}".prop_map(|s| CheckpointName::new(s).expect("a valid name"))
}

fn request() -> impl Strategy<Value = AdminRequest> {
    prop_oneof![
        Just(AdminRequest::Status),
        Just(AdminRequest::Pause),
        Just(AdminRequest::Resume),
        (1u64..=u64::MAX).prop_map(|ticks| AdminRequest::Step { ticks }),
        time_scale().prop_map(|scale| AdminRequest::Speed { scale }),
        any::<u64>().prop_map(|tick| AdminRequest::RunTo { tick }),
        any::<u64>().prop_map(|tick| AdminRequest::Seek { tick }),
        time_scale().prop_map(|speed| AdminRequest::Reverse { speed }),
        (any::<u64>(), any::<u64>(), time_scale()).prop_map(|(a, b, speed)| {
            AdminRequest::Replay {
                from: a.min(b),
                to: a.max(b),
                speed,
            }
        }),
        (checkpoint_name(), any::<bool>())
            .prop_map(|(name, overwrite)| AdminRequest::Save { name, overwrite }),
        checkpoint_name().prop_map(|name| AdminRequest::Load { name }),
        any::<bool>().prop_map(|on| AdminRequest::Record { on }),
        spawn_desc().prop_map(|desc| AdminRequest::Spawn { desc }),
        any::<u32>().prop_map(|id| AdminRequest::Despawn { id }),
        (any::<u32>(), vec3(1e6), proptest::option::of(vec3(1e6)))
            .prop_map(|(id, impulse, point)| AdminRequest::Impulse { id, impulse, point }),
        (any::<u64>(), "\\PC{0,60}")
            .prop_map(|(client, reason)| AdminRequest::Kick { client, reason }),
        proptest::option::of(any::<u64>()).prop_map(|tick| AdminRequest::Hash { tick }),
    ]
}

fn call() -> impl Strategy<Value = AdminCall> {
    (any::<u32>(), request()).prop_map(|(id, request)| AdminCall { id, request })
}

fn status() -> impl Strategy<Value = StatusReport> {
    (
        (
            any::<u64>(),
            0.0f64..1e9,
            0.0f64..4e9,
            prop_oneof![Just(0.0), 0.0f64..=MAX_TIME_SCALE],
            0.0f64..1e5,
            any::<bool>(),
        ),
        (
            any::<u32>(),
            any::<u32>(),
            0.0f64..1e4,
            any::<u64>(),
            any::<bool>(),
            any::<u64>(),
            prop_oneof![
                Just(TimeMode::Live),
                Just(TimeMode::History),
                Just(TimeMode::Forward),
                Just(TimeMode::Reverse),
                Just(TimeMode::Replay),
            ],
        ),
    )
        .prop_map(
            |(
                (tick, sim_time, wall_time_unix, time_scale, achieved_rate, paused),
                (clients, bodies, tick_ms_p99, state_hash, recording, live_tick, mode),
            )| StatusReport {
                tick,
                sim_time,
                wall_time_unix,
                time_scale,
                achieved_rate,
                paused,
                clients,
                bodies,
                tick_ms_p99,
                state_hash,
                recording,
                live_tick,
                mode,
            },
        )
}

fn error_kind() -> impl Strategy<Value = AdminErrorKind> {
    prop_oneof![
        Just(AdminErrorKind::Invalid),
        Just(AdminErrorKind::NotFound),
        Just(AdminErrorKind::OutOfRange),
        Just(AdminErrorKind::NotRecorded),
        Just(AdminErrorKind::Busy),
        Just(AdminErrorKind::Io),
        Just(AdminErrorKind::Unsupported),
    ]
}

fn response() -> impl Strategy<Value = AdminResponse> {
    prop_oneof![
        status().prop_map(AdminResponse::Status),
        Just(AdminResponse::Ok),
        (
            any::<u64>(),
            any::<u64>(),
            proptest::option::of(any::<u64>())
        )
            .prop_map(|(tick, state_hash, recorded_hash)| AdminResponse::Hash {
                tick,
                state_hash,
                recorded_hash
            }),
        any::<u32>().prop_map(|id| AdminResponse::Spawned { id }),
        (error_kind(), "\\PC{0,200}")
            .prop_map(|(kind, message)| AdminResponse::Error(AdminError { kind, message })),
    ]
}

fn reply() -> impl Strategy<Value = AdminReply> {
    (any::<u32>(), response()).prop_map(|(id, response)| AdminReply { id, response })
}

fn hello() -> impl Strategy<Value = AdminHello> {
    (any::<u16>(), "[0-9a-f]{0,256}", "[a-z.@-]{0,64}").prop_map(|(version, token, operator)| {
        AdminHello {
            version,
            token,
            operator,
        }
    })
}

fn handshake() -> impl Strategy<Value = AdminHandshake> {
    prop_oneof![
        (any::<u16>(), "[0-9a-z.+-]{0,64}", 1u32..1000).prop_map(
            |(version, server_version, tick_hz)| AdminHandshake::Welcome(AdminWelcome {
                version,
                server_version,
                tick_hz
            })
        ),
        (any::<u16>(), any::<u16>()).prop_map(|(server, client)| AdminHandshake::Refused(
            AdminRefusal::VersionMismatch { server, client }
        )),
        Just(AdminHandshake::Refused(AdminRefusal::BadCredential)),
        Just(AdminHandshake::Refused(AdminRefusal::Malformed)),
        any::<u32>().prop_map(
            |retry_after_ms| AdminHandshake::Refused(AdminRefusal::Throttled { retry_after_ms })
        ),
    ]
}

/// Encodes `msgs` as one stream, feeds it to a decoder in pieces of
/// `chunk` bytes, and returns what comes out.
fn through_stream<T: ControlMessage + Clone>(msgs: &[T], chunk: usize) -> Vec<T> {
    let stream: Vec<u8> = msgs.iter().flat_map(|m| encode_frame(m).unwrap()).collect();
    let mut d = FrameDecoder::new();
    let mut got = Vec::new();
    for piece in stream.chunks(chunk) {
        d.push(piece).unwrap();
        while let Some(m) = d.next::<T>() {
            got.push(m.unwrap());
        }
    }
    assert_eq!(d.buffered(), 0);
    got
}

fn decode_stream<T: ControlMessage>(bytes: &[u8], chunk: usize) {
    let mut d = FrameDecoder::new();
    for piece in bytes.chunks(chunk.max(1)) {
        if d.push(piece).is_err() {
            return;
        }
        // At most one message per 4 bytes, and a fatal error repeats.
        for _ in 0..=bytes.len() / 4 {
            match d.next::<T>() {
                None => break,
                Some(Err(ControlError::FrameTooLarge { .. })) => return,
                Some(Ok(m)) => {
                    // Whatever decodes has passed validation, so it
                    // re-encodes.
                    assert!(encode_frame(&m).is_ok());
                }
                Some(Err(_)) => {}
            }
        }
    }
}

fn all_decoders(bytes: &[u8], chunk: usize) {
    let _ = decode_payload::<AdminHello>(bytes);
    let _ = decode_payload::<AdminHandshake>(bytes);
    let _ = decode_payload::<AdminCall>(bytes);
    let _ = decode_payload::<AdminReply>(bytes);
    decode_stream::<AdminHello>(bytes, chunk);
    decode_stream::<AdminHandshake>(bytes, chunk);
    decode_stream::<AdminCall>(bytes, chunk);
    decode_stream::<AdminReply>(bytes, chunk);
}

fn mutate(bytes: &mut [u8], flips: &[(prop::sample::Index, u8)]) {
    for (at, x) in flips {
        let i = at.index(bytes.len());
        bytes[i] ^= x;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn calls_round_trip(calls in vec(call(), 1..5), chunk in 1usize..200) {
        prop_assert_eq!(through_stream(&calls, chunk), calls);
    }

    #[test]
    fn replies_round_trip(replies in vec(reply(), 1..5), chunk in 1usize..200) {
        prop_assert_eq!(through_stream(&replies, chunk), replies);
    }

    #[test]
    fn hellos_and_handshakes_round_trip(h in hello(), answer in handshake(), chunk in 1usize..50) {
        prop_assert_eq!(through_stream(std::slice::from_ref(&h), chunk), vec![h]);
        prop_assert_eq!(through_stream(std::slice::from_ref(&answer), chunk), vec![answer]);
    }

    #[test]
    fn random_bytes_never_panic_the_admin_decoders(
        bytes in vec(any::<u8>(), 0..600),
        chunk in 1usize..64,
    ) {
        all_decoders(&bytes, chunk);
    }

    #[test]
    fn mutated_calls_never_panic_and_stay_valid(
        msg in call(),
        flips in vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
    ) {
        let mut bytes = encode_frame(&msg).unwrap();
        mutate(&mut bytes, &flips);
        if let Ok(m) = decode_payload::<AdminCall>(&bytes[4..]) {
            prop_assert!(encode_frame(&m).is_ok());
        }
        all_decoders(&bytes, 7);
    }

    #[test]
    fn mutated_replies_never_panic_and_stay_valid(
        msg in reply(),
        flips in vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
    ) {
        let mut bytes = encode_frame(&msg).unwrap();
        mutate(&mut bytes, &flips);
        if let Ok(m) = decode_payload::<AdminReply>(&bytes[4..]) {
            prop_assert!(encode_frame(&m).is_ok());
        }
        all_decoders(&bytes, 7);
    }

    #[test]
    fn mutated_hellos_never_panic_and_stay_valid(
        msg in hello(),
        flips in vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
    ) {
        let mut bytes = encode_frame(&msg).unwrap();
        mutate(&mut bytes, &flips);
        if let Ok(m) = decode_payload::<AdminHello>(&bytes[4..]) {
            prop_assert!(encode_frame(&m).is_ok());
        }
        all_decoders(&bytes, 3);
    }

    #[test]
    fn time_scales_outside_the_range_are_refused(scale in prop_oneof![
        -1e9f64..=0.0,
        (MAX_TIME_SCALE + 1e-9)..1e9,
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(-0.0),
    ]) {
        for request in [
            AdminRequest::Speed { scale },
            AdminRequest::Reverse { speed: scale },
            AdminRequest::Replay { from: 0, to: 1, speed: scale },
        ] {
            prop_assert!(request.check().is_err());
            let call = AdminCall { id: 1, request };
            prop_assert!(encode_frame(&call).is_err());
            // The peer refuses it too: encode past the sender's check.
            let bytes = postcard::to_allocvec(&call).unwrap();
            prop_assert!(decode_payload::<AdminCall>(&bytes).is_err());
        }
    }

    #[test]
    fn backwards_replays_are_refused(from in 1u64.., back in 1u64..) {
        let to = from.saturating_sub(back);
        prop_assume!(to < from);
        let request = AdminRequest::Replay { from, to, speed: 1.0 };
        prop_assert_eq!(
            request.check(),
            Err(AdminValidationError::ReplayBackwards { from, to })
        );
    }

    #[test]
    fn only_the_credential_matches(
        expected in "[0-9a-f]{1,128}",
        other in "[0-9a-f]{0,130}",
    ) {
        prop_assert!(credential_matches(&expected, &expected));
        prop_assert_eq!(credential_matches(&expected, &other), expected == other);
        // A prefix, an extension and one changed character all fail.
        prop_assert!(!credential_matches(&expected, &expected[..expected.len() - 1]));
        let longer = format!("{expected}0");
        prop_assert!(!credential_matches(&expected, &longer));
        let mut changed = expected.clone().into_bytes();
        changed[0] = if changed[0] == b'x' { b'y' } else { b'x' };
        prop_assert!(!credential_matches(&expected, std::str::from_utf8(&changed).unwrap()));
    }
}

fn call_of(request: AdminRequest) -> AdminCall {
    AdminCall { id: 9, request }
}

/// `request` fails its check with `expected`, and neither side of the
/// wire lets it through.
fn refused(request: AdminRequest, expected: AdminValidationError) {
    assert_eq!(request.check(), Err(expected.clone()), "{request:?}");
    let call = call_of(request);
    let control = ControlError::from(expected);
    assert_eq!(encode_frame(&call), Err(control.clone()));
    let bytes = postcard::to_allocvec(&call).unwrap();
    assert_eq!(decode_payload::<AdminCall>(&bytes), Err(control));
}

fn crate_spawn() -> SpawnDesc {
    SpawnDesc {
        kind: EntityKind::Dynamic,
        shape: ShapeDesc::Cuboid {
            half_extents: [0.5; 3],
        },
        mass: MassSpec::Mass(10.0),
        position: [0.0, 2.0, 0.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        color: [200, 100, 50, 255],
        name: "crate".into(),
    }
}

#[test]
fn requests_an_operator_may_not_make_are_refused_with_their_reason() {
    use AdminValidationError as E;
    let scale = |what, scale| E::TimeScale {
        what,
        scale,
        min: MIN_TIME_SCALE,
        max: MAX_TIME_SCALE,
    };
    refused(
        AdminRequest::Speed { scale: f64::NAN },
        E::NotFinite { what: "time scale" },
    );
    refused(AdminRequest::Speed { scale: 0.0 }, scale("time scale", 0.0));
    refused(
        AdminRequest::Speed { scale: 65.0 },
        scale("time scale", 65.0),
    );
    refused(
        AdminRequest::Speed { scale: -1.0 },
        scale("time scale", -1.0),
    );
    assert!(AdminRequest::Speed { scale: 64.0 }.check().is_ok());
    refused(
        AdminRequest::Reverse {
            speed: f64::INFINITY,
        },
        E::NotFinite {
            what: "reverse speed",
        },
    );
    refused(
        AdminRequest::Replay {
            from: 10,
            to: 9,
            speed: 1.0,
        },
        E::ReplayBackwards { from: 10, to: 9 },
    );
    assert!(AdminRequest::Replay {
        from: 10,
        to: 10,
        speed: 1.0
    }
    .check()
    .is_ok());
    refused(
        AdminRequest::Step { ticks: 0 },
        E::OutOfRange { what: "step ticks" },
    );

    // Checkpoints are names in the server's checkpoint directory, never
    // paths; a name off the wire is checked after decoding.
    let unchecked = |s: &str| -> CheckpointName {
        postcard::from_bytes(&postcard::to_allocvec(s).unwrap()).unwrap()
    };
    for (bad, why) in [
        ("", E::EmptyName),
        ("/etc/passwd", E::NameCharacter('/')),
        ("../escape", E::NameCharacter('/')),
        ("..", E::NameStartsWithDot),
        (".hidden", E::NameStartsWithDot),
        ("a/b", E::NameCharacter('/')),
        ("a\\b", E::NameCharacter('\\')),
        ("world\0.bin", E::NameCharacter('\0')),
        ("with space", E::NameCharacter(' ')),
        ("café", E::NameCharacter('é')),
    ] {
        assert_eq!(CheckpointName::new(bad), Err(why.clone()), "{bad:?}");
        refused(
            AdminRequest::Save {
                name: unchecked(bad),
                overwrite: false,
            },
            why.clone(),
        );
        refused(
            AdminRequest::Load {
                name: unchecked(bad),
            },
            why,
        );
    }
    refused(
        AdminRequest::Load {
            name: unchecked(&"a".repeat(MAX_CHECKPOINT_NAME_BYTES + 1)),
        },
        E::TooLong {
            what: "checkpoint name",
            len: MAX_CHECKPOINT_NAME_BYTES + 1,
            max: MAX_CHECKPOINT_NAME_BYTES,
        },
    );
    for good in [
        "a".repeat(MAX_CHECKPOINT_NAME_BYTES),
        "before.ckpt".into(),
        "run-2_final..isim".into(),
        "0".into(),
    ] {
        let name = CheckpointName::new(good.clone()).expect("a valid name");
        assert_eq!(name.as_str(), good);
        assert!(AdminRequest::Save {
            name,
            overwrite: true
        }
        .check()
        .is_ok());
    }
    refused(
        AdminRequest::Kick {
            client: 1,
            reason: "x".repeat(MAX_KICK_REASON_BYTES + 1),
        },
        E::TooLong {
            what: "kick reason",
            len: MAX_KICK_REASON_BYTES + 1,
            max: MAX_KICK_REASON_BYTES,
        },
    );
    refused(
        AdminRequest::Impulse {
            id: 1,
            impulse: [0.0, f64::NAN, 0.0],
            point: None,
        },
        E::NotFinite { what: "impulse" },
    );
    refused(
        AdminRequest::Impulse {
            id: 1,
            impulse: [0.0; 3],
            point: Some([f64::NEG_INFINITY, 0.0, 0.0]),
        },
        E::NotFinite {
            what: "impulse point",
        },
    );
}

#[test]
fn spawns_are_checked_like_the_control_channel_checks_them() {
    use AdminValidationError as E;
    let spawn = |f: fn(&mut SpawnDesc)| {
        let mut desc = crate_spawn();
        f(&mut desc);
        AdminRequest::Spawn { desc }
    };
    assert!(spawn(|_| {}).check().is_ok());
    refused(
        spawn(|d| d.position[1] = f64::NAN),
        E::NotFinite {
            what: "spawn position",
        },
    );
    refused(
        spawn(|d| d.velocity[2] = f64::INFINITY),
        E::NotFinite {
            what: "spawn velocity",
        },
    );
    refused(
        spawn(|d| d.rotation = [0.0; 4]),
        E::OutOfRange {
            what: "spawn rotation",
        },
    );
    refused(
        spawn(|d| d.mass = MassSpec::Mass(0.0)),
        E::OutOfRange { what: "spawn mass" },
    );
    refused(
        spawn(|d| d.mass = MassSpec::Density(f64::NAN)),
        E::NotFinite {
            what: "spawn density",
        },
    );
    refused(
        spawn(|d| d.name = "x".repeat(65)),
        E::TooLong {
            what: "entity name",
            len: 65,
            max: 64,
        },
    );
    refused(
        spawn(|d| d.shape = ShapeDesc::Sphere { radius: -1.0 }),
        E::Spawn(ControlError::OutOfRange {
            what: "shape radius",
        }),
    );
    refused(
        spawn(|d| {
            d.shape = ShapeDesc::TriMesh {
                vertices: vec![[0.0; 3]; 3],
                triangles: vec![[0, 1, 3]],
            }
        }),
        E::Spawn(ControlError::BadIndex {
            index: 3,
            vertices: 3,
        }),
    );
    refused(
        spawn(|d| {
            d.shape = ShapeDesc::ConvexHull {
                points: vec![[0.0; 3]; ShapeDesc::MAX_POINTS + 1],
            }
        }),
        E::Spawn(ControlError::TooMany {
            what: "hull points",
            len: ShapeDesc::MAX_POINTS + 1,
            max: ShapeDesc::MAX_POINTS,
        }),
    );
    // The clients' view of the spawned body is the spawn's.
    let entity = crate_spawn().entity(42);
    assert_eq!(entity.id, 42);
    assert_eq!(entity.shape, crate_spawn().shape);
    assert_eq!(entity.owner, None);
}

#[test]
fn replies_and_hellos_are_bounded() {
    use AdminValidationError as E;
    let report = StatusReport {
        tick: 600,
        sim_time: 10.0,
        wall_time_unix: 1.75e9,
        time_scale: 1.0,
        achieved_rate: 60.0,
        paused: false,
        clients: 3,
        bodies: 1000,
        tick_ms_p99: 2.5,
        state_hash: 0xdead_beef,
        recording: true,
        live_tick: 600,
        mode: TimeMode::Live,
    };
    assert!(AdminResponse::Status(report).check().is_ok());
    let paused = StatusReport {
        time_scale: 0.0,
        paused: true,
        ..report
    };
    assert!(AdminResponse::Status(paused).check().is_ok());
    for (bad, e) in [
        (
            StatusReport {
                sim_time: f64::NAN,
                ..report
            },
            E::NotFinite { what: "sim time" },
        ),
        (
            StatusReport {
                achieved_rate: -1.0,
                ..report
            },
            E::OutOfRange {
                what: "achieved rate",
            },
        ),
        (
            StatusReport {
                time_scale: 65.0,
                ..report
            },
            E::TimeScale {
                what: "time scale",
                scale: 65.0,
                min: 0.0,
                max: MAX_TIME_SCALE,
            },
        ),
        (
            StatusReport {
                tick_ms_p99: f64::INFINITY,
                ..report
            },
            E::NotFinite { what: "tick p99" },
        ),
    ] {
        assert_eq!(AdminResponse::Status(bad).check(), Err(e));
        let reply = AdminReply {
            id: 1,
            response: AdminResponse::Status(bad),
        };
        assert!(encode_frame(&reply).is_err());
        let bytes = postcard::to_allocvec(&reply).unwrap();
        assert!(decode_payload::<AdminReply>(&bytes).is_err());
    }
    let long = AdminResponse::Error(AdminError {
        kind: AdminErrorKind::Io,
        message: "x".repeat(MAX_ADMIN_ERROR_BYTES + 1),
    });
    assert!(matches!(long.check(), Err(E::TooLong { .. })));
    assert_eq!(
        AdminError::new(AdminErrorKind::Io, "x".repeat(MAX_ADMIN_ERROR_BYTES + 1))
            .message
            .len(),
        MAX_ADMIN_ERROR_BYTES
    );
    assert!(AdminHandshake::Welcome(AdminWelcome {
        version: ADMIN_PROTOCOL_VERSION,
        server_version: "0.1.0".into(),
        tick_hz: 0,
    })
    .check()
    .is_err());

    let hello = |token: String, operator: &str| AdminHello {
        version: ADMIN_PROTOCOL_VERSION,
        token,
        operator: operator.into(),
    };
    assert!(hello("a".repeat(MAX_CREDENTIAL_BYTES), "ops")
        .check()
        .is_ok());
    assert!(matches!(
        hello("a".repeat(MAX_CREDENTIAL_BYTES + 1), "ops").check(),
        Err(E::TooLong { .. })
    ));
    assert!(matches!(
        hello("a".into(), &"o".repeat(MAX_OPERATOR_BYTES + 1)).check(),
        Err(E::TooLong { .. })
    ));
    assert_eq!(
        hello("a".into(), "ops\nforged audit line").check(),
        Err(E::ControlCharacter)
    );
}

#[test]
fn the_handshake_checks_version_then_credential() {
    let credential = "0f".repeat(32);
    let hello = |version, token: &str| AdminHello {
        version,
        token: token.into(),
        operator: "alice".into(),
    };
    assert_eq!(
        admin_handshake(&hello(ADMIN_PROTOCOL_VERSION, &credential), &credential),
        Ok(())
    );
    assert_eq!(
        admin_handshake(&hello(ADMIN_PROTOCOL_VERSION + 1, "wrong"), &credential),
        Err(AdminRefusal::VersionMismatch {
            server: ADMIN_PROTOCOL_VERSION,
            client: ADMIN_PROTOCOL_VERSION + 1,
        })
    );
    assert_eq!(
        admin_handshake(&hello(ADMIN_PROTOCOL_VERSION, "wrong"), &credential),
        Err(AdminRefusal::BadCredential)
    );
    assert_eq!(
        admin_handshake(&hello(ADMIN_PROTOCOL_VERSION, ""), &credential),
        Err(AdminRefusal::BadCredential)
    );
    let mut rude = hello(ADMIN_PROTOCOL_VERSION, &credential);
    rude.operator = "\u{1b}[2J".into();
    assert_eq!(
        admin_handshake(&rude, &credential),
        Err(AdminRefusal::Malformed)
    );
    // A server without a credential admits no one, not even an empty one.
    assert!(!credential_matches("", ""));
    assert_eq!(
        admin_handshake(&hello(ADMIN_PROTOCOL_VERSION, ""), ""),
        Err(AdminRefusal::BadCredential)
    );
}

#[test]
fn issue_11_throttled_refusals_round_trip_and_operator_names_have_one_rule() {
    let refused = AdminHandshake::Refused(AdminRefusal::Throttled {
        retry_after_ms: 60_000,
    });
    let frame = encode_frame(&refused).expect("encodes");
    let mut frames = FrameDecoder::new();
    frames.push(&frame).expect("fits");
    assert_eq!(frames.next::<AdminHandshake>(), Some(Ok(refused)));
    // Version 3 added the refusal: a version 2 tool is told it is old.
    assert_eq!(ADMIN_PROTOCOL_VERSION, 3);
    assert!(inertia_protocol::admin::check_operator_name("alice").is_ok());
    assert!(inertia_protocol::admin::check_operator_name(&"o".repeat(MAX_OPERATOR_BYTES)).is_ok());
    assert!(matches!(
        inertia_protocol::admin::check_operator_name(&"o".repeat(MAX_OPERATOR_BYTES + 1)),
        Err(AdminValidationError::TooLong { .. })
    ));
    assert_eq!(
        inertia_protocol::admin::check_operator_name("a\u{7}b"),
        Err(AdminValidationError::ControlCharacter)
    );
}
