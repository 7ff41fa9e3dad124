//! What the first ticks cost against the tick budget, said once when the
//! server starts: a scene too heavy for the machine (100 000 bodies on two
//! cores steps under two ticks a second) would otherwise run slower than
//! real time with nothing in the log to say why.
//!
//! Sans-IO: the tick thread feeds each tick's duration to
//! [`TickCostCheck::observe`], which gives its verdict once, after
//! [`STARTUP_TICKS`] ticks; the simulation logs it.

use std::time::Duration;

/// Ticks measured before the verdict. The median of these is taken, so
/// the first tick's one-off costs (allocating contact caches, building
/// the broad phase) do not decide it.
pub const STARTUP_TICKS: usize = 10;

/// The verdict on the first ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TickCost {
    /// Ticks measured.
    pub ticks: usize,
    /// Their median duration.
    pub median: Duration,
    /// The longest of them.
    pub max: Duration,
    /// The tick budget: one tick interval of simulated time at the
    /// configured rate (1/tick_hz s).
    pub budget: Duration,
}

impl TickCost {
    /// The median tick's share of the budget (1.0: all of it).
    pub fn share(&self) -> f64 {
        self.median.as_secs_f64() / self.budget.as_secs_f64()
    }

    /// Whether a median tick takes longer than the budget: the simulation
    /// cannot keep real time on this machine.
    pub fn over_budget(&self) -> bool {
        self.median > self.budget
    }

    /// Ticks a second this machine can step at the median cost, Hz.
    pub fn sustainable_hz(&self) -> f64 {
        1.0 / self.median.as_secs_f64().max(1e-9)
    }
}

/// Collects the first [`STARTUP_TICKS`] tick durations.
#[derive(Debug, Clone)]
pub struct TickCostCheck {
    budget: Duration,
    seen: Vec<Duration>,
    verdict: Option<TickCost>,
}

impl TickCostCheck {
    /// A check against the budget of `tick_hz` ticks a second.
    pub fn new(tick_hz: u32) -> Self {
        Self {
            budget: Duration::from_secs_f64(1.0 / f64::from(tick_hz.max(1))),
            seen: Vec::with_capacity(STARTUP_TICKS),
            verdict: None,
        }
    }

    /// Feeds one tick's duration; gives the verdict once, on the
    /// [`STARTUP_TICKS`]th tick, and `None` before and after.
    pub fn observe(&mut self, tick: Duration) -> Option<TickCost> {
        if self.verdict.is_some() {
            return None;
        }
        self.seen.push(tick);
        if self.seen.len() < STARTUP_TICKS {
            return None;
        }
        let mut sorted = std::mem::take(&mut self.seen);
        sorted.sort_unstable();
        let verdict = TickCost {
            ticks: sorted.len(),
            median: sorted[sorted.len() / 2],
            max: sorted[sorted.len() - 1],
            budget: self.budget,
        };
        self.verdict = Some(verdict);
        Some(verdict)
    }

    /// The verdict, once given.
    pub fn verdict(&self) -> Option<TickCost> {
        self.verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn issue_11_verdict_comes_once_after_the_startup_ticks() {
        let mut check = TickCostCheck::new(100);
        for _ in 0..STARTUP_TICKS - 1 {
            assert_eq!(check.observe(ms(1)), None);
        }
        let cost = check
            .observe(ms(1))
            .expect("the verdict on the last startup tick");
        assert_eq!(cost.ticks, STARTUP_TICKS);
        assert_eq!(cost.budget, ms(10));
        assert!(!cost.over_budget());
        assert!((cost.share() - 0.1).abs() < 1e-9);
        assert_eq!(check.observe(ms(500)), None, "said once");
        assert_eq!(check.verdict(), Some(cost));
    }

    #[test]
    fn issue_11_a_slow_first_tick_alone_is_not_over_budget() {
        let mut check = TickCostCheck::new(60);
        let mut verdict = check.observe(ms(900));
        for _ in 1..STARTUP_TICKS {
            verdict = check.observe(ms(2));
        }
        let cost = verdict.expect("a verdict");
        assert_eq!(cost.median, ms(2));
        assert_eq!(cost.max, ms(900));
        assert!(!cost.over_budget());
    }

    #[test]
    fn issue_11_ticks_over_the_budget_say_the_rate_the_machine_keeps() {
        let mut check = TickCostCheck::new(60);
        let mut verdict = None;
        for _ in 0..STARTUP_TICKS {
            verdict = check.observe(ms(580));
        }
        let cost = verdict.expect("a verdict");
        assert!(cost.over_budget());
        assert!((cost.sustainable_hz() - 1.0 / 0.58).abs() < 1e-6);
        assert!(cost.share() > 34.0);
    }
}
