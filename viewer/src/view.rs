//! One viewer's state, window or not: the SDK connection, the catalogue of
//! what was described, the camera, the HUD and the admin link. Each frame
//! [`Viewer::prepare`] turns the interpolated world and the HUD into what the
//! [`crate::render::Renderer`] draws.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Instant;

use inertia_client::interp::Sample;
use inertia_client::{dev, BlockingClient, ClientEvent, ReplayStatus};

use crate::admin::AdminLink;
use crate::camera::OrbitCamera;
use crate::controls::Controls;
use crate::hud::{self, HudAction, HudModel, HudState};
use crate::render::HudPaint;
use crate::scene::{position_in, Catalogue, DrawList};
use crate::ViewerError;

/// The kill-cam's length, s.
pub const KILL_CAM_S: f32 = 5.0;

/// How to reach the server.
#[derive(Debug, Clone)]
pub struct ConnectArgs {
    /// The server's game address (default: the credentials file's).
    pub server: Option<SocketAddr>,
    /// The dev credentials file (tokens, certificate fingerprint, admin
    /// token).
    pub credentials: PathBuf,
    /// Drive the clock with the admin credential of the same file.
    pub admin: bool,
}

/// What one frame draws.
pub struct Prepared {
    /// The world's instances.
    pub list: DrawList,
    /// The HUD, when it was asked for.
    pub hud: Option<HudPaint>,
    /// What egui wants of the window (cursor, clipboard).
    pub platform: egui::PlatformOutput,
    /// The interpolated world the list was made from.
    pub frame: Sample,
}

impl std::fmt::Debug for Prepared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Prepared")
            .field("list", &self.list.items.len())
            .field("hud", &self.hud.is_some())
            .field("render_tick", &self.frame.render_tick)
            .finish_non_exhaustive()
    }
}

/// A connected viewer.
pub struct Viewer {
    client: BlockingClient,
    server: SocketAddr,
    /// What was described so far.
    pub catalogue: Catalogue,
    /// The camera.
    pub camera: OrbitCamera,
    /// True while the camera follows our avatar.
    pub following: bool,
    hud: HudState,
    egui: egui::Context,
    admin: Option<AdminLink>,
    last_frame: Option<Instant>,
    fps: f64,
    last_census: Instant,
}

impl std::fmt::Debug for Viewer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewer")
            .field("server", &self.server)
            .field("entities", &self.catalogue.len())
            .field("camera", &self.camera)
            .finish_non_exhaustive()
    }
}

impl Viewer {
    /// Joins the server as a client (and as its operator with `admin`).
    pub fn connect(args: &ConnectArgs) -> Result<Self, ViewerError> {
        let (addr, token, _) = dev::dev_token(&args.credentials, None).map_err(|e| {
            ViewerError::Credentials(format!("{}: {e}", args.credentials.display()))
        })?;
        let addr = args.server.unwrap_or(addr);
        let client = BlockingClient::connect(addr, &token)
            .map_err(|e| ViewerError::Connect(format!("{addr}: {e}")))?;
        let admin = if args.admin {
            Some(
                AdminLink::start(args.credentials.clone(), args.server)
                    .map_err(|e| ViewerError::Connect(format!("admin link: {e}")))?,
            )
        } else {
            None
        };
        let mut view = Self {
            client,
            server: addr,
            catalogue: Catalogue::new(),
            camera: OrbitCamera::default(),
            following: false,
            hud: HudState::default(),
            egui: egui::Context::default(),
            admin,
            last_frame: None,
            fps: 0.0,
            last_census: Instant::now(),
        };
        view.relearn();
        Ok(view)
    }

    /// The connection.
    pub fn client(&self) -> &BlockingClient {
        &self.client
    }

    /// The egui context the HUD draws with.
    pub fn egui(&self) -> &egui::Context {
        &self.egui
    }

    fn relearn(&mut self) {
        let catalogue = &mut self.catalogue;
        *catalogue = Catalogue::new();
        self.client.with_entities(|table| {
            for (_, e) in table.iter() {
                catalogue.learn(&e.desc);
            }
        });
    }

    /// Takes in the connection's events: what was described and what left.
    fn absorb_events(&mut self) {
        let mut described = Vec::new();
        while let Some(event) = self.client.poll_event() {
            match event {
                ClientEvent::Spawned(id) => described.push(id),
                ClientEvent::Despawned(id) => self.catalogue.forget(id),
                _ => {}
            }
        }
        if !described.is_empty() {
            let catalogue = &mut self.catalogue;
            self.client.with_entities(|table| {
                for id in described {
                    if let Some(e) = table.get(id) {
                        catalogue.learn(&e.desc);
                    }
                }
            });
        }
        // Events can be dropped when the game does not read them for long;
        // once a second, the catalogue is checked against the SDK's table.
        if self.last_census.elapsed().as_secs_f64() >= 1.0 {
            self.last_census = Instant::now();
            if self.client.with_entities(|t| t.len()) != self.catalogue.len() {
                self.relearn();
            }
        }
    }

    /// Asks for the kill-cam: the last [`KILL_CAM_S`] s again at real
    /// time, centred on the own avatar, beside the live match (key R).
    pub fn kill_cam(&self) {
        if let Err(e) = self.client.kill_cam(KILL_CAM_S, 1.0, None) {
            tracing::warn!(error = %e, "no kill-cam");
        }
    }

    /// The HUD's headline: the game's, and the replay playing with the
    /// tick it shows (drawn at `render_tick`).
    fn headline(&self, render_tick: f64) -> Option<String> {
        let game = self.controls().headline(&self.client);
        let replay = match self.client.replay_status() {
            ReplayStatus::Playing { to_tick, .. } => Some(format!(
                "REPLAY  tick {} of {to_tick}",
                render_tick.max(0.0) as u64
            )),
            ReplayStatus::Refused(why) => Some(format!("no replay: {why}")),
            _ => None,
        };
        match (game, replay) {
            (Some(g), Some(r)) => Some(format!("{g}   {r}")),
            (g, r) => g.or(r),
        }
    }

    /// The controls and headline of the game the server runs.
    pub fn controls(&self) -> Controls {
        Controls::for_game(&self.client.server_info().game)
    }

    /// Our avatar, once described.
    pub fn avatar(&self) -> Option<inertia_protocol::EntityId> {
        self.catalogue
            .avatar_of(self.client.server_info().client_id)
    }

    /// The game's properties as HUD lines: each match property, then
    /// each of our avatar's (as `my <name>`), as of the tick drawn.
    pub fn property_lines(
        &self,
        avatar: Option<inertia_protocol::EntityId>,
    ) -> Vec<(String, String)> {
        let schema = self.client.property_schema();
        let mut lines: Vec<(String, String)> = schema
            .match_state
            .iter()
            .zip(self.client.match_state())
            .map(|(d, v)| (d.name.clone(), v.to_string()))
            .collect();
        if let Some(values) = avatar.and_then(|id| self.client.properties(id)) {
            lines.extend(
                schema
                    .entity
                    .iter()
                    .zip(values)
                    .map(|(d, v)| (format!("my {}", d.name), v.to_string())),
            );
        }
        lines
    }

    /// Carries out what the HUD asked for.
    fn act(&mut self, actions: Vec<HudAction>) {
        for a in actions {
            match a {
                HudAction::Admin(request) => {
                    if let Some(admin) = &self.admin {
                        admin.send(*request);
                    }
                }
                HudAction::Follow(on) => self.following = on,
            }
        }
    }

    /// Asks the server's clock for `request` (with the admin credential).
    pub fn admin_call(&self, request: inertia_protocol::admin::AdminRequest) -> bool {
        match &self.admin {
            Some(a) => {
                a.send(request);
                true
            }
            None => false,
        }
    }

    /// The newest admin status, when the viewer has the admin link.
    pub fn admin_status(&self) -> Option<inertia_protocol::admin::StatusReport> {
        self.admin.as_ref().and_then(|a| a.view().status)
    }

    /// Takes in what arrived (descriptions, departures) and returns the
    /// world interpolated to now, with the camera moved if it follows.
    pub fn update(&mut self) -> Sample {
        let now = Instant::now();
        let dt = self
            .last_frame
            .map_or(1.0 / 60.0, |t| (now - t).as_secs_f64());
        self.last_frame = Some(now);
        if dt > 0.0 {
            self.fps = if self.fps == 0.0 {
                1.0 / dt
            } else {
                0.9 * self.fps + 0.1 / dt
            };
        }
        self.absorb_events();
        let live = self.client.sample();
        // While a replay plays it is the picture; the live match goes on
        // beneath it and is back the frame the replay ends.
        let frame = match self.client.replay_status() {
            ReplayStatus::Playing { .. } => self.client.replay_sample().unwrap_or(live),
            _ => live,
        };
        if self.following {
            if let Some(p) = self.avatar().and_then(|id| position_in(&frame, id)) {
                self.camera.follow(p, dt as f32);
            }
        }
        frame
    }

    /// One frame: [`Viewer::update`], then, with `hud_input` (the screen's
    /// size and events), the HUD laid out. The HUD's textures must reach
    /// the renderer: a [`Prepared`] with a HUD is to be drawn.
    pub fn prepare(&mut self, hud_input: Option<egui::RawInput>) -> Prepared {
        let frame = self.update();
        let avatar = self.avatar();
        let list = self.catalogue.draw_list(&frame);
        let Some(input) = hud_input else {
            return Prepared {
                list,
                hud: None,
                platform: egui::PlatformOutput::default(),
                frame,
            };
        };
        let info = self.client.server_info();
        let model = HudModel {
            server: self.server.to_string(),
            client_id: info.client_id,
            tick_hz: info.tick_hz,
            render_tick: frame.render_tick,
            timeline: self.client.timeline(),
            stats: self.client.stats(),
            entities: list.items.len(),
            admin: self.admin.as_ref().map(|a| a.view()),
            fps: self.fps,
            following: self.following,
            has_avatar: avatar.is_some(),
            properties: self.property_lines(avatar),
            headline: self.headline(frame.render_tick),
        };
        let mut actions = Vec::new();
        let hud_state = &mut self.hud;
        let output = self
            .egui
            .run_ui(input, |ui| actions = hud::show(ui, &model, hud_state));
        self.act(actions);
        let pixels_per_point = output.pixels_per_point;
        let primitives = self.egui.tessellate(output.shapes, pixels_per_point);
        Prepared {
            list,
            hud: Some(HudPaint {
                primitives,
                textures: output.textures_delta,
                pixels_per_point,
            }),
            platform: output.platform_output,
            frame,
        }
    }

    /// Leaves the server.
    pub fn close(self) {
        self.client.close();
    }
}
