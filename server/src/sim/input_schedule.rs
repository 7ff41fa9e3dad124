//! Inputs applied on the tick they are for.
//!
//! A client stamps each input with the tick it wants it applied at: the
//! SDK runs ahead of the server by the round trip plus a margin (see
//! `inertia_client::lead`), so an input normally arrives a tick or more
//! before its tick. The [`InputSchedule`] holds each client's inputs until
//! their tick comes, and the tick thread hands them to the game rules at
//! the start of that tick, in order. The world then moves the same way
//! whatever the network did to the datagrams on their way, as long as
//! each input arrived in time.
//!
//! - **Late**: an input whose tick has already been stepped is applied at
//!   once (at the start of the next tick) and counted.
//! - **Too early**: an input more than [`ScheduleConfig::max_ahead`] ticks
//!   ahead is refused and counted (a client whose clock ran away cannot
//!   park inputs for minutes).
//! - **Too late**: an input more than [`ScheduleConfig::max_behind`] ticks
//!   behind is refused and counted (it would move a player on a world
//!   long gone).
//!
//! The schedule is the one place that checks an input's tick against the
//! server's: the rules see only inputs within this window.
//! - **Order**: inputs arrive in sequence order (the session's
//!   `InputBuffer` sees to that). Each client's effective ticks never go
//!   backwards: an input stamped earlier than the one before it is held
//!   to that one's tick, so a later input never overtakes an earlier one.
//! - **Bounded**: at most [`ScheduleConfig::max_pending`] inputs wait per
//!   client; more are refused and counted.
//!
//! Nothing here reads a clock: the tick thread passes the tick it is at.
//! Inputs enter the recording's journal when they are applied (at their
//! tick), so a replay applies them at the same tick without this schedule.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use inertia_protocol::control::InputReport;
use inertia_protocol::PlayerInput;

use crate::rules::ClientId;

/// How far from the server's tick inputs may be, and how many may wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScheduleConfig {
    /// The furthest ahead of the server's tick an input may be, ticks.
    pub max_ahead: u64,
    /// The furthest behind the server's tick an input may be, ticks.
    pub max_behind: u64,
    /// The most inputs one client may have waiting.
    pub max_pending: usize,
}

impl ScheduleConfig {
    /// Inputs up to one second ahead and two seconds behind at `tick_hz`,
    /// and up to two seconds' worth waiting per client.
    pub fn for_tick_rate(tick_hz: u32) -> Self {
        let ahead = u64::from(tick_hz.max(1));
        Self {
            max_ahead: ahead,
            max_behind: 2 * ahead,
            max_pending: (2 * ahead as usize).max(16),
        }
    }
}

/// What [`InputSchedule::offer`] did with an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Offered {
    /// Held until its tick.
    Held,
    /// Its tick has passed: apply it now.
    Late,
    /// Refused (counted): more than [`ScheduleConfig::max_ahead`] ticks
    /// ahead.
    TooEarly,
    /// Refused (counted): more than [`ScheduleConfig::max_behind`] ticks
    /// behind.
    TooLate,
    /// Refused (counted): [`ScheduleConfig::max_pending`] inputs of this
    /// client are waiting already.
    Full,
}

#[derive(Debug, Clone, Default)]
struct ClientInputs {
    /// Waiting inputs in the order they arrived, with their effective
    /// ticks (non-decreasing).
    pending: VecDeque<(u64, PlayerInput)>,
    /// The effective tick of the newest input taken.
    last_tick: Option<u64>,
    timing: InputReport,
    /// The least lead in the window under way, ticks.
    window_min_lead: Option<i32>,
}

/// Every client's inputs waiting for their ticks.
#[derive(Debug, Clone)]
pub struct InputSchedule {
    config: ScheduleConfig,
    clients: BTreeMap<ClientId, ClientInputs>,
    /// Every client's report as of the last window's end, shared with
    /// the frames published until the next (made once a window, not once
    /// a loop).
    reports: Arc<BTreeMap<ClientId, InputReport>>,
}

impl InputSchedule {
    /// An empty schedule.
    pub fn new(config: ScheduleConfig) -> Self {
        Self {
            config,
            clients: BTreeMap::new(),
            reports: Arc::default(),
        }
    }

    /// How far ahead and how many inputs it holds.
    pub fn config(&self) -> ScheduleConfig {
        self.config
    }

    /// Takes `input` from `client` while the server is at `now` (the tick
    /// the next step starts from).
    pub fn offer(&mut self, client: ClientId, input: &PlayerInput, now: u64) -> Offered {
        let c = self.clients.entry(client).or_default();
        let tick = c.last_tick.map_or(input.tick, |last| input.tick.max(last));
        let lead = tick as i128 - i128::from(now);
        let lead = lead.clamp(i128::from(i32::MIN), i128::from(i32::MAX)) as i32;
        c.window_min_lead = Some(c.window_min_lead.map_or(lead, |m| m.min(lead)));
        if tick > now.saturating_add(self.config.max_ahead) {
            c.timing.refused += 1;
            return Offered::TooEarly;
        }
        if input.tick.saturating_add(self.config.max_behind) < now {
            c.timing.refused += 1;
            return Offered::TooLate;
        }
        if c.pending.len() >= self.config.max_pending {
            c.timing.refused += 1;
            return Offered::Full;
        }
        c.last_tick = Some(tick);
        if tick >= now {
            c.timing.on_time += 1;
        } else {
            c.timing.late += 1;
            if c.pending.is_empty() {
                return Offered::Late;
            }
            // Late behind inputs still waiting (the server was paused):
            // those go first.
        }
        c.pending.push_back((tick, *input));
        Offered::Held
    }

    /// The inputs due at the start of tick `now`, each client's in order,
    /// clients by id: every input whose effective tick is `now` or
    /// earlier.
    pub fn due(&mut self, now: u64) -> Vec<(ClientId, PlayerInput)> {
        let mut out = Vec::new();
        for (&client, c) in &mut self.clients {
            while c.pending.front().is_some_and(|&(tick, _)| tick <= now) {
                if let Some((_, input)) = c.pending.pop_front() {
                    out.push((client, input));
                }
            }
        }
        out
    }

    /// Ends the window of [`InputReport::min_lead`] (the tick thread
    /// does so every second of ticks) and starts the next.
    pub fn end_window(&mut self) {
        for c in self.clients.values_mut() {
            c.timing.min_lead = c.window_min_lead.take();
        }
        self.reports = Arc::new(self.clients.iter().map(|(&id, c)| (id, c.timing)).collect());
    }

    /// The client's timing so far.
    pub fn timing(&self, client: ClientId) -> Option<InputReport> {
        self.clients.get(&client).map(|c| c.timing)
    }

    /// Every client's report as of the last window's end (what the
    /// clients are told, at most once a window).
    pub fn reports(&self) -> Arc<BTreeMap<ClientId, InputReport>> {
        self.reports.clone()
    }

    /// Inputs waiting, all clients together.
    pub fn pending(&self) -> usize {
        self.clients.values().map(|c| c.pending.len()).sum()
    }

    /// Forgets a client that left.
    pub fn forget(&mut self, client: ClientId) {
        self.clients.remove(&client);
    }

    /// Drops every waiting input (the world was replaced: a load or a
    /// restore), keeping the counts.
    pub fn clear_pending(&mut self) {
        for c in self.clients.values_mut() {
            c.pending.clear();
            c.last_tick = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(sequence: u32, tick: u64) -> PlayerInput {
        PlayerInput {
            sequence,
            tick,
            ..PlayerInput::default()
        }
    }

    fn schedule() -> InputSchedule {
        InputSchedule::new(ScheduleConfig {
            max_ahead: 10,
            max_behind: 20,
            max_pending: 4,
        })
    }

    #[test]
    fn inputs_wait_for_their_tick_and_come_out_in_order() {
        let mut s = schedule();
        assert_eq!(s.offer(1, &input(1, 102), 100), Offered::Held);
        assert_eq!(s.offer(1, &input(2, 103), 100), Offered::Held);
        assert_eq!(s.offer(2, &input(7, 102), 101), Offered::Held);
        assert!(s.due(100).is_empty());
        assert!(s.due(101).is_empty());
        let due: Vec<(ClientId, u32)> = s.due(102).iter().map(|(c, i)| (*c, i.sequence)).collect();
        assert_eq!(due, [(1, 1), (2, 7)]);
        assert_eq!(s.due(103)[0].1.sequence, 2);
        assert_eq!(s.pending(), 0);
        assert_eq!(s.timing(1).unwrap().min_lead, None, "no window ended yet");
        s.end_window();
        let t = s.timing(1).unwrap();
        assert_eq!(
            (t.on_time, t.late, t.refused, t.min_lead),
            (2, 0, 0, Some(2))
        );
        s.end_window();
        assert_eq!(
            s.timing(1).unwrap().min_lead,
            None,
            "none in the next window"
        );
    }

    #[test]
    fn a_late_input_is_applied_at_once_and_counted() {
        let mut s = schedule();
        assert_eq!(s.offer(1, &input(1, 95), 100), Offered::Late);
        s.end_window();
        let t = s.timing(1).unwrap();
        assert_eq!((t.late, t.min_lead), (1, Some(-5)));
        // Behind an input still waiting, a late one waits its turn.
        assert_eq!(s.offer(1, &input(2, 104), 100), Offered::Held);
        assert_eq!(s.offer(1, &input(3, 90), 100), Offered::Held);
        assert!(s.due(103).is_empty());
        let due: Vec<u32> = s.due(104).iter().map(|(_, i)| i.sequence).collect();
        assert_eq!(due, [2, 3], "the later one does not overtake");
    }

    #[test]
    fn too_early_and_too_many_are_refused() {
        let mut s = schedule();
        assert_eq!(s.offer(1, &input(1, 111), 100), Offered::TooEarly);
        assert_eq!(s.offer(1, &input(2, u64::MAX), 100), Offered::TooEarly);
        for k in 0..4 {
            assert_eq!(s.offer(1, &input(3 + k, 105), 100), Offered::Held);
        }
        assert_eq!(s.offer(1, &input(9, 105), 100), Offered::Full);
        assert_eq!(s.timing(1).unwrap().refused, 3);
        assert_eq!(s.pending(), 4);
        s.forget(1);
        assert_eq!(s.pending(), 0);
        assert_eq!(s.timing(1), None);
    }

    #[test]
    fn inputs_outside_the_tick_window_are_refused() {
        let mut s = schedule();
        assert_eq!(s.offer(1, &input(1, 79), 100), Offered::TooLate);
        assert_eq!(s.offer(1, &input(2, 80), 100), Offered::Late);
        assert_eq!(s.offer(2, &input(1, 110), 100), Offered::Held);
        assert_eq!(s.offer(2, &input(2, 111), 100), Offered::TooEarly);
        assert_eq!(s.offer(3, &input(1, u64::MAX), u64::MAX - 1), Offered::Held);
        assert_eq!(s.offer(4, &input(1, 0), u64::MAX), Offered::TooLate);
        assert_eq!(s.timing(1).unwrap().refused, 1);
    }

    #[test]
    fn ticks_of_one_client_never_go_backwards() {
        let mut s = schedule();
        s.offer(1, &input(1, 105), 100);
        s.offer(1, &input(2, 103), 100);
        assert!(s.due(104).is_empty(), "held to the tick of the one before");
        assert_eq!(s.due(105).len(), 2);
        s.clear_pending();
        assert_eq!(s.offer(1, &input(3, 101), 100), Offered::Held);
    }
}
