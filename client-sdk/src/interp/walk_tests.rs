//! Samples put into the buffer one by one or walked in beside the ones it holds are the same samples.

use super::*;

fn state(id: EntityId, x: f64) -> ViewEntity {
    ViewEntity {
        id,
        position: DVec3::new(x, 0.0, 0.0),
        rotation: DQuat::IDENTITY,
        linear_velocity: Some(DVec3::X),
        angular_velocity: None,
        at_rest: false,
    }
}

#[test]
fn samples_walked_in_are_the_samples_put_in_one_by_one() {
    let mut walked = InterpolationBuffer::new(60.0);
    let mut each = InterpolationBuffer::new(60.0);
    for n in 0..40u64 {
        let meta = SnapshotMeta {
            seq: Some(n as u16),
            tick: 2 * n,
            time_scale: 1.0,
            paused: false,
        };
        // Entities come and go; every other snapshot carries a few of
        // them (looked up, not walked); every fifth out of order.
        let keep = |id: u64| {
            if n % 2 == 0 {
                (id + n) % 3 != 0
            } else {
                (id + n) % 13 == 0
            }
        };
        let mut states: Vec<ViewEntity> = (0..40)
            .filter(|&id| keep(id))
            .map(|id| state(id as EntityId, (n * 10 + id) as f64))
            .collect();
        if n % 5 == 4 {
            states.reverse();
        }
        let t = n as f64 / 30.0;
        walked.push_states(t, meta, &states);
        for &s in &states {
            each.push_states(t, meta, &[s]);
        }
        if n % 4 == 0 {
            walked.sample(t);
            each.sample(t);
        }
    }
    for id in 0..40 {
        let samples =
            |b: &InterpolationBuffer| b.states(id).map(|(t, s)| (t, *s)).collect::<Vec<_>>();
        assert_eq!(samples(&walked), samples(&each), "entity {id}");
    }
    assert_eq!(walked.sample(1.5), each.sample(1.5));
}
