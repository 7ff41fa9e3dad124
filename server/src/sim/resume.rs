//! `--resume`: carrying on from the recording after a crash.
//!
//! The recorder syncs at least once a wall second, so after a `kill -9`
//! the recording on disk ends at most about a second before the crash
//! (a torn last record is cut when the directory is opened). Resuming
//! restores the newest keyframe and re-simulates the recorded journal up
//! to the last tick hashed, checking each hash on the way, then applies
//! what was journaled after that tick. Clients who were in the game are
//! not connected any more: they leave (their avatars go). The recording
//! then goes on in the same directory, so history before the crash stays
//! seekable.

use std::path::Path;
use std::time::Instant;

use super::Simulation;
use crate::record::{RecordOptions, RecordWriter};
use crate::replay::{History, HistoryError, SimState, StateError};

/// What resuming did.
#[derive(Debug, Clone, PartialEq)]
pub struct ResumeReport {
    /// The keyframe restored.
    pub keyframe_tick: u64,
    /// The tick reached (the last durable one).
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
    /// Torn bytes cut off the recording's tail.
    pub bytes_cut: u64,
    /// Wall time, s.
    pub seconds: f64,
}

/// Why the server could not resume.
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
    /// The newest keyframe does not restore.
    #[error("the keyframe at tick {tick} does not restore: {source}")]
    State {
        /// Its tick.
        tick: u64,
        /// Why.
        source: StateError,
    },
}

/// Reads the recording at `dir` for resuming, first cutting a torn tail
/// (returns the history and the bytes cut).
pub fn read_for_resume(dir: &Path, budget: usize) -> Result<(History, u64), ResumeError> {
    let shown = dir.display().to_string();
    if !dir.exists() {
        return Err(ResumeError::Empty(shown));
    }
    let writer =
        RecordWriter::open(dir, RecordOptions::default()).map_err(|source| ResumeError::Open {
            dir: shown.clone(),
            source,
        })?;
    let cut = writer.open_report().bytes_cut();
    drop(writer);
    let history =
        History::load(dir, budget).map_err(|source| ResumeError::History { dir: shown, source })?;
    Ok((history, cut))
}

impl Simulation {
    /// Carries on from `history` (see the module docs). The simulation
    /// must not be recording yet; start recording afterwards.
    pub fn resume(
        &mut self,
        history: History,
        bytes_cut: u64,
    ) -> Result<ResumeReport, ResumeError> {
        let started = Instant::now();
        let keyframe = history
            .latest_keyframe()
            .ok_or_else(|| ResumeError::Empty("the recording".into()))?;
        let state = SimState::decode(&keyframe.bytes).map_err(|source| ResumeError::State {
            tick: keyframe.tick,
            source,
        })?;
        self.restore(&state).map_err(|source| ResumeError::State {
            tick: keyframe.tick,
            source,
        })?;
        let end = history
            .last_hashed()
            .unwrap_or(keyframe.tick)
            .max(keyframe.tick);
        let mut report = ResumeReport {
            keyframe_tick: keyframe.tick,
            tick: end,
            resimulated: 0,
            hashes_checked: 0,
            mismatches: 0,
            clients: Vec::new(),
            bytes_cut,
            seconds: 0.0,
        };
        let mut skip = keyframe.applied as usize;
        loop {
            let t = self.world.tick();
            for e in history.journal_at(t).iter().skip(skip) {
                self.apply_entry(e);
            }
            skip = 0;
            if t >= end {
                break;
            }
            self.tick();
            report.resimulated += 1;
            if let Some(want) = history.hash_at(self.world.tick()) {
                report.hashes_checked += 1;
                if want != self.world.state_hash() {
                    report.mismatches += 1;
                }
            }
        }
        self.history = Some(history);
        report.clients = self.clients.iter().copied().collect();
        self.clock = self.clock.clone().with_tick(self.world.tick());
        self.catalog_stale = true;
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
