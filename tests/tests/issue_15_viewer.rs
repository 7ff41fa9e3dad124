//! The viewer off-screen against a real demo server on loopback: its
//! pictures show the demo's objects, and its clock controls (the admin
//! link behind the HUD's buttons) pause and seek the world it draws.
//!
//! Drawing runs on Mesa's CPU drivers where there is no GPU; with no
//! adapter at all these fail unless `INERTIA_SKIP_GPU_TESTS=1`.

use std::time::{Duration, Instant};

use inertia_client::interp::Sample;
use inertia_protocol::admin::{AdminRequest, StatusReport, TimeMode};
use inertia_tests::server::{start_server, test_config};
use inertia_viewer::headless::{self, Image, OffScreen, When};
use inertia_viewer::view::{ConnectArgs, Viewer};

const SKIP_ENV: &str = "INERTIA_SKIP_GPU_TESTS";

fn off_screen(width: u32, height: u32) -> Option<OffScreen> {
    match OffScreen::new(width, height) {
        Ok(s) => {
            eprintln!("viewer tests draw on: {}", s.adapter());
            Some(s)
        }
        Err(e) if std::env::var(SKIP_ENV).as_deref() == Ok("1") => {
            eprintln!("SKIPPED (no graphics adapter, {SKIP_ENV}=1): {e}");
            None
        }
        Err(e) => panic!("{e}\n(set {SKIP_ENV}=1 to skip the GPU tests on this machine)"),
    }
}

/// The fraction of pixels that differ by more than 16 in a channel.
fn differing(a: &Image, b: &Image) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let n = (a.width * a.height) as usize;
    let differ = a
        .rgba
        .chunks(4)
        .zip(b.rgba.chunks(4))
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 16))
        .count();
    differ as f64 / n as f64
}

/// Keeps the viewer running (as a window would, 30 frames a second) until
/// `done` holds of the admin status, for at most 20 s.
fn until(view: &mut Viewer, what: &str, done: impl Fn(&StatusReport) -> bool) -> StatusReport {
    let start = Instant::now();
    loop {
        view.update();
        if let Some(s) = view.admin_status() {
            if done(&s) {
                return s;
            }
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "{what}: not within 20 s"
        );
        std::thread::sleep(Duration::from_millis(33));
    }
}

/// Runs the viewer for `seconds`, as a window would.
fn run_for(view: &mut Viewer, seconds: f64) -> Sample {
    let start = Instant::now();
    loop {
        let frame = view.update();
        if start.elapsed().as_secs_f64() >= seconds {
            return frame;
        }
        std::thread::sleep(Duration::from_millis(33));
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_15_the_viewer_draws_the_demo_and_its_clock_controls_pause_and_seek_it() {
    let server = start_server(test_config(None, "viewer")).await;
    let args = ConnectArgs {
        server: Some(server.addr()),
        credentials: server.credentials_path().expect("dev mode").clone(),
        admin: true,
    };
    tokio::task::spawn_blocking(move || {
        let Some(mut screen) = off_screen(480, 270) else {
            return;
        };
        let mut view = Viewer::connect(&args).expect("joins");
        headless::wait_for(&mut view, When::Settled).expect("the world arrives");

        // The demo's objects are drawn: against the same picture with
        // only the scenery (what snapshots never move), the bodies cover
        // a good part of it.
        let full = screen.capture(&mut view, false).expect("a picture");
        let scenery = view.catalogue.draw_list(&Sample::default());
        let moving = view.catalogue.draw_list(&view.client().sample());
        assert!(
            moving.items.len() > scenery.items.len() + 100,
            "{} drawn, {} of them scenery",
            moving.items.len(),
            scenery.items.len()
        );
        let background = screen
            .draw(&view.catalogue, &scenery, &view.camera, None)
            .expect("a picture");
        let covered = differing(&full, &background);
        assert!(
            covered > 0.02,
            "the bodies cover {:.2} % of the picture",
            covered * 100.0
        );
        // The sky is at the top, the ground below it.
        let sky = full.pixel(full.width / 2, 2);
        assert!(sky[2] > sky[0] && sky[2] > 150, "sky {sky:?}");

        // Pause (the HUD's Pause button): the picture freezes.
        assert!(view.admin_call(AdminRequest::Pause));
        let paused = until(&mut view, "pause", |s| s.paused);
        // Points the datagram budget deferred before the pause (the demo
        // streams about two thousand soft-body and fluid points) still
        // arrive for the paused tick: the picture comes to rest once they
        // have, and then stays.
        run_for(&mut view, 0.5);
        let mut a = screen.capture(&mut view, false).expect("a picture");
        for _ in 0..10 {
            run_for(&mut view, 0.3);
            let next = screen.capture(&mut view, false).expect("a picture");
            let still = differing(&a, &next) == 0.0;
            a = next;
            if still {
                break;
            }
        }
        let tick_a = view.client().sample().render_tick;
        run_for(&mut view, 0.7);
        let b = screen.capture(&mut view, false).expect("a picture");
        let tick_b = view.client().sample().render_tick;
        assert_eq!(tick_a, tick_b, "the picture's tick moved while paused");
        assert_eq!(differing(&a, &b), 0.0, "the picture changed while paused");

        // Seek 3 s back (the scrubber): the world drawn is the recorded one.
        let target = paused.tick.saturating_sub(180).max(1);
        assert!(view.admin_call(AdminRequest::Seek { tick: target }));
        let shown = until(&mut view, "seek", |s| s.tick == target);
        assert_eq!(shown.mode, TimeMode::History);
        let frame = run_for(&mut view, 1.0);
        assert!(
            (frame.render_tick - target as f64).abs() < 1.0,
            "drawing tick {} after a seek to {target}",
            frame.render_tick
        );
        let c = screen.capture(&mut view, false).expect("a picture");
        assert!(
            differing(&a, &c) > 0.0005,
            "the picture 3 s earlier is the same as the paused one"
        );

        // A frame sequence: the files are PNG pictures.
        let dir =
            std::env::temp_dir().join(format!("inertia-viewer-frames-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let written =
            headless::record_frames(&mut view, &mut screen, &dir, 0.5, 10.0, true).expect("frames");
        assert_eq!(written.len(), 5);
        for path in &written {
            let bytes = std::fs::read(path).expect("written");
            assert!(
                bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
                "{}",
                path.display()
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
        view.close();
    })
    .await
    .expect("the viewer thread");
    server.shutdown().await;
}
