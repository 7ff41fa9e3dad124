//! The rules of orbs: a ball per player, rolled by its [`Drive`]; orbs on
//! the floor once every player is [`Ask::Ready`]; an orb a ball touches is
//! its player's; the round ends when the last is taken or the clock runs
//! out, and the player holding the most wins.

use std::collections::BTreeMap;

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_protocol::input::GameInput;
use inertia_protocol::message::{Delivery, GameMessage, MessageRefusal};
use inertia_protocol::property::PropertySchema;
use inertia_protocol::{EntityId, EntityKind, PlayerInput};
use inertia_server::rules::{
    ClientId, EntityLook, GameRules, InputRefusal, JoinRefusal, Recipients, SimContext,
};
use serde::{Deserialize, Serialize};

use crate::properties::{self, CLOCK, ORBS, ORBS_LEFT, OVER, PHASE, PLAYING, WAITING};
use crate::{Ask, Drive, Tell};

/// A ball's radius, m.
pub const BALL_RADIUS: f64 = 0.5;
/// A ball's density, kg/m³.
pub const BALL_DENSITY: f64 = 200.0;
/// An orb's radius, m.
pub const ORB_RADIUS: f64 = 0.3;
/// The force a full stick rolls a ball with, N (twice as much dashing).
pub const ROLL_FORCE: f64 = 2_000.0;
/// A round's length, s.
pub const ROUND_SECONDS: f64 = 90.0;

/// The force a drive rolls a ball with, N: the rules' and the client's
/// prediction's ([`crate::predict::Roller`]) alike.
pub fn roll_force(drive: &Drive) -> DVec3 {
    let scale = if drive.dash { 2.0 } else { 1.0 } * ROLL_FORCE / 127.0;
    DVec3::new(f64::from(drive.stick[0]), 0.0, f64::from(drive.stick[1])) * scale
}

/// Where the orbs lie, m: one a stride from each place to start, then a
/// ring round the middle.
fn orb_places(spawn_points: &[DVec3]) -> Vec<DVec3> {
    let mut places: Vec<DVec3> = spawn_points
        .iter()
        .map(|p| DVec3::new(p.x + 1.5, 0.5, p.z))
        .collect();
    places.extend((0..8).map(|k| {
        let a = f64::from(k) * std::f64::consts::TAU / 8.0;
        DVec3::new(4.0 * a.cos(), 0.5, 4.0 * a.sin())
    }));
    places
}

/// One player (saved with the rules' state: field order is the format).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
struct Player {
    ball: EntityId,
    stick: [i8; 2],
    dash: bool,
    ready: bool,
    orbs: u8,
}

/// Everything the rules remember between ticks.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
struct Round {
    players: BTreeMap<ClientId, Player>,
    /// The orbs on the floor and where they lie, m.
    orbs: Vec<(EntityId, [f64; 3])>,
    phase: u64,
    ticks_left: u64,
    winner: Option<ClientId>,
}

/// The rules of orbs.
#[derive(Debug, Default)]
pub struct OrbsRules {
    round: Round,
}

impl OrbsRules {
    /// Puts the orbs on the floor and starts the clock.
    fn start(&mut self, ctx: &mut SimContext<'_>) {
        let places = orb_places(ctx.spawn_points());
        for (i, at) in places.into_iter().enumerate() {
            let Ok(shape) = Shape::sphere(ORB_RADIUS) else {
                return;
            };
            let desc = RigidBodyDesc::fixed(shape, Pose::from_translation(at)).as_sensor();
            let look = EntityLook {
                kind: EntityKind::Static,
                color: [255, 200, 40, 255],
                owner: None,
                name: format!("orb[{i}]"),
            };
            if let Ok(id) = ctx.spawn(&desc, look) {
                self.round.orbs.push((id, at.to_array()));
            }
        }
        self.round.phase = PLAYING;
        self.round.ticks_left = (ROUND_SECONDS / ctx.dt()).round() as u64;
        let _ = ctx.send(Recipients::All, Delivery::Reliable, &Tell::Started);
        self.show_round(ctx);
    }

    /// The round's properties as they are now.
    fn show_round(&self, ctx: &mut SimContext<'_>) {
        let r = &self.round;
        let _ = ctx.set_match_property(ORBS_LEFT, r.orbs.len().min(255) as u64);
        let _ = ctx.set_match_property(CLOCK, (r.ticks_left as f64 * ctx.dt()) as f32);
        let _ = ctx.set_match_property(PHASE, r.phase);
    }

    /// Gives each ball the orbs it touches (orbs are sensors: balls roll
    /// through them, and the rules, which know where each lies, see the
    /// touch).
    fn collect(&mut self, ctx: &mut SimContext<'_>) {
        let clients: Vec<ClientId> = self.round.players.keys().copied().collect();
        for client in clients {
            let Some(ball) = self.round.players.get(&client).map(|p| p.ball) else {
                continue;
            };
            let Some(at) = ctx.body(ball).map(|b| b.center_of_mass()) else {
                continue;
            };
            let reach = BALL_RADIUS + ORB_RADIUS;
            while let Some(k) = self
                .round
                .orbs
                .iter()
                .position(|(_, o)| DVec3::from_array(*o).distance(at) <= reach)
            {
                let (orb, _) = self.round.orbs.remove(k);
                ctx.despawn(orb);
                let Some(p) = self.round.players.get_mut(&client) else {
                    continue;
                };
                p.orbs = p.orbs.saturating_add(1);
                let orbs = p.orbs;
                let _ = ctx.set_property(ball, ORBS, orbs);
                let _ = ctx.send(
                    Recipients::All,
                    Delivery::Reliable,
                    &Tell::Collected { client, orbs },
                );
            }
        }
    }

    /// Ends the round: the player with the most orbs wins (the lowest
    /// client id among equals).
    fn finish(&mut self, ctx: &mut SimContext<'_>) {
        let winner = self
            .round
            .players
            .iter()
            .max_by_key(|(client, p)| (p.orbs, std::cmp::Reverse(**client)))
            .map(|(client, _)| *client);
        self.round.phase = OVER;
        self.round.winner = winner;
        if let Some(client) = winner {
            let _ = ctx.send(Recipients::All, Delivery::Reliable, &Tell::Won { client });
        }
    }
}

impl GameRules for OrbsRules {
    fn name(&self) -> &str {
        "orbs"
    }

    fn input_bytes(&self) -> usize {
        Drive::BYTES
    }

    fn properties(&self) -> PropertySchema {
        properties::schema()
    }

    fn on_connect(
        &mut self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, JoinRefusal> {
        let points = ctx.spawn_points();
        let at = points
            .get(self.round.players.len() % points.len().max(1))
            .copied()
            .ok_or(JoinRefusal::NoRoom)?;
        let shape = Shape::sphere(BALL_RADIUS).map_err(|e| JoinRefusal::Rules(e.to_string()))?;
        let desc = RigidBodyDesc::dynamic(shape, BALL_DENSITY, Pose::from_translation(at))
            .map_err(|e| JoinRefusal::Rules(e.to_string()))?;
        let look = EntityLook {
            kind: EntityKind::Avatar,
            color: [60, 140, 240, 255],
            owner: Some(client),
            name: format!("ball of {client}"),
        };
        let ball = ctx
            .spawn(&desc, look)
            .map_err(|e| JoinRefusal::Rules(e.to_string()))?;
        self.round.players.insert(
            client,
            Player {
                ball,
                ..Player::default()
            },
        );
        let _ = ctx.set_property(ball, ORBS, 0u8);
        self.show_round(ctx);
        Ok(ball)
    }

    fn on_disconnect(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        if let Some(p) = self.round.players.remove(&client) {
            ctx.despawn(p.ball);
        }
    }

    fn on_input(
        &mut self,
        client: ClientId,
        input: &PlayerInput,
        _ctx: &mut SimContext<'_>,
    ) -> Result<(), InputRefusal> {
        let drive = Drive::from_payload(&input.payload)?;
        let p = self
            .round
            .players
            .get_mut(&client)
            .ok_or(InputRefusal::NotJoined(client))?;
        p.stick = drive.stick;
        p.dash = drive.dash;
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
        let p = self
            .round
            .players
            .get_mut(&client)
            .ok_or(MessageRefusal::NotConnected)?;
        match ask {
            Ask::Ready => {
                p.ready = true;
                let all = self.round.players.values().all(|p| p.ready);
                if all && self.round.phase == WAITING {
                    self.start(ctx);
                }
            }
            Ask::Say(text) => {
                let said = Tell::Said { client, text };
                ctx.send(Recipients::All, Delivery::Reliable, &said)?;
            }
        }
        Ok(())
    }

    fn before_tick(&mut self, ctx: &mut SimContext<'_>) {
        for p in self.round.players.values() {
            let drive = Drive {
                stick: p.stick,
                dash: p.dash,
            };
            let _ = ctx.set_control_force(p.ball, roll_force(&drive));
        }
    }

    fn after_tick(&mut self, ctx: &mut SimContext<'_>) {
        if self.round.phase != PLAYING {
            return;
        }
        self.collect(ctx);
        self.round.ticks_left = self.round.ticks_left.saturating_sub(1);
        if self.round.orbs.is_empty() || self.round.ticks_left == 0 {
            self.finish(ctx);
        }
        self.show_round(ctx);
    }

    fn match_over(&self) -> Option<String> {
        let client = self.round.winner?;
        let orbs = self.round.players.get(&client).map_or(0, |p| p.orbs);
        Some(format!("client {client} wins with {orbs} orbs"))
    }

    fn save_state(&self) -> Vec<u8> {
        postcard::to_allocvec(&self.round).unwrap_or_default()
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.is_empty() {
            self.round = Round::default();
            return Ok(());
        }
        self.round = postcard::from_bytes(bytes).map_err(|e| format!("orbs round: {e}"))?;
        Ok(())
    }
}
