//! The recording state machine: starting a session (its recorder opened
//! off the tick thread), the journal of each tick, tick hashes,
//! keyframes and in-memory checkpoints, and ending a session (with a
//! final keyframe when the state is sound). [`Recording`] is the part of
//! the simulation that holds it; the simulation's own recording commands,
//! which need the state to capture, hand it what it asks for.

use std::sync::Arc;

use super::meter::TickMeter;
use super::{SimConfig, Simulation};
use crate::metrics::Metrics;
use crate::record::{Record, Recorder, RecorderConfig};
use crate::replay::{History, JournalEntry, SimState};

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

/// The recording part of a simulation: the session being recorded, the
/// journal of the current tick, and the history held in memory for
/// seeking.
#[derive(Debug)]
pub(super) struct Recording {
    /// Where and how to record; `None`: this simulation cannot record.
    config: Option<RecorderConfig>,
    metrics: Option<Metrics>,
    /// Most bytes of keyframes and checkpoints held for seeking.
    history_budget: usize,
    /// A checkpoint is held in memory every this many ticks (0: none).
    checkpoint_ticks: u64,
    /// The recorder of the session being recorded.
    recorder: Option<Recorder>,
    /// A stopped recorder whose thread may still be writing out.
    retired: Option<Recorder>,
    /// A recorder is being opened off the tick thread.
    opening: bool,
    /// Journal entries of the current tick not yet handed to the recorder.
    journal: Vec<JournalEntry>,
    /// Journal entries of the current tick handed over so far.
    journal_at_tick: u32,
    /// The recording held in memory for seeking (kept when recording
    /// stops, until a recording that cannot follow it starts).
    pub(super) history: Option<History>,
}

impl Recording {
    /// Not recording, under `config`.
    pub(super) fn new(config: &SimConfig) -> Self {
        Self {
            config: config.recording.clone(),
            metrics: config.metrics.clone(),
            history_budget: config.history_budget,
            checkpoint_ticks: config.checkpoint_ticks,
            recorder: None,
            retired: None,
            opening: false,
            journal: Vec::new(),
            journal_at_tick: 0,
            history: None,
        }
    }

    /// Forgets the current tick's journal (the state it belonged to was
    /// replaced).
    pub(super) fn forget_journal(&mut self) {
        self.journal.clear();
        self.journal_at_tick = 0;
    }

    /// Whether a session is being recorded.
    pub(super) fn is_on(&self) -> bool {
        self.recorder.is_some()
    }

    /// Journal entries of the current tick so far, handed over or not.
    pub(super) fn applied_at_tick(&self) -> u32 {
        self.journal_at_tick + self.journal.len() as u32
    }

    /// Journal entries of the current tick handed over so far.
    pub(super) fn handed_at_tick(&self) -> u32 {
        self.journal_at_tick
    }

    /// The first half of starting a session at `tick` (see
    /// [`Simulation::prepare_recording`]).
    fn prepare(&mut self, tick: u64, live: bool) -> Result<Option<RecorderOpening>, String> {
        if self.recorder.is_some() {
            return Ok(None);
        }
        if self.opening {
            return Err("a recording is being started already".into());
        }
        let Some(config) = self.config.clone() else {
            return Err("this server has no recording directory".into());
        };
        if !live {
            return Err("history is being shown; go back to the live tick first".into());
        }
        self.opening = true;
        Ok(Some(RecorderOpening {
            config,
            first_tick: tick,
            retired: self.retired.take(),
            metrics: self.metrics.clone(),
        }))
    }

    /// The second half: a session starts at `tick` on `recorder` with a
    /// keyframe of `capture(entries of the tick already applied)`.
    fn adopt(
        &mut self,
        recorder: Result<Recorder, String>,
        tick: u64,
        live: bool,
        start: Record,
        capture: impl FnOnce(u32) -> SimState,
    ) -> Result<(), String> {
        self.opening = false;
        let recorder = recorder?;
        if self.recorder.is_some() || !live {
            recorder.stop();
            return Err("the simulation changed while the recording was being opened".into());
        }
        // Entries of this tick from before the session are in its keyframe.
        // A session that continues the history held (after `--resume`)
        // counts the ones already recorded for this tick.
        self.journal.clear();
        let budget = self.history_budget;
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
        let state = Arc::new(capture(applied).encode());
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
        self.recorder = Some(recorder);
        Ok(())
    }

    /// Stops the session (the recorder thread writes out and syncs what
    /// it has on its own; nobody waits for it).
    pub(super) fn stop(&mut self) {
        if let Some(mut recorder) = self.recorder.take() {
            recorder.close();
            if let Some(old) = self.retired.replace(recorder) {
                old.stop();
            }
        }
    }

    /// Ends the session with `last` (a keyframe, or nothing) and waits
    /// until everything, and any retired recorder's, is on disk.
    fn finish(&mut self, last: Option<Record>) {
        if let Some(recorder) = self.recorder.take() {
            recorder.finish(last);
        }
        if let Some(old) = self.retired.take() {
            old.stop();
        }
    }

    /// Hands a record to the recorder; a dropped one stops the recording
    /// (a gap would break replay).
    pub(super) fn send(&mut self, record: Record, tick: u64, meter: &TickMeter) -> bool {
        let Some(recorder) = &self.recorder else {
            return false;
        };
        match recorder.send(record) {
            Ok(()) => true,
            Err(e) => {
                meter.record_gap();
                tracing::error!(
                    error = %e,
                    tick,
                    "the recording has a gap and stops here; `record on` starts a new one"
                );
                self.stop();
                false
            }
        }
    }

    /// Notes a change to the live simulation in the current tick's
    /// journal (while recording).
    pub(super) fn journal_push(&mut self, entry: JournalEntry) {
        if self.recorder.is_some() {
            self.journal.push(entry);
        }
    }

    /// Hands the journal entries of `tick` so far to the recorder and the
    /// history.
    pub(super) fn flush_journal(&mut self, tick: u64, meter: &TickMeter) {
        if self.journal.is_empty() {
            return;
        }
        let entries = std::mem::take(&mut self.journal);
        let bytes = crate::replay::journal::encode(tick, &entries);
        let record = Record::Journal {
            tick,
            entries: bytes,
        };
        if self.send(record, tick, meter) {
            self.journal_at_tick += entries.len() as u32;
            if let Some(h) = &mut self.history {
                h.add_journal(tick, &entries);
            }
        }
    }

    /// The records of tick `tick`, just run, whose state hash is `hash`:
    /// the hash, then a keyframe or an in-memory checkpoint when one is
    /// due (of `capture(0)`).
    pub(super) fn record_tick(
        &mut self,
        tick: u64,
        hash: u64,
        meter: &TickMeter,
        capture: impl FnOnce(u32) -> SimState,
    ) {
        self.journal_at_tick = 0;
        let Some(recorder) = &self.recorder else {
            return;
        };
        let keyframe_ticks = recorder.config().keyframe_ticks.max(1);
        if !self.send(Record::TickHash { tick, hash }, tick, meter) {
            return;
        }
        if let Some(h) = &mut self.history {
            h.add_hash(tick, hash);
        }
        let checkpoint_ticks = self.checkpoint_ticks;
        if tick % keyframe_ticks == 0 {
            let state = Arc::new(capture(0).encode());
            let record = Record::Keyframe {
                tick,
                state: state.as_ref().clone(),
            };
            if self.send(record, tick, meter) {
                if let Some(h) = &mut self.history {
                    h.add_keyframe(tick, 0, state);
                }
            }
        } else if checkpoint_ticks > 0 && tick % checkpoint_ticks == 0 {
            let state = capture(0).encode();
            if let Some(h) = &mut self.history {
                h.add_checkpoint(tick, state);
            }
        }
    }
}

impl Simulation {
    /// Whether this tick's state is being recorded.
    pub fn recording(&self) -> bool {
        self.recording.is_on()
    }

    /// The recorder, while recording.
    pub fn recorder(&self) -> Option<&Recorder> {
        self.recording.recorder.as_ref()
    }

    /// Where recordings go, if this simulation can record.
    pub fn recording_config(&self) -> Option<&RecorderConfig> {
        self.recording.config.as_ref()
    }

    /// The recording held in memory for seeking, if any.
    pub fn history(&self) -> Option<&History> {
        self.recording.history.as_ref()
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
        let tick = self.shown().world.tick();
        let live = self.timelines.is_live();
        self.recording.prepare(tick, live)
    }

    /// The second half: starts the session on the recorder opened (or
    /// reports why it could not be).
    pub fn adopt_recorder(&mut self, recorder: Result<Recorder, String>) -> Result<(), String> {
        let tick = self.shown().world.tick();
        let start = Record::SessionStart {
            tick,
            tick_hz: self.config.tick_hz,
            scene: self.scene_name.clone(),
        };
        let (timelines, rules) = (&self.timelines, &*self.rules);
        self.recording
            .adopt(recorder, tick, timelines.is_live(), start, |applied| {
                super::capture(timelines.shown(), rules, applied)
            })
    }

    /// Stops recording (the recorder thread writes out and syncs what it
    /// has on its own; the tick thread does not wait for it).
    pub fn stop_recording(&mut self) {
        self.recording.stop();
    }

    /// Ends the recording with a keyframe of the current tick and waits
    /// until everything is on disk (shutdown).
    pub fn finish_recording(&mut self) {
        if !self.timelines.is_live() {
            self.go_live();
        }
        self.flush_journal();
        let last = self.recording.is_on().then(|| {
            let tick = self.shown().world.tick();
            let state = self.capture(self.recording.handed_at_tick()).encode();
            tracing::info!(tick, "recording ended with a keyframe");
            Record::Keyframe { tick, state }
        });
        self.recording.finish(last);
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
            let recording = self.recording.is_on();
            self.finish_recording();
            return recording;
        }
        if self.recording.is_on() {
            tracing::warn!(
                tick = self.shown().world.tick(),
                "recording ended without a keyframe: the failure cut a tick short"
            );
        }
        self.recording.finish(None);
        false
    }

    /// Records an administrator's edit of the world at the current tick
    /// (`who` the operator, `what` a short description).
    pub fn record_admin_edit(&mut self, who: &str, what: &str) {
        let tick = self.shown().world.tick();
        let record = Record::AdminEdit {
            tick,
            who: who.to_string(),
            what: what.as_bytes().to_vec(),
        };
        self.recording.send(record, tick, &self.meter);
    }

    /// Notes a change to the live simulation in the current tick's journal
    /// (while recording live).
    pub(super) fn journal_push(&mut self, entry: JournalEntry) {
        if self.timelines.is_live() {
            self.recording.journal_push(entry);
        }
    }

    /// Hands the current tick's journal entries so far to the recorder
    /// and the history.
    pub fn flush_journal(&mut self) {
        let tick = self.shown().world.tick();
        self.recording.flush_journal(tick, &self.meter);
    }
}
