//! The interpolation functions and the buffer on a steady stream and on entities that stop coming.

use super::*;

fn snapshot(seq: u16, tick: u64, x: f64, vx: Option<f64>) -> Sent {
    Sent {
        meta: SnapshotMeta {
            seq: Some(seq),
            tick,
            time_scale: 1.0,
            paused: false,
        },
        entities: vec![ViewEntity {
            id: 7,
            position: DVec3::new(x, 0.0, 0.0),
            rotation: DQuat::IDENTITY,
            linear_velocity: vx.map(|v| DVec3::new(v, 0.0, 0.0)),
            angular_velocity: None,
            at_rest: false,
        }],
    }
}

#[test]
fn hermite_is_exact_for_cubics_and_slerp_takes_the_short_way() {
    // x(t) = t³ on [1, 2]: velocities 3 and 12.
    let p = hermite(
        DVec3::X,
        DVec3::X * 3.0,
        DVec3::X * 8.0,
        DVec3::X * 12.0,
        1.0,
        0.5,
    );
    assert!((p.x - 1.5f64.powi(3)).abs() < 1e-12);
    let a = DQuat::from_rotation_y(0.1);
    let b = -DQuat::from_rotation_y(0.3);
    let m = slerp(a, b, 0.5);
    assert!(m.angle_between(DQuat::from_rotation_y(0.2)) < 1e-9);
}

#[test]
fn a_steady_stream_renders_behind_by_the_delay_and_in_between() {
    let mut buf = InterpolationBuffer::new(60.0);
    let mut frames = 0;
    let mut t = 0.0;
    for k in 0..120u64 {
        // 30 Hz snapshots, 2 ticks apart, moving 1 m per tick.
        let arrive = k as f64 / 30.0 + 0.05;
        while t < arrive {
            let f = buf.sample(t);
            if let Some(e) = f.get(7) {
                assert!((e.position.x - f.render_tick).abs() < 1e-9);
                frames += 1;
            }
            t += 1.0 / 144.0;
        }
        push(
            &mut buf,
            arrive,
            snapshot(k as u16, 2 * k, 2.0 * k as f64, Some(60.0)),
        );
    }
    assert!(frames > 400);
    let stats = buf.stats();
    assert_eq!(stats.stalls, 0);
    assert_eq!(stats.extrapolations, 0);
    let lag = (buf.clock().arrival_tick(t).unwrap() - buf.render_tick().unwrap()) / 60.0;
    assert!(
        (lag - buf.delay()).abs() < 0.02,
        "lag {lag} delay {}",
        buf.delay()
    );
    // 2 intervals and a margin.
    assert!((0.06..0.09).contains(&buf.delay()), "delay {}", buf.delay());
}

#[test]
fn an_entity_absent_from_later_snapshots_holds_within_the_bound() {
    let mut buf = InterpolationBuffer::new(60.0);
    push(&mut buf, 0.0, snapshot(0, 0, 0.0, Some(60.0)));
    let mut other = snapshot(1, 2, 0.0, None);
    other.entities[0].id = 8;
    push(&mut buf, 0.01, other);
    // Render far ahead: 7 is extrapolated by at most 0.1 s (6 m).
    for k in 0..200 {
        buf.sample(k as f64 * 0.01);
    }
    let f = buf.sample(2.0);
    let e = f.get(7).unwrap();
    assert!(e.extrapolated);
    assert!(e.position.x <= 6.0 + 1e-9);
    assert_eq!(buf.stats().stalls, 1);
    buf.remove(7);
    assert!(buf.sample(2.1).get(7).is_none());
}
