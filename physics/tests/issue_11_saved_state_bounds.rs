//! Found by the `fuzz_world_state` target (issue 11): a saved world whose
//! tick was 2⁶⁴ − 2 restored, and the next step overflowed the tick count
//! (a panic with overflow checks, a wrap to tick 0 without). A saved tick
//! or time past what a world reaches is now refused as malformed, and the
//! world is left as it was.

use inertia_physics::limits::{MAX_TICK, MAX_TIME};
use inertia_physics::saved_state::reseal;
use inertia_physics::{SavedStateError, World, WorldConfig};

/// Byte offsets in a saved world: magic (8), version (4), tick (8), time (8).
const TICK_AT: usize = 12;
const TIME_AT: usize = 20;

fn world() -> World {
    World::new(WorldConfig {
        threads: 1,
        ..WorldConfig::default()
    })
    .expect("a world")
}

fn with(bytes: &[u8], at: usize, field: [u8; 8]) -> Vec<u8> {
    let mut out = bytes.to_vec();
    out[at..at + 8].copy_from_slice(&field);
    assert!(reseal(&mut out));
    out
}

#[test]
fn issue_11_saved_tick_past_the_last_is_refused() {
    let mut w = world();
    w.step(1.0 / 60.0).expect("a step");
    let saved = w.save();
    let hash = w.state_hash();
    for tick in [u64::MAX - 1, u64::MAX, MAX_TICK + 1] {
        let bad = with(&saved, TICK_AT, tick.to_le_bytes());
        match w.restore(&bad) {
            Err(SavedStateError::Invalid(why)) => assert!(why.contains("tick"), "{why}"),
            other => panic!("tick {tick}: {other:?}"),
        }
        assert_eq!(w.state_hash(), hash, "a refused restore changed nothing");
    }
    // The last tick restores and steps.
    w.restore(&with(&saved, TICK_AT, MAX_TICK.to_le_bytes()))
        .expect("the last tick restores");
    w.step(1.0 / 60.0).expect("and steps");
    assert_eq!(w.tick(), MAX_TICK + 1);
}

#[test]
fn issue_11_saved_time_outside_its_range_is_refused() {
    let mut w = world();
    let saved = w.save();
    for time in [-1.0f64, MAX_TIME * 2.0, f64::MAX] {
        let bad = with(&saved, TIME_AT, time.to_bits().to_le_bytes());
        match w.restore(&bad) {
            Err(SavedStateError::Invalid(why)) => assert!(why.contains("time"), "{why}"),
            other => panic!("time {time}: {other:?}"),
        }
    }
}
