//! The rules of football: a capsule per player, run by its [`Play`]'s
//! stick, jumping and kicking on the press of a button; a ball; goals that
//! are sensors in the scene; a kickoff when both teams have a player and
//! after every goal; a match clock, then golden goal; the first team to
//! [`FootballSettings::goals_to_win`], or the one ahead when the clock
//! runs out, wins.

use std::collections::BTreeMap;

use inertia_physics::character::{self, WalkSettings};
use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_protocol::input::GameInput;
use inertia_protocol::message::{Delivery, GameMessage, MessageRefusal};
use inertia_protocol::property::PropertySchema;
use inertia_protocol::{EntityId, EntityKind, PlayerInput};
use inertia_server::rules::{
    ClientId, EntityLook, GameRules, InputRefusal, JoinRefusal, Recipients, RemovalReason,
    SimContext,
};
use serde::{Deserialize, Serialize};

use crate::input::buttons;
use crate::pitch::{self, BALL_MASS, BALL_RADIUS, CENTRE_SPOT};
use crate::properties::{
    self, Phase, Team, CLOCK, GOALS, PHASE, SCORE_BLUE, SCORE_RED, TEAM, WINNER,
};
use crate::{Ask, Play, Tell};

/// The scene's goal sensors, by the team that defends each.
pub const GOAL_NAMES: [(Team, &str); 2] = [(Team::Red, "goal red"), (Team::Blue, "goal blue")];

/// Tuning of [`FootballRules`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FootballSettings {
    /// A match's length of play, s (then golden goal if level).
    pub match_seconds: f64,
    /// Goals that win the match at once.
    pub goals_to_win: u8,
    /// How long everyone stands in place before a kickoff, s.
    pub kickoff_seconds: f64,
    /// How long the final score shows before the match is over for the
    /// server (which then drains and stops), s.
    pub final_whistle_seconds: f64,
    /// How a player's capsule runs and jumps (the client's prediction,
    /// [`crate::predict::Runner`], runs it the same).
    pub walk: WalkSettings,
    /// The speed a kick gives the ball, m/s (the server caps one impulse's
    /// change at 12 m/s).
    pub kick_speed: f64,
    /// How far beyond touching a kick reaches, m.
    pub kick_reach: f64,
    /// Least time between a player's kicks, s.
    pub kick_cooldown: f64,
}

impl Default for FootballSettings {
    fn default() -> Self {
        Self {
            match_seconds: 180.0,
            goals_to_win: 5,
            kickoff_seconds: 1.5,
            final_whistle_seconds: 5.0,
            walk: WalkSettings::default(),
            kick_speed: 11.0,
            kick_reach: 0.6,
            kick_cooldown: 0.3,
        }
    }
}

/// One player (saved with the rules' state: field order is the format).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Player {
    avatar: EntityId,
    team: Team,
    /// The latest accepted play.
    play: Play,
    /// Buttons of the previous play, for press edges.
    held: u8,
    /// A jump (kick) was pressed since the last tick.
    jump_pressed: bool,
    kick_pressed: bool,
    /// No jump (kick) before this tick.
    jump_ready_at: u64,
    kick_ready_at: u64,
    goals: u8,
}

/// Everything the rules remember between ticks (saved with keyframes and
/// checkpoints: field order is the format).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Match {
    players: BTreeMap<ClientId, Player>,
    ball: Option<EntityId>,
    /// The goal sensors, by the team that defends each (red's, blue's).
    goals: Option<[EntityId; 2]>,
    phase: Phase,
    /// Whether play ever started (the clock was set).
    started: bool,
    /// Red's goals, blue's.
    score: [u8; 2],
    /// Ticks of play left (0: golden goal).
    ticks_left: u64,
    /// Ticks left in a kickoff's or the final whistle's wait.
    wait_ticks: u64,
    /// Who kicks off next.
    kicking_off: Team,
    /// Who touched the ball last with a kick.
    last_kick: Option<ClientId>,
    winner: Option<Team>,
}

impl Default for Match {
    fn default() -> Self {
        Match {
            players: BTreeMap::new(),
            ball: None,
            goals: None,
            phase: Phase::Waiting,
            started: false,
            score: [0, 0],
            ticks_left: 0,
            wait_ticks: 0,
            kicking_off: Team::Red,
            last_kick: None,
            winner: None,
        }
    }
}

/// The rules of football.
#[derive(Debug, Default)]
pub struct FootballRules {
    settings: FootballSettings,
    game: Match,
}

impl FootballRules {
    /// Rules tuned by `settings`.
    pub fn new(settings: FootballSettings) -> Self {
        Self {
            settings,
            game: Match::default(),
        }
    }

    /// The ball's body, its place and the goals, found or made once: the
    /// goals are the scene's sensors named in [`GOAL_NAMES`]; the ball is
    /// the rules' own.
    fn ensure_pitch(&mut self, ctx: &mut SimContext<'_>) {
        if self.game.goals.is_none() {
            let find = |name: &str| {
                ctx.entities()
                    .iter()
                    .find(|(_, e)| e.desc.name == name)
                    .map(|(id, _)| id)
            };
            if let (Some(red), Some(blue)) = (find(GOAL_NAMES[0].1), find(GOAL_NAMES[1].1)) {
                self.game.goals = Some([red, blue]);
            }
        }
        if self.game.ball.is_none() {
            self.game.ball = spawn_ball(ctx);
        }
    }

    fn team_size(&self, team: Team) -> usize {
        self.game
            .players
            .values()
            .filter(|p| p.team == team)
            .count()
    }

    /// Everyone to their places, the ball to the centre spot, all at rest;
    /// the clock waits [`FootballSettings::kickoff_seconds`].
    fn kickoff(&mut self, ctx: &mut SimContext<'_>) {
        self.game.phase = Phase::Kickoff;
        self.game.wait_ticks = character::ticks(self.settings.kickoff_seconds, ctx.dt());
        self.game.last_kick = None;
        let mut counts = [0usize; 2];
        for p in self.game.players.values() {
            let k = usize::from(p.team == Team::Blue);
            let at = pitch::kickoff_place(p.team, counts[k]);
            counts[k] += 1;
            let _ = ctx.set_pose(p.avatar, Pose::from_translation(at));
            let _ = ctx.set_velocity(p.avatar, DVec3::ZERO, DVec3::ZERO);
        }
        self.place_ball(ctx);
        let team = self.game.kicking_off;
        let _ = ctx.send(Recipients::All, Delivery::Reliable, &Tell::Kickoff { team });
    }

    fn place_ball(&mut self, ctx: &mut SimContext<'_>) {
        if let Some(ball) = self.game.ball {
            let _ = ctx.set_pose(ball, Pose::from_translation(CENTRE_SPOT));
            let _ = ctx.set_velocity(ball, DVec3::ZERO, DVec3::ZERO);
        }
    }

    /// Whether the standing capsule of `avatar` is on something solid.
    fn grounded(&self, avatar: EntityId, ctx: &SimContext<'_>) -> bool {
        let Some(b) = ctx.body(avatar) else {
            return false;
        };
        self.settings
            .walk
            .grounded(b.center_of_mass(), |from, dir, reach| {
                ctx.cast_ray(from, dir, reach, Some(avatar)).is_some()
            })
    }

    /// One player's tick: run, jump, kick.
    fn drive(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        let s = self.settings;
        let held = self.game.phase == Phase::Kickoff;
        let ball = self.game.ball;
        let Some(p) = self.game.players.get_mut(&client) else {
            return;
        };
        let avatar = p.avatar;
        let (jump, kick) = (
            std::mem::take(&mut p.jump_pressed),
            std::mem::take(&mut p.kick_pressed),
        );
        let play = p.play;
        let Some(b) = ctx.body(avatar) else { return };
        let (v, com) = (b.linear_velocity(), b.center_of_mass());
        let grounded = self.grounded(avatar, ctx);
        let Some(p) = self.game.players.get_mut(&client) else {
            return;
        };
        if held {
            // Standing in place for the kickoff.
            let _ = ctx.set_control_force(avatar, s.walk.walk_force([0.0, 0.0], v, grounded));
            return;
        }
        let _ = ctx.set_control_force(avatar, s.walk.walk_force(play.movement(), v, grounded));
        let (tick, dt) = (ctx.tick(), ctx.dt());
        if let Some(j) = s.walk.jump(jump, grounded, tick, p.jump_ready_at, v, dt) {
            if ctx.apply_impulse(avatar, j.impulse, com).is_ok() {
                p.jump_ready_at = j.ready_at;
            }
        }
        let Some(ball) = ball else { return };
        if !kick || tick < p.kick_ready_at {
            return;
        }
        let Some(at) = ctx.body(ball).map(|b| b.center_of_mass()) else {
            return;
        };
        // The gap between the ball and the capsule's surface, m.
        let axis_y =
            at.y.clamp(com.y - s.walk.half_height, com.y + s.walk.half_height);
        let gap = at.distance(DVec3::new(com.x, axis_y, com.z)) - s.walk.radius - BALL_RADIUS;
        if gap > s.kick_reach {
            return;
        }
        p.kick_ready_at = tick + character::ticks(s.kick_cooldown, dt);
        let impulse = play.kick_direction() * (s.kick_speed * BALL_MASS);
        if ctx.apply_impulse(ball, impulse, at).is_ok() {
            self.game.last_kick = Some(client);
        }
    }

    /// Whether the ball lies in a goal, and which team that scores for.
    fn scored(&self, ctx: &SimContext<'_>) -> Option<Team> {
        let (ball, goals) = (self.game.ball?, self.game.goals?);
        let touching = ctx.sensors_touching(ball);
        if touching.contains(&goals[0]) {
            Some(Team::Blue)
        } else if touching.contains(&goals[1]) {
            Some(Team::Red)
        } else {
            None
        }
    }

    fn goal(&mut self, team: Team, ctx: &mut SimContext<'_>) {
        let k = usize::from(team == Team::Blue);
        self.game.score[k] = self.game.score[k].saturating_add(1);
        let scorer = self
            .game
            .last_kick
            .filter(|c| self.game.players.get(c).is_some_and(|p| p.team == team));
        if let Some(p) = scorer.and_then(|c| self.game.players.get_mut(&c)) {
            p.goals = p.goals.saturating_add(1);
            let _ = ctx.set_property(p.avatar, GOALS, p.goals);
        }
        let tell = Tell::Goal {
            tick: ctx.tick(),
            team,
            scorer,
            score: self.game.score,
        };
        let _ = ctx.send(Recipients::All, Delivery::Reliable, &tell);
        let golden = self.game.ticks_left == 0;
        if golden || self.game.score[k] >= self.settings.goals_to_win {
            self.finish(team, ctx);
        } else {
            self.game.kicking_off = team.other();
            self.kickoff(ctx);
        }
    }

    fn finish(&mut self, winner: Team, ctx: &mut SimContext<'_>) {
        self.game.phase = Phase::Over;
        self.game.winner = Some(winner);
        self.game.wait_ticks = character::ticks(self.settings.final_whistle_seconds, ctx.dt());
        let tell = Tell::Over {
            winner,
            score: self.game.score,
        };
        let _ = ctx.send(Recipients::All, Delivery::Reliable, &tell);
    }

    /// The match's properties as they are now (the clock in whole seconds,
    /// so that it changes once a second).
    fn show(&self, ctx: &mut SimContext<'_>) {
        let g = &self.game;
        let _ = ctx.set_match_property(SCORE_RED, g.score[0]);
        let _ = ctx.set_match_property(SCORE_BLUE, g.score[1]);
        let seconds = (g.ticks_left as f64 * ctx.dt()).ceil() as f32;
        let _ = ctx.set_match_property(CLOCK, seconds);
        let _ = ctx.set_match_property(PHASE, g.phase.code());
        let _ = ctx.set_match_property(WINNER, g.winner.map_or(0, Team::code));
    }

    /// Starts or stops play as the teams fill and empty.
    fn follow_teams(&mut self, ctx: &mut SimContext<'_>) {
        let both = self.team_size(Team::Red) > 0 && self.team_size(Team::Blue) > 0;
        match self.game.phase {
            Phase::Waiting if both => {
                if !self.game.started {
                    self.game.started = true;
                    self.game.ticks_left =
                        character::ticks(self.settings.match_seconds, ctx.dt()).max(1);
                }
                self.kickoff(ctx);
            }
            Phase::Kickoff | Phase::Playing if !both => self.game.phase = Phase::Waiting,
            _ => {}
        }
    }
}

/// The ball: a bouncy sphere of [`BALL_MASS`] on the centre spot.
fn spawn_ball(ctx: &mut SimContext<'_>) -> Option<EntityId> {
    let shape = Shape::sphere(BALL_RADIUS).ok()?;
    let desc = RigidBodyDesc::dynamic(shape, 1.0, Pose::from_translation(CENTRE_SPOT))
        .ok()?
        .with_mass(BALL_MASS)
        .ok()?
        .with_restitution(0.5)
        .with_damping(0.3, 0.8)
        .with_ccd(true)
        .with_can_sleep(false);
    let look = EntityLook {
        kind: EntityKind::Dynamic,
        color: [245, 245, 245, 255],
        owner: None,
        name: "ball".into(),
    };
    ctx.spawn(&desc, look).ok()
}

impl GameRules for FootballRules {
    fn name(&self) -> &str {
        "football"
    }

    fn input_bytes(&self) -> usize {
        Play::BYTES
    }

    fn properties(&self) -> PropertySchema {
        properties::schema()
    }

    fn on_connect(
        &mut self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, JoinRefusal> {
        self.ensure_pitch(ctx);
        let team = if self.team_size(Team::Blue) < self.team_size(Team::Red) {
            Team::Blue
        } else {
            Team::Red
        };
        let index = self.team_size(team);
        let desc = self
            .settings
            .walk
            .body_desc(pitch::kickoff_place(team, index))
            .map_err(|e| JoinRefusal::Rules(e.to_string()))?;
        let look = EntityLook {
            kind: EntityKind::Avatar,
            color: team_color(team),
            owner: Some(client),
            name: format!("{} {client}", team.name()),
        };
        let avatar = ctx
            .spawn(&desc, look)
            .map_err(|e| JoinRefusal::Rules(e.to_string()))?;
        self.game.players.insert(
            client,
            Player {
                avatar,
                team,
                play: Play::default(),
                held: 0,
                jump_pressed: false,
                kick_pressed: false,
                jump_ready_at: 0,
                kick_ready_at: 0,
                goals: 0,
            },
        );
        let _ = ctx.set_property(avatar, TEAM, team.code());
        let _ = ctx.set_property(avatar, GOALS, 0u8);
        let _ = ctx.send(
            Recipients::All,
            Delivery::Reliable,
            &Tell::Joined { client, team },
        );
        self.follow_teams(ctx);
        self.show(ctx);
        Ok(avatar)
    }

    fn on_disconnect(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        if let Some(p) = self.game.players.remove(&client) {
            ctx.despawn(p.avatar);
        }
        if self.game.last_kick == Some(client) {
            self.game.last_kick = None;
        }
        self.follow_teams(ctx);
        self.show(ctx);
    }

    fn on_input(
        &mut self,
        client: ClientId,
        input: &PlayerInput,
        _ctx: &mut SimContext<'_>,
    ) -> Result<(), InputRefusal> {
        let play = Play::from_payload(&input.payload)?;
        let p = self
            .game
            .players
            .get_mut(&client)
            .ok_or(InputRefusal::NotJoined(client))?;
        let pressed = play.buttons & !p.held;
        p.held = play.buttons;
        p.jump_pressed |= pressed & buttons::JUMP != 0;
        p.kick_pressed |= pressed & buttons::KICK != 0;
        p.play = play;
        Ok(())
    }

    fn on_message(
        &mut self,
        client: ClientId,
        _delivery: Delivery,
        bytes: &[u8],
        ctx: &mut SimContext<'_>,
    ) -> Result<(), MessageRefusal> {
        let ask = Ask::decode(bytes)?;
        let Some(p) = self.game.players.get(&client) else {
            return Err(MessageRefusal::NotConnected);
        };
        match ask {
            Ask::Say(text) => {
                ctx.send(
                    Recipients::All,
                    Delivery::Reliable,
                    &Tell::Said { client, text },
                )?;
            }
            Ask::SwitchTeam => {
                let (from, avatar) = (p.team, p.avatar);
                let to = from.other();
                if !matches!(self.game.phase, Phase::Waiting | Phase::Kickoff) {
                    return Err(MessageRefusal::Rules(
                        "teams change only before play".into(),
                    ));
                }
                if self.team_size(to) + 1 > self.team_size(from) {
                    return Err(MessageRefusal::Rules(format!(
                        "{} would have more players than {}",
                        to.name(),
                        from.name()
                    )));
                }
                if let Some(p) = self.game.players.get_mut(&client) {
                    p.team = to;
                }
                let _ = ctx.set_property(avatar, TEAM, to.code());
                let _ = ctx.send(
                    Recipients::All,
                    Delivery::Reliable,
                    &Tell::Joined { client, team: to },
                );
                if self.game.phase == Phase::Kickoff {
                    self.kickoff(ctx);
                }
                self.follow_teams(ctx);
            }
        }
        Ok(())
    }

    fn on_removed(&mut self, entity: EntityId, _reason: RemovalReason, _ctx: &mut SimContext<'_>) {
        if self.game.ball == Some(entity) {
            self.game.ball = None;
        }
    }

    fn before_tick(&mut self, ctx: &mut SimContext<'_>) {
        let clients: Vec<ClientId> = self.game.players.keys().copied().collect();
        for client in clients {
            self.drive(client, ctx);
        }
    }

    fn after_tick(&mut self, ctx: &mut SimContext<'_>) {
        self.ensure_pitch(ctx);
        // A ball that left the pitch (over a wall, or out of the world)
        // comes back to the centre spot.
        let ball_at = self
            .game
            .ball
            .and_then(|b| ctx.body(b))
            .map(|b| b.center_of_mass());
        if ball_at.is_some_and(|at| !pitch::on_pitch(at, 1.0)) {
            self.place_ball(ctx);
        }
        match self.game.phase {
            Phase::Waiting => {}
            Phase::Kickoff => {
                self.place_ball(ctx);
                self.game.wait_ticks = self.game.wait_ticks.saturating_sub(1);
                if self.game.wait_ticks == 0 {
                    self.game.phase = Phase::Playing;
                }
            }
            Phase::Playing => {
                if let Some(team) = self.scored(ctx) {
                    self.goal(team, ctx);
                } else if self.game.ticks_left > 0 {
                    self.game.ticks_left -= 1;
                    let [red, blue] = self.game.score;
                    if self.game.ticks_left == 0 && red != blue {
                        self.finish(if red > blue { Team::Red } else { Team::Blue }, ctx);
                    }
                }
            }
            Phase::Over => {
                self.game.wait_ticks = self.game.wait_ticks.saturating_sub(1);
            }
        }
        self.show(ctx);
    }

    fn match_over(&self) -> Option<String> {
        if self.game.phase != Phase::Over || self.game.wait_ticks > 0 {
            return None;
        }
        let winner = self.game.winner?;
        let [red, blue] = self.game.score;
        Some(format!("{} wins, red {red} – blue {blue}", winner.name()))
    }

    fn save_state(&self) -> Vec<u8> {
        postcard::to_allocvec(&self.game).unwrap_or_default()
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.is_empty() {
            self.game = Match::default();
            return Ok(());
        }
        self.game = postcard::from_bytes(bytes).map_err(|e| format!("football match: {e}"))?;
        Ok(())
    }
}

/// A team's shirt colour, RGBA.
pub fn team_color(team: Team) -> [u8; 4] {
    match team {
        Team::Red => [220, 60, 50, 255],
        Team::Blue => [50, 100, 230, 255],
    }
}
