//! A bot that plays football from what any client sees: its own player,
//! its team and the ball. It runs round behind the ball, facing the goal it
//! attacks, and kicks it at that goal once it is close and lined up. The
//! tests play whole matches with bots; `football-bots` sends some to a
//! server for a person to play against.

use inertia_client::Client;
use inertia_physics::glam::DVec3;
use inertia_protocol::property::PropertyValue;

use crate::input::buttons;
use crate::pitch::{self, BALL_RADIUS};
use crate::properties::Team;
use crate::Play;

/// What a bot sees each tick, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BotView {
    /// Its player's centre.
    pub me: DVec3,
    /// Its team.
    pub team: Team,
    /// The ball's centre, when the ball is in view.
    pub ball: Option<DVec3>,
}

/// What a client sees of the match as a bot's view: its player and the
/// ball as of the newest snapshot, its team from its player's `team`
/// property. `None` until its player and its team are in view.
pub fn view_of(client: &Client) -> Option<BotView> {
    let me = client.client_id();
    let (mine, ball) = client.with_entities(|known| {
        let mut mine = None;
        let mut ball = None;
        for (id, e) in known.iter() {
            if e.desc.owner == Some(me) {
                mine = Some((id, e.position()));
            } else if e.desc.name == "ball" {
                ball = Some(e.position());
            }
        }
        (mine, ball)
    });
    let (mine, at) = mine?;
    let team = match client.property(mine, "team")? {
        PropertyValue::UInt(code) => Team::from_code(code)?,
        _ => return None,
    };
    Some(BotView { me: at, team, ball })
}

/// A bot: the play it sends for each view.
#[derive(Debug, Clone, Default)]
pub struct Bot {
    /// Whether the kick button was down in its last play (a kick is a
    /// press: down after up).
    kicking: bool,
}

/// A capsule's radius plus a little, m: how close a bot stands to the
/// ball to kick it.
const STAND_OFF: f64 = 0.35 + BALL_RADIUS + 0.25;
/// How high a bot kicks, degrees.
const KICK_PITCH: f64 = 12.0;

fn flat(v: DVec3) -> DVec3 {
    DVec3::new(v.x, 0.0, v.z)
}

impl Bot {
    /// A bot that has not played yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The play for what the bot sees now.
    pub fn play(&mut self, view: &BotView) -> Play {
        let Some(ball) = view.ball else {
            self.kicking = false;
            return Play::default();
        };
        let me = flat(view.me);
        let ball = flat(ball);
        let goal = flat(pitch::goal_attacked_by(view.team));
        let to_goal = (goal - ball).normalize_or(DVec3::X * view.team.attacks());
        let behind = ball - to_goal * STAND_OFF;
        // Its side of the ball along the line to the goal: past the ball,
        // it runs round it rather than through it.
        let past = (me - ball).dot(to_goal) > -0.2;
        let target = if past {
            let across = DVec3::new(-to_goal.z, 0.0, to_goal.x);
            let side = if (me - ball).dot(across) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            behind + across * side * 1.5 - to_goal * 0.8
        } else {
            // Lined up: run on through the ball.
            behind + to_goal * 0.6
        };
        let way = target - me;
        let stick = if way.length() > 1e-6 {
            way.normalize() * (way.length() / 0.5).min(1.0)
        } else {
            DVec3::ZERO
        };
        let yaw = to_goal.x.atan2(to_goal.z);
        let near = me.distance(ball) < STAND_OFF + 0.5;
        let lined_up = (ball - me).normalize_or(DVec3::ZERO).dot(to_goal) > 0.6;
        let press = near && lined_up && !self.kicking;
        self.kicking = press;
        let pressed = if press { buttons::KICK } else { 0 };
        Play::new([stick.x, stick.z], yaw, KICK_PITCH, pressed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bot_runs_round_the_ball_and_kicks_it_when_lined_up() {
        let mut bot = Bot::new();
        // Red attacks +x; a ball ahead of it on the line to goal.
        let view = BotView {
            me: DVec3::new(-1.0, 1.0, 0.0),
            team: Team::Red,
            ball: Some(DVec3::new(0.0, 0.35, 0.0)),
        };
        let play = bot.play(&view);
        assert_eq!(play.buttons, buttons::KICK);
        assert!(play.stick[0] > 100, "{play:?}");
        // It lets go before the next kick.
        assert_eq!(bot.play(&view).buttons, 0);
        assert_eq!(bot.play(&view).buttons, buttons::KICK);
        // Past the ball, it runs round (sideways and back), not kicking.
        let past = BotView {
            me: DVec3::new(1.5, 1.0, 0.2),
            ..view
        };
        let play = bot.play(&past);
        assert_eq!(play.buttons, 0);
        assert!(play.stick[0] < 0 && play.stick[1] > 0, "{play:?}");
    }
}
