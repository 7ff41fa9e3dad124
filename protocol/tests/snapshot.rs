//! The snapshot codec end to end: round trips of random worlds, untrusted
//! bytes, a moving world over a lossy link, budgets, priorities, interest
//! and sequence wraparound.

use std::collections::BTreeMap;

use glam::{DQuat, DVec3};
use inertia_protocol::rng::SplitMix;
use inertia_protocol::sim_link::{SimLink, SimLinkConfig};
use inertia_protocol::snapshot::{DecodedSnapshot, QuantizedEntity, HELD_VIEWS, MAX_TIME_SCALE};
use inertia_protocol::{
    EntityState, Interest, PriorityAccumulator, SnapshotConfig, SnapshotDecoder, SnapshotEncoder,
    SnapshotError,
};
use proptest::prelude::*;

fn config(velocities: bool) -> SnapshotConfig {
    SnapshotConfig {
        velocities,
        ..SnapshotConfig::default()
    }
}

/// A config whose datagrams hold whole worlds of a few hundred entities.
/// The ids of the entities in the decoder's view of snapshot `sequence`.
fn view_ids(dec: &SnapshotDecoder, sequence: u16) -> Vec<u32> {
    dec.entities(sequence)
        .unwrap()
        .iter()
        .map(|e| e.id)
        .collect()
}

fn roomy(velocities: bool) -> SnapshotConfig {
    SnapshotConfig {
        max_datagram: 65_000,
        ..config(velocities)
    }
}

fn random_rotation(r: &mut SplitMix) -> DQuat {
    let q = DQuat::from_xyzw(
        r.uniform() - 0.5,
        r.uniform() - 0.5,
        r.uniform() - 0.5,
        r.uniform() - 0.5,
    );
    if q.length() < 1e-3 {
        DQuat::IDENTITY
    } else {
        q.normalize()
    }
}

/// `n` entities with random ids (ascending), places and motions.
fn random_world(r: &mut SplitMix, n: usize) -> Vec<EntityState> {
    let mut id = 0u32;
    (0..n)
        .map(|_| {
            id += 1 + (r.next_u64() % 40) as u32;
            EntityState {
                id,
                position: DVec3::new(
                    (r.uniform() - 0.5) * 400.0,
                    r.uniform() * 50.0,
                    (r.uniform() - 0.5) * 400.0,
                ),
                rotation: random_rotation(r),
                linear_velocity: DVec3::new(r.uniform() - 0.5, r.uniform(), 0.0) * 20.0,
                angular_velocity: DVec3::ZERO,
                asleep: r.uniform() < 0.3,
            }
        })
        .collect()
}

/// Moves some entities a little, some a lot, rotates some, puts some to
/// sleep and wakes others.
fn mutate(r: &mut SplitMix, world: &mut [EntityState]) {
    for e in world.iter_mut() {
        match r.next_u64() % 6 {
            0 => e.position += DVec3::new(r.uniform(), r.uniform(), r.uniform()) * 0.002,
            1 => e.position += DVec3::new(r.uniform() - 0.5, 0.0, r.uniform() - 0.5) * 3.0,
            2 => e.rotation = (DQuat::from_rotation_y(r.uniform() * 0.05) * e.rotation).normalize(),
            3 => e.rotation = random_rotation(r),
            4 => e.asleep = !e.asleep,
            _ => {}
        }
    }
}

fn quantized(world: &[EntityState], config: &SnapshotConfig) -> Vec<(u32, QuantizedEntity)> {
    world
        .iter()
        .map(|e| (e.id, QuantizedEntity::new(e, config)))
        .collect()
}

#[test]
fn random_worlds_round_trip_exactly_with_and_without_baseline() {
    for velocities in [false, true] {
        let config = roomy(velocities);
        let mut r = SplitMix(11 + u64::from(velocities));
        for _ in 0..20 {
            let mut enc = SnapshotEncoder::new(config).unwrap();
            let mut dec = SnapshotDecoder::new(config).unwrap();
            let mut pri = PriorityAccumulator::new(Interest::everything());
            let mut world = random_world(&mut r, 300);
            for step in 0..4u64 {
                let bytes = enc.encode(100 + step, 1.0, false, &world, &mut pri, usize::MAX);
                let report = enc.last_report();
                assert_eq!(report.deferred, 0, "the whole world fits");
                assert_eq!(report.baseline.is_some(), step > 0);
                let got = dec.decode(&bytes).unwrap();
                assert_eq!(got.tick, 100 + step);
                // The client's view is the server's quantized world, exactly.
                let view = dec.view(got.sequence).unwrap();
                assert_eq!(*view, enc.view(got.sequence).unwrap());
                assert_eq!(view.entities(), &quantized(&world, &config)[..]);
                let entities = dec.entities(got.sequence).unwrap();
                // What it carried is in the view as it carried it.
                for u in &got.updated {
                    let i = entities.binary_search_by_key(&u.id, |e| e.id).unwrap();
                    assert_eq!(entities[i], *u);
                }
                for (v, (id, q)) in entities.iter().zip(view.entities()) {
                    assert_eq!(*v, q.dequantize(*id, &config));
                    assert_eq!(v.linear_velocity.is_some(), velocities && !v.at_rest);
                }
                let (newest, _) = dec.ack_state();
                enc.on_ack(newest.unwrap());
                mutate(&mut r, &mut world);
            }
        }
    }
}

#[test]
fn values_come_back_within_the_grid() {
    let config = roomy(true);
    let mut r = SplitMix(3);
    let world = random_world(&mut r, 200);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let bytes = enc.encode(1, 0.5, true, &world, &mut pri, usize::MAX);
    let got = dec.decode(&bytes).unwrap();
    assert_eq!((got.time_scale, got.paused), (0.5, true));
    for (e, v) in world.iter().zip(&got.updated) {
        assert_eq!(e.id, v.id);
        assert!((e.position - v.position).abs().max_element() <= 0.0005 + 1e-9);
        let angle = 2.0 * e.rotation.dot(v.rotation).abs().min(1.0).acos();
        assert!(angle.to_degrees() < 0.15, "{}°", angle.to_degrees());
        if let Some(vel) = v.linear_velocity {
            assert!((e.linear_velocity - vel).abs().max_element() <= 0.005 + 1e-9);
        }
    }
}

/// A world of `n` bodies on circles, a few asleep at any time.
fn moving_world(n: u32, tick: u64) -> Vec<EntityState> {
    let t = tick as f64 / 60.0;
    (0..n)
        .map(|i| {
            let phase = f64::from(i) * 0.37;
            let asleep = (tick / 60 + u64::from(i)) % 4 == 0;
            let t = if asleep {
                (tick / 60 * 60) as f64 / 60.0
            } else {
                t
            };
            let speed = 0.2 + f64::from(i % 7) * 0.3;
            EntityState {
                id: i * 3 + 1,
                position: DVec3::new(
                    f64::from(i % 20) * 2.0 + (t * speed + phase).cos(),
                    0.5 + 0.1 * (t * 2.0 + phase).sin().abs(),
                    f64::from(i / 20) * 2.0 + (t * speed + phase).sin(),
                ),
                rotation: DQuat::from_euler(glam::EulerRot::YXZ, t * speed, t * 0.1, phase),
                linear_velocity: DVec3::new(-(t * speed).sin(), 0.0, (t * speed).cos()) * speed,
                angular_velocity: DVec3::ZERO,
                asleep,
            }
        })
        .collect()
}

/// Drives an encoder and a decoder through lossy links both ways (the
/// acks on the way back) and checks, for every snapshot the client
/// decodes, that its view is the view the server says it sent.
fn drive(seed: u64, velocities: bool, budget: usize, snapshots: u64) -> (u64, u64) {
    let (dups, reordered, unchecked) = drive_with_delay(seed, velocities, budget, snapshots, 0.05);
    assert_eq!(
        unchecked, 0,
        "every view the client decoded, the server could rebuild"
    );
    (dups, reordered)
}

/// [`drive`] over links of `delay` s each way; also returns how many
/// decoded snapshots the server could not rebuild to compare (their
/// baseline let go: only past [`HELD_VIEWS`] baselines in flight). The
/// encoder never holds more than that many whole views besides the
/// acknowledged one, and the client never misses a baseline.
fn drive_with_delay(
    seed: u64,
    velocities: bool,
    budget: usize,
    snapshots: u64,
    delay: f64,
) -> (u64, u64, u64) {
    let config = config(velocities);
    let link = SimLinkConfig {
        delay,
        jitter: 0.02,
        loss: 0.05,
        duplicate: 0.03,
    };
    let mut down = SimLink::new(link, seed).unwrap();
    let mut up = SimLink::new(link, seed ^ 0xACC).unwrap();
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let mut out_of_order = 0;
    let mut unchecked = 0;
    for tick in 0..snapshots {
        let now = tick as f64 / 60.0;
        let world = moving_world(150, tick);
        let bytes = enc.encode(tick, 1.0, false, &world, &mut pri, budget);
        assert!(bytes.len() <= budget.min(config.max_datagram));
        assert!(enc.held_views() <= HELD_VIEWS + 1, "{}", enc.held_views());
        down.send(now, bytes);
        for packet in down.receive(now) {
            match dec.decode(&packet) {
                Ok(got) => {
                    let view = dec.view(got.sequence).unwrap();
                    match enc.view(got.sequence) {
                        Some(sent) => assert_eq!(*view, sent, "seq {}", got.sequence),
                        None => unchecked += 1,
                    }
                    out_of_order += u64::from(!got.newest);
                    let (newest, bits) = dec.ack_state();
                    let mut ack = Vec::new();
                    ack.extend_from_slice(&newest.unwrap().to_le_bytes());
                    ack.extend_from_slice(&bits.to_le_bytes());
                    up.send(now, ack);
                }
                Err(SnapshotError::Duplicate { .. }) => {}
                Err(e) => panic!("snapshot {tick}: {e}"),
            }
        }
        for ack in up.receive(now) {
            enc.on_ack(u16::from_le_bytes([ack[0], ack[1]]));
        }
    }
    let stats = dec.stats();
    assert!(stats.decoded > snapshots * 85 / 100, "{stats:?}");
    (stats.duplicate, out_of_order, unchecked)
}

#[test]
fn a_moving_world_over_a_lossy_link_stays_in_step() {
    let mut dups = 0;
    let mut reordered = 0;
    for (seed, velocities) in [(1, false), (2, true), (3, false)] {
        let (d, o) = drive(seed, velocities, 1200, 600);
        dups += d;
        reordered += o;
    }
    assert!(
        dups > 0 && reordered > 0,
        "the link exercised duplicates ({dups}) and reordering ({reordered})"
    );
}

#[test]
fn whole_views_are_held_only_for_baselines_in_flight() {
    // Round trips of 12 and of 36 snapshot periods: the first within
    // HELD_VIEWS, every view rebuilt; the second beyond it, the encoder
    // still within its views and the client never short of a baseline.
    let (_, _, unchecked) = drive_with_delay(6, true, 1200, 600, 0.1);
    assert_eq!(unchecked, 0);
    drive_with_delay(7, false, 1200, 600, 0.3);
}

#[test]
fn a_client_that_never_acknowledges_gets_whole_snapshots_in_budget_and_holds_no_view() {
    let config = config(true);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let mut sent_ids = std::collections::BTreeSet::new();
    for tick in 0..300u64 {
        let world = moving_world(1000, tick);
        let bytes = enc.encode(tick, 1.0, false, &world, &mut pri, 1200);
        let report = enc.last_report();
        assert!(bytes.len() <= 1200);
        assert_eq!(
            report.baseline, None,
            "nothing acknowledged, nothing to build on"
        );
        assert!(report.included > 0, "every snapshot carries what fits");
        assert_eq!(enc.held_views(), 0);
        let view = enc
            .view(report.sequence)
            .expect("the last snapshot is remembered");
        sent_ids.extend(view.entities().iter().map(|e| e.0));
    }
    // The priorities rotate through the world while the client says nothing.
    assert_eq!(sent_ids.len(), 1000);
}

#[test]
fn a_tight_budget_is_respected_and_the_views_still_agree() {
    drive(4, true, 200, 600);
    drive(5, false, 120, 400);
}

#[test]
fn every_changed_entity_is_eventually_sent() {
    // 200 bodies all moving every tick, room for a handful a snapshot, a
    // perfect link with immediate acks: every body must still go out, over
    // and over, with a bounded wait.
    let config = config(false);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let mut last_sent: BTreeMap<u32, u64> = BTreeMap::new();
    let mut worst_wait = 0;
    for tick in 0..2000u64 {
        let mut world = moving_world(200, tick);
        for e in &mut world {
            e.asleep = false;
        }
        let bytes = enc.encode(tick, 1.0, false, &world, &mut pri, 80);
        let got = dec.decode(&bytes).unwrap();
        enc.on_ack(got.sequence);
        for id in got.updated.iter().map(|e| e.id) {
            let since = last_sent.insert(id, tick).unwrap_or(0);
            worst_wait = worst_wait.max(tick - since);
        }
        if tick > 1000 {
            for e in &world {
                let since = last_sent.get(&e.id).copied().unwrap_or(0);
                assert!(tick - since < 200, "entity {} starved since {since}", e.id);
            }
        }
    }
    assert_eq!(last_sent.len(), 200);
    assert!(worst_wait < 200, "worst wait {worst_wait} snapshots");
}

#[test]
fn out_of_interest_and_despawned_entities_leave_the_view() {
    let config = roomy(false);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut interest = Interest::around(DVec3::ZERO, 10.0, 20.0);
    interest.always_relevant.insert(40);
    let mut pri = PriorityAccumulator::new(interest);
    let at = |id: u32, x: f64| EntityState {
        id,
        position: DVec3::new(x, 0.0, 0.0),
        rotation: DQuat::IDENTITY,
        linear_velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        asleep: false,
    };
    let world = vec![at(10, 1.0), at(20, 15.0), at(30, 25.0), at(40, 500.0)];
    let got = dec
        .decode(&enc.encode(0, 1.0, false, &world, &mut pri, 2000))
        .unwrap();
    let ids = view_ids(&dec, got.sequence);
    assert_eq!(ids, [10, 20, 40]);
    enc.on_ack(got.sequence);
    // 20 walks out of range, 10 despawns.
    let world = vec![at(20, 21.0), at(30, 25.0), at(40, 500.0)];
    let got = dec
        .decode(&enc.encode(1, 1.0, false, &world, &mut pri, 2000))
        .unwrap();
    assert_eq!(got.removed, [10, 20]);
    let ids = view_ids(&dec, got.sequence);
    assert_eq!(ids, [40]);
}

/// A rope streamed as a point set (ids after its set's, as
/// `EntityDesc::point_id` numbers them) is culled point by point: the
/// points beyond the interest's reach never travel, and a point that
/// swings out of it leaves the view while the rest stay.
#[test]
fn issue_16_a_point_sets_points_are_culled_by_interest_one_by_one() {
    let config = roomy(false);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::new(Interest::around(DVec3::ZERO, 10.0, 20.0));
    // Set 100 with 30 points, one every metre along x from 5 m.
    let rope = |swing: f64| -> Vec<EntityState> {
        (0..30u32)
            .map(|i| EntityState {
                id: 100 + 1 + i,
                position: DVec3::new(5.0 + f64::from(i), if i == 3 { swing } else { 0.0 }, 0.0),
                rotation: DQuat::IDENTITY,
                linear_velocity: DVec3::ZERO,
                angular_velocity: DVec3::ZERO,
                asleep: false,
            })
            .collect()
    };
    let got = dec
        .decode(&enc.encode(0, 1.0, false, &rope(0.0), &mut pri, 4000))
        .unwrap();
    let ids = view_ids(&dec, got.sequence);
    // Points 0 to 14 lie within 20 m (5 m to 19 m along x).
    assert_eq!(ids, (101..=115).collect::<Vec<_>>());
    enc.on_ack(got.sequence);
    // Point 3 (at 8 m) swings 30 m up, out of reach: it alone leaves.
    let got = dec
        .decode(&enc.encode(1, 1.0, false, &rope(30.0), &mut pri, 4000))
        .unwrap();
    assert_eq!(got.removed, [104]);
    assert!(got.updated.is_empty(), "the rest did not move");
    let held = dec.entities(got.sequence).unwrap();
    assert_eq!(held.len(), 14);
}

#[test]
fn decoding_into_a_used_snapshot_is_decoding_afresh_and_an_error_leaves_it_alone() {
    let config = roomy(true);
    let mut r = SplitMix(21);
    let mut world = random_world(&mut r, 200);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::new(Interest::everything());
    let (mut fresh, mut reused) = (
        SnapshotDecoder::new(config).unwrap(),
        SnapshotDecoder::new(config).unwrap(),
    );
    let mut out = DecodedSnapshot::default();
    for step in 0..6u64 {
        let bytes = enc.encode(step, 1.0, false, &world, &mut pri, 900);
        let want = fresh.decode(&bytes).unwrap();
        reused.decode_into(&bytes, &mut out).unwrap();
        assert_eq!(out, want);
        // A duplicate is an error and leaves the last snapshot as it was.
        assert!(reused.decode_into(&bytes, &mut out).is_err());
        assert_eq!(out, want);
        enc.on_ack(want.sequence);
        mutate(&mut r, &mut world);
    }
}

#[test]
fn baselines_duplicates_and_stale_snapshots_are_typed_errors() {
    let config = roomy(false);
    let mut r = SplitMix(8);
    let mut world = random_world(&mut r, 50);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let first = enc.encode(0, 1.0, false, &world, &mut pri, usize::MAX);
    dec.decode(&first).unwrap();
    assert_eq!(
        dec.decode(&first),
        Err(SnapshotError::Duplicate { sequence: 0 })
    );
    enc.on_ack(0);
    mutate(&mut r, &mut world);
    let second = enc.encode(1, 1.0, false, &world, &mut pri, usize::MAX);
    let mut fresh = SnapshotDecoder::new(config).unwrap();
    assert_eq!(
        fresh.decode(&second),
        Err(SnapshotError::MissingBaseline {
            sequence: 1,
            baseline: 0
        })
    );
    assert_eq!(fresh.stats().missing_baseline, 1);
    assert_eq!(fresh.ack_state(), (None, 0));
    // Jump 100 snapshots ahead; the old one is then stale.
    let mut stale = None;
    for k in 2..102 {
        let b = enc.encode(k, 1.0, false, &world, &mut pri, usize::MAX);
        if k == 5 {
            stale = Some(b);
        } else if k == 101 {
            dec.decode(&b).unwrap();
        }
    }
    assert!(matches!(
        dec.decode(&stale.unwrap()),
        Err(SnapshotError::Stale {
            sequence: 5,
            newest: 101
        })
    ));
    assert_eq!(
        dec.decode(&[0x49, 0, 0]),
        Err(SnapshotError::WrongKind { tag: 0x49 })
    );
    assert!(matches!(
        dec.decode(&vec![0x53; 70_000]),
        Err(SnapshotError::TooLong { len: 70_000, .. })
    ));
}

#[test]
fn acks_name_the_newest_and_the_32_before_it() {
    let config = config(false);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let world = moving_world(5, 0);
    let packets: Vec<Vec<u8>> = (0..40)
        .map(|k| enc.encode(k, 1.0, false, &world, &mut pri, 1200))
        .collect();
    // Receive 0..=39 except 37, 30 and 2, with 36 arriving after 39.
    for k in (0..40).filter(|k| ![2, 30, 36, 37].contains(k)) {
        dec.decode(&packets[k]).unwrap();
    }
    assert!(!dec.decode(&packets[36]).unwrap().newest);
    let (newest, bits) = dec.ack_state();
    assert_eq!(newest, Some(39));
    for back in 1..=32u16 {
        let seq = 39 - back;
        let expected = ![2, 30, 37].contains(&seq);
        assert_eq!(bits >> (back - 1) & 1 == 1, expected, "seq {seq}");
    }
}

#[test]
fn sequence_numbers_wrap_around() {
    let config = config(false);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let mut with_baseline = 0;
    for tick in 0..70_000u64 {
        let world = moving_world(3, tick);
        let bytes = enc.encode(tick, 1.0, false, &world, &mut pri, 1200);
        // Every tenth snapshot is lost; acks come back three snapshots late.
        if tick % 10 == 9 {
            continue;
        }
        let got = dec.decode(&bytes).unwrap();
        assert_eq!(got.tick, tick);
        assert_eq!(dec.view(got.sequence), enc.view(got.sequence).as_ref());
        with_baseline += u64::from(got.baseline.is_some());
        if tick >= 3 && (tick - 3) % 10 != 9 {
            enc.on_ack((tick - 3) as u16);
        }
    }
    assert!(with_baseline > 60_000, "{with_baseline}");
}

/// Overwrites `n` bits of `bytes` at bit `at` (least significant first).
fn set_bits(bytes: &mut [u8], at: usize, value: u64, n: usize) {
    for i in 0..n {
        let (byte, bit) = ((at + i) / 8, (at + i) % 8);
        if value >> i & 1 == 1 {
            bytes[byte] |= 1 << bit;
        } else {
            bytes[byte] &= !(1 << bit);
        }
    }
}

/// Reads `n` bits of `bytes` at bit `at` (least significant first).
fn get_bits(bytes: &[u8], at: usize, n: usize) -> u64 {
    (0..n).fold(0, |v, i| {
        let (byte, bit) = ((at + i) / 8, (at + i) % 8);
        v | u64::from(bytes[byte] >> bit & 1) << i
    })
}

/// Where the f32 time scale of a snapshot without a baseline sits: after
/// tag 8, sequence 16, has_baseline 1, relative 1, tick 64 and is_one 1.
const SCALE_BIT: usize = 8 + 16 + 1 + 1 + 64 + 1;

/// A first snapshot (no baseline) whose header carries `time_scale` as
/// an f32, whatever the encoder would have allowed.
fn with_raw_scale(time_scale: f32) -> Vec<u8> {
    let config = config(true);
    let mut r = SplitMix(5);
    let world = random_world(&mut r, 10);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let mut bytes = enc.encode(1000, 2.0, false, &world, &mut pri, usize::MAX);
    assert_eq!(get_bits(&bytes, SCALE_BIT - 1, 1), 0, "is_one");
    assert_eq!(get_bits(&bytes, SCALE_BIT, 32), u64::from(2.0f32.to_bits()));
    set_bits(&mut bytes, SCALE_BIT, u64::from(time_scale.to_bits()), 32);
    bytes
}

#[test]
fn reverse_play_scales_are_carried_and_the_rest_refused() {
    for ok in [-1.0f32, -0.25, -64.0, 64.0, 0.0, -0.0, 3.5] {
        let got = SnapshotDecoder::new(config(true))
            .unwrap()
            .decode(&with_raw_scale(ok))
            .unwrap_or_else(|e| panic!("scale {ok} refused: {e}"));
        assert_eq!(got.time_scale.to_bits(), ok.to_bits());
        assert_eq!(got.tick, 1000);
    }
    for bad in [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        -64.001,
        64.001,
        -1e9,
        1e9,
    ] {
        let got = SnapshotDecoder::new(config(true))
            .unwrap()
            .decode(&with_raw_scale(bad));
        assert!(
            matches!(got, Err(SnapshotError::Malformed(_))),
            "scale {bad}: {got:?}"
        );
    }
    assert_eq!(MAX_TIME_SCALE, 64.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn time_scales_either_way_round_trip(
        time_scale in prop_oneof![
            -MAX_TIME_SCALE..=MAX_TIME_SCALE,
            Just(-1.0f32),
            Just(1.0f32),
            Just(0.0f32),
            Just(-MAX_TIME_SCALE),
            Just(MAX_TIME_SCALE),
        ],
        paused in any::<bool>(),
        tick in any::<u64>(),
        baseline in any::<bool>(),
    ) {
        let config = config(false);
        let mut r = SplitMix(tick);
        let world = random_world(&mut r, 8);
        let mut enc = SnapshotEncoder::new(config).unwrap();
        let mut dec = SnapshotDecoder::new(config).unwrap();
        let mut pri = PriorityAccumulator::default();
        if baseline {
            // A reverse-play step: the tick goes down against the baseline.
            let first = enc.encode(tick, time_scale, paused, &world, &mut pri, 1200);
            dec.decode(&first).unwrap();
            enc.on_ack(0);
        }
        let tick = if baseline { tick.wrapping_sub(2) } else { tick };
        let bytes = enc.encode(tick, time_scale, paused, &world, &mut pri, 1200);
        let got = dec.decode(&bytes).unwrap();
        prop_assert_eq!(got.tick, tick);
        prop_assert_eq!(got.time_scale.to_bits(), time_scale.to_bits());
        prop_assert_eq!(got.paused, paused);
    }

    #[test]
    fn any_scale_given_to_the_encoder_decodes(time_scale in any::<f32>()) {
        let config = config(false);
        let world = random_world(&mut SplitMix(1), 4);
        let mut enc = SnapshotEncoder::new(config).unwrap();
        let mut pri = PriorityAccumulator::default();
        let bytes = enc.encode(7, time_scale, false, &world, &mut pri, 1200);
        let got = SnapshotDecoder::new(config).unwrap().decode(&bytes).unwrap();
        let expected = if time_scale.is_finite() {
            time_scale.clamp(-MAX_TIME_SCALE, MAX_TIME_SCALE)
        } else {
            0.0
        };
        prop_assert_eq!(got.time_scale.to_bits(), expected.to_bits());
    }

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..1500)) {
        let mut dec = SnapshotDecoder::new(config(true)).unwrap();
        let _ = dec.decode(&bytes);
        let mut tagged = bytes;
        if let Some(b) = tagged.first_mut() {
            *b = 0x53;
        }
        let _ = dec.decode(&tagged);
    }

    #[test]
    fn mutated_snapshots_never_panic(
        seed in any::<u64>(),
        flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        cut in any::<usize>(),
    ) {
        let config = config(seed % 2 == 0);
        let mut r = SplitMix(seed);
        let mut world = random_world(&mut r, 40);
        let mut enc = SnapshotEncoder::new(config).unwrap();
        let mut dec = SnapshotDecoder::new(config).unwrap();
        let mut pri = PriorityAccumulator::default();
        let first = enc.encode(seed, 1.0, false, &world, &mut pri, 1200);
        dec.decode(&first).unwrap();
        enc.on_ack(0);
        mutate(&mut r, &mut world);
        let scale = if seed % 3 == 0 { -1.0 } else { 2.0 };
        let mut bytes = enc.encode(seed + 1, scale, false, &world, &mut pri, 1200);
        let clean = bytes.clone();
        for (at, x) in flips {
            let n = bytes.len();
            bytes[at % n] ^= x;
        }
        if cut % 3 == 0 {
            bytes.truncate(cut % (bytes.len() + 1));
        }
        let mutant = dec.decode(&bytes);
        // The clean one still decodes afterwards unless the mutant was
        // taken as it (a flip in padding bits only), or was taken as a
        // newer snapshot whose ring slot is the clean one's baseline's (a
        // flip that makes sequence 1 into 64, against baseline 0).
        if bytes != clean {
            match dec.decode(&clean) {
                Ok(got) => prop_assert_eq!(dec.view(got.sequence).cloned(), enc.view(got.sequence)),
                Err(SnapshotError::Duplicate { .. }) => {}
                Err(SnapshotError::MissingBaseline { .. }) if mutant.is_ok() => {}
                Err(e) => prop_assert!(false, "clean snapshot refused: {}", e),
            }
        }
    }
}

/// Clients coding one frame with shared deltas get, byte for byte, the
/// datagrams they get coding it alone; and the sharing is used: clients
/// that received the same update of an entity reuse its delta.
#[test]
fn shared_deltas_give_every_client_the_bytes_it_gets_alone() {
    let config = config(true);
    let mut r = SplitMix(77);
    let mut world = random_world(&mut r, 400);
    // Clients with different budgets, interests and ack habits, so that
    // their baselines differ in some entities and agree in others.
    let clients: Vec<(usize, Interest, u64)> = (0..6)
        .map(|c| {
            let interest = if c % 2 == 0 {
                Interest::everything()
            } else {
                Interest::around(DVec3::new(c as f64 * 30.0, 0.0, 0.0), 60.0, 150.0)
            };
            (300 + 200 * c, interest, 1 + c as u64 % 3)
        })
        .collect();
    let start = |interest: &Interest| {
        (
            SnapshotEncoder::new(config).unwrap(),
            PriorityAccumulator::new(interest.clone()),
            SnapshotDecoder::new(config).unwrap(),
        )
    };
    let mut alone: Vec<_> = clients.iter().map(|(_, i, _)| start(i)).collect();
    let mut together: Vec<_> = clients.iter().map(|(_, i, _)| start(i)).collect();
    let mut shared = inertia_protocol::snapshot::SharedDeltas::new();
    for tick in 0..60u64 {
        let frame =
            inertia_protocol::snapshot::QuantizedFrame::new(tick, 1.0, false, &world, &config);
        for (c, (budget, _, ack_every)) in clients.iter().enumerate() {
            let (enc, pri, dec) = &mut alone[c];
            let a = enc.encode_frame(&frame, pri, *budget);
            let (enc_t, pri_t, dec_t) = &mut together[c];
            let b = enc_t.encode_shared(&frame, &mut shared, pri_t, *budget);
            assert_eq!(a, b, "client {c} at tick {tick}");
            assert_eq!(enc.last_report(), enc_t.last_report());
            // Both copies of the client take and acknowledge the same.
            dec.decode(&a).unwrap();
            dec_t.decode(&b).unwrap();
            if tick % ack_every == 0 {
                enc.on_ack_state(dec.ack_state().0, 0);
                enc_t.on_ack_state(dec_t.ack_state().0, 0);
            }
        }
        mutate(&mut r, &mut world);
    }
    assert!(shared.reused() > 1000, "deltas reused: {}", shared.reused());
}

/// The case the property test met: a single flip turned sequence 1 into
/// 64, which decodes against baseline 0 and takes its ring slot, so the
/// clean snapshot 1 then misses its baseline (refused, not a panic).
#[test]
fn a_mutant_that_takes_its_baselines_slot_leaves_the_clean_one_refused_cleanly() {
    let config = config(false);
    let mut r = SplitMix(1);
    let mut world = random_world(&mut r, 40);
    let mut enc = SnapshotEncoder::new(config).unwrap();
    let mut dec = SnapshotDecoder::new(config).unwrap();
    let mut pri = PriorityAccumulator::default();
    let first = enc.encode(1, 1.0, false, &world, &mut pri, 1200);
    dec.decode(&first).unwrap();
    enc.on_ack(0);
    mutate(&mut r, &mut world);
    let clean = enc.encode(2, 1.0, false, &world, &mut pri, 1200);
    // The flip of 0x41 somewhere in the sequence that makes 1 into 64.
    let mutant = (0..clean.len())
        .find_map(|i| {
            let mut m = clean.clone();
            m[i] ^= 0x41;
            let taken = dec.clone().decode(&m).ok()?;
            (taken.sequence == 64).then_some(m)
        })
        .expect("one flip makes sequence 64");
    let got = dec.decode(&mutant).expect("a well-formed snapshot 64");
    assert_eq!((got.sequence, got.baseline), (64, Some(0)));
    assert!(matches!(
        dec.decode(&clean),
        Err(SnapshotError::MissingBaseline {
            sequence: 1,
            baseline: 0
        })
    ));
}
