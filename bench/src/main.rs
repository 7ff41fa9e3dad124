//! `inertia-bench <suite> [--json] [--quick]`: runs one benchmark suite and
//! prints one record per measured case (JSON lines with `--json`).

use std::process::ExitCode;

/// Both engines allocate in their worker threads; glibc's allocator then
/// serialises the threads on its arena locks. mimalloc keeps per-thread
/// heaps, so neither engine's thread scaling measures the allocator.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use clap::{Parser, ValueEnum};
use inertia_bench::report::{Machine, Reporter};
use inertia_bench::suites::Suite;
use inertia_bench::Opts;
use inertia_server::config::PhysicsPinning;

#[derive(Debug, Clone, Copy, ValueEnum)]
enum SuiteArg {
    /// Order of convergence and energy drift of every integrator.
    Integrators,
    /// Particles 1e5/1e6, cloth 256x256 and n-body 1e4 against a memory copy, CPU and GPU.
    Particles,
    /// Exact vs Barnes–Hut mutual gravity at 1e4 bodies.
    Nbody,
    /// Our rigid-body engine against rapier3d: pyramids, balls, piles, joints, ragdolls.
    Physics,
    /// Snapshot bandwidth and error: Fiedler's 901 cubes at 60 Hz over a link with 5 % loss.
    Bandwidth,
    /// Clients one server serves at 60 Hz ticks and 30 Hz snapshots (1000 moving bodies, many bots to a process).
    Capacity,
    /// Recording bytes per hour, seek time and verify speed of a recorded game (1000 bodies, 8 bots).
    Replay,
    /// Players' kill-cams beside 200 live clients and 1000 moving bodies: time to the first replay snapshot, the live tick and snapshot rate without and with 10 replays, and that a replay shows what was live.
    Replays,
    /// An hour of simulated time at fast-forward with recording and client churn: memory and file handles bounded.
    Soak,
    /// Soft bodies and fluids on XPBD small steps: cloth 64², 128², 387², a jelly, fluid 10k and 100k; 1 and 2 threads.
    Soft,
}

impl From<SuiteArg> for Suite {
    fn from(s: SuiteArg) -> Self {
        match s {
            SuiteArg::Integrators => Suite::Integrators,
            SuiteArg::Particles => Suite::Particles,
            SuiteArg::Nbody => Suite::Nbody,
            SuiteArg::Physics => Suite::Physics,
            SuiteArg::Bandwidth => Suite::Bandwidth,
            SuiteArg::Capacity => Suite::Capacity,
            SuiteArg::Replay => Suite::Replay,
            SuiteArg::Replays => Suite::Replays,
            SuiteArg::Soak => Suite::Soak,
            SuiteArg::Soft => Suite::Soft,
        }
    }
}

/// Measures what Inertia claims. See bench/README.md for every field.
#[derive(Debug, Parser)]
#[command(name = "inertia-bench", version)]
struct Cli {
    /// The suite to run.
    suite: SuiteArg,
    /// One JSON object per line per measured case on stdout, nothing else.
    #[arg(long)]
    json: bool,
    /// Small sizes and few repetitions: a smoke test, not a measurement.
    #[arg(long)]
    quick: bool,
    /// Run only the cases whose name contains this (e.g. `particles_1e6`,
    /// `rk4`, `nbody`, `pyramid_20`).
    #[arg(long, value_name = "SUBSTRING")]
    only: Option<String>,
    /// Seconds to stream, for suites that run over time (`bandwidth`;
    /// `capacity`: seconds measured per client count).
    #[arg(long, value_name = "SECONDS")]
    seconds: Option<u32>,
    /// Client counts to step through (`capacity`), e.g. `1,2,4`.
    #[arg(long, value_name = "K,K,...", value_delimiter = ',')]
    clients: Option<Vec<u32>>,
    /// Minutes of play to record (`replay`; default 10), or of simulated
    /// time to soak (`soak`; default 60).
    #[arg(long, value_name = "M")]
    minutes: Option<f64>,
    /// Keyframe intervals, ticks, one recording each (`replay`; default
    /// 600), e.g. `60,120,300,600`.
    #[arg(long, value_name = "K,K,...", value_delimiter = ',')]
    keyframe_ticks: Option<Vec<u64>>,
    /// Seeks to time per recording (`replay`; default 100).
    #[arg(long, value_name = "N")]
    seeks: Option<u32>,
    /// Dynamic bodies in the scene (`replay`; default 1000).
    #[arg(long, value_name = "B")]
    bodies: Option<u32>,
    /// Clients playing (`replay`; default 8), or joining in each wave
    /// (`soak`; default 4).
    #[arg(long, value_name = "N")]
    bots: Option<u32>,
    /// Run the GPU cases sized for a real GPU (`soft`: `fluid_1m`) on a
    /// CPU adapter (Mesa lavapipe) too, where they take minutes.
    #[arg(long)]
    gpu_large: bool,
    /// Pin the workers of the two-thread worlds one to a core (`soft`):
    /// auto (where the process may run on no more cores than that), never
    /// or always (default auto).
    #[arg(long, value_enum, default_value_t = PhysicsPinning::Auto)]
    pin_threads: PhysicsPinning,
    /// Draw the suite's records as SVG into DIR (`physics.svg`,
    /// `capacity.svg`, `bandwidth.svg`, `replay.svg`, `soft.svg`; other
    /// suites have no picture yet).
    #[arg(long, value_name = "DIR")]
    plot: Option<std::path::PathBuf>,
    /// With `--plot`: draw the suite's records in this results file (JSON
    /// lines, as `--json` prints them) instead of running the suite.
    #[arg(long, value_name = "FILE", requires = "plot")]
    from: Option<std::path::PathBuf>,
}

/// Draws `records` of `suite` into `dir`, saying what it wrote.
fn draw(
    suite: &Suite,
    records: &[inertia_bench::plot::Printed],
    dir: &std::path::Path,
) -> ExitCode {
    match inertia_bench::plot::plot(suite.name(), records, dir) {
        Ok(written) if written.is_empty() => {
            eprintln!(
                "inertia-bench {}: no picture for this suite (or no records)",
                suite.name()
            );
            ExitCode::SUCCESS
        }
        Ok(written) => {
            for path in written {
                eprintln!("inertia-bench {}: wrote {}", suite.name(), path.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("inertia-bench {}: {e}", suite.name());
            ExitCode::FAILURE
        }
    }
}

fn main() -> ExitCode {
    // `inertia-bench bot …`: one bot process of the capacity and soak suites, started
    // by the suite itself (hidden from the help).
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("bot") {
        return match inertia_bench::suites::bots::bot_main(&args[1..]) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("inertia-bench bot: {e}");
                ExitCode::FAILURE
            }
        };
    }
    let cli = Cli::parse();
    let suite = Suite::from(cli.suite);
    if let (Some(dir), Some(from)) = (&cli.plot, &cli.from) {
        return match inertia_bench::plot::read_records(from, suite.name()) {
            Ok(records) => draw(&suite, &records, dir),
            Err(e) => {
                eprintln!("inertia-bench {}: {e}", suite.name());
                ExitCode::FAILURE
            }
        };
    }
    let mut reporter = Reporter::new(suite.name(), Machine::detect(), cli.json);
    match suite.run(
        &Opts {
            quick: cli.quick,
            only: cli.only,
            seconds: cli.seconds,
            clients: cli.clients,
            minutes: cli.minutes,
            keyframe_ticks: cli.keyframe_ticks,
            seeks: cli.seeks,
            bodies: cli.bodies,
            bots: cli.bots,
            gpu_large: cli.gpu_large,
            pin_threads: cli.pin_threads.into(),
        },
        &mut reporter,
    ) {
        Ok(()) => match &cli.plot {
            Some(dir) => draw(&suite, reporter.printed(), dir),
            None => ExitCode::SUCCESS,
        },
        Err(e) => {
            eprintln!("inertia-bench {}: {e}", suite.name());
            ExitCode::FAILURE
        }
    }
}
