//! Re-simulating a recording directory from its first keyframe and
//! checking every stored hash (and every keyframe against the state
//! re-simulation reached), for tools and tests.
//!
//! A damaged recording is verified as far as it can be trusted: the
//! salvaging reader ([`RecordReader::salvage`]) reads on at the next
//! intact frame past damage, and re-simulation starts again at the next
//! keyframe after it (what lies between cannot be re-simulated: a lost
//! journal would make every later hash differ). Each place is reported
//! ([`VerifyReport::damage`]), and the recording does not verify.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::{SimConfig, Simulation};
use crate::record::{Record, RecordReader, Salvaged};
use crate::replay::journal;
use crate::replay::SimState;
use crate::rules::GameRules;

/// What [`verify`] found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VerifyReport {
    /// Recording sessions seen.
    pub sessions: u64,
    /// First and last tick re-simulated.
    pub first_tick: u64,
    /// The last tick reached.
    pub last_tick: u64,
    /// Ticks re-simulated.
    pub ticks: u64,
    /// Stored hashes compared.
    pub hashes_checked: u64,
    /// Keyframes compared with the re-simulated state.
    pub keyframes_checked: u64,
    /// Ticks whose hash differed (the first few).
    pub mismatches: Vec<(u64, u64, u64)>,
    /// How many hashes differed in all.
    pub mismatch_count: u64,
    /// The damage read past, in the order met.
    pub damage: Vec<SkippedDamage>,
    /// The newest segment ends in a torn tail (an append cut short by a
    /// crash; the records before it are whole): noted, not damage.
    pub torn_tail: bool,
    /// Wall time, s.
    pub seconds: f64,
}

impl VerifyReport {
    /// Ticks re-simulated per wall second.
    pub fn ticks_per_second(&self) -> f64 {
        if self.seconds > 0.0 {
            self.ticks as f64 / self.seconds
        } else {
            0.0
        }
    }

    /// True when every hash matched and nothing was damaged.
    pub fn ok(&self) -> bool {
        self.mismatch_count == 0 && self.damage.is_empty()
    }
}

/// One damaged place a verification read past.
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedDamage {
    /// The segment file.
    pub path: PathBuf,
    /// Byte offset of the damage in it.
    pub offset: u64,
    /// What is wrong there.
    pub why: String,
    /// Where reading went on in the same file; `None`: the rest of the
    /// segment was skipped.
    pub read_on_at: Option<u64>,
    /// The keyframe re-simulation started again at after it; `None`: no
    /// keyframe came after it.
    pub restarted_at: Option<u64>,
}

/// Why a recording could not be verified at all.
#[derive(Debug, thiserror::Error)]
pub enum VerifyError {
    /// The store refused.
    #[error(transparent)]
    Record(#[from] crate::record::RecordError),
    /// A keyframe or journal does not decode.
    #[error("tick {tick}: {what}")]
    Bad {
        /// Where.
        tick: u64,
        /// What.
        what: String,
    },
    /// No keyframe to start from.
    #[error("the recording holds no keyframe")]
    NoKeyframe,
}

/// Re-simulates the recording at `dir` under fresh rules from
/// `make_rules`, checking every stored hash; `progress(tick, last)` is
/// called now and then (`last` the recording's last tick).
pub fn verify(
    dir: &Path,
    mut make_rules: impl FnMut() -> Box<dyn GameRules>,
    mut progress: impl FnMut(u64, u64),
) -> Result<VerifyReport, VerifyError> {
    let started = Instant::now();
    let reader = RecordReader::open(dir)?;
    // The last tick, for the progress: a damaged recording's newest
    // segment's first, when its segments cannot be read through.
    let last = match reader.segments() {
        Ok(segments) => segments.iter().map(|s| s.last_tick).max().unwrap_or(0),
        // A file that is no segment at all is not a damaged recording.
        Err(
            e @ crate::record::RecordError::Corrupt {
                offset: 0,
                why: crate::record::Corruption::BadMagic,
                ..
            },
        ) => return Err(e.into()),
        Err(_) => reader
            .segment_files()
            .iter()
            .map(|s| s.first_tick)
            .max()
            .unwrap_or(0),
    };
    let mut report = VerifyReport::default();
    let mut sim: Option<Simulation> = None;
    // A new session restarts from its keyframe.
    let mut fresh_session = true;
    // Entries of the current tick recorded after the state reached: a
    // keyframe holds those recorded before it (its `applied`).
    let mut pending: Vec<journal::JournalEntry> = Vec::new();
    // Since damage, until a keyframe: nothing can be re-simulated.
    let mut lost = false;
    for step in reader.salvage() {
        let record = match step? {
            Salvaged::Record { record, .. } => record,
            Salvaged::Damaged { damage, read_on_at } => {
                report.damage.push(SkippedDamage {
                    path: damage.path,
                    offset: damage.offset,
                    why: damage.why.to_string(),
                    read_on_at,
                    restarted_at: None,
                });
                lost = true;
                fresh_session = true;
                pending.clear();
                continue;
            }
            Salvaged::TornTail(_) => {
                report.torn_tail = true;
                continue;
            }
        };
        if lost && !matches!(record, Record::Keyframe { .. }) {
            continue;
        }
        match record {
            Record::SessionStart { .. } => {
                report.sessions += 1;
                fresh_session = true;
            }
            Record::Keyframe { tick, state } => {
                let bad = |what: String| VerifyError::Bad { tick, what };
                let state = SimState::decode(&state).map_err(|e| bad(e.to_string()))?;
                match &mut sim {
                    Some(s) if !fresh_session => {
                        // Catch up to the keyframe, then compare worlds.
                        advance(s, &mut pending, tick, &mut report);
                        if s.world().tick() == tick && state.applied == 0 {
                            let mut probe = inertia_physics::World::new(*s.world().config())
                                .map_err(|e| bad(e.to_string()))?;
                            probe
                                .restore(&state.world)
                                .map_err(|e| bad(e.to_string()))?;
                            let mut properties = s.properties().clone();
                            properties.restore(&state.properties).map_err(bad)?;
                            let mut rules = make_rules();
                            rules.restore_state(&state.rules).map_err(bad)?;
                            report.keyframes_checked += 1;
                            let want = super::timeline::state_hash(
                                probe.state_hash(),
                                properties.hash(),
                                rules.state_hash(),
                            );
                            let got = s.state_hash();
                            if want != got {
                                note_mismatch(&mut report, tick, want, got);
                            }
                        }
                    }
                    _ => {
                        let mut s =
                            Simulation::from_state(&state, make_rules(), SimConfig::default())
                                .map_err(|e| bad(e.to_string()))?;
                        s.clock_mut().pause();
                        if sim.is_none() {
                            report.first_tick = tick;
                        }
                        if lost {
                            lost = false;
                            if let Some(d) = report.damage.last_mut() {
                                d.restarted_at = Some(tick);
                            }
                        }
                        pending.clear();
                        sim = Some(s);
                        fresh_session = false;
                    }
                }
            }
            Record::Journal { tick, entries } => {
                let entries = journal::decode(tick, &entries).map_err(|e| VerifyError::Bad {
                    tick,
                    what: e.to_string(),
                })?;
                if let Some(s) = &mut sim {
                    advance(s, &mut pending, tick, &mut report);
                    if s.world().tick() == tick {
                        pending.extend(entries);
                    }
                }
            }
            Record::TickHash { tick, hash } => {
                if let Some(s) = &mut sim {
                    advance(s, &mut pending, tick, &mut report);
                    if s.world().tick() == tick {
                        report.hashes_checked += 1;
                        let got = s.state_hash();
                        if got != hash {
                            note_mismatch(&mut report, tick, hash, got);
                        }
                    }
                    if tick % 600 == 0 {
                        progress(tick, last);
                    }
                }
            }
            Record::Inputs { .. } | Record::AdminEdit { .. } => {}
        }
    }
    if let Some(s) = &sim {
        report.last_tick = s.world().tick();
    } else {
        return Err(VerifyError::NoKeyframe);
    }
    progress(report.last_tick, last);
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// Steps `sim` up to `tick`, applying each tick's pending journal first.
fn advance(
    sim: &mut Simulation,
    pending: &mut Vec<journal::JournalEntry>,
    tick: u64,
    report: &mut VerifyReport,
) {
    while sim.world().tick() < tick {
        for e in pending.drain(..) {
            sim.apply_entry(&e);
        }
        sim.run_ticks(1);
        report.ticks += 1;
    }
}

fn note_mismatch(report: &mut VerifyReport, tick: u64, want: u64, got: u64) {
    report.mismatch_count += 1;
    if report.mismatches.len() < 16 {
        report.mismatches.push((tick, want, got));
    }
}
