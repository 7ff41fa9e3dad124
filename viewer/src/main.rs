//! `inertia-viewer`: watch an Inertia server.
//!
//! ```text
//! inertia-viewer [--server ADDR] [--credentials FILE] [--no-admin]
//! inertia-viewer --headless --screenshot OUT.png [--at-tick N] [--size 1280x720]
//! inertia-viewer --headless --frames DIR --seconds S [--fps 30]
//! ```

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use inertia_client::dev;
use inertia_viewer::camera::OrbitCamera;
use inertia_viewer::headless::{self, OffScreen, When};
use inertia_viewer::view::{ConnectArgs, Viewer};
use inertia_viewer::{window, ViewerError};

#[derive(Debug, Parser)]
#[command(about = "Watch an Inertia server: the world drawn live, a HUD, and the clock's controls")]
struct Args {
    #[command(flatten)]
    dev: dev::DevArgs,
    /// Watch as a player only: no admin connection, no clock controls.
    #[arg(long)]
    no_admin: bool,
    /// Draw off-screen (no window): with --screenshot or --frames.
    #[arg(long)]
    headless: bool,
    /// Write one picture (PNG) and exit.
    #[arg(long, value_name = "OUT.png")]
    screenshot: Option<PathBuf>,
    /// Take the picture once this tick is drawn (default: once the world
    /// has arrived and a second of snapshots is buffered).
    #[arg(long, value_name = "N")]
    at_tick: Option<u64>,
    /// Write a PNG sequence (frame_00000.png, …) into this folder.
    #[arg(long, value_name = "DIR")]
    frames: Option<PathBuf>,
    /// How long the sequence lasts, s of wall time.
    #[arg(long, default_value_t = 5.0)]
    seconds: f64,
    /// Frames per second of the sequence.
    #[arg(long, default_value_t = 30.0)]
    fps: f64,
    /// Picture size off-screen, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Leave the HUD out of off-screen pictures.
    #[arg(long)]
    no_hud: bool,
    /// Camera as YAW,PITCH,DISTANCE (rad, rad, m) about the arena's middle,
    /// or YAW,PITCH,DISTANCE,X,Y,Z about the point X,Y,Z (m).
    #[arg(long, value_parser = parse_camera)]
    camera: Option<OrbitCamera>,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("{s}: expected WIDTHxHEIGHT, e.g. 1280x720"))?;
    let side = |v: &str| {
        v.parse::<u32>()
            .ok()
            .filter(|&n| (1..=8192).contains(&n))
            .ok_or_else(|| format!("{v}: a side is 1 to 8192 pixels"))
    };
    Ok((side(w)?, side(h)?))
}

fn parse_camera(s: &str) -> Result<OrbitCamera, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>().map_err(|e| format!("{x}: {e}")))
        .collect::<Result<_, _>>()?;
    let finite = v.iter().all(|x| x.is_finite());
    match v[..] {
        [yaw, pitch, distance] if finite && distance > 0.0 => {
            Ok(OrbitCamera::looking(yaw, pitch, distance))
        }
        [yaw, pitch, distance, x, y, z] if finite && distance > 0.0 => Ok(OrbitCamera {
            target: glam::Vec3::new(x, y, z),
            ..OrbitCamera::looking(yaw, pitch, distance)
        }),
        _ => Err(format!(
            "{s}: expected YAW,PITCH,DISTANCE or YAW,PITCH,DISTANCE,X,Y,Z (finite, distance > 0)"
        )),
    }
}

fn run(args: Args) -> Result<(), ViewerError> {
    let off_screen = args.headless || args.screenshot.is_some() || args.frames.is_some();
    if args.headless && args.screenshot.is_none() && args.frames.is_none() {
        return Err(ViewerError::Usage(
            "--headless needs --screenshot OUT.png or --frames DIR".into(),
        ));
    }
    let mut view = Viewer::connect(&ConnectArgs {
        server: args.dev.server,
        credentials: args.dev.credentials.clone(),
        admin: !args.no_admin,
    })?;
    if let Some(camera) = args.camera {
        view.camera = camera;
    }
    if !off_screen {
        return window::run(view);
    }
    let (width, height) = args.size;
    let mut screen = OffScreen::new(width, height)?;
    eprintln!(
        "inertia-viewer: drawing off-screen on {} ({} samples a pixel)",
        screen.adapter(),
        screen.samples()
    );
    let when = args.at_tick.map_or(When::Settled, When::AtTick);
    headless::wait_for(&mut view, when)?;
    let hud = !args.no_hud;
    if let Some(path) = &args.screenshot {
        let image = screen.capture(&mut view, hud)?;
        image.write_png(path)?;
        eprintln!(
            "inertia-viewer: wrote {} ({}×{})",
            path.display(),
            image.width,
            image.height
        );
    }
    if let Some(dir) = &args.frames {
        let written =
            headless::record_frames(&mut view, &mut screen, dir, args.seconds, args.fps, hud)?;
        eprintln!(
            "inertia-viewer: wrote {} frames into {}",
            written.len(),
            dir.display()
        );
    }
    view.close();
    Ok(())
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("inertia-viewer: {e}");
            ExitCode::FAILURE
        }
    }
}
