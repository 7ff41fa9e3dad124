//! The server clock estimate against scripted snapshot arrivals.

use super::*;

fn meta(seq: u16, tick: u64, time_scale: f32, paused: bool) -> SnapshotMeta {
    SnapshotMeta {
        seq: Some(seq),
        tick,
        time_scale,
        paused,
    }
}

/// A deterministic jitter in [0, 1).
fn noise(k: u64) -> f64 {
    let mut z = k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn the_estimate_follows_the_fastest_arrivals_through_jitter() {
    let mut clock = ServerClock::new(60.0);
    // Snapshots at 30 Hz of a 60 Hz server, 50 ms ± 20 ms late, the
    // local clock 1000 s ahead of the server's.
    for k in 0..300u64 {
        let sent = k as f64 / 30.0;
        let arrive = 1000.0 + sent + 0.03 + 0.04 * noise(k);
        assert_eq!(
            clock.observe(arrive, meta(k as u16, 2 * k, 1.0, false)),
            Observation::InOrder
        );
    }
    // The envelope is the 30 ms path: at local 1000 + 10 + 0.03 the
    // freshest tick in hand is the one sent at 10 s, tick 600.
    let e = clock.arrival_tick(1010.03).unwrap();
    assert!((e - 600.0).abs() < 0.3, "estimate {e}");
    assert!(clock.jitter() > 0.03 && clock.jitter() < 0.045);
    let i = clock.snapshot_interval().unwrap();
    assert!((i - 1.0 / 30.0).abs() < 0.005, "interval {i}");
    // Increasing and smooth between arrivals.
    let mut last = clock.arrival_tick(1009.0).unwrap();
    for k in 1..100 {
        let now = clock.arrival_tick(1009.0 + k as f64 * 0.01).unwrap();
        assert!(now > last && now - last < 0.7);
        last = now;
    }
}

#[test]
fn pause_holds_the_tick_and_a_new_scale_reanchors() {
    let mut clock = ServerClock::new(60.0);
    for k in 0..60u64 {
        clock.observe(k as f64 / 30.0 + 0.05, meta(k as u16, 2 * k, 1.0, false));
    }
    clock.observe(2.05, meta(60, 120, 0.0, true));
    assert!(clock.paused());
    assert_eq!(clock.arrival_tick(2.5), Some(120.0));
    assert_eq!(clock.arrival_tick(9.0), Some(120.0));
    // The paused tick was last at or before 120 just now.
    assert_eq!(clock.local_time_of_tick(120.0, 9.0), Some(9.0));
    // Resume at a quarter speed: 15 ticks/s.
    for k in 0..30u64 {
        let t = 10.0 + k as f64 / 30.0 + 0.05;
        let tick = 120 + (k as f64 * 0.5) as u64;
        clock.observe(t, meta(61 + k as u16, tick, 0.25, false));
    }
    assert!(!clock.paused());
    assert_eq!(clock.tick_rate(), 15.0);
    let e = clock.arrival_tick(11.05).unwrap();
    assert!((e - 135.0).abs() < 1.0, "estimate {e}");
    // The pause is remembered as a flat stretch ending at the resume.
    let resumed = clock.local_time_of_tick(120.0, 11.0).unwrap();
    assert!((10.0..10.1).contains(&resumed), "resumed at {resumed}");
}

#[test]
fn reordered_packets_are_late_and_a_rewind_is_one_discontinuity() {
    let mut clock = ServerClock::new(60.0);
    for k in 0..30u64 {
        clock.observe(k as f64 / 30.0, meta(k as u16, 600 + 2 * k, 1.0, false));
    }
    // An old packet, in sequence terms: late, not a seek.
    assert_eq!(
        clock.observe(1.0, meta(20, 640, 1.0, false)),
        Observation::Late
    );
    // The server seeks back to tick 100.
    let obs = clock.observe(1.01, meta(30, 100, 1.0, false));
    let Observation::Discontinuity(d) = obs else {
        panic!("expected a discontinuity, got {obs:?}");
    };
    assert!(d.is_backwards());
    assert_eq!((d.from_tick, d.to_tick), (658, 100));
    // A straggler of the old timeline is stale, the new one goes on.
    assert_eq!(
        clock.observe(1.02, meta(29, 658, 1.0, false)),
        Observation::Stale
    );
    assert_eq!(
        clock.observe(1.04, meta(31, 102, 1.0, false)),
        Observation::InOrder
    );
}

#[test]
fn without_sequence_numbers_small_steps_back_are_reordering() {
    let mut clock = ServerClock::new(60.0);
    for k in 0..30u64 {
        clock.observe_tick(k as f64 / 30.0, 2 * k, 1.0, false);
    }
    assert_eq!(clock.observe_tick(1.0, 54, 1.0, false), Observation::Late);
    assert_eq!(
        clock.observe_tick(1.0, 60, 1.0, false),
        Observation::InOrder
    );
    assert!(matches!(
        clock.observe_tick(1.03, 5000, 1.0, false),
        Observation::Discontinuity(_)
    ));
    assert!(matches!(
        clock.observe_tick(1.06, 10, 1.0, false),
        Observation::Discontinuity(_)
    ));
}

#[test]
fn reverse_play_runs_the_estimate_down_along_the_fastest_arrivals() {
    let mut clock = ServerClock::new(60.0);
    // Forwards for 2 s, then history backwards at speed 1 from tick
    // 120: 30 Hz snapshots, 50 ms ± 20 ms late, sequence numbers still
    // increasing.
    for k in 0..300u64 {
        let sent = k as f64 / 30.0;
        let arrive = 1000.0 + sent + 0.03 + 0.04 * noise(k);
        let (tick, scale) = if k <= 60 {
            (10_000 + 2 * k, 1.0)
        } else {
            (10_120 - 2 * (k - 60), -1.0)
        };
        let obs = clock.observe(arrive, meta(k as u16, tick, scale, false));
        assert_eq!(obs, Observation::InOrder, "k {k}");
    }
    assert_eq!(clock.direction(), -1.0);
    assert_eq!(clock.tick_rate(), -60.0);
    assert_eq!(clock.time_scale(), -1.0);
    // At local 1000 + 9 + 0.03 the freshest tick in hand is the one
    // sent at 9 s: 10 120 − 2 × (270 − 60) = 9700.
    let e = clock.arrival_tick(1009.03).unwrap();
    assert!((e - 9700.0).abs() < 0.3, "estimate {e}");
    assert!(clock.jitter() > 0.03 && clock.jitter() < 0.045);
    // Decreasing and smooth between arrivals.
    let mut last = clock.arrival_tick(1008.0).unwrap();
    for k in 1..100 {
        let now = clock.arrival_tick(1008.0 + k as f64 * 0.01).unwrap();
        assert!(now < last && last - now < 0.7);
        last = now;
    }
    // The tick 9730 was reached (from above) half a second before 9700.
    let at = clock.local_time_of_tick(9730.0, 1009.03).unwrap();
    assert!((at - 1008.53).abs() < 0.01, "reached at {at}");
    // Round trip puts the server further down.
    clock.rtt_sample(0.1);
    let ahead = clock.estimated_tick(1009.0).unwrap() - clock.arrival_tick(1009.0).unwrap();
    assert!((ahead + 3.0).abs() < 1e-9);
}

#[test]
fn turning_is_a_new_segment_and_a_seek_in_reverse_a_discontinuity() {
    let mut clock = ServerClock::new(60.0);
    let mut seq = 0u16;
    let mut send = |clock: &mut ServerClock, t: f64, tick: u64, scale: f32| {
        seq += 1;
        clock.observe(t, meta(seq, tick, scale, false))
    };
    for k in 0..30u64 {
        assert_eq!(
            send(&mut clock, k as f64 / 30.0, 1000 + 2 * k, 1.0),
            Observation::InOrder
        );
    }
    // The server played on a tick past the newest, then turned.
    assert_eq!(send(&mut clock, 1.0, 1057, -1.0), Observation::InOrder);
    assert_eq!(clock.direction(), -1.0);
    for k in 1..30u64 {
        let obs = send(&mut clock, 1.0 + k as f64 / 30.0, 1057 - 2 * k, -1.0);
        assert_eq!(obs, Observation::InOrder);
    }
    // In sequence, a tick that goes up while reversing is a seek.
    let obs = send(&mut clock, 2.0, 1010, -1.0);
    let Observation::Discontinuity(d) = obs else {
        panic!("expected a discontinuity, got {obs:?}");
    };
    assert_eq!((d.from_tick, d.to_tick), (999, 1010));
    // So is a jump far down (a seek back while reversing).
    for k in 1..10u64 {
        send(&mut clock, 2.0 + k as f64 / 30.0, 1010 - 2 * k, -1.0);
    }
    assert!(matches!(
        send(&mut clock, 2.34, 100, -1.0),
        Observation::Discontinuity(d) if d.is_backwards()
    ));
    // Turning forwards again, or pausing, carries on.
    assert_eq!(send(&mut clock, 2.37, 99, 2.0), Observation::InOrder);
    assert_eq!(clock.tick_rate(), 120.0);
    assert_eq!(send(&mut clock, 2.40, 103, -0.5), Observation::InOrder);
    assert_eq!(clock.tick_rate(), -30.0);
    assert_eq!(send(&mut clock, 2.43, 102, 0.0), Observation::InOrder);
    assert!(clock.paused() && clock.direction() == 1.0);
    assert_eq!(send(&mut clock, 2.46, 102, -1.0), Observation::InOrder);
    // A turn far from the newest tick is a seek.
    assert!(matches!(
        send(&mut clock, 2.50, 900, 1.0),
        Observation::Discontinuity(_)
    ));
}

#[test]
fn without_sequence_numbers_reverse_play_tells_reordering_from_seeks() {
    let mut clock = ServerClock::new(60.0);
    for k in 0..30u64 {
        clock.observe_tick(k as f64 / 30.0, 5000 - 2 * k, -1.0, false);
    }
    // A little above the newest (4942): reordered.
    assert_eq!(
        clock.observe_tick(1.0, 4946, -1.0, false),
        Observation::Late
    );
    assert_eq!(
        clock.observe_tick(1.0, 4940, -1.0, false),
        Observation::InOrder
    );
    // Far above: a seek; far below: a seek too.
    assert!(matches!(
        clock.observe_tick(1.03, 9000, -1.0, false),
        Observation::Discontinuity(_)
    ));
    assert!(matches!(
        clock.observe_tick(1.06, 10, -1.0, false),
        Observation::Discontinuity(_)
    ));
    // A turn, then a straggler from before it: late, not another turn.
    let mut clock = ServerClock::new(60.0);
    for k in 0..30u64 {
        clock.observe_tick(k as f64 / 30.0, 1000 + 2 * k, 1.0, false);
    }
    assert_eq!(
        clock.observe_tick(1.0, 1057, -1.0, false),
        Observation::InOrder
    );
    assert_eq!(
        clock.observe_tick(1.01, 1058, 1.0, false),
        Observation::Late
    );
    assert_eq!(clock.direction(), -1.0);
    assert_eq!(
        clock.observe_tick(1.03, 1055, -1.0, false),
        Observation::InOrder
    );
}

#[test]
fn rtt_puts_the_server_ahead_of_the_arrivals() {
    let mut clock = ServerClock::new(60.0);
    clock.observe(0.0, meta(0, 0, 1.0, false));
    clock.rtt_sample(0.1);
    let ahead = clock.estimated_tick(0.0).unwrap() - clock.arrival_tick(0.0).unwrap();
    assert!((ahead - 3.0).abs() < 1e-9);
    assert!(seq_older(65535, 2) && !seq_older(2, 65535));
}
