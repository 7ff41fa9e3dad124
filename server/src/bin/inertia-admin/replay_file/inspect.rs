//! `replay-file inspect`: what a recording holds — its segments, its
//! sessions, the ticks it covers and how much simulated time that is, its
//! records and journal entries by kind, its size and the size of an hour
//! of simulation, and any damage.

use std::ops::ControlFlow;
use std::path::Path;
use std::process::ExitCode;

use inertia_server::record::{Record, RecordKind};
use inertia_server::replay::journal::{self, JournalEntry};
use inertia_server::replay::SimState;
use serde_json::json;

use super::scan::{self, file_name, ScanDamage};
use super::{bytes_text, count, misuse, size_text};
use crate::Failure;

/// One segment file as scanned.
#[derive(Debug, Clone)]
struct Segment {
    /// Its file name.
    file: String,
    /// Tick of its first and last intact record (`None` when it holds
    /// none).
    ticks: Option<(u64, u64)>,
    /// Intact records.
    records: u64,
    /// Its size on disk, bytes.
    bytes: u64,
}

/// A recording session: from a session start (or, where retention removed
/// it, from the first record) to the next.
#[derive(Debug, Clone)]
struct Session {
    /// The tick it starts at.
    start_tick: u64,
    /// The last tick it recorded.
    last_tick: u64,
    /// The scene's name (`None` when its session start is gone).
    scene: Option<String>,
    /// Its tick rate, Hz (`None` when its session start is gone).
    tick_hz: Option<u32>,
}

/// Records and journal entries, by kind.
#[derive(Debug, Clone, Default)]
struct Counts {
    session_starts: u64,
    keyframes: u64,
    journal_records: u64,
    tick_hashes: u64,
    admin_edits: u64,
    /// `Inputs` records (written by tools; the server writes journals).
    input_records: u64,
    joins: u64,
    leaves: u64,
    inputs: u64,
    messages: u64,
    edits: u64,
    /// Journal records that did not decode (each is also damage).
    bad_journals: u64,
}

/// What [`run`] reports.
#[derive(Debug, Clone, Default)]
struct Summary {
    segments: Vec<Segment>,
    sessions: Vec<Session>,
    /// The first and last tick of any record.
    ticks: Option<(u64, u64)>,
    counts: Counts,
    /// Framed bytes by record kind (frame overhead included), indexed by
    /// the kind byte − 1.
    kind_bytes: [u64; 7],
    /// The segment files' sizes summed, bytes.
    total_bytes: u64,
    damage: Vec<ScanDamage>,
    /// Journal records that did not decode: tick and why.
    bad_journals: Vec<(u64, String)>,
}

impl Summary {
    /// The tick rate of the recording, Hz: its first session's that names
    /// one.
    fn tick_hz(&self) -> Option<u32> {
        self.sessions.iter().find_map(|s| s.tick_hz)
    }

    /// Simulated seconds a session covers at its tick rate (the
    /// recording's where its own is unknown).
    fn session_seconds(&self, s: &Session) -> Option<f64> {
        let hz = s.tick_hz.or(self.tick_hz()).filter(|&hz| hz > 0)?;
        Some((s.last_tick - s.start_tick) as f64 / f64::from(hz))
    }

    /// Simulated seconds the whole recording covers: its sessions'
    /// summed (ticks between sessions were not recorded).
    fn duration_s(&self) -> Option<f64> {
        self.sessions
            .iter()
            .map(|s| self.session_seconds(s))
            .sum::<Option<f64>>()
    }

    /// Bytes on disk per hour of simulated time.
    fn bytes_per_sim_hour(&self) -> Option<f64> {
        self.duration_s()
            .filter(|&d| d > 0.0)
            .map(|d| self.total_bytes as f64 * 3600.0 / d)
    }

    /// Damage other than a torn tail.
    fn corrupt(&self) -> bool {
        self.damage.iter().any(|d| !d.torn_tail) || !self.bad_journals.is_empty()
    }

    fn note(&mut self, record: &Record) {
        let tick = record.tick();
        self.ticks = Some(match self.ticks {
            Some((first, last)) => (first.min(tick), last.max(tick)),
            None => (tick, tick),
        });
        self.kind_bytes[record.kind() as usize - 1] += 9 + record.payload_len();
        if let Record::SessionStart {
            tick,
            tick_hz,
            scene,
        } = record
        {
            self.sessions.push(Session {
                start_tick: *tick,
                last_tick: *tick,
                scene: Some(scene.clone()),
                tick_hz: Some(*tick_hz),
            });
        } else if self.sessions.is_empty() {
            self.sessions.push(Session {
                start_tick: tick,
                last_tick: tick,
                scene: None,
                tick_hz: None,
            });
        }
        if let Some(s) = self.sessions.last_mut() {
            s.last_tick = s.last_tick.max(tick);
        }
        let c = &mut self.counts;
        match record {
            Record::SessionStart { .. } => c.session_starts += 1,
            Record::Keyframe { .. } => c.keyframes += 1,
            Record::TickHash { .. } => c.tick_hashes += 1,
            Record::AdminEdit { .. } => c.admin_edits += 1,
            Record::Inputs { .. } => c.input_records += 1,
            Record::Journal { tick, entries } => {
                c.journal_records += 1;
                match journal::decode(*tick, entries) {
                    Ok(entries) => {
                        for e in &entries {
                            match e {
                                JournalEntry::Join(_) => c.joins += 1,
                                JournalEntry::Leave(_) => c.leaves += 1,
                                JournalEntry::Input(..) => c.inputs += 1,
                                JournalEntry::Message(..) => c.messages += 1,
                                JournalEntry::Edit(_) => c.edits += 1,
                            }
                        }
                    }
                    Err(e) => {
                        c.bad_journals += 1;
                        if self.bad_journals.len() < 16 {
                            self.bad_journals.push((*tick, e.to_string()));
                        }
                    }
                }
            }
        }
    }

    fn json(&self, dir: &Path) -> serde_json::Value {
        let c = &self.counts;
        let kind_bytes = |k: RecordKind| self.kind_bytes[k as usize - 1];
        json!({
            "dir": dir.display().to_string(),
            "segments": self.segments.iter().map(|s| json!({
                "file": s.file,
                "first_tick": s.ticks.map(|t| t.0),
                "last_tick": s.ticks.map(|t| t.1),
                "records": s.records,
                "bytes": s.bytes,
            })).collect::<Vec<_>>(),
            "sessions": self.sessions.iter().map(|s| json!({
                "start_tick": s.start_tick,
                "last_tick": s.last_tick,
                "scene": s.scene,
                "tick_hz": s.tick_hz,
                "duration_s": self.session_seconds(s),
            })).collect::<Vec<_>>(),
            "first_tick": self.ticks.map(|t| t.0),
            "last_tick": self.ticks.map(|t| t.1),
            "tick_hz": self.tick_hz(),
            "duration_s": self.duration_s(),
            "records": {
                "session_starts": c.session_starts,
                "keyframes": c.keyframes,
                "journal": c.journal_records,
                "tick_hashes": c.tick_hashes,
                "admin_edits": c.admin_edits,
                "inputs": c.input_records,
            },
            "record_bytes": {
                "session_starts": kind_bytes(RecordKind::SessionStart),
                "keyframes": kind_bytes(RecordKind::Keyframe),
                "journal": kind_bytes(RecordKind::Journal),
                "tick_hashes": kind_bytes(RecordKind::TickHash),
                "admin_edits": kind_bytes(RecordKind::AdminEdit),
                "inputs": kind_bytes(RecordKind::Inputs) + kind_bytes(RecordKind::InputsWithView),
            },
            "journal_entries": {
                "joins": c.joins,
                "leaves": c.leaves,
                "inputs": c.inputs,
                "messages": c.messages,
                "edits": c.edits,
            },
            "total_bytes": self.total_bytes,
            "bytes_per_sim_hour": self.bytes_per_sim_hour(),
            "damage": self.damage.iter().map(ScanDamage::json).collect::<Vec<_>>(),
            "bad_journals": self.bad_journals.iter().map(|(tick, why)| json!({
                "tick": tick,
                "why": why,
            })).collect::<Vec<_>>(),
            "torn_tail": self.damage.iter().any(|d| d.torn_tail),
            "damaged": self.corrupt(),
        })
    }

    fn text(&self, dir: &Path) -> String {
        let mut out = vec![format!("recording {}", dir.display())];
        out.push(format!(
            "{}, {}",
            count(self.segments.len() as u64, "segment", "segments"),
            bytes_text(self.total_bytes)
        ));
        for s in &self.segments {
            let ticks = match s.ticks {
                Some((a, b)) => format!("ticks {a}..={b}"),
                None => "no records".into(),
            };
            out.push(format!(
                "  {}  {ticks}, {}, {}",
                s.file,
                count(s.records, "record", "records"),
                bytes_text(s.bytes)
            ));
        }
        out.push(count(self.sessions.len() as u64, "session", "sessions"));
        for s in &self.sessions {
            let scene = match &s.scene {
                Some(name) => format!("scene {name:?}"),
                None => "session start not kept (retention)".into(),
            };
            let hz = s.tick_hz.map_or("? Hz".into(), |hz| format!("{hz} Hz"));
            let secs = self
                .session_seconds(s)
                .map_or(String::new(), |d| format!(" ({d:.3} s)"));
            out.push(format!(
                "  from tick {}: {scene}, {hz}, through tick {}{secs}",
                s.start_tick, s.last_tick
            ));
        }
        match (self.ticks, self.duration_s(), self.tick_hz()) {
            (Some((a, b)), Some(d), Some(hz)) => {
                out.push(format!("ticks {a}..={b}, {d:.3} simulated s at {hz} Hz"))
            }
            (Some((a, b)), _, _) => out.push(format!("ticks {a}..={b}, tick rate unknown")),
            (None, _, _) => out.push("no records".into()),
        }
        let c = &self.counts;
        let kb = |k: RecordKind| size_text(self.kind_bytes[k as usize - 1]);
        out.push(format!(
            "{} ({}), {} ({}), {}, {}, {}",
            count(c.keyframes, "keyframe", "keyframes"),
            kb(RecordKind::Keyframe),
            count(c.journal_records, "journal record", "journal records"),
            kb(RecordKind::Journal),
            count(c.tick_hashes, "tick hash", "tick hashes"),
            count(c.admin_edits, "admin edit", "admin edits"),
            count(c.session_starts, "session start", "session starts"),
        ));
        if c.input_records > 0 {
            out.push(count(c.input_records, "inputs record", "inputs records"));
        }
        out.push(format!(
            "journal entries: {}, {}, {}, {}, {}",
            count(c.joins, "join", "joins"),
            count(c.leaves, "leave", "leaves"),
            count(c.inputs, "input", "inputs"),
            count(c.messages, "message", "messages"),
            count(c.edits, "edit", "edits"),
        ));
        match self.bytes_per_sim_hour() {
            Some(b) => out.push(format!(
                "{} per simulated hour",
                size_text(b.round() as u64)
            )),
            None => out.push("bytes per simulated hour unknown (no simulated time)".into()),
        }
        if self.damage.is_empty() && self.bad_journals.is_empty() {
            out.push("damage: none".into());
        }
        for d in &self.damage {
            out.push(d.text());
        }
        for (tick, why) in &self.bad_journals {
            out.push(format!(
                "corrupt: the journal of tick {tick} does not decode: {why}"
            ));
        }
        out.join("\n")
    }
}

/// Summarises the recording at `dir` and prints it. Exit 1 (after the
/// summary) when it is damaged beyond a torn tail.
pub fn run(dir: &Path, json: bool) -> Result<ExitCode, Failure> {
    let files = scan::open(dir)?;
    let mut summary = Summary::default();
    for (i, file) in files.iter().enumerate() {
        let newest = i + 1 == files.len();
        let mut bad_keyframes = Vec::new();
        let scan = scan::scan_segment(file, newest, |offset, record| {
            if let Record::Keyframe { tick, state } = &record {
                // A keyframe that does not decode is damage, checksum or
                // not: resume and seeks cannot start from it.
                if let Err(e) = SimState::decode(state) {
                    bad_keyframes.push(ScanDamage::bad_record(
                        &file.path,
                        offset,
                        format!("the keyframe of tick {tick} does not decode: {e}"),
                    ));
                }
            }
            summary.note(&record);
            ControlFlow::Continue(())
        });
        summary.damage.extend(bad_keyframes);
        summary.total_bytes += scan.bytes;
        summary.segments.push(Segment {
            file: file_name(&file.path),
            ticks: scan.first_tick.zip(scan.last_tick),
            records: scan.records,
            bytes: scan.bytes,
        });
        summary.damage.extend(scan.damage);
    }
    if summary.ticks.is_none() && summary.damage.iter().any(ScanDamage::not_a_segment) {
        return Err(misuse(
            "not_a_recording",
            format!(
                "{}: not a recording ({})",
                dir.display(),
                summary.damage[0].text()
            ),
        ));
    }
    if json {
        println!("{}", summary.json(dir));
    } else {
        println!("{}", summary.text(dir));
    }
    if summary.corrupt() {
        let what = summary
            .damage
            .iter()
            .find(|d| !d.torn_tail)
            .map(ScanDamage::text)
            .or_else(|| {
                summary
                    .bad_journals
                    .first()
                    .map(|(t, why)| format!("the journal of tick {t} does not decode: {why}"))
            })
            .unwrap_or_default();
        // The summary is the output (with `--json`, the one object).
        eprintln!("inertia-admin: the recording is damaged: {what}");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}
