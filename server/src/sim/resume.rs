//! `--resume`: carrying on from the recording after a crash.
//!
//! The recorder syncs at least once a wall second, so after a `kill -9`
//! the recording on disk ends at most about a second before the crash,
//! perhaps in a torn last record. Resuming restores the newest keyframe
//! that can be trusted and re-simulates the recorded journal from it up to
//! the last tick hashed after it, checking each hash on the way, then
//! applies what was journaled after that tick. Clients who were in the
//! game are not connected any more: they leave (their avatars go). The
//! recording then goes on in the same directory, so history before the
//! crash stays seekable.
//!
//! # Damage
//!
//! It happens in two steps, so that a resume that cannot go on changes
//! nothing on disk:
//!
//! 1. [`read_for_resume`] only reads: it loads the recording with
//!    [`History::salvage`], which reads past damage at the next intact
//!    record (a flipped bit costs the records it hit, not the rest of its
//!    segment), takes up replay again at the next keyframe after it, and
//!    stops before a torn tail.
//! 2. [`Simulation::resume`] restores the newest keyframe that decodes and
//!    restores, falling back keyframe by keyframe (one that does not is
//!    damage too), and re-simulates from it up to the last tick hashed in
//!    its session — so a run of records broken by damage ends at the
//!    damage, and one after it starts at its first keyframe. Only then does it open the directory for writing, which cuts
//!    a genuine torn tail (an incomplete last record at the end of the
//!    newest segment), keeping the bytes cut in a file beside it. Damaged
//!    segments are left exactly as they are; when the newest one is
//!    damaged, recording goes on in a new segment.
//!
//! The [`ResumeReport`] says what damage was found and what was kept
//! aside.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::Simulation;
use crate::record::{RecordOptions, RecordWriter, SegmentDamage, TailCut};
use crate::replay::{Damage, DamageKind, History, HistoryError, SimState};

/// What resuming did.
#[derive(Debug, Clone, PartialEq)]
pub struct ResumeReport {
    /// The keyframe restored.
    pub keyframe_tick: u64,
    /// The tick reached (the last durable one that could be trusted).
    pub tick: u64,
    /// Ticks re-simulated from the keyframe.
    pub resimulated: u64,
    /// Recorded hashes compared on the way.
    pub hashes_checked: u64,
    /// Of those, how many differed (should be 0).
    pub mismatches: u64,
    /// Clients who were in the game: not connected any more, they must
    /// leave ([`Simulation::leave`]) once recording has restarted, so the
    /// leaves are journaled.
    pub clients: Vec<crate::rules::ClientId>,
    /// The torn tail cut off the newest segment, and where its bytes were
    /// kept.
    pub torn_tail: Option<TailCut>,
    /// Damage found, oldest first: damaged frames (skipped up to the next
    /// intact one, and replay up to the next keyframe), keyframes that do not decode or restore
    /// (skipped), journals that do not decode. All of it left on disk as
    /// it was.
    pub damage: Vec<Damage>,
    /// The newest segment is damaged: recording goes on in a new segment.
    pub newest_damaged: Option<SegmentDamage>,
    /// Wall time, s.
    pub seconds: f64,
}

impl ResumeReport {
    /// Torn bytes cut off the recording's tail (and kept aside).
    pub fn bytes_cut(&self) -> u64 {
        self.torn_tail.as_ref().map_or(0, |c| c.bytes_cut)
    }
}

/// Why the server could not resume. None of these leaves a file changed.
#[derive(Debug, thiserror::Error)]
pub enum ResumeError {
    /// The recording could not be read.
    #[error("cannot read the recording at {dir}: {source}")]
    History {
        /// The directory.
        dir: String,
        /// Why.
        source: HistoryError,
    },
    /// The recording could not be opened for repair.
    #[error("cannot open the recording at {dir}: {source}")]
    Open {
        /// The directory.
        dir: String,
        /// Why.
        source: crate::record::RecordError,
    },
    /// There is nothing to resume from.
    #[error("the recording at {0} holds no keyframe to resume from")]
    Empty(String),
    /// Every keyframe is damaged or lies past damage: nothing can be
    /// trusted to resume from.
    #[error(
        "the recording at {dir} holds no intact keyframe to resume from; damage: {}",
        list(damage)
    )]
    NoIntactKeyframe {
        /// The directory.
        dir: String,
        /// The damage found, oldest first.
        damage: Vec<Damage>,
    },
}

fn list(damage: &[Damage]) -> String {
    damage
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("; ")
}

/// The recording read for resuming (nothing written yet): give it to
/// [`Simulation::resume`].
#[derive(Debug)]
pub struct ResumePlan {
    dir: PathBuf,
    history: History,
    report: crate::replay::SalvageReport,
}

impl ResumePlan {
    /// The recording as loaded.
    pub fn history(&self) -> &History {
        &self.history
    }

    /// Damage found reading it, oldest first.
    pub fn damage(&self) -> &[Damage] {
        &self.report.damage
    }
}

/// Reads the recording at `dir` for resuming, past damage as far as it
/// can be trusted (see the module docs). Writes nothing.
pub fn read_for_resume(dir: &Path, budget: usize) -> Result<ResumePlan, ResumeError> {
    let shown = dir.display().to_string();
    if !dir.exists() {
        return Err(ResumeError::Empty(shown));
    }
    let (history, report) = History::salvage(dir, budget)
        .map_err(|source| ResumeError::History { dir: shown, source })?;
    Ok(ResumePlan {
        dir: dir.to_path_buf(),
        history,
        report,
    })
}

impl Simulation {
    /// Carries on from the recording read into `plan` (see the module
    /// docs): restores its newest keyframe that can be trusted,
    /// re-simulates to the last tick hashed after it, then cuts a torn
    /// tail off the recording (keeping it aside). The simulation must not
    /// be recording yet; start recording afterwards. When no keyframe can
    /// be restored neither the simulation nor any file has changed.
    pub fn resume(&mut self, plan: ResumePlan) -> Result<ResumeReport, ResumeError> {
        let started = Instant::now();
        let ResumePlan {
            dir,
            mut history,
            report: salvage,
        } = plan;
        let shown = dir.display().to_string();
        let mut damage = salvage.damage;
        // The newest keyframe that decodes and restores.
        let mut restored = None;
        for keyframe in history.keyframes_newest_first() {
            let result = SimState::decode(&keyframe.bytes).and_then(|s| self.restore(&s));
            match result {
                Ok(()) => {
                    restored = Some(keyframe);
                    break;
                }
                Err(error) => {
                    tracing::warn!(
                        tick = keyframe.tick,
                        error = %error,
                        "a keyframe does not restore; trying the one before"
                    );
                    let (path, offset) = salvage
                        .keyframes
                        .get(&(keyframe.tick, keyframe.applied))
                        .cloned()
                        .unwrap_or_else(|| (dir.clone(), 0));
                    damage.push(Damage {
                        path,
                        offset,
                        why: DamageKind::Keyframe {
                            tick: keyframe.tick,
                            error,
                        },
                    });
                    history.remove_keyframe(keyframe.tick, keyframe.applied);
                }
            }
        }
        damage.sort_by(|a, b| (&a.path, a.offset).cmp(&(&b.path, b.offset)));
        let Some(keyframe) = restored else {
            return Err(if damage.is_empty() {
                ResumeError::Empty(shown)
            } else {
                ResumeError::NoIntactKeyframe { dir: shown, damage }
            });
        };
        let end = history
            .last_hashed_from(keyframe.tick)
            .unwrap_or(keyframe.tick)
            .max(keyframe.tick);
        let mut report = ResumeReport {
            keyframe_tick: keyframe.tick,
            tick: end,
            resimulated: 0,
            hashes_checked: 0,
            mismatches: 0,
            clients: Vec::new(),
            torn_tail: None,
            damage,
            newest_damaged: None,
            seconds: 0.0,
        };
        let mut skip = keyframe.applied as usize;
        loop {
            let t = self.shown().world.tick();
            for e in history.journal_at(t).iter().skip(skip) {
                self.apply_entry(e);
            }
            skip = 0;
            if t >= end {
                break;
            }
            self.tick();
            report.resimulated += 1;
            if let Some(want) = history.hash_at(self.shown().world.tick()) {
                report.hashes_checked += 1;
                if want != self.state_hash() {
                    report.mismatches += 1;
                }
            }
        }
        // Only now touch the disk: cut a torn tail (kept aside).
        let writer = RecordWriter::open(&dir, RecordOptions::default())
            .map_err(|source| ResumeError::Open { dir: shown, source })?;
        crate::record::recorder::log_open(&dir, &writer);
        let opened = writer.open_report().clone();
        drop(writer);
        report.torn_tail = opened.cut;
        report.newest_damaged = opened.damaged;
        self.recording.history = Some(history);
        report.clients = self.shown().clients.iter().copied().collect();
        let shown = self.shown_mut();
        shown.clock = shown.clock.clone().with_tick(shown.world.tick());
        self.publication.timeline_swapped();
        report.seconds = started.elapsed().as_secs_f64();
        if report.mismatches > 0 {
            tracing::error!(
                mismatches = report.mismatches,
                checked = report.hashes_checked,
                "re-simulation after the crash differed from the recording"
            );
        }
        Ok(report)
    }
}
