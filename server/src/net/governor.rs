//! Degrading by policy: when the server cannot serve every client at its
//! full snapshot rate, some clients get half the rate, chosen by a stated
//! order, before the tick overruns or every client starts missing slots.
//!
//! The snapshot stage measures each slot: the wall time it took to serve
//! (which grows when the machine is short of cores, since the stage runs
//! below the tick thread's priority) and the last tick's duration, each
//! as a share of its period, smoothed over the last few slots
//! ([`SMOOTHING`]), each counting for at most [`MAX_SAMPLE_LOAD`] of its
//! period, so that one slow tick or one preempted slot does not count.
//! The load is *over* when serving takes more than [`STAGE_SHARE`] of the
//! snapshot period (slots would soon be missed, for every client alike)
//! or the tick more than [`TICK_SHARE`] of its budget while serving takes
//! at least [`STAGE_FLOOR`] of the period (below it, lowering rates would
//! free too little to speed the tick); then another step of clients
//! ([`STEP_FRACTION`] of them, at least one) goes to half rate at once. Only after [`CALM_SLOTS`] slots in a row that
//! were *calm* (under [`CALM_FRACTION`] of those shares) does a step come
//! back, so the rate does not flap; while it stays calm, another step
//! comes back every [`RESTORE_EVERY`] slots, so that a burst (a wave of
//! handshakes, say) costs clients their rate for seconds, not minutes. A
//! world whose own tick nears its budget lowers rates too, while the
//! encoders take a share of the cores worth freeing for it.
//!
//! Which clients go first ([`degrade_rank`]): spectators (no avatar)
//! before players, and among each, the newest connection first, so the
//! players who have been in the match longest keep their rate longest.
//! A client at half rate is served in every other slot, half of them in
//! even slots and half in odd ones, so the slots stay level.
//!
//! [`RateGovernor`] is plain state with no clock or socket: the stage
//! feeds it durations, and the tests drive it the same way.

use std::time::Duration;

/// Most of the snapshot period that serving one slot may take before the
/// governor lowers rates.
pub const STAGE_SHARE: f64 = 0.85;
/// Most of the tick budget (1 / tick rate) the last tick may take before
/// the governor lowers rates.
pub const TICK_SHARE: f64 = 0.8;
/// The least share of the snapshot period serving must take for a slow
/// tick to lower rates: below it the encoders use too little of the cores
/// for lowering their work to speed the tick.
pub const STAGE_FLOOR: f64 = 0.2;
/// Slots in a row under [`CALM_FRACTION`] of the shares before a step of
/// clients gets its full rate back (1 s at 30 Hz).
pub const CALM_SLOTS: u32 = 30;
/// While calm goes on, slots between further steps back.
pub const RESTORE_EVERY: u32 = 5;
/// A slot is calm under this fraction of [`STAGE_SHARE`] and
/// [`TICK_SHARE`].
pub const CALM_FRACTION: f64 = 0.7;
/// Weight of the newest slot in the smoothed loads (an exponential
/// moving average over about 1 / SMOOTHING slots).
pub const SMOOTHING: f64 = 0.2;
/// The most one slot's serving time, or one tick's time, counts for in
/// the smoothed loads, as a share of its period: three slots this long in
/// a row put the load over [`STAGE_SHARE`]; one does not.
pub const MAX_SAMPLE_LOAD: f64 = 2.0;
/// The share of the clients one step moves.
pub const STEP_FRACTION: f64 = 0.1;
/// The slot divisor of a degraded client: served every second slot.
pub const DEGRADED_EVERY: u32 = 2;
/// Slots after a step down before the next one, unless a slot already
/// takes the whole period: a step shows in the smoothed load only after
/// its clients have skipped a slot and the average has caught up, and
/// stepping on every slot until then lowered several steps for an
/// overload one would have cured (then took seconds to give them back).
pub const SETTLE_SLOTS: u32 = DEGRADED_EVERY + 5;

/// How many clients are served at a lower rate, and when that changes.
#[derive(Debug, Clone)]
pub struct RateGovernor {
    /// The snapshot period, s.
    period: f64,
    /// The tick budget, s.
    tick_budget: f64,
    /// Smoothed serving time over the period, and tick over its budget.
    stage_load: f64,
    tick_load: f64,
    /// Clients at the lower rate now.
    degraded: usize,
    /// Calm slots in a row so far.
    calm: u32,
    /// Slots still to wait after a step down before another.
    settling: u32,
}

/// What the governor decided after a slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// Keep the rates as they are.
    Hold,
    /// More clients go to the lower rate.
    Degrade,
    /// Fewer clients stay at the lower rate.
    Restore,
}

impl RateGovernor {
    /// A governor for `snapshot_hz` slots a second and `tick_hz` ticks,
    /// with every client at its full rate.
    pub fn new(snapshot_hz: u32, tick_hz: u32) -> Self {
        Self {
            period: 1.0 / f64::from(snapshot_hz.max(1)),
            tick_budget: 1.0 / f64::from(tick_hz.max(1)),
            stage_load: 0.0,
            tick_load: 0.0,
            degraded: 0,
            calm: 0,
            settling: 0,
        }
    }

    /// Clients to serve at the lower rate now.
    pub fn degraded(&self) -> usize {
        self.degraded
    }

    /// After a slot that took `serving` to serve `clients` clients, with
    /// the last tick at `tick`: moves a step of clients to or from the
    /// lower rate, and says which.
    pub fn after_slot(&mut self, serving: Duration, tick: Duration, clients: usize) -> Decision {
        // One slot or tick counts for at most MAX_SAMPLE_LOAD of its
        // period: a single stall (the host, a page fault storm) cannot
        // push the average over alone, as a run of them does.
        let smooth = |load: f64, now: f64| load + SMOOTHING * (now.min(MAX_SAMPLE_LOAD) - load);
        self.stage_load = smooth(self.stage_load, serving.as_secs_f64() / self.period);
        self.tick_load = smooth(self.tick_load, tick.as_secs_f64() / self.tick_budget);
        let (stage, tick) = (self.stage_load, self.tick_load);
        let step = ((clients as f64 * STEP_FRACTION).ceil() as usize).max(1);
        self.degraded = self.degraded.min(clients);
        let settled = self.settling == 0;
        self.settling = self.settling.saturating_sub(1);
        // The tick counts only while the encoders take a share of the
        // cores worth freeing: halving the rates of clients that cost a
        // few percent of a core does nothing for a tick slow on its own
        // (a heavy world, a busy neighbour), and cost every client its
        // rate at 50 clients on a machine three-quarters idle.
        let tick_over = tick > TICK_SHARE && stage >= STAGE_FLOOR;
        let tick_calm = tick < TICK_SHARE * CALM_FRACTION || stage < STAGE_FLOOR * CALM_FRACTION;
        if stage > STAGE_SHARE || tick_over {
            self.calm = 0;
            // A slot longer than the period is late already: no waiting.
            let late = serving.as_secs_f64() > self.period;
            if self.degraded < clients && (settled || late) {
                self.degraded = (self.degraded + step).min(clients);
                self.settling = SETTLE_SLOTS;
                return Decision::Degrade;
            }
            return Decision::Hold;
        }
        if stage < STAGE_SHARE * CALM_FRACTION && tick_calm {
            self.calm += 1;
        } else {
            self.calm = 0;
        }
        if self.calm >= CALM_SLOTS && self.degraded > 0 {
            // The next step back comes RESTORE_EVERY calm slots later.
            self.calm = CALM_SLOTS - RESTORE_EVERY;
            self.degraded = self.degraded.saturating_sub(step);
            return Decision::Restore;
        }
        Decision::Hold
    }
}

/// One client as the policy sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Candidate {
    /// The connection's number (higher: connected later).
    pub connection: u64,
    /// Whether the client plays (has an avatar) or only watches.
    pub plays: bool,
}

/// Where a client stands in the order clients lose their full rate in
/// (lower first): spectators, then players; the newest connection first
/// in each.
pub fn degrade_rank(c: &Candidate) -> (bool, std::cmp::Reverse<u64>) {
    (c.plays, std::cmp::Reverse(c.connection))
}

/// The slot divisor and phase for the client at `rank` by
/// [`degrade_rank`] when `degraded` clients are at the lower rate:
/// `(1, 0)` for full rate, else `(DEGRADED_EVERY, phase)` with phases
/// alternating so the degraded clients split between the slots.
pub fn rate_for(rank: usize, degraded: usize) -> (u32, u32) {
    if rank < degraded {
        (DEGRADED_EVERY, (rank % DEGRADED_EVERY as usize) as u32)
    } else {
        (1, 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    /// Feeds the same slot until the governor acts; returns the decision
    /// and how many slots that took.
    fn until_acted(
        g: &mut RateGovernor,
        serving: Duration,
        tick: Duration,
        n: usize,
    ) -> (Decision, usize) {
        for slots in 1..=1000 {
            let d = g.after_slot(serving, tick, n);
            if d != Decision::Hold {
                return (d, slots);
            }
        }
        (Decision::Hold, 1000)
    }

    #[test]
    fn sustained_overload_degrades_step_by_step_and_calm_restores_slowly() {
        let mut g = RateGovernor::new(30, 60);
        // 33 ms slots: 32 ms of serving is over 85 %, soon (smoothed).
        let (d, slots) = until_acted(&mut g, 32 * MS, 2 * MS, 200);
        assert_eq!(d, Decision::Degrade);
        assert!((3..=12).contains(&slots), "{slots}");
        assert_eq!(g.degraded(), 20);
        // Still over: the next step comes once the first has had time to
        // show.
        let (d, slots) = until_acted(&mut g, 32 * MS, 2 * MS, 200);
        assert_eq!((d, slots), (Decision::Degrade, SETTLE_SLOTS as usize + 1));
        assert_eq!(g.degraded(), 40);
        // Between the calm share and the share: held, not calm (once the
        // smoothed load has come down from above the share).
        for _ in 0..10 {
            g.after_slot(25 * MS, 2 * MS, 200);
        }
        let held = g.degraded();
        for _ in 0..(4 * CALM_SLOTS) {
            assert_eq!(g.after_slot(25 * MS, 2 * MS, 200), Decision::Hold);
        }
        // Calm: one step back after CALM_SLOTS calm slots (the smoothed
        // load takes a few slots to fall under the calm share), then one
        // every RESTORE_EVERY slots.
        let (d, slots) = until_acted(&mut g, 2 * MS, 2 * MS, 200);
        assert_eq!(d, Decision::Restore);
        assert!(slots >= CALM_SLOTS as usize, "{slots}");
        assert_eq!(g.degraded(), held - 20);
        let (d, slots) = until_acted(&mut g, 2 * MS, 2 * MS, 200);
        assert_eq!((d, slots), (Decision::Restore, RESTORE_EVERY as usize));
        assert_eq!(g.degraded(), held - 40);
    }

    #[test]
    fn tick_spikes_on_a_quiet_server_do_not_hold_rates_down() {
        let mut g = RateGovernor::new(30, 60);
        g.after_slot(40 * MS, 4 * MS, 100);
        for _ in 0..10 {
            g.after_slot(40 * MS, 4 * MS, 100);
        }
        assert!(g.degraded() > 0);
        // A 4 ms tick with a 23 ms one every fiftieth slot: calm enough.
        for slot in 0..300 {
            let tick = if slot % 50 == 0 { 23 * MS } else { 4 * MS };
            g.after_slot(3 * MS, tick, 100);
        }
        assert_eq!(g.degraded(), 0);
    }

    #[test]
    fn one_slow_tick_or_slot_does_not_degrade() {
        let mut g = RateGovernor::new(30, 60);
        for _ in 0..30 {
            assert_eq!(g.after_slot(5 * MS, 3 * MS, 100), Decision::Hold);
        }
        assert_eq!(g.after_slot(5 * MS, 25 * MS, 100), Decision::Hold);
        assert_eq!(g.after_slot(45 * MS, 3 * MS, 100), Decision::Hold);
        assert_eq!(g.degraded(), 0);
    }

    #[test]
    fn a_tick_near_its_budget_degrades_while_the_encoders_take_a_share_worth_freeing() {
        let mut g = RateGovernor::new(30, 60);
        // 16.7 ms budget: 15 ms is over 80 %; serving takes 10 ms of 33.
        let (d, _) = until_acted(&mut g, 10 * MS, 15 * MS, 5);
        assert_eq!(d, Decision::Degrade);
        assert_eq!(g.degraded(), 1, "at least one client a step");
    }

    #[test]
    fn issue_12_a_slow_tick_does_not_lower_rates_when_the_encoders_take_little() {
        let mut g = RateGovernor::new(30, 60);
        // Serving takes 3 ms of 33: halving rates would free next to
        // nothing for a tick that is slow on its own.
        for _ in 0..300 {
            assert_eq!(g.after_slot(3 * MS, 15 * MS, 50), Decision::Hold);
        }
        assert_eq!(g.degraded(), 0);
        // Clients lowered while serving was heavy come back once it is
        // light, though the tick stays slow.
        let (d, _) = until_acted(&mut g, 32 * MS, 15 * MS, 50);
        assert_eq!(d, Decision::Degrade);
        let (d, _) = until_acted(&mut g, 2 * MS, 15 * MS, 50);
        assert_eq!(d, Decision::Restore);
    }

    #[test]
    fn issue_12_an_overload_one_step_cures_lowers_one_step_not_many() {
        let mut g = RateGovernor::new(30, 60);
        // 30 ms of a 33 ms slot: over the share until a step lowers it.
        let (d, _) = until_acted(&mut g, 30 * MS, 2 * MS, 100);
        assert_eq!(d, Decision::Degrade);
        // The step brings serving down to 25 ms, under the share, once its
        // clients have skipped a slot (two slots on); the smoothed load
        // takes a few more to follow, and no further step comes meanwhile.
        for _ in 0..DEGRADED_EVERY {
            g.after_slot(30 * MS, 2 * MS, 100);
        }
        for _ in 0..60 {
            g.after_slot(25 * MS, 2 * MS, 100);
        }
        assert_eq!(g.degraded(), 10, "one step of a tenth");
    }

    #[test]
    fn issue_12_one_stalled_slot_does_not_degrade() {
        let mut g = RateGovernor::new(30, 60);
        for _ in 0..30 {
            g.after_slot(3 * MS, 4 * MS, 50);
        }
        // The stage's thread lost its core for 150 ms once (the host, a
        // page fault storm): one slot, not an overload.
        assert_eq!(g.after_slot(150 * MS, 4 * MS, 50), Decision::Hold);
        for _ in 0..30 {
            assert_eq!(g.after_slot(3 * MS, 4 * MS, 50), Decision::Hold);
        }
        // Stalled slot after stalled slot is one.
        let (d, slots) = until_acted(&mut g, 150 * MS, 4 * MS, 50);
        assert_eq!(d, Decision::Degrade);
        assert!(slots <= 3, "{slots}");
    }

    #[test]
    fn the_degraded_never_exceed_the_clients() {
        let mut g = RateGovernor::new(30, 60);
        for _ in 0..30 {
            g.after_slot(40 * MS, 2 * MS, 7);
        }
        assert_eq!(g.degraded(), 7);
        assert_eq!(g.after_slot(40 * MS, 2 * MS, 7), Decision::Hold);
        // Clients left: the count follows.
        g.after_slot(10 * MS, 2 * MS, 3);
        assert_eq!(g.degraded(), 3);
    }

    #[test]
    fn spectators_then_the_newest_players_lose_their_rate_first() {
        let mut clients = [
            Candidate {
                connection: 1,
                plays: true,
            },
            Candidate {
                connection: 2,
                plays: false,
            },
            Candidate {
                connection: 3,
                plays: true,
            },
            Candidate {
                connection: 4,
                plays: false,
            },
        ];
        clients.sort_unstable_by_key(degrade_rank);
        let order: Vec<u64> = clients.iter().map(|c| c.connection).collect();
        assert_eq!(order, [4, 2, 3, 1]);
        let rates: Vec<(u32, u32)> = (0..4).map(|r| rate_for(r, 3)).collect();
        assert_eq!(rates, [(2, 0), (2, 1), (2, 0), (1, 0)]);
    }
}
