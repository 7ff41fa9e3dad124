//! The HUD (egui): what the connection and the server's clock are doing,
//! and, with the admin credential, the clock's controls and a timeline
//! scrubber. It draws from a [`HudModel`] and answers with [`HudAction`]s;
//! the caller carries them out.

use inertia_client::clock::SnapshotMeta;
use inertia_client::stats::ClientStats;
use inertia_protocol::admin::{AdminRequest, StatusReport, TimeMode};

use crate::admin::AdminView;

/// Everything the HUD shows.
#[derive(Debug, Clone, Default)]
pub struct HudModel {
    /// The server's address, as given.
    pub server: String,
    /// Our client id.
    pub client_id: u64,
    /// Server ticks per simulated second, Hz.
    pub tick_hz: u32,
    /// The tick drawn (fractional: interpolated).
    pub render_tick: f64,
    /// The newest snapshot's clock.
    pub timeline: Option<SnapshotMeta>,
    /// The connection's figures.
    pub stats: ClientStats,
    /// Entities drawn.
    pub entities: usize,
    /// The admin link, when the viewer has the admin credential.
    pub admin: Option<AdminView>,
    /// Frames drawn per second.
    pub fps: f64,
    /// True while the camera follows our avatar.
    pub following: bool,
    /// True once our avatar has been described.
    pub has_avatar: bool,
    /// The game's properties to show, a line each: the match's, then our
    /// avatar's (name, value as of the tick drawn).
    pub properties: Vec<(String, String)>,
    /// The game's headline (football's score and clock), at the top.
    pub headline: Option<String>,
}

/// What the operator asked for.
#[derive(Debug, Clone, PartialEq)]
pub enum HudAction {
    /// An admin call (only offered with the admin credential).
    Admin(Box<AdminRequest>),
    /// Follow our avatar with the camera, or stop.
    Follow(bool),
}

/// What the HUD remembers between frames.
#[derive(Debug, Clone)]
pub struct HudState {
    /// The scrubber's tick while it is dragged.
    scrub: Option<u64>,
    /// The speed chosen for play and reverse.
    speed: f64,
}

impl Default for HudState {
    fn default() -> Self {
        Self {
            scrub: None,
            speed: 1.0,
        }
    }
}

/// Speeds offered, simulated seconds per wall second.
const SPEEDS: [f64; 6] = [0.125, 0.25, 0.5, 1.0, 2.0, 4.0];

/// The clock in words: what is shown and how fast, e.g. `live ×1`,
/// `history, paused`, `reverse ×2`.
pub fn clock_line(timeline: Option<&SnapshotMeta>, status: Option<&StatusReport>) -> String {
    let scale = |s: f64| {
        let s = s.abs();
        if (s - s.round()).abs() < 1e-9 {
            format!("×{s:.0}")
        } else {
            format!("×{s}")
        }
    };
    if let Some(s) = status {
        let mode = s.mode.name();
        return if s.paused {
            format!("{mode}, paused")
        } else {
            format!("{mode} {}", scale(s.time_scale))
        };
    }
    match timeline {
        None => "waiting for the first snapshot".into(),
        Some(t) if t.paused => "paused".into(),
        Some(t) if t.time_scale < 0.0 => format!("reverse {}", scale(f64::from(t.time_scale))),
        Some(t) => format!("running {}", scale(f64::from(t.time_scale))),
    }
}

/// Draws the HUD on egui's root `ui` and returns what the operator asked
/// for.
pub fn show(ui: &mut egui::Ui, model: &HudModel, state: &mut HudState) -> Vec<HudAction> {
    let mut actions = Vec::new();
    let status = model.admin.as_ref().and_then(|a| a.status.as_ref());
    if let Some(admin) = &model.admin {
        egui::Panel::bottom("clock").show(ui, |ui| {
            clock_controls(ui, admin, state, &mut actions);
        });
    }
    if let Some(headline) = &model.headline {
        egui::Area::new(egui::Id::unique("headline"))
            .anchor(egui::Align2::CENTER_TOP, [0.0, 8.0])
            .show(ui.ctx(), |ui| {
                ui.label(egui::RichText::new(headline).size(22.0).strong());
            });
    }
    egui::Window::new("Inertia")
        .anchor(egui::Align2::RIGHT_TOP, [-8.0, 8.0])
        .resizable(false)
        .collapsible(true)
        .show(ui.ctx(), |ui| {
            egui::Grid::new("figures").num_columns(2).show(ui, |ui| {
                let mut row = |name: &str, value: String| {
                    ui.label(name);
                    ui.monospace(value);
                    ui.end_row();
                };
                row("server", model.server.clone());
                row("client", format!("{:016x}", model.client_id));
                row("tick", format!("{:.0}", model.render_tick.max(0.0)));
                let hz = f64::from(model.tick_hz.max(1));
                row(
                    "sim time",
                    format!("{:.2} s", model.render_tick.max(0.0) / hz),
                );
                row("clock", clock_line(model.timeline.as_ref(), status));
                row(
                    "clients",
                    status.map_or("—".into(), |s| s.clients.to_string()),
                );
                row("entities", model.entities.to_string());
                row("RTT", format!("{:.1} ms", model.stats.rtt_ms));
                row("received", format!("{:.0} kbit/s", model.stats.kbps));
                row("buffer", format!("{:.0} ms", model.stats.buffer_ms));
                row("loss", format!("{:.1} %", model.stats.loss * 100.0));
                row("frames", format!("{:.0} /s", model.fps));
                for (name, value) in &model.properties {
                    row(name, value.clone());
                }
            });
            if model.has_avatar {
                let mut follow = model.following;
                if ui.checkbox(&mut follow, "follow my avatar (F)").changed() {
                    actions.push(HudAction::Follow(follow));
                }
            }
        });
    actions
}

fn clock_controls(
    ui: &mut egui::Ui,
    admin: &AdminView,
    state: &mut HudState,
    actions: &mut Vec<HudAction>,
) {
    let Some(status) = &admin.status else {
        ui.label(if admin.connected {
            "admin: connected, waiting for the status".to_string()
        } else {
            admin
                .last_error
                .clone()
                .unwrap_or_else(|| "admin: connecting".into())
        });
        return;
    };
    let mut call = |r: AdminRequest| actions.push(HudAction::Admin(Box::new(r)));
    ui.horizontal(|ui| {
        if status.paused {
            if ui.button("Play").clicked() {
                call(AdminRequest::Resume);
            }
        } else if ui.button("Pause").clicked() {
            call(AdminRequest::Pause);
        }
        if ui.button("Step").clicked() {
            call(AdminRequest::Step { ticks: 1 });
        }
        if ui.button("Step 10").clicked() {
            call(AdminRequest::Step { ticks: 10 });
        }
        ui.separator();
        ui.label("speed");
        for s in SPEEDS {
            let label = if s < 1.0 {
                format!("1/{:.0}", 1.0 / s)
            } else {
                format!("{s:.0}")
            };
            if ui.selectable_label(state.speed == s, label).clicked() {
                state.speed = s;
                if status.mode == TimeMode::Reverse {
                    call(AdminRequest::Reverse { speed: s });
                } else {
                    call(AdminRequest::Speed { scale: s });
                }
            }
        }
        ui.separator();
        if ui.button("Reverse").clicked() {
            call(AdminRequest::Reverse { speed: state.speed });
        }
        if status.mode != TimeMode::Live && ui.button("Back to live").clicked() {
            call(AdminRequest::Seek {
                tick: status.live_tick,
            });
            call(AdminRequest::Resume);
        }
        ui.separator();
        ui.label(format!(
            "tick {} of {} · {}",
            status.tick,
            status.live_tick,
            if status.recording {
                "recording"
            } else {
                "not recording"
            }
        ));
    });
    // The scrubber: drag to choose a tick, let go to seek there.
    let mut tick = state.scrub.unwrap_or(status.tick);
    ui.spacing_mut().slider_width = (ui.available_width() - 140.0).max(100.0);
    let slider = egui::Slider::new(&mut tick, 0..=status.live_tick.max(1))
        .text("seek")
        .integer();
    let response = ui.add(slider);
    if response.dragged() || response.changed() {
        state.scrub = Some(tick);
    }
    if response.drag_stopped() || (response.changed() && !response.dragged()) {
        if let Some(tick) = state.scrub.take() {
            call(AdminRequest::Seek { tick });
        }
    }
    if let Some(e) = &admin.last_error {
        ui.colored_label(egui::Color32::from_rgb(220, 80, 60), e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(time_scale: f32, paused: bool) -> SnapshotMeta {
        SnapshotMeta {
            seq: None,
            tick: 5,
            time_scale,
            paused,
        }
    }

    #[test]
    fn the_clock_line_reads_the_snapshot_header_without_the_admin_credential() {
        assert_eq!(clock_line(None, None), "waiting for the first snapshot");
        assert_eq!(clock_line(Some(&meta(1.0, false)), None), "running ×1");
        assert_eq!(clock_line(Some(&meta(0.25, false)), None), "running ×0.25");
        assert_eq!(clock_line(Some(&meta(0.0, true)), None), "paused");
        assert_eq!(clock_line(Some(&meta(-2.0, false)), None), "reverse ×2");
    }

    #[test]
    fn the_clock_line_prefers_the_server_s_status() {
        let status = StatusReport {
            tick: 10,
            sim_time: 0.0,
            wall_time_unix: 0.0,
            time_scale: 0.0,
            achieved_rate: 0.0,
            paused: true,
            clients: 1,
            bodies: 1,
            tick_ms_p99: 0.0,
            state_hash: 0,
            recording: true,
            live_tick: 20,
            mode: TimeMode::History,
        };
        assert_eq!(
            clock_line(Some(&meta(1.0, false)), Some(&status)),
            "history, paused"
        );
    }

    /// The HUD lays out without a window: egui needs only a screen size.
    fn run_hud(model: &HudModel, state: &mut HudState) -> (Vec<HudAction>, usize) {
        let ctx = egui::Context::default();
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(1280.0, 720.0),
            )),
            ..Default::default()
        };
        let mut actions = Vec::new();
        let mut out = ctx.run_ui(input, |ui| actions = show(ui, model, state));
        out.textures_delta.clear();
        let shapes = out.shapes.len();
        (actions, shapes)
    }

    #[test]
    fn the_hud_draws_and_asks_for_nothing_by_itself() {
        let mut model = HudModel {
            server: "127.0.0.1:7777".into(),
            tick_hz: 60,
            render_tick: 120.0,
            ..Default::default()
        };
        let mut state = HudState::default();
        let (actions, shapes) = run_hud(&model, &mut state);
        assert!(actions.is_empty());
        assert!(shapes > 0);
        model.admin = Some(AdminView {
            connected: true,
            status: None,
            last_error: None,
        });
        let (actions, _) = run_hud(&model, &mut state);
        assert!(actions.is_empty());
    }
}
