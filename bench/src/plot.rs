//! Pictures of the bench records (SVG, with plotters):
//! `inertia-bench <suite> --plot DIR` draws the records the run made, and
//! `--from FILE` draws those of that suite in a committed results file
//! (`bench/results/<machine>.jsonl`) instead of running.
//!
//! - `physics.svg`: ours against rapier3d per scene, ms per step at 1 and 2
//!   threads (sleeping off), on a log scale, the newest record of each.
//! - `capacity.svg`: tick p99 and the server's CPU against clients, one
//!   line per run (the newest three), with the 60 Hz tick budget.
//! - `bandwidth.svg`: the snapshot stream's kbit/s second by second, with
//!   the budget, the mean and when the client's view first held every
//!   entity (the newest record that has the series).
//! - `replay.svg`: how long seeks took, a histogram per keyframe interval
//!   (the newest record of each that has the seek times).
//! - `soft.svg`: ms per step of each soft-body and fluid case, per backend
//!   and thread count, on a log scale, with the 8 ms target of the 128²
//!   cloth and the 10k fluid (the newest record of each).
//!
//! Other suites have no picture yet.

use std::path::{Path, PathBuf};

use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use serde_json::{Map, Value};

use crate::BenchError;

/// A record as printed: `suite`, `machine`, then the suite's fields.
pub type Printed = Map<String, Value>;

/// The records of `suite` in the JSON-lines file at `path`, in order.
pub fn read_records(path: &Path, suite: &str) -> Result<Vec<Printed>, BenchError> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let record: Printed =
            serde_json::from_str(line).map_err(|e| format!("{}:{}: {e}", path.display(), n + 1))?;
        if record.get("suite").and_then(Value::as_str) == Some(suite) {
            out.push(record);
        }
    }
    Ok(out)
}

/// Draws `suite`'s pictures of `records` into `dir`; the files written
/// (none for a suite without a picture).
pub fn plot(suite: &str, records: &[Printed], dir: &Path) -> Result<Vec<PathBuf>, BenchError> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let path = dir.join(format!("{suite}.svg"));
    let drawn = match suite {
        "physics" => physics(records, &path)?,
        "capacity" => capacity(records, &path)?,
        "bandwidth" => bandwidth(records, &path)?,
        "replay" => replay(records, &path)?,
        "soft" => soft(records, &path)?,
        _ => false,
    };
    Ok(if drawn { vec![path] } else { Vec::new() })
}

fn num(r: &Printed, key: &str) -> Option<f64> {
    r.get(key).and_then(Value::as_f64)
}

/// Ours and rapier's ms per step for one scene.
#[derive(Debug, Clone, Default)]
struct SceneTimes {
    scene: String,
    /// `[ours 1 t, rapier 1 t, ours 2 t, rapier 2 t]`, ms.
    ms: [Option<f64>; 4],
}

/// The newest awake record of each scene and thread count, in the order
/// scenes first appear.
fn scene_times(records: &[Printed]) -> Vec<SceneTimes> {
    let mut out: Vec<SceneTimes> = Vec::new();
    for r in records {
        let (Some(scene), Some(threads)) = (
            r.get("scene").and_then(Value::as_str),
            r.get("threads").and_then(Value::as_u64),
        ) else {
            continue;
        };
        if r.get("sleeping").and_then(Value::as_bool) != Some(false) || !(1..=2).contains(&threads)
        {
            continue;
        }
        let at = match out.iter().position(|s| s.scene == scene) {
            Some(i) => i,
            None => {
                out.push(SceneTimes {
                    scene: scene.to_string(),
                    ..SceneTimes::default()
                });
                out.len() - 1
            }
        };
        let base = 2 * (threads as usize - 1);
        out[at].ms[base] = num(r, "ours_ms_median");
        out[at].ms[base + 1] = num(r, "rapier_ms_median");
    }
    out
}

const BAR_COLOURS: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(114, 170, 214),
    RGBColor(255, 187, 120),
];
const BAR_NAMES: [&str; 4] = [
    "ours, 1 thread",
    "rapier3d, 1 thread",
    "ours, 2 threads",
    "rapier3d, 2 threads",
];

fn physics(records: &[Printed], path: &Path) -> Result<bool, BenchError> {
    let scenes = scene_times(records);
    let names: Vec<String> = scenes.iter().map(|s| s.scene.clone()).collect();
    let series: Vec<Bars> = (0..4)
        .map(|k| Bars {
            label: BAR_NAMES[k],
            colour: BAR_COLOURS[k],
            values: scenes.iter().map(|s| s.ms[k]).collect(),
        })
        .collect();
    let machine = machine_name(records);
    log_bars(
        path,
        &format!("inertia-bench physics: ms per step, ours and rapier3d ({machine})"),
        &names,
        &series,
        None,
    )
}

/// One series of a bar chart: a value (or none) per case.
struct Bars {
    label: &'static str,
    colour: RGBColor,
    values: Vec<Option<f64>>,
}

/// Bars of ms per step per case, a group per case and a bar per series,
/// on a log scale, with an optional horizontal target line `(ms, label)`.
/// Draws nothing (false) when there are no cases; series without a value
/// are left out of the legend.
fn log_bars(
    path: &Path,
    title: &str,
    names: &[String],
    series: &[Bars],
    target: Option<(f64, &str)>,
) -> Result<bool, BenchError> {
    if names.is_empty() {
        return Ok(false);
    }
    let values = series
        .iter()
        .flat_map(|s| s.values.iter().flatten().copied());
    let floor = target.map_or(0.0, |t| t.0);
    let (lo, hi) = values.fold((f64::MAX, floor), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let (lo, hi) = (lo.max(1e-3) / 2.0, hi * 2.0);
    let n = names.len();
    let root = canvas(path, (1100, 520))?;
    let mut chart = axes(&root)
        .caption(title, ("sans-serif", 20))
        .build_cartesian_2d(-0.5f64..n as f64 - 0.5, (lo..hi).log_scale())
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 {
                names.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc("ms per step (median, log scale)")
        .draw()
        .map_err(plot_error)?;
    let width = 0.8 / series.len().max(1) as f64;
    for (k, s) in series.iter().enumerate() {
        if s.values.iter().all(Option::is_none) {
            continue;
        }
        let colour = s.colour;
        let bars = s.values.iter().enumerate().filter_map(|(i, v)| {
            let left = i as f64 - 0.4 + width * k as f64;
            Some(Rectangle::new(
                [(left, lo), (left + 0.9 * width, (*v)?)],
                colour.filled(),
            ))
        });
        chart
            .draw_series(bars)
            .map_err(plot_error)?
            .label(s.label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour.filled()));
    }
    if let Some((ms, label)) = target {
        chart
            .draw_series(LineSeries::new(
                [(-0.5, ms), (n as f64 - 0.5, ms)],
                RED.stroke_width(2),
            ))
            .map_err(plot_error)?
            .label(label)
            .legend(|(x, y)| PathElement::new([(x, y), (x + 12, y)], RED.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
    root.present().map_err(plot_error)?;
    Ok(true)
}

/// One step of a capacity run: clients, tick p99 (ms), server CPU (%).
type Step = (f64, f64, f64);
/// One capacity run, its steps in order.
type Run = Vec<Step>;
/// Which value of a step a panel draws.
type Pick = fn(&Step) -> f64;

/// The runs in `records`: a step with no more clients than the one before
/// starts a new run.
fn capacity_runs(records: &[Printed]) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for r in records {
        let (Some(k), Some(p99), Some(cpu)) = (
            num(r, "clients"),
            num(r, "tick_ms_p99"),
            num(r, "server_cpu_percent"),
        ) else {
            continue;
        };
        match runs.last_mut() {
            Some(run) if run.last().is_some_and(|&(prev, _, _)| k > prev) => {
                run.push((k, p99, cpu))
            }
            _ => runs.push(vec![(k, p99, cpu)]),
        }
    }
    runs
}

fn capacity(records: &[Printed], path: &Path) -> Result<bool, BenchError> {
    let runs = capacity_runs(records);
    let runs = &runs[runs.len().saturating_sub(3)..];
    if runs.is_empty() {
        return Ok(false);
    }
    let steps = runs.iter().flatten();
    let k_max = steps.clone().map(|s| s.0).fold(1.0, f64::max) * 1.05;
    let p99_max = steps.clone().map(|s| s.1).fold(16.7, f64::max) * 1.15;
    let cpu_max = steps.map(|s| s.2).fold(100.0, f64::max) * 1.1;
    let root = canvas(path, (1000, 700))?;
    let machine = machine_name(records);
    let root = root
        .titled(
            &format!("inertia-bench capacity: 1000 moving bodies, 60 Hz ticks, 30 Hz snapshots ({machine})"),
            ("sans-serif", 20),
        )
        .map_err(plot_error)?;
    let (top, bottom) = root.split_vertically(340);
    let colours = [
        RGBColor(31, 119, 180),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
    ];
    // Tick p99 over its budget, with the legend; then the server's CPU.
    let panels: [(_, _, _, Pick, _); 2] = [
        (&top, "tick p99, ms", p99_max, |s| s.1, Some(16.7)),
        (&bottom, "server CPU, % of one core", cpu_max, |s| s.2, None),
    ];
    for (area, y_desc, y_max, pick, budget) in panels {
        let mut chart = axes(area)
            .build_cartesian_2d(0.0..k_max, 0.0..y_max)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("clients")
            .y_desc(y_desc)
            .draw()
            .map_err(plot_error)?;
        if let Some(budget) = budget {
            chart
                .draw_series(LineSeries::new(
                    [(0.0, budget), (k_max, budget)],
                    BLACK.mix(0.5),
                ))
                .map_err(plot_error)?
                .label(format!("tick budget ({budget} ms)"))
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.5)));
        }
        for (i, run) in runs.iter().enumerate() {
            let c = colours[i % colours.len()];
            chart
                .draw_series(LineSeries::new(
                    run.iter().map(|s| (s.0, pick(s))),
                    c.stroke_width(2),
                ))
                .map_err(plot_error)?
                .label(format!("run {}", i + 1))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
            chart
                .draw_series(
                    run.iter()
                        .map(|s| Circle::new((s.0, pick(s)), 3, c.filled())),
                )
                .map_err(plot_error)?;
        }
        if budget.is_some() {
            legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        }
    }
    root.present().map_err(plot_error)?;
    Ok(true)
}

fn bandwidth(records: &[Printed], path: &Path) -> Result<bool, BenchError> {
    let Some(r) = records.iter().rev().find(|r| r.contains_key("kbps_per_s")) else {
        return Ok(false);
    };
    let series: Vec<f64> = r["kbps_per_s"]
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default();
    if series.is_empty() {
        return Ok(false);
    }
    let budget = num(r, "budget_kbps").unwrap_or(0.0);
    let mean = num(r, "kbps_mean").unwrap_or(0.0);
    let joined = num(r, "full_view_after_s").filter(|s| s.is_finite());
    let seconds = series.len() as f64;
    let y_max = series.iter().copied().fold(budget, f64::max) * 1.15;
    let root = canvas(path, (1000, 450))?;
    let machine = machine_name(records);
    let mut chart = axes(&root)
        .caption(
            format!("inertia-bench bandwidth: Fiedler's 901 cubes, 60 Hz, 5 % loss ({machine})"),
            ("sans-serif", 20),
        )
        .build_cartesian_2d(0.0..seconds, 0.0..y_max)
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_desc("seconds")
        .y_desc("kbit/s (each second's snapshots)")
        .draw()
        .map_err(plot_error)?;
    let blue = RGBColor(31, 119, 180);
    chart
        .draw_series(LineSeries::new(
            series.iter().enumerate().map(|(i, &k)| (i as f64 + 0.5, k)),
            blue.stroke_width(2),
        ))
        .map_err(plot_error)?
        .label("sent")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], blue));
    for (value, label, colour) in [
        (budget, format!("budget ({budget:.0} kbit/s)"), RED),
        (mean, format!("mean ({mean:.1} kbit/s)"), GREEN),
    ] {
        chart
            .draw_series(LineSeries::new(
                [(0.0, value), (seconds, value)],
                colour.mix(0.7),
            ))
            .map_err(plot_error)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
    }
    if let Some(t) = joined {
        chart
            .draw_series(LineSeries::new([(t, 0.0), (t, y_max)], BLACK.mix(0.4)))
            .map_err(plot_error)?
            .label(format!("every entity in view ({t:.1} s)"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.4)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(plot_error)?;
    Ok(true)
}

/// Seek times, ms, by keyframe interval: the newest record of each.
fn seek_times(records: &[Printed]) -> Vec<(u64, Vec<f64>)> {
    let mut out: Vec<(u64, Vec<f64>)> = Vec::new();
    for r in records {
        let (Some(k), Some(seeks)) = (
            r.get("keyframe_ticks").and_then(Value::as_u64),
            r.get("seek_ms").and_then(Value::as_array),
        ) else {
            continue;
        };
        let seeks: Vec<f64> = seeks.iter().filter_map(Value::as_f64).collect();
        match out.iter_mut().find(|(kk, _)| *kk == k) {
            Some(slot) => slot.1 = seeks,
            None => out.push((k, seeks)),
        }
    }
    out.retain(|(_, s)| !s.is_empty());
    out.sort_by_key(|(k, _)| *k);
    out
}

/// Bins of seek times: `BINS` equal ones from 0 to the slowest.
const BINS: usize = 24;

fn replay(records: &[Printed], path: &Path) -> Result<bool, BenchError> {
    let runs = seek_times(records);
    if runs.is_empty() {
        return Ok(false);
    }
    let slowest = runs
        .iter()
        .flat_map(|(_, s)| s.iter().copied())
        .fold(1e-3, f64::max);
    let width = slowest / BINS as f64 * 1.0001;
    let counts: Vec<(u64, [u32; BINS])> = runs
        .iter()
        .map(|(k, seeks)| {
            let mut bins = [0u32; BINS];
            for &s in seeks {
                bins[((s / width) as usize).min(BINS - 1)] += 1;
            }
            (*k, bins)
        })
        .collect();
    let y_max = counts
        .iter()
        .flat_map(|(_, b)| b.iter().copied())
        .max()
        .unwrap_or(1) as f64
        * 1.15;
    let root = canvas(path, (1000, 450))?;
    let machine = machine_name(records);
    let mut chart = axes(&root)
        .caption(
            format!("inertia-bench replay: seek times into a recorded game ({machine})"),
            ("sans-serif", 20),
        )
        .build_cartesian_2d(0.0..slowest * 1.02, 0.0..y_max)
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_desc("seek time, ms")
        .y_desc("seeks")
        .draw()
        .map_err(plot_error)?;
    let n = counts.len() as f64;
    for (i, (k, bins)) in counts.iter().enumerate() {
        let c = BAR_COLOURS[i % BAR_COLOURS.len()];
        let bars = bins
            .iter()
            .enumerate()
            .filter(|(_, &n)| n > 0)
            .map(|(b, &count)| {
                let left = b as f64 * width + width * i as f64 / n;
                Rectangle::new(
                    [(left, 0.0), (left + width / n, f64::from(count))],
                    c.filled(),
                )
            });
        chart
            .draw_series(bars)
            .map_err(plot_error)?
            .label(format!("keyframe every {k} ticks"))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], c.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(plot_error)?;
    Ok(true)
}

/// The series of `soft.svg`: a backend, a thread count, whether the
/// binary was built for the machine's own CPU (`target_cpu_native`) and
/// whether the worker threads were pinned (`pinned`; rows from before the
/// field were not; `None`: either).
const SOFT_SERIES: [(&str, u64, bool, Option<bool>, &str); 5] = [
    ("cpu", 1, false, None, "CPU, 1 thread"),
    ("cpu", 2, false, Some(false), "CPU, 2 threads"),
    ("cpu", 2, false, Some(true), "CPU, 2 threads, pinned"),
    ("cpu", 2, true, None, "CPU, 2 threads, target-cpu=native"),
    ("gpu", 0, false, None, "GPU"),
];

/// The colours of [`SOFT_SERIES`].
const SOFT_COLOURS: [RGBColor; 5] = [
    BAR_COLOURS[0],
    BAR_COLOURS[1],
    RGBColor(44, 160, 44),
    BAR_COLOURS[2],
    BAR_COLOURS[3],
];

fn soft(records: &[Printed], path: &Path) -> Result<bool, BenchError> {
    // The newest ms per step of each case and series, cases in the order
    // they first appear.
    let mut cases: Vec<(String, [Option<f64>; 5])> = Vec::new();
    for r in records {
        let (Some(case), Some(backend), Some(ms)) = (
            r.get("case").and_then(Value::as_str),
            r.get("backend").and_then(Value::as_str),
            num(r, "ms_per_step"),
        ) else {
            continue;
        };
        let threads = r.get("threads").and_then(Value::as_u64).unwrap_or(0);
        let flag = |name: &str| r.get(name).and_then(Value::as_bool).unwrap_or(false);
        let (native, pinned) = (flag("target_cpu_native"), flag("pinned"));
        let Some(k) = SOFT_SERIES.iter().position(|(b, t, n, p, _)| {
            *b == backend
                && (*b == "gpu" || (*t == threads && *n == native && p.is_none_or(|p| p == pinned)))
        }) else {
            continue;
        };
        let at = match cases.iter().position(|c| c.0 == case) {
            Some(i) => i,
            None => {
                cases.push((case.to_string(), [None; 5]));
                cases.len() - 1
            }
        };
        cases[at].1[k] = Some(ms);
    }
    let names: Vec<String> = cases.iter().map(|c| c.0.clone()).collect();
    let series: Vec<Bars> = SOFT_SERIES
        .iter()
        .enumerate()
        .map(|(k, (_, _, _, _, label))| Bars {
            label,
            colour: SOFT_COLOURS[k],
            values: cases.iter().map(|c| c.1[k]).collect(),
        })
        .collect();
    let machine = machine_name(records);
    log_bars(
        path,
        &format!("inertia-bench soft: ms per step at 60 Hz ({machine})"),
        &names,
        &series,
        Some((8.0, "target: 8 ms (cloth 128², fluid 10k, 2 threads)")),
    )
}

/// The CPU the records were measured on (the newest record's).
fn machine_name(records: &[Printed]) -> String {
    records
        .iter()
        .rev()
        .find_map(|r| r.get("machine")?.get("cpu")?.as_str().map(str::to_string))
        .unwrap_or_else(|| "unknown machine".into())
}

/// A white canvas of `size` pixels, drawn to `path`.
fn canvas(path: &Path, size: (u32, u32)) -> Result<DrawingArea<SVGBackend<'_>, Shift>, BenchError> {
    let root = SVGBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    Ok(root)
}

/// A chart on `area` with the margin and the room for axis labels that
/// every picture has.
fn axes<'a, 'b, DB: DrawingBackend>(area: &'a DrawingArea<DB, Shift>) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60);
    builder
}

/// The series' legend, boxed, at `at`.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    at: SeriesLabelPosition,
) -> Result<(), BenchError> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(at)
        .draw()
        .map_err(plot_error)
}

fn plot_error<E: std::fmt::Display>(e: E) -> BenchError {
    format!("plot: {e}").into()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(text: &str) -> Printed {
        serde_json::from_str(text).unwrap()
    }

    #[test]
    fn the_newest_awake_record_of_each_scene_is_drawn() {
        let records = [
            record(
                r#"{"scene":"a","threads":1,"sleeping":false,"ours_ms_median":9.0,"rapier_ms_median":3.0}"#,
            ),
            record(
                r#"{"scene":"a","threads":1,"sleeping":false,"ours_ms_median":2.0,"rapier_ms_median":1.0}"#,
            ),
            record(
                r#"{"scene":"a","threads":1,"sleeping":true,"ours_ms_median":0.1,"rapier_ms_median":0.1}"#,
            ),
            record(
                r#"{"scene":"b","threads":2,"sleeping":false,"ours_ms_median":4.0,"rapier_ms_median":5.0}"#,
            ),
            record(r#"{"scene":"demo","threads":1,"ours_ms_median":0.3}"#),
        ];
        let times = scene_times(&records);
        assert_eq!(times.len(), 2);
        assert_eq!(times[0].ms, [Some(2.0), Some(1.0), None, None]);
        assert_eq!(times[1].ms, [None, None, Some(4.0), Some(5.0)]);
        let dir = std::env::temp_dir().join(format!("inertia-plot-{}", std::process::id()));
        let written = plot("physics", &records, &dir).unwrap();
        let svg = std::fs::read_to_string(&written[0]).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("rapier3d, 2 threads"));
        assert!(plot("nbody", &records, &dir).unwrap().is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn seek_histograms_keep_the_newest_record_of_each_interval() {
        let records = [
            record(r#"{"keyframe_ticks":600,"seek_ms":[90.0]}"#),
            record(r#"{"keyframe_ticks":60,"seek_ms":[1.0,2.0,30.0]}"#),
            record(r#"{"keyframe_ticks":600,"seek_ms":[10.0,20.0]}"#),
            record(r#"{"keyframe_ticks":300,"seek_ms_median":5.0}"#),
        ];
        let runs = seek_times(&records);
        assert_eq!(runs, [(60, vec![1.0, 2.0, 30.0]), (600, vec![10.0, 20.0])]);
        let dir = std::env::temp_dir().join(format!("inertia-plot-replay-{}", std::process::id()));
        let written = plot("replay", &records, &dir).unwrap();
        assert!(std::fs::read_to_string(&written[0])
            .unwrap()
            .contains("keyframe every 600 ticks"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn capacity_runs_start_where_the_clients_go_down() {
        let step = |k: u32| {
            record(&format!(
                r#"{{"clients":{k},"tick_ms_p99":4.0,"server_cpu_percent":30.0}}"#
            ))
        };
        let records = [
            step(50),
            step(100),
            step(50),
            step(100),
            step(300),
            record(r#"{"max_clients_at_60hz":300}"#),
        ];
        let runs = capacity_runs(&records);
        assert_eq!(runs.iter().map(Vec::len).collect::<Vec<_>>(), [2, 3]);
    }
}
