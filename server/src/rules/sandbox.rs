//! The default game: a capsule avatar per client, walked by a capped
//! control force, a jump from the ground and a push for what is in front.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use inertia_physics::character::{self, WalkSettings};
use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::{BodyKind, RigidBodyDesc};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_protocol::input::GameInput;
use inertia_protocol::{EntityId, EntityKind, PlayerInput};
use inertia_sandbox::{buttons, SandboxInput, SANDBOX_INPUT_BYTES};

use inertia_protocol::message::{Delivery, GameMessage, MessageRefusal};
use inertia_protocol::property::{PropertyDecl, PropertyKind, PropertySchema, PropertyValue};
use inertia_sandbox::{Removal, SandboxEvent, SandboxRequest};

use super::{
    ClientId, EntityLook, GameRules, InputRefusal, JoinRefusal, Recipients, RemovalReason,
    SimContext,
};

/// The sandbox's entity properties, by index: an avatar's jumps and
/// pushes so far.
const JUMPS: usize = 0;
const PUSHES: usize = 1;
/// The sandbox's match property: players in the game.
const PLAYERS: usize = 0;

/// Adds one to an avatar's count `index` (saturating at its 16 bits).
fn count_up(ctx: &mut SimContext<'_>, avatar: EntityId, index: usize) {
    if let Ok(PropertyValue::UInt(n)) = ctx.property(avatar, index) {
        let _ = ctx.set_property(avatar, index, (n + 1).min(u64::from(u16::MAX)));
    }
}

/// Tells every client what happened, reliably (an event is a message the
/// sandbox's clients decode as [`SandboxEvent`]).
fn tell(ctx: &mut SimContext<'_>, event: SandboxEvent) {
    // An event is a few bytes: never past the bound.
    let _ = ctx.send(Recipients::All, Delivery::Reliable, &event);
}

/// Tuning of [`SandboxRules`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SandboxSettings {
    /// The avatar's capsule and how it walks and jumps (the SDK's
    /// prediction walks it with the same settings).
    pub walk: WalkSettings,
    /// How far in front a push reaches, m.
    pub push_reach: f64,
    /// Impulse of a push, N·s (capped by the context's limits).
    pub push_impulse: f64,
    /// Least time between pushes, s.
    pub push_cooldown: f64,
}

impl Default for SandboxSettings {
    fn default() -> Self {
        Self {
            walk: WalkSettings::default(),
            push_reach: 1.5,
            push_impulse: 400.0,
            push_cooldown: 0.4,
        }
    }
}

/// One client in the sandbox (saved with the rules' state: field order is
/// the format).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct Player {
    avatar: EntityId,
    /// The latest accepted (clamped) input.
    input: HeldInput,
    /// The sequence of the latest input applied (the connection hands
    /// each sequence on once, in order).
    last_sequence: Option<u32>,
    /// Buttons of the previous input, for press edges.
    held: u8,
    /// A jump (push) was pressed since the last tick.
    jump_pressed: bool,
    push_pressed: bool,
    /// No jump (push) before this tick.
    jump_ready_at: u64,
    push_ready_at: u64,
}

/// A player's latest accepted input as the sandbox keeps it: the input's
/// stamp and its [`SandboxInput`], the stick clamped to length 1 and the
/// yaw wrapped into (−π, π] (saved with the rules' state: field order is
/// the format, the one inputs had before games defined their own).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
struct HeldInput {
    sequence: u32,
    tick: u64,
    /// Desired movement in the horizontal plane (x, z), length ≤ 1.
    movement: [f32; 2],
    /// Facing angle about +Y, rad, in (−π, π].
    yaw: f32,
    /// Held buttons ([`buttons`]).
    buttons: u8,
    /// How far behind its tick the player's view was, ticks.
    view_behind: f32,
}

impl HeldInput {
    /// Reads an input's payload as a [`SandboxInput`];
    /// refused when the bytes are not one.
    fn from_input(input: &PlayerInput) -> Result<HeldInput, InputRefusal> {
        let game = SandboxInput::from_payload(&input.payload)?;
        let [mut mx, mut mz] = game.movement;
        let len = (mx * mx + mz * mz).sqrt();
        if len > 1.0 {
            mx /= len;
            mz /= len;
        }
        let mut yaw = (f64::from(game.yaw) + PI).rem_euclid(2.0 * PI) - PI;
        if yaw <= -PI {
            yaw += 2.0 * PI;
        }
        Ok(HeldInput {
            sequence: input.sequence,
            tick: input.tick,
            movement: [mx, mz],
            yaw: yaw as f32,
            buttons: game.buttons,
            view_behind: input.view_behind,
        })
    }
}

/// The default game: every client walks a capsule avatar around the scene,
/// jumps, and pushes things.
#[derive(Debug, Default)]
pub struct SandboxRules {
    settings: SandboxSettings,
    players: BTreeMap<ClientId, Player>,
}

impl SandboxRules {
    /// Sandbox rules with `settings`.
    pub fn new(settings: SandboxSettings) -> Self {
        Self {
            settings,
            players: BTreeMap::new(),
        }
    }

    /// The avatar of a client.
    pub fn avatar(&self, client: ClientId) -> Option<EntityId> {
        self.players.get(&client).map(|p| p.avatar)
    }

    fn avatar_desc(&self, at: DVec3) -> Result<RigidBodyDesc, JoinRefusal> {
        self.settings
            .walk
            .body_desc(at)
            .map_err(|e| JoinRefusal::Rules(e.to_string()))
    }

    fn spawn_avatar(
        &self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, JoinRefusal> {
        let s = &self.settings;
        let half = s.walk.half_height + s.walk.radius;
        let shape = Shape::capsule(s.walk.half_height, s.walk.radius)
            .map_err(|e| JoinRefusal::Rules(e.to_string()))?;
        // The first spawn point with nothing in the way; then the same
        // points lifted by one avatar height at a time.
        let mut place = None;
        'search: for lift in 0..4 {
            for &p in ctx.spawn_points() {
                let at = p + DVec3::Y * (lift as f64 * (2.0 * half + 0.1));
                let free = ctx
                    .world()
                    .overlap_shape(&shape, Pose::from_translation(at))
                    .map(|hits| {
                        hits.iter()
                            .all(|&h| ctx.world().body(h).is_some_and(|b| b.is_sensor()))
                    })
                    .unwrap_or(false);
                if free {
                    place = Some(at);
                    break 'search;
                }
            }
        }
        let at = place.ok_or(JoinRefusal::NoRoom)?;
        let desc = self.avatar_desc(at)?;
        let palette = [
            [66, 133, 244, 255],
            [219, 68, 55, 255],
            [244, 180, 0, 255],
            [15, 157, 88, 255],
            [171, 71, 188, 255],
        ];
        ctx.spawn(
            &desc,
            EntityLook {
                kind: EntityKind::Avatar,
                color: palette[(client % palette.len() as u64) as usize],
                owner: Some(client),
                name: format!("avatar {client}"),
            },
        )
        .map_err(|e| JoinRefusal::Rules(e.to_string()))
    }

    /// Whether the avatar stands on something: rays from its centre down
    /// to a little below its feet hit a solid body (see
    /// [`WalkSettings::grounded`]).
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

    fn drive(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        let s = self.settings;
        let Some(p) = self.players.get_mut(&client) else {
            return;
        };
        let avatar = p.avatar;
        let (jump, push) = (
            std::mem::take(&mut p.jump_pressed),
            std::mem::take(&mut p.push_pressed),
        );
        let input = p.input;
        let Some(b) = ctx.body(avatar) else { return };
        let (v, com) = (b.linear_velocity(), b.center_of_mass());
        let grounded = self.grounded(avatar, ctx);
        let Some(p) = self.players.get_mut(&client) else {
            return;
        };

        // Walk: a force towards the desired horizontal velocity.
        let walk = s.walk;
        let _ = ctx.set_control_force(avatar, walk.walk_force(input.movement, v, grounded));

        let tick = ctx.tick();
        let dt = ctx.dt();
        if let Some(j) = walk.jump(jump, grounded, tick, p.jump_ready_at, v, dt) {
            if ctx.apply_impulse(avatar, j.impulse, com).is_ok() {
                p.jump_ready_at = j.ready_at;
                tell(ctx, SandboxEvent::Jumped { avatar });
                count_up(ctx, avatar, JUMPS);
            }
        }
        if push && tick >= p.push_ready_at {
            p.push_ready_at = tick + character::ticks(s.push_cooldown, dt);
            let yaw = f64::from(input.yaw);
            let facing = DVec3::new(yaw.sin(), 0.0, yaw.cos());
            let radius = s.push_reach * 0.5;
            let center = com + facing * (s.walk.radius + radius);
            for target in ctx.overlap_sphere(center, radius) {
                if target == avatar {
                    continue;
                }
                let Some(tb) = ctx.body(target) else { continue };
                if tb.kind() != BodyKind::Dynamic {
                    continue;
                }
                let at = tb.center_of_mass();
                let dir = (facing + DVec3::Y * 0.2).normalize();
                if let Ok(given) = ctx.apply_impulse(target, dir * s.push_impulse, at) {
                    count_up(ctx, avatar, PUSHES);
                    tell(
                        ctx,
                        SandboxEvent::Pushed {
                            avatar,
                            target,
                            impulse: given.as_vec3().to_array(),
                        },
                    );
                }
            }
        }
    }
}

impl GameRules for SandboxRules {
    fn name(&self) -> &str {
        "sandbox"
    }

    fn input_bytes(&self) -> usize {
        SANDBOX_INPUT_BYTES
    }

    /// Each avatar's jumps and pushes, and the players in the game.
    fn properties(&self) -> PropertySchema {
        PropertySchema {
            entity: vec![
                PropertyDecl::new("jumps", PropertyKind::UInt { bits: 16 }),
                PropertyDecl::new("pushes", PropertyKind::UInt { bits: 16 }),
            ],
            match_state: vec![PropertyDecl::new(
                "players",
                PropertyKind::UInt { bits: 10 },
            )],
        }
    }

    fn on_connect(
        &mut self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, JoinRefusal> {
        if self.players.contains_key(&client) {
            return Err(JoinRefusal::AlreadyJoined(client));
        }
        let avatar = self.spawn_avatar(client, ctx)?;
        self.players.insert(
            client,
            Player {
                avatar,
                input: HeldInput::default(),
                last_sequence: None,
                held: 0,
                jump_pressed: false,
                push_pressed: false,
                jump_ready_at: 0,
                push_ready_at: 0,
            },
        );
        tell(ctx, SandboxEvent::Joined { client, avatar });
        let _ = ctx.set_match_property(PLAYERS, self.players.len().min(1023) as u64);
        Ok(avatar)
    }

    fn on_disconnect(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        if let Some(p) = self.players.remove(&client) {
            ctx.despawn(p.avatar);
            tell(ctx, SandboxEvent::Left { client });
            let _ = ctx.set_match_property(PLAYERS, self.players.len().min(1023) as u64);
        }
    }

    fn on_input(
        &mut self,
        client: ClientId,
        input: &PlayerInput,
        _ctx: &mut SimContext<'_>,
    ) -> Result<(), InputRefusal> {
        let p = self
            .players
            .get_mut(&client)
            .ok_or(InputRefusal::NotJoined(client))?;
        let input = HeldInput::from_input(input)?;
        let pressed = input.buttons & !p.held;
        p.jump_pressed |= pressed & buttons::JUMP != 0;
        p.push_pressed |= pressed & buttons::PUSH != 0;
        p.held = input.buttons;
        p.last_sequence = Some(input.sequence);
        p.input = input;
        Ok(())
    }

    fn before_tick(&mut self, ctx: &mut SimContext<'_>) {
        let clients: Vec<ClientId> = self.players.keys().copied().collect();
        for client in clients {
            let lost = self
                .players
                .get(&client)
                .is_some_and(|p| ctx.entities().get(p.avatar).is_none());
            if lost {
                match self.spawn_avatar(client, ctx) {
                    Ok(avatar) => {
                        if let Some(p) = self.players.get_mut(&client) {
                            p.avatar = avatar;
                        }
                        tell(ctx, SandboxEvent::Respawned { client, avatar });
                    }
                    // No room this tick: try again next tick.
                    Err(_) => continue,
                }
            }
            self.drive(client, ctx);
        }
    }

    /// A player's [`SandboxRequest`]: a chat line goes to everyone; a
    /// respawn puts the player's avatar back at a free spawn point (as a
    /// new avatar, like one that fell off the world).
    fn on_message(
        &mut self,
        client: ClientId,
        _delivery: Delivery,
        bytes: &[u8],
        ctx: &mut SimContext<'_>,
    ) -> Result<(), MessageRefusal> {
        if !self.players.contains_key(&client) {
            return Err(MessageRefusal::NotConnected);
        }
        match SandboxRequest::decode(bytes)? {
            SandboxRequest::Chat { text } => tell(ctx, SandboxEvent::Chat { client, text }),
            SandboxRequest::Respawn => {
                let avatar = self
                    .spawn_avatar(client, ctx)
                    .map_err(|e| MessageRefusal::Rules(e.to_string()))?;
                if let Some(p) = self.players.get_mut(&client) {
                    ctx.despawn(std::mem::replace(&mut p.avatar, avatar));
                }
                tell(ctx, SandboxEvent::Respawned { client, avatar });
            }
        }
        Ok(())
    }

    fn on_removed(&mut self, entity: EntityId, reason: RemovalReason, ctx: &mut SimContext<'_>) {
        let reason = match reason {
            RemovalReason::OutOfBounds => Removal::OutOfBounds,
            RemovalReason::Quarantined => Removal::Quarantined,
            RemovalReason::Despawned => Removal::Despawned,
        };
        tell(ctx, SandboxEvent::Removed { entity, reason });
    }

    fn save_state(&self) -> Vec<u8> {
        postcard::to_allocvec(&self.players).unwrap_or_default()
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let players: BTreeMap<ClientId, Player> =
            postcard::from_bytes(bytes).map_err(|e| format!("sandbox players: {e}"))?;
        self.players = players;
        Ok(())
    }
}
