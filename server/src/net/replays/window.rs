//! The recent past a server keeps for players' replays: the frames it
//! published, quantized as the live clients were sent them, one per
//! snapshot slot, for the last few seconds and within a memory budget.
//!
//! A replay shows what was live, exactly: the same quantized states every
//! client was coded from at those ticks (Overwatch's kill cam likewise
//! replays recorded replicated state rather than the simulation: "Replay
//! Technology in Overwatch", GDC 2017). Re-simulating from a checkpoint
//! would cost a 1000-body world's tick per replayed tick for every
//! viewer; a held frame costs its columns' memory (about 70 bytes an
//! entity that moves) and nothing to show again.

use std::collections::VecDeque;
use std::sync::Arc;

use inertia_protocol::snapshot::QuantizedFrame;

/// The frames held for replays, oldest first, by ascending tick.
#[derive(Debug)]
pub struct ReplayWindow {
    frames: VecDeque<Arc<QuantizedFrame>>,
    /// The memory the frames take, bytes.
    bytes: usize,
    /// The most ticks between the oldest and the newest frame held.
    max_ticks: u64,
    /// The most memory the frames may take, bytes.
    max_bytes: usize,
}

impl ReplayWindow {
    /// A window of at most `max_ticks` ticks and `max_bytes` bytes
    /// (0 ticks: it holds nothing, and replays are refused).
    pub fn new(max_ticks: u64, max_bytes: usize) -> Self {
        Self {
            frames: VecDeque::new(),
            bytes: 0,
            max_ticks,
            max_bytes,
        }
    }

    /// Whether it holds anything at all (a window of 0 ticks never does).
    pub fn enabled(&self) -> bool {
        self.max_ticks > 0
    }

    /// The longest stretch it holds, ticks.
    pub fn max_ticks(&self) -> u64 {
        self.max_ticks
    }

    /// Keeps `frame`, a live frame just served, dropping the frames that
    /// leave the window (by age, then by memory). A frame of a tick not
    /// after the newest held is the live timeline moving back (a loaded
    /// checkpoint, a reset): what was held is no longer its past, and
    /// goes.
    pub fn push(&mut self, frame: &QuantizedFrame) {
        if !self.enabled() {
            return;
        }
        if let Some(newest) = self.newest() {
            if frame.tick == newest {
                return;
            }
            if frame.tick < newest {
                self.clear();
            }
        }
        let frame = Arc::new(frame.clone());
        self.bytes += frame.heap_bytes();
        self.frames.push_back(frame);
        let newest = self.newest().unwrap_or(0);
        while self.frames.len() > 1
            && (self.frames[0].tick + self.max_ticks < newest || self.bytes > self.max_bytes)
        {
            self.pop_oldest();
        }
    }

    fn pop_oldest(&mut self) {
        if let Some(f) = self.frames.pop_front() {
            self.bytes -= f.heap_bytes();
        }
    }

    /// Forgets every frame.
    pub fn clear(&mut self) {
        self.frames.clear();
        self.bytes = 0;
    }

    /// The oldest tick held.
    pub fn oldest(&self) -> Option<u64> {
        self.frames.front().map(|f| f.tick)
    }

    /// The newest tick held.
    pub fn newest(&self) -> Option<u64> {
        self.frames.back().map(|f| f.tick)
    }

    /// The memory the frames take, bytes.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// How many frames it holds.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether it holds no frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The newest frame at or before `tick`.
    pub fn at_or_before(&self, tick: u64) -> Option<&Arc<QuantizedFrame>> {
        let after = self.frames.partition_point(|f| f.tick <= tick);
        after.checked_sub(1).map(|i| &self.frames[i])
    }

    /// The oldest frame at or after `tick`.
    pub fn at_or_after(&self, tick: u64) -> Option<&Arc<QuantizedFrame>> {
        let i = self.frames.partition_point(|f| f.tick < tick);
        self.frames.get(i)
    }

    /// The first frame after `tick`.
    pub fn after(&self, tick: u64) -> Option<&Arc<QuantizedFrame>> {
        let i = self.frames.partition_point(|f| f.tick <= tick);
        self.frames.get(i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};
    use inertia_protocol::snapshot::SnapshotConfig;
    use inertia_protocol::EntityState;

    fn frame(tick: u64, n: u32) -> QuantizedFrame {
        let states: Vec<EntityState> = (1..=n)
            .map(|id| EntityState {
                id,
                position: DVec3::new(f64::from(id), 1.0, 0.0),
                rotation: DQuat::IDENTITY,
                linear_velocity: DVec3::ZERO,
                angular_velocity: DVec3::ZERO,
                asleep: false,
            })
            .collect();
        QuantizedFrame::new(tick, 1.0, false, &states, &SnapshotConfig::default())
    }

    #[test]
    fn it_keeps_the_last_ticks_within_its_memory_and_finds_frames_by_tick() {
        let mut w = ReplayWindow::new(100, usize::MAX);
        for t in (0..400).step_by(2) {
            w.push(&frame(t, 10));
        }
        assert_eq!((w.oldest(), w.newest()), (Some(298), Some(398)));
        assert_eq!(w.at_or_before(301).map(|f| f.tick), Some(300));
        assert_eq!(w.at_or_after(301).map(|f| f.tick), Some(302));
        assert_eq!(w.after(300).map(|f| f.tick), Some(302));
        assert!(w.at_or_before(200).is_none());
        assert!(w.after(398).is_none());
        // The same tick again (a paused clock) is kept once.
        w.push(&frame(398, 10));
        assert_eq!(w.len(), 51);

        let one = frame(0, 100).heap_bytes();
        let mut small = ReplayWindow::new(1000, one * 5);
        for t in 0..20 {
            small.push(&frame(t, 100));
        }
        assert_eq!(small.len(), 5);
        assert!(small.bytes() <= one * 5);
        assert_eq!(small.oldest(), Some(15));
    }

    #[test]
    fn a_live_timeline_moving_back_forgets_what_was_its_past() {
        let mut w = ReplayWindow::new(100, usize::MAX);
        for t in 10..20 {
            w.push(&frame(t, 1));
        }
        w.push(&frame(5, 1));
        assert_eq!((w.oldest(), w.newest(), w.len()), (Some(5), Some(5), 1));
        let mut off = ReplayWindow::new(0, usize::MAX);
        off.push(&frame(1, 1));
        assert!(off.is_empty() && !off.enabled());
    }
}
