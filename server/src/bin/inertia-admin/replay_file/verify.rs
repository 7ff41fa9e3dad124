//! `replay-file verify`: re-simulates a recording from its first keyframe
//! under the sandbox rules and checks every stored tick hash (and every
//! keyframe against the state re-simulation reached), with a progress bar
//! on a terminal. A damaged recording is verified as far as it can be
//! trusted: reading goes on past the damage and re-simulation starts again
//! at the next keyframe, and each damaged place is listed. Exit 0 when
//! everything matches, 1 when a hash differs or the recording is damaged.

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use inertia_server::record::{Corruption, RecordError};
use inertia_server::rules::SandboxRules;
use inertia_server::sim::verify::{verify, VerifyError, VerifyReport};
use serde_json::json;

use super::{count, data_error, hex, misuse, scan};
use crate::Failure;

/// Mismatches printed for people (the JSON carries all the report holds).
const SHOWN_MISMATCHES: usize = 8;

/// Re-simulates the recording at `dir` and prints what it found.
pub fn run(dir: &Path, json: bool) -> Result<ExitCode, Failure> {
    let files = scan::open(dir)?;
    let first = files.first().map_or(0, |s| s.first_tick);
    let bar = progress_bar();
    let report = verify(
        dir,
        || Box::new(SandboxRules::default()),
        |tick, last| {
            bar.set_length(last.saturating_sub(first));
            bar.set_position(tick.saturating_sub(first));
            bar.set_message(format!("tick {tick}"));
        },
    );
    bar.finish_and_clear();
    let report = report.map_err(|e| failure(dir, e))?;
    if json {
        println!("{}", report_json(&report));
    } else {
        println!("{}", report_text(&report));
    }
    if report.ok() {
        return Ok(ExitCode::SUCCESS);
    }
    if let Some(d) = report.damage.first() {
        eprintln!(
            "inertia-admin: the recording is damaged in {} place{} (the first: {} at byte {}: {}); \
             the rest was verified from the next keyframe after each",
            report.damage.len(),
            if report.damage.len() == 1 { "" } else { "s" },
            d.path.display(),
            d.offset,
            d.why,
        );
    }
    if report.mismatch_count == 0 {
        return Ok(ExitCode::from(1));
    }
    let first = report
        .mismatches
        .first()
        .map_or(String::new(), |(tick, _, _)| {
            format!("; the first at tick {tick}")
        });
    eprintln!(
        "inertia-admin: {} of {} checks differ{first}: the recording does not re-simulate to its hashes",
        report.mismatch_count,
        report.hashes_checked + report.keyframes_checked,
    );
    Ok(ExitCode::from(1))
}

/// A bar of ticks re-simulated on stderr, drawn only when stderr is a
/// terminal.
fn progress_bar() -> ProgressBar {
    let target = if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    };
    let bar = ProgressBar::with_draw_target(Some(0), target);
    if let Ok(style) = ProgressStyle::with_template(
        "verifying [{bar:40}] {percent:>3}% {msg} ({per_sec}, eta {eta})",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// What a [`VerifyError`] means for the operator: a file that is not a
/// recording is misuse (exit 2); anything else is damage (exit 1).
fn failure(dir: &Path, e: VerifyError) -> Failure {
    match e {
        VerifyError::Record(RecordError::Corrupt {
            offset: 0,
            why: Corruption::BadMagic,
            path,
        }) => misuse(
            "not_a_recording",
            format!(
                "{}: not a recording ({} is not a segment file: bad magic)",
                dir.display(),
                path.display()
            ),
        ),
        VerifyError::Record(e @ RecordError::Corrupt { .. }) => data_error(
            "damaged",
            format!("the recording is damaged and cannot be re-simulated past it: {e}"),
        ),
        VerifyError::Record(e) => data_error("io", e.to_string()),
        VerifyError::NoKeyframe => data_error(
            "damaged",
            format!(
                "{}: the recording holds no keyframe to re-simulate from",
                dir.display()
            ),
        ),
        e @ VerifyError::Bad { .. } => {
            data_error("damaged", format!("the recording is damaged: {e}"))
        }
    }
}

fn report_json(r: &VerifyReport) -> serde_json::Value {
    json!({
        "ok": r.ok(),
        "ticks": r.ticks,
        "hashes_checked": r.hashes_checked,
        "keyframes_checked": r.keyframes_checked,
        "mismatches": r.mismatches.iter().map(|&(tick, recorded, got)| json!({
            "tick": tick,
            "recorded": hex(recorded),
            "resimulated": hex(got),
        })).collect::<Vec<_>>(),
        "mismatch_count": r.mismatch_count,
        "ticks_per_s": r.ticks_per_second(),
        "first_tick": r.first_tick,
        "last_tick": r.last_tick,
        "sessions": r.sessions,
        "seconds": r.seconds,
        "damage": r.damage.iter().map(|d| json!({
            "path": d.path.display().to_string(),
            "offset": d.offset,
            "why": d.why,
            "read_on_at": d.read_on_at,
            "restarted_at": d.restarted_at,
        })).collect::<Vec<_>>(),
        "torn_tail": r.torn_tail,
    })
}

fn report_text(r: &VerifyReport) -> String {
    let mut out = vec![
        format!(
            "re-simulated {} (ticks {}..={}, {}) in {:.2} s: {:.0} ticks/s",
            count(r.ticks, "tick", "ticks"),
            r.first_tick,
            r.last_tick,
            count(r.sessions, "session", "sessions"),
            r.seconds,
            r.ticks_per_second(),
        ),
        format!(
            "checked {} and {}",
            count(r.hashes_checked, "tick hash", "tick hashes"),
            count(r.keyframes_checked, "keyframe", "keyframes"),
        ),
    ];
    for d in &r.damage {
        let on = match d.read_on_at {
            Some(at) => format!("read on at byte {at}"),
            None => "the rest of the segment skipped".into(),
        };
        let again = match d.restarted_at {
            Some(tick) => format!("re-simulated again from the keyframe of tick {tick}"),
            None => "no keyframe after it".into(),
        };
        out.push(format!(
            "DAMAGED {} at byte {}: {}; {on}; {again}",
            d.path.display(),
            d.offset,
            d.why
        ));
    }
    if r.torn_tail {
        out.push("the newest segment ends in a torn tail (a crash mid-append): not damage".into());
    }
    if r.mismatch_count == 0 && r.damage.is_empty() {
        out.push("every hash matches".into());
    } else if r.mismatch_count == 0 {
        out.push("every hash checked matches".into());
    } else {
        out.push(format!(
            "{} DIFFER; the first:",
            count(r.mismatch_count, "check", "checks")
        ));
        for (tick, recorded, got) in r.mismatches.iter().take(SHOWN_MISMATCHES) {
            out.push(format!(
                "  tick {tick}: recorded {}, re-simulated {}",
                hex(*recorded),
                hex(*got)
            ));
        }
    }
    out.join("\n")
}
