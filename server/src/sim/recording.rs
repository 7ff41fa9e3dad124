//! The recording state machine: starting a session (its recorder opened
//! off the tick thread), the journal of each tick, tick hashes,
//! keyframes and in-memory checkpoints, and ending a session (with a
//! final keyframe when the state is sound).

use std::sync::atomic::Ordering;
use std::sync::Arc;

use super::Simulation;
use crate::metrics::Metrics;
use crate::record::{Record, Recorder, RecorderConfig};
use crate::replay::{History, JournalEntry};

/// A recorder being opened off the tick thread
/// ([`Simulation::prepare_recording`]).
#[derive(Debug)]
pub struct RecorderOpening {
    config: RecorderConfig,
    first_tick: u64,
    retired: Option<Recorder>,
    metrics: Option<Metrics>,
}

impl RecorderOpening {
    /// Waits for an earlier recorder to write out, then opens the
    /// recording directory and starts the recorder thread (disk work: not
    /// on the tick thread).
    pub fn open(self) -> Result<Recorder, String> {
        if let Some(old) = self.retired {
            old.stop();
        }
        Recorder::start(self.config, self.first_tick, self.metrics).map_err(|e| e.to_string())
    }
}

/// A session being recorded.
pub(super) struct Recording {
    pub(super) recorder: Recorder,
}

impl Simulation {
    /// Whether this tick's state is being recorded.
    pub fn recording(&self) -> bool {
        self.recording.is_some()
    }

    /// The recorder, while recording.
    pub fn recorder(&self) -> Option<&Recorder> {
        self.recording.as_ref().map(|r| &r.recorder)
    }

    /// Where recordings go, if this simulation can record.
    pub fn recording_config(&self) -> Option<&RecorderConfig> {
        self.config.recording.as_ref()
    }

    /// Starts a recording session at the current tick: `SessionStart`,
    /// then a keyframe. Nothing happens when already recording.
    pub fn start_recording(&mut self) -> Result<(), String> {
        match self.prepare_recording()? {
            None => Ok(()),
            Some(opening) => {
                let recorder = opening.open();
                self.adopt_recorder(recorder)
            }
        }
    }

    /// The first half of starting a recording without touching the disk
    /// on the tick thread: what [`RecorderOpening::open`] needs (run it
    /// elsewhere, then [`Simulation::adopt_recorder`]). `None` when
    /// already recording.
    pub fn prepare_recording(&mut self) -> Result<Option<RecorderOpening>, String> {
        if self.recording.is_some() {
            return Ok(None);
        }
        if self.opening_recorder {
            return Err("a recording is being started already".into());
        }
        let Some(config) = self.config.recording.clone() else {
            return Err("this server has no recording directory".into());
        };
        if self.view.is_some() {
            return Err("history is being shown; go back to the live tick first".into());
        }
        self.opening_recorder = true;
        Ok(Some(RecorderOpening {
            config,
            first_tick: self.shown().world.tick(),
            retired: self.retired.take(),
            metrics: self.config.metrics.clone(),
        }))
    }

    /// The second half: starts the session on the recorder opened (or
    /// reports why it could not be).
    pub fn adopt_recorder(&mut self, recorder: Result<Recorder, String>) -> Result<(), String> {
        self.opening_recorder = false;
        let recorder = recorder?;
        if self.recording.is_some() || self.view.is_some() {
            recorder.stop();
            return Err("the simulation changed while the recording was being opened".into());
        }
        let tick = self.shown().world.tick();
        // Entries of this tick from before the session are in its keyframe.
        // A session that continues the history held (after `--resume`)
        // counts the ones already recorded for this tick.
        self.journal.clear();
        let budget = self.config.history_budget;
        let history = self.history.get_or_insert_with(|| History::new(budget));
        if recorder.moved_aside().is_some() || history.range().is_some_and(|(_, last)| last > tick)
        {
            // It belonged to a recording that was moved aside.
            *history = History::new(budget);
        }
        let continues = history.range().is_some_and(|(_, last)| last == tick);
        self.journal_at_tick = if continues {
            history.journal_at(tick).len() as u32
        } else {
            0
        };
        let applied = self.journal_at_tick;
        let state = Arc::new(self.capture(applied).encode());
        let start = Record::SessionStart {
            tick,
            tick_hz: self.config.tick_hz,
            scene: self.scene_name.clone(),
        };
        let keyframe = Record::Keyframe {
            tick,
            state: state.as_ref().clone(),
        };
        recorder
            .send(start)
            .and_then(|()| recorder.send(keyframe))
            .map_err(|e| e.to_string())?;
        if let Some(history) = &mut self.history {
            if !continues {
                history.start_session(tick);
            }
            history.add_keyframe(tick, applied, state);
        }
        self.recording = Some(Recording { recorder });
        Ok(())
    }

    /// The recording held in memory for seeking, if any.
    pub fn history(&self) -> Option<&History> {
        self.history.as_ref()
    }

    /// Stops recording (the recorder thread writes out and syncs what it
    /// has on its own; the tick thread does not wait for it).
    pub fn stop_recording(&mut self) {
        if let Some(mut rec) = self.recording.take() {
            rec.recorder.close();
            if let Some(old) = self.retired.replace(rec.recorder) {
                old.stop();
            }
        }
    }

    /// Ends the recording with a keyframe of the current tick and waits
    /// until everything is on disk (shutdown).
    pub fn finish_recording(&mut self) {
        if self.view.is_some() {
            self.go_live();
        }
        self.flush_journal();
        if let Some(rec) = self.recording.take() {
            let tick = self.shown().world.tick();
            let state = self.capture(self.journal_at_tick).encode();
            rec.recorder.finish(Some(Record::Keyframe { tick, state }));
            tracing::info!(tick, "recording ended with a keyframe");
        }
        if let Some(old) = self.retired.take() {
            old.stop();
        }
    }

    /// Whether the state shown is whole: no tick was cut short, and every
    /// body's position and velocities are finite.
    pub fn state_is_sound(&self) -> bool {
        !self.in_tick
            && self.shown().world.bodies().all(|(_, b)| {
                b.center_of_mass().is_finite()
                    && b.linear_velocity().is_finite()
                    && b.angular_velocity().is_finite()
            })
    }

    /// Ends the recording after a failure: with a keyframe of the current
    /// state if [it is sound](Self::state_is_sound), else with what the
    /// recorder has (the last whole tick). Returns whether a keyframe was
    /// written.
    pub fn end_after_failure(&mut self) -> bool {
        if self.state_is_sound() {
            let recording = self.recording.is_some();
            self.finish_recording();
            return recording;
        }
        if let Some(rec) = self.recording.take() {
            rec.recorder.finish(None);
            tracing::warn!(
                tick = self.shown().world.tick(),
                "recording ended without a keyframe: the failure cut a tick short"
            );
        }
        if let Some(old) = self.retired.take() {
            old.stop();
        }
        false
    }

    /// Records an administrator's edit of the world at the current tick
    /// (`who` the operator, `what` a short description).
    pub fn record_admin_edit(&mut self, who: &str, what: &str) {
        let tick = self.shown().world.tick();
        self.send_record(Record::AdminEdit {
            tick,
            who: who.to_string(),
            what: what.as_bytes().to_vec(),
        });
    }

    /// Hands a record to the recorder; a dropped one stops the recording.
    pub(super) fn send_record(&mut self, record: Record) -> bool {
        let Some(rec) = &self.recording else {
            return false;
        };
        match rec.recorder.send(record) {
            Ok(()) => true,
            Err(e) => {
                self.stats.record_gaps.fetch_add(1, Ordering::Relaxed);
                tracing::error!(
                    error = %e,
                    tick = self.shown().world.tick(),
                    "the recording has a gap and stops here; `record on` starts a new one"
                );
                self.stop_recording();
                false
            }
        }
    }

    /// Notes a change to the live simulation in the current tick's journal
    /// (while recording).
    pub(super) fn journal_push(&mut self, entry: JournalEntry) {
        if self.recording.is_some() && self.view.is_none() {
            self.journal.push(entry);
        }
    }

    /// Hands the current tick's journal entries so far to the recorder
    /// and the history.
    pub fn flush_journal(&mut self) {
        if self.journal.is_empty() {
            return;
        }
        let entries = std::mem::take(&mut self.journal);
        let tick = self.shown().world.tick();
        let bytes = crate::replay::journal::encode(tick, &entries);
        if self.send_record(Record::Journal {
            tick,
            entries: bytes,
        }) {
            self.journal_at_tick += entries.len() as u32;
            if let Some(h) = &mut self.history {
                h.add_journal(tick, &entries);
            }
        }
    }

    /// The records of the tick just run.
    pub(super) fn record_tick(&mut self) {
        self.journal_at_tick = 0;
        let Some(rec) = &self.recording else {
            return;
        };
        let tick = self.shown().world.tick();
        let keyframe_ticks = rec.recorder.config().keyframe_ticks.max(1);
        let hash = self.shown().world.state_hash();
        if !self.send_record(Record::TickHash { tick, hash }) {
            return;
        }
        if let Some(h) = &mut self.history {
            h.add_hash(tick, hash);
        }
        let checkpoint_ticks = self.config.checkpoint_ticks;
        if tick % keyframe_ticks == 0 {
            let state = Arc::new(self.capture(0).encode());
            if self.send_record(Record::Keyframe {
                tick,
                state: state.as_ref().clone(),
            }) {
                if let Some(h) = &mut self.history {
                    h.add_keyframe(tick, 0, state);
                }
            }
        } else if checkpoint_ticks > 0 && tick % checkpoint_ticks == 0 {
            let state = self.capture(0).encode();
            if let Some(h) = &mut self.history {
                h.add_checkpoint(tick, state);
            }
        }
    }
}
