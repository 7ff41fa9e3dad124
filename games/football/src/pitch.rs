//! The pitch's measurements, which the scene (`scenes/pitch.ron`), the
//! rules and the bots share. The pitch runs along x: the red team defends
//! the goal at −x and attacks the one at +x; blue the other way round.

use inertia_physics::glam::DVec3;

use crate::properties::Team;

/// Half the pitch's length, goal line to goal line, m.
pub const HALF_LENGTH: f64 = 16.0;
/// Half the pitch's width, touchline to touchline, m.
pub const HALF_WIDTH: f64 = 10.0;
/// Half a goal mouth's width, m.
pub const GOAL_HALF_WIDTH: f64 = 2.5;
/// A goal mouth's height, m.
pub const GOAL_HEIGHT: f64 = 2.0;

/// The ball's radius, m.
pub const BALL_RADIUS: f64 = 0.35;
/// The ball's mass, kg.
pub const BALL_MASS: f64 = 0.8;

/// Where the ball is put for a kickoff, m: the centre spot, just above
/// the grass.
pub const CENTRE_SPOT: DVec3 = DVec3::new(0.0, BALL_RADIUS + 0.05, 0.0);

/// The centre of the goal `team` attacks, on its line, m.
pub fn goal_attacked_by(team: Team) -> DVec3 {
    DVec3::new(team.attacks() * HALF_LENGTH, GOAL_HEIGHT * 0.4, 0.0)
}

/// Where the `index`th player of `team` stands at a kickoff, m: in its
/// own half, in a fan of places that takes up to eight, at a capsule's
/// standing height.
pub fn kickoff_place(team: Team, index: usize) -> DVec3 {
    const PLACES: [(f64, f64); 8] = [
        (4.0, 0.0),
        (6.0, -4.0),
        (6.0, 4.0),
        (10.0, 0.0),
        (9.0, -7.0),
        (9.0, 7.0),
        (13.0, -3.0),
        (13.0, 3.0),
    ];
    let (back, side) = PLACES[index % PLACES.len()];
    DVec3::new(-team.attacks() * back, 1.0, side)
}

/// Whether `at` (m) lies within the pitch's walls, with `margin` m to
/// spare.
pub fn on_pitch(at: DVec3, margin: f64) -> bool {
    at.x.abs() <= HALF_LENGTH + 2.0 + margin && at.z.abs() <= HALF_WIDTH + margin && at.y > -1.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules::GOAL_NAMES;
    use inertia_server::scene::{Scene, SceneFormat};

    #[test]
    fn the_pitch_builds_with_a_sensor_behind_each_goal_line() {
        let scene = Scene::parse(crate::PITCH, SceneFormat::Ron).expect("the pitch parses");
        let built = scene.build().expect("the pitch builds");
        for (team, name) in GOAL_NAMES {
            let h = built.bodies_by_name[name];
            let goal = built.world.body(h).expect("the goal's body");
            assert!(goal.is_sensor(), "{name} is a sensor");
            let at = goal.center_of_mass();
            // Red defends the goal at -x: the one blue attacks.
            assert!(
                at.x * team.attacks() < -HALF_LENGTH && at.z.abs() < 1e-9,
                "{name} at {at}"
            );
            let attacker = goal_attacked_by(team.other());
            assert!(
                (attacker.x - at.x).abs() < 2.0,
                "{name}: {attacker} vs {at}"
            );
        }
        assert!(on_pitch(CENTRE_SPOT, 0.0));
        assert!(!on_pitch(DVec3::new(0.0, 0.5, HALF_WIDTH + 3.0), 1.0));
    }
}
