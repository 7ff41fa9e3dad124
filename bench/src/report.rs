//! What every measured case prints: the machine that produced it and one
//! record per case, either as a JSON object on its own line (`--json`, the
//! contract in DESIGN.md) or as a human-readable line.
//!
//! Progress and side remarks (wall times, warnings) go to stderr, so that
//! `--json` output on stdout is nothing but records.

use std::io::Write;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use serde_json::{Map, Value};

/// The machine a run measured: CPU model and logical core count.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Machine {
    /// CPU model name from `/proc/cpuinfo` ("unknown" where there is none).
    pub cpu: String,
    /// Logical cores the process may use.
    pub logical_cores: usize,
}

impl Machine {
    /// Reads the machine description once.
    pub fn detect() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".to_string());
        Self {
            cpu,
            logical_cores: logical_cores(),
        }
    }
}

/// Logical cores available to this process (at least 1).
pub fn logical_cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// CPU thread counts measured: 1 and 2, and every core if there are more.
pub fn thread_counts() -> Vec<usize> {
    let mut t = vec![1, 2];
    let n = logical_cores();
    if n > 2 {
        t.push(n);
    }
    t
}

/// `1e6` for 1 000 000, the number itself otherwise.
pub fn sci(n: usize) -> String {
    let mut k = 0;
    let mut m = n;
    while m >= 10 && m % 10 == 0 {
        m /= 10;
        k += 1;
    }
    if m == 1 && k > 0 {
        format!("1e{k}")
    } else {
        n.to_string()
    }
}

/// One measured case: an ordered set of named fields.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Measurement(pub Map<String, Value>);

impl Measurement {
    /// An empty record.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds (or replaces) a field.
    pub fn field(mut self, key: &str, value: impl Into<Value>) -> Self {
        self.0.insert(key.to_string(), value.into());
        self
    }

    /// Adds a float field; a non-finite value is written as `null`, as JSON
    /// has no infinity or NaN.
    pub fn num(self, key: &str, value: f64) -> Self {
        let v = if value.is_finite() {
            Value::from(value)
        } else {
            Value::Null
        };
        self.field(key, v)
    }

    /// A field's value.
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.0.get(key)
    }

    /// Adds how this binary was built: `target_cpu_native` (with
    /// `-C target-cpu=native`) and `avx2` (may use AVX2).
    pub fn build_flags(self) -> Self {
        self.field("target_cpu_native", target_cpu_native())
            .field("avx2", cfg!(target_feature = "avx2"))
    }
}

/// The flags this binary was compiled with (`CARGO_ENCODED_RUSTFLAGS`,
/// separators turned into spaces; see `build.rs`).
pub const RUSTFLAGS: &str = env!("INERTIA_BENCH_RUSTFLAGS");

/// Whether the binary was built with `-C target-cpu=native`.
pub fn target_cpu_native() -> bool {
    RUSTFLAGS.contains("target-cpu=native")
}

/// Where suites send their records.
pub trait Sink {
    /// Receives one measured case (without `suite` and `machine`, which the
    /// reporter adds).
    fn record(&mut self, r: Measurement);
}

impl Sink for Vec<Measurement> {
    fn record(&mut self, r: Measurement) {
        self.push(r);
    }
}

/// Prints records to stdout as they arrive.
#[derive(Debug)]
pub struct Reporter {
    suite: String,
    machine: Machine,
    json: bool,
    printed_header: bool,
    /// Every record printed, in full (for `--plot`).
    printed: Vec<Map<String, Value>>,
}

impl Reporter {
    /// A reporter for `suite` on `machine`; `json` selects JSON lines.
    pub fn new(suite: &str, machine: Machine, json: bool) -> Self {
        Self {
            suite: suite.to_string(),
            machine,
            json,
            printed_header: false,
            printed: Vec::new(),
        }
    }

    /// Every record printed so far, in full.
    pub fn printed(&self) -> &[Map<String, Value>] {
        &self.printed
    }

    /// The full record as printed: `suite` and `machine` first, then the
    /// suite's fields.
    pub fn complete(&self, r: Measurement) -> Map<String, Value> {
        let mut m = Map::new();
        m.insert("suite".into(), Value::from(self.suite.clone()));
        m.insert(
            "machine".into(),
            serde_json::to_value(&self.machine).expect("machine serializes"),
        );
        for (k, v) in r.0 {
            m.insert(k, v);
        }
        m
    }
}

impl Sink for Reporter {
    fn record(&mut self, r: Measurement) {
        let m = self.complete(r);
        self.printed.push(m.clone());
        let mut out = std::io::stdout().lock();
        let line = if self.json {
            serde_json::to_string(&m).expect("records serialize")
        } else {
            let mut s = String::new();
            if !self.printed_header {
                s.push_str(&format!(
                    "# {} on {} ({} logical cores)\n",
                    self.suite, self.machine.cpu, self.machine.logical_cores
                ));
                self.printed_header = true;
            }
            s.push_str(&human_line(&m));
            s
        };
        // A closed pipe (`| head`) is not worth a panic.
        let _ = writeln!(out, "{line}");
        let _ = out.flush();
    }
}

/// `case backend threads | key=value ...`, numbers to 4 significant digits.
fn human_line(m: &Map<String, Value>) -> String {
    const HEAD: [&str; 6] = ["case", "scene", "integrator", "method", "backend", "theta"];
    let mut head = Vec::new();
    for k in HEAD {
        match m.get(k) {
            Some(Value::String(s)) => head.push(s.clone()),
            Some(Value::Number(n)) => head.push(format!("{k}={n}")),
            _ => {}
        }
    }
    if let Some(t) = m.get("threads") {
        head.push(format!("threads={t}"));
    }
    let rest: Vec<String> = m
        .iter()
        .filter(|(k, _)| {
            !HEAD.contains(&k.as_str()) && !matches!(k.as_str(), "suite" | "machine" | "threads")
        })
        .map(|(k, v)| format!("{k}={}", human_value(v)))
        .collect();
    format!("{:<40} {}", head.join(" "), rest.join(" "))
}

fn human_value(v: &Value) -> String {
    match v {
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            if x != 0.0 && (x.abs() >= 1e5 || x.abs() < 1e-3) {
                format!("{x:.3e}")
            } else {
                format!("{}", (x * 1e4).round() / 1e4)
            }
        }
        Value::String(s) => s.clone(),
        Value::Array(a) => format!(
            "[{}]",
            a.iter().map(human_value).collect::<Vec<_>>().join(",")
        ),
        other => other.to_string(),
    }
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub fn progress(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_prefix(what.to_string());
    pb.enable_steady_tick(Duration::from_millis(200));
    pb
}

/// A sink that hides a progress bar while a record is printed, so records
/// on a terminal's stdout do not interleave with the bar on its stderr.
pub struct Suspended<'a> {
    pb: &'a ProgressBar,
    inner: &'a mut dyn Sink,
}

impl std::fmt::Debug for Suspended<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Suspended").finish_non_exhaustive()
    }
}

impl<'a> Suspended<'a> {
    /// Wraps `inner` around `pb`.
    pub fn new(pb: &'a ProgressBar, inner: &'a mut dyn Sink) -> Self {
        Self { pb, inner }
    }
}

impl Sink for Suspended<'_> {
    fn record(&mut self, r: Measurement) {
        let inner = &mut *self.inner;
        self.pb.suspend(|| inner.record(r));
    }
}

/// Prints a remark on stderr without tearing a progress bar.
pub fn note(pb: &ProgressBar, msg: &str) {
    pb.suspend(|| eprintln!("{msg}"));
}

/// Median of a non-empty sample (mean of the middle two for even lengths).
pub fn median(xs: &[f64]) -> f64 {
    assert!(!xs.is_empty(), "median of an empty sample");
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, fixed-seed generator for
/// reproducible scenes, shared with the protocol's tests and link.
pub use inertia_protocol::rng::SplitMix as SplitMix64;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_odd_and_even() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
    }

    #[test]
    fn splitmix_is_reproducible_and_in_range() {
        let (mut a, mut b) = (SplitMix64(7), SplitMix64(7));
        for _ in 0..1000 {
            let x = a.uniform();
            assert_eq!(x, b.uniform());
            assert!((0.0..1.0).contains(&x));
        }
    }

    #[test]
    fn non_finite_numbers_become_null() {
        let r = Measurement::new().num("x", f64::INFINITY).num("y", 1.5);
        assert_eq!(r.get("x"), Some(&Value::Null));
        assert_eq!(r.get("y"), Some(&Value::from(1.5)));
    }
}
