//! `soak`: an hour of simulated time at fast-forward, recording on and
//! clients coming and going, with the server's memory and file handles
//! sampled throughout.
//!
//! A whole dev-mode server runs in this process on the demo scene (126
//! bodies, a cloth, ropes, ragdolls), recording to a temporary data
//! directory with a retention limit of [`RECORD_MAX_MB`] MiB (so old
//! segments are deleted as it goes) and a seek budget of
//! [`SEEK_MEMORY_MB`] MiB. It runs at time scale [`TIME_SCALE`]: as fast as
//! the machine steps, up to 64 simulated seconds per wall second. Bots
//! (this executable's hidden `bot` subcommand, separate processes so that
//! their memory is not the server's) join in waves: every
//! [`CHURN_WALL_S`] s of wall time a new wave of `--bots` (default 4)
//! joins, each bot living two waves, and the oldest wave is killed without
//! a goodbye, so clients both leave and time out.
//!
//! Sampled once a wall second: the process's resident set (`VmRSS`), its
//! open file descriptors (`/proc/self/fd`), the memory held for seeking by
//! part (`inertia_seek_memory_bytes`), the recording's bytes on disk, the
//! ticks run and the clients connected.
//!
//! The bounds it checks, stated against the resident set after a warm-up
//! of [`WARMUP_SIM_S`] simulated seconds (allocator pools, the first
//! keyframes, the bots' first joins):
//!
//! * memory: RSS ≤ warm RSS + the seek budget + what is held outside it
//!   (the per-tick hashes and the journal, which grow with the recording:
//!   8 bytes a tick and the inputs) + [`RSS_SLACK_MB`] MiB;
//! * file handles: open descriptors ≤ warm count + [`FD_SLACK`].
//!
//! Every sample goes to `target/soak/samples.jsonl` and the curve to
//! `target/soak/rss.svg` (RSS and seek memory against simulated minutes);
//! the record reports the bounds, the peaks, and the RSS slope over the
//! second half of the run (MiB per simulated hour).

use std::collections::VecDeque;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use inertia_server::config::ServerConfig;
use inertia_server::server::start;
use plotters::prelude::*;

use super::bots::Bots;
use super::capacity::exposed;
use crate::report::{note, progress, Measurement, Sink};
use crate::usage::{fds, rss_mb};
use crate::{BenchError, Opts};

/// Simulated minutes by default (`--minutes`).
pub const DEFAULT_MINUTES: f64 = 60.0;
/// Bots per wave by default (`--bots`).
pub const DEFAULT_BOTS: u32 = 4;
/// Ticks per simulated second.
pub const TICK_HZ: u32 = 60;
/// Time scale asked for: simulated seconds per wall second.
pub const TIME_SCALE: f64 = 64.0;
/// Retention limit of the recording, MiB.
pub const RECORD_MAX_MB: u64 = 8;
/// Memory for seeking, MiB.
pub const SEEK_MEMORY_MB: u64 = 64;
/// Wall seconds between waves of bots.
pub const CHURN_WALL_S: f64 = 10.0;
/// Simulated seconds run before the baseline is taken.
pub const WARMUP_SIM_S: f64 = 60.0;
/// Memory allowed above the stated parts, MiB.
pub const RSS_SLACK_MB: f64 = 64.0;
/// File descriptors allowed above the warm count.
pub const FD_SLACK: u64 = 32;

/// One sample.
#[derive(Debug, Clone, Copy, serde::Serialize)]
struct SoakSample {
    wall_s: f64,
    sim_minutes: f64,
    ticks: u64,
    rss_mb: f64,
    fds: u64,
    seek_budgeted_mb: f64,
    seek_unbudgeted_mb: f64,
    recording_mb: f64,
    clients: u64,
}

/// Bytes of every file under `dir`, MiB.
fn dir_mb(dir: &Path) -> f64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0.0;
    };
    entries
        .filter_map(|e| e.ok()?.metadata().ok())
        .filter(|m| m.is_file())
        .map(|m| m.len() as f64)
        .sum::<f64>()
        / (1024.0 * 1024.0)
}

/// The seek memory gauge's parts, MiB: (keyframes + checkpoints, hashes +
/// journal).
fn seek_mb(text: &str) -> (f64, f64) {
    let part = |p: &str| {
        exposed(text, &format!("inertia_seek_memory_bytes{{part=\"{p}\"}}")).unwrap_or(0.0)
    };
    let mb = 1024.0 * 1024.0;
    (
        (part("keyframes") + part("checkpoints")) / mb,
        (part("hashes") + part("journal")) / mb,
    )
}

/// Runs the soak and reports one record.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    if !opts.wants("soak") {
        return Ok(());
    }
    let minutes = opts
        .minutes
        .unwrap_or(if opts.quick { 2.0 } else { DEFAULT_MINUTES });
    let bots_per_wave = opts
        .bots
        .unwrap_or(if opts.quick { 1 } else { DEFAULT_BOTS });
    if !minutes.is_finite() || minutes <= 0.0 || bots_per_wave == 0 {
        return Err("soak needs --minutes above 0 and --bots of at least 1".into());
    }
    let warmup_sim_s = if opts.quick { 10.0 } else { WARMUP_SIM_S };
    let target_ticks = (minutes * 60.0 * f64::from(TICK_HZ)) as u64;

    let data_dir = std::env::temp_dir().join(format!("inertia-bench-soak-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&data_dir);
    let out_dir = PathBuf::from("target/soak");
    std::fs::create_dir_all(&out_dir)?;
    let config = ServerConfig {
        listen: Some("127.0.0.1:0".parse()?),
        metrics: "127.0.0.1:0".parse()?,
        data_dir: data_dir.clone(),
        tick_hz: TICK_HZ,
        record: true,
        record_max_bytes: RECORD_MAX_MB * 1024 * 1024,
        seek_memory_mb: SEEK_MEMORY_MB,
        ..ServerConfig::default()
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .thread_name("inertia-bench-server")
        .enable_all()
        .build()?;
    let server = runtime.block_on(start(config))?;
    let credentials = server
        .credentials_path()
        .ok_or("the soak server runs in dev mode")?
        .clone();
    server
        .sim()
        .set_time_scale(TIME_SCALE)
        .map_err(|e| format!("setting the time scale: {e}"))?;

    let pb = progress(target_ticks, "soak (ticks)");
    let stats = server.sim().stats();
    let began = Instant::now();
    let mut samples: Vec<SoakSample> = Vec::new();
    let mut waves: VecDeque<Bots> = VecDeque::new();
    let mut next_wave = Instant::now();
    let mut next_id = 1u64;
    let mut joined = 0u64;
    let mut samples_file = std::fs::File::create(out_dir.join("samples.jsonl"))?;
    let result: Result<(), BenchError> = loop {
        if Instant::now() >= next_wave {
            if waves.len() >= 2 {
                // Killed without a goodbye: the server times it out.
                drop(waves.pop_front());
            }
            let ids: Vec<u64> = (next_id..next_id + u64::from(bots_per_wave)).collect();
            next_id += u64::from(bots_per_wave);
            joined += ids.len() as u64;
            match Bots::spawn(&credentials, &ids, 2.0 * CHURN_WALL_S + 5.0) {
                Ok(b) => waves.push_back(b),
                Err(e) => break Err(e),
            }
            next_wave += Duration::from_secs_f64(CHURN_WALL_S);
        }
        std::thread::sleep(Duration::from_secs(1));
        let ticks = stats.ticks.load(Ordering::Relaxed);
        let text = server.metrics().encode();
        let (seek_budgeted_mb, seek_unbudgeted_mb) = seek_mb(&text);
        let sample = SoakSample {
            wall_s: began.elapsed().as_secs_f64(),
            sim_minutes: ticks as f64 / f64::from(TICK_HZ) / 60.0,
            ticks,
            rss_mb: rss_mb(),
            fds: fds(),
            seek_budgeted_mb,
            seek_unbudgeted_mb,
            recording_mb: dir_mb(&data_dir.join("recording")),
            clients: server.clients() as u64,
        };
        writeln!(samples_file, "{}", serde_json::to_string(&sample)?)?;
        samples.push(sample);
        pb.set_position(ticks.min(target_ticks));
        if let Some(why) = server.failure() {
            break Err(format!("the simulation stopped: {why}").into());
        }
        if ticks >= target_ticks {
            break Ok(());
        }
    };
    pb.finish_and_clear();
    drop(waves);
    runtime.block_on(server.shutdown());
    drop(runtime);
    let _ = std::fs::remove_dir_all(&data_dir);
    result?;

    let warm = samples
        .iter()
        .find(|s| s.sim_minutes * 60.0 >= warmup_sim_s)
        .copied()
        .ok_or("the soak ended before its warm-up")?;
    let last = *samples.last().ok_or("no samples")?;
    let peak_rss = samples.iter().map(|s| s.rss_mb).fold(f64::MIN, f64::max);
    let peak_fds = samples.iter().map(|s| s.fds).max().unwrap_or(0);
    let rss_bound = warm.rss_mb + SEEK_MEMORY_MB as f64 + last.seek_unbudgeted_mb + RSS_SLACK_MB;
    let fd_bound = warm.fds + FD_SLACK;
    let second_half: Vec<&SoakSample> = samples
        .iter()
        .filter(|s| s.sim_minutes >= last.sim_minutes / 2.0)
        .collect();
    let slope = slope_mb_per_hour(&second_half);
    let bounded = peak_rss <= rss_bound && peak_fds <= fd_bound;
    let plot = out_dir.join("rss.svg");
    if let Err(e) = draw(&plot, &samples, rss_bound) {
        note(&pb, &format!("soak: no plot ({e})"));
    }
    sink.record(
        Measurement::new()
            .field("case", "soak_demo")
            .num("sim_minutes", last.sim_minutes)
            .num("wall_s", last.wall_s)
            .num("sim_speed", last.sim_minutes * 60.0 / last.wall_s)
            .field("ticks", last.ticks)
            .field("clients_joined", joined)
            .num("rss_warm_mb", warm.rss_mb)
            .num("rss_peak_mb", peak_rss)
            .num("rss_last_mb", last.rss_mb)
            .num("rss_bound_mb", rss_bound)
            .num("rss_slope_mb_per_sim_hour", slope)
            .num(
                "seek_budgeted_peak_mb",
                samples
                    .iter()
                    .map(|s| s.seek_budgeted_mb)
                    .fold(0.0, f64::max),
            )
            .num("seek_unbudgeted_last_mb", last.seek_unbudgeted_mb)
            .num(
                "recording_peak_mb",
                samples.iter().map(|s| s.recording_mb).fold(0.0, f64::max),
            )
            .field("fds_warm", warm.fds)
            .field("fds_peak", peak_fds)
            .field("fds_bound", fd_bound)
            .field("bounded", bounded)
            .field(
                "samples",
                out_dir.join("samples.jsonl").display().to_string(),
            )
            .field("plot", plot.display().to_string()),
    );
    if bounded {
        Ok(())
    } else {
        Err(format!(
            "out of bounds: RSS peak {peak_rss:.0} MiB (bound {rss_bound:.0}), \
             {peak_fds} file descriptors (bound {fd_bound})"
        )
        .into())
    }
}

/// Least-squares slope of RSS against simulated time, MiB per hour.
fn slope_mb_per_hour(samples: &[&SoakSample]) -> f64 {
    let n = samples.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let hours = |s: &SoakSample| s.sim_minutes / 60.0;
    let mx = samples.iter().map(|s| hours(s)).sum::<f64>() / n;
    let my = samples.iter().map(|s| s.rss_mb).sum::<f64>() / n;
    let sxy: f64 = samples
        .iter()
        .map(|s| (hours(s) - mx) * (s.rss_mb - my))
        .sum();
    let sxx: f64 = samples.iter().map(|s| (hours(s) - mx).powi(2)).sum();
    if sxx == 0.0 {
        f64::NAN
    } else {
        sxy / sxx
    }
}

/// Draws RSS, its bound and the seek memory against simulated minutes.
fn draw(
    path: &Path,
    samples: &[SoakSample],
    rss_bound: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (900, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let x_max = samples.last().map_or(1.0, |s| s.sim_minutes).max(1.0);
    let y_max = samples.iter().map(|s| s.rss_mb).fold(rss_bound, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "inertia-bench soak: server memory over an hour of simulated time",
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x_max, 0.0..y_max)?;
    chart
        .configure_mesh()
        .x_desc("simulated minutes")
        .y_desc("MiB")
        .draw()?;
    let series = |f: fn(&SoakSample) -> f64| samples.iter().map(move |s| (s.sim_minutes, f(s)));
    chart
        .draw_series(LineSeries::new(series(|s| s.rss_mb), &BLUE))?
        .label("resident set")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    chart
        .draw_series(LineSeries::new(
            series(|s| s.seek_budgeted_mb + s.seek_unbudgeted_mb),
            &GREEN,
        ))?
        .label("held for seeking")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREEN));
    chart
        .draw_series(LineSeries::new(
            [(0.0, rss_bound), (x_max, rss_bound)],
            &RED,
        ))?
        .label("stated bound")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(sim_minutes: f64, rss_mb: f64) -> SoakSample {
        SoakSample {
            wall_s: 0.0,
            sim_minutes,
            ticks: 0,
            rss_mb,
            fds: 0,
            seek_budgeted_mb: 0.0,
            seek_unbudgeted_mb: 0.0,
            recording_mb: 0.0,
            clients: 0,
        }
    }

    #[test]
    fn slope_is_mib_per_simulated_hour() {
        let samples: Vec<SoakSample> = (0..=60)
            .map(|m| at(f64::from(m), 100.0 + 0.5 * f64::from(m)))
            .collect();
        let refs: Vec<&SoakSample> = samples.iter().collect();
        assert!((slope_mb_per_hour(&refs) - 30.0).abs() < 1e-9);
        assert!(slope_mb_per_hour(&refs[..1]).is_nan());
    }

    #[test]
    fn seek_memory_is_read_by_part() {
        let text = "inertia_seek_memory_bytes{part=\"keyframes\"} 1048576\n\
                    inertia_seek_memory_bytes{part=\"checkpoints\"} 1048576\n\
                    inertia_seek_memory_bytes{part=\"hashes\"} 524288\n\
                    inertia_seek_memory_bytes{part=\"journal\"} 524288\n";
        assert_eq!(seek_mb(text), (2.0, 1.0));
    }

    #[test]
    fn this_process_is_measured() {
        assert!(rss_mb() > 1.0);
        assert!(fds() >= 3);
    }
}
