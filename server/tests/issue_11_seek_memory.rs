//! Issue 11: the memory held for seeking is bounded by the budget.
//!
//! An idle recording server grew without bound: every checkpoint of a world
//! at rest packs to almost nothing against its keyframe, but the packed
//! buffer was held at the size zstd reserves for the whole state, and only
//! its length was counted against the budget. This binary counts every
//! byte the Rust heap holds (its own global allocator) while a recording
//! simulation with a small budget runs for many checkpoints, and checks the
//! growth stays within the budget plus the stated baseline.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use inertia_server::record::RecorderConfig;
use inertia_server::replay::history::PACK_QUEUE;
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{SimConfig, Simulation};

/// The system allocator, counting the bytes it has live.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is passed straight to `System`; the counter only
// adds what was handed out and subtracts what was given back.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's layout, passed on as it is.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's layout, passed on as it is.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` with this layout (every
        // allocation here is made by `System`).
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as for `dealloc`; `new_size` is the caller's.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            LIVE.fetch_add(new_size, Ordering::Relaxed);
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

fn live() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// The resident set of this process, bytes (0 where /proc is not there):
/// shown, not checked (zstd's own heap and the allocator's arenas are in
/// it, and so is whatever other tests in this binary hold).
fn rss() -> usize {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("VmRSS:"))?;
            line.split_whitespace().nth(1)?.parse::<usize>().ok()
        })
        .map_or(0, |kb| kb * 1024)
}

/// An idle world: 400 balls resting on the ground, soon asleep, so that
/// every checkpoint is nearly the keyframe before it.
const RESTING: &str = r#"(
    name: "resting",
    world: (gravity: (0.0, -9.81, 0.0), sleep: true),
    spawn_points: [(0.0, 1.0, -15.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (30.0, 0.5, 30.0)), position: (0.0, -0.5, 0.0)),
    ],
    generators: [
        Grid(name: "ball", counts: (20, 1, 20), spacing: (1.0, 0.0, 1.0), origin: (-10.0, 0.25, -10.0),
             body: (shape: Sphere(radius: 0.25), density: 300.0), ),
    ],
)"#;

/// Memory for seeking, bytes.
const BUDGET: usize = 2 << 20;
/// A keyframe every this many ticks.
const KEYFRAME_TICKS: u64 = 300;
/// A checkpoint every this many ticks.
const CHECKPOINT_TICKS: u64 = 2;
/// Ticks recorded: 1500 checkpoints, each of them about one whole state
/// (200 kB) while the packed buffers kept their worst-case capacity.
const TICKS: u64 = 3000;
/// The stated baseline beyond the budget: every tick's hash, at most 16
/// bytes a tick (8, and runs of 4096 made whole) ...
const BASELINE_PER_TICK: usize = 16;
/// ... whole states in flight: the packer's queue, the one it packs and
/// its scratch buffer (`PACK_QUEUE + 2`), and a keyframe or two waiting
/// in the recorder's queue ...
const BASELINE_STATES: usize = PACK_QUEUE + 4;
/// ... and the recorder's buffers.
const BASELINE_FIXED: usize = 1 << 20;

fn temp_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("inertia-issue-11-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    dir
}

#[test]
fn issue_11_seek_memory_bounded() {
    let dir = temp_dir();
    let built = Scene::parse(RESTING, SceneFormat::Ron)
        .expect("the scene parses")
        .build()
        .expect("the scene builds");
    let config = SimConfig {
        recording: Some(RecorderConfig {
            keyframe_ticks: KEYFRAME_TICKS,
            ..RecorderConfig::new(dir.join("recording"))
        }),
        record_at_start: false,
        history_budget: BUDGET,
        checkpoint_ticks: CHECKPOINT_TICKS,
        ..SimConfig::default()
    };
    let mut sim = Simulation::new(built, Box::new(SandboxRules::default()), config);

    // Let the balls fall asleep and the simulation make its working
    // buffers, then take the heap as it is and start recording.
    sim.run_ticks(120);
    let state = sim.capture(0).encode().len();
    let before = live();
    let rss_before = rss();
    sim.start_recording().expect("recording starts");

    let mut peak = 0;
    for t in 0..TICKS {
        sim.run_ticks(1);
        if t % 100 == 0 {
            // Give the packer time to keep up (it drops what it cannot).
            std::thread::sleep(Duration::from_millis(5));
        }
        peak = peak.max(live().saturating_sub(before));
    }
    std::thread::sleep(Duration::from_millis(200));
    sim.run_ticks(1);
    let grown = live().saturating_sub(before);
    let rss_grown = rss().saturating_sub(rss_before);
    peak = peak.max(grown);

    let history = sim.history().expect("a history");
    let (keyframes, keyframe_bytes) = history.keyframe_stats();
    let (checkpoints, checkpoint_bytes) = history.checkpoint_stats();
    let held = history.held();
    let allowed =
        BUDGET + BASELINE_PER_TICK * TICKS as usize + BASELINE_STATES * state + BASELINE_FIXED;
    eprintln!(
        "budget {BUDGET} B, state {state} B; the heap grew {grown} B over {TICKS} ticks \
         (peak {peak} B, allowed {allowed} B); held: {keyframes} keyframes {keyframe_bytes} B, \
         {checkpoints} checkpoints {checkpoint_bytes} B, {held:?}; \
         the resident set grew {rss_grown} B"
    );
    assert!(
        held.budgeted() <= BUDGET,
        "{} B of keyframes and checkpoints held, over the budget of {BUDGET} B",
        held.budgeted()
    );
    assert_eq!(
        (held.keyframes, held.checkpoints),
        (keyframe_bytes, checkpoint_bytes)
    );
    assert!(
        checkpoints > 20,
        "checkpoints are made and held ({checkpoints})"
    );
    assert!(
        peak <= allowed,
        "the heap grew by {peak} B, more than the budget {BUDGET} B plus the baseline"
    );
    drop(sim);
    let _ = std::fs::remove_dir_all(&dir);
}
