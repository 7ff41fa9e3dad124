//! How far ahead of the server the client stamps its inputs.
//!
//! The server applies each input at the tick it is stamped with, and one
//! that arrives after its tick has passed is applied late (see the
//! server's `sim::input_schedule`). So the client runs ahead: it stamps an
//! input with the tick the server will be at when the input arrives, plus
//! a margin for jitter. From the [`ServerClock`]:
//!
//! ```text
//! target = arrival tick            (the freshest snapshot in hand now, on
//!                                   the minimum-delay envelope)
//!        + round trip × tick rate  (down to us, and the input's way back)
//!        + jitter × tick rate      (how much later than the envelope
//!                                   snapshots arrive, 95th percentile)
//!        + margin                  (ticks, adapted to the server's reports)
//! ```
//!
//! The server reports about once a second how early the inputs of the
//! last second arrived at worst ([`InputReport::min_lead`]). A report of
//! less than [`LeadConfig::wanted_lead`] ticks (late or just in time)
//! raises the margin by the shortfall at once; a report of more than
//! [`LeadConfig::wanted_lead`] + [`LeadConfig::slack`] lowers it by
//! [`LeadConfig::ease`] of the excess, so the client comes back over a
//! few seconds when the network calms down (or once the inputs it made
//! before its clock had settled are behind it).
//!
//! The target never goes backwards, and it never stands still while the
//! server's clock runs: when the wanted target falls (a lower margin, a
//! shorter round trip, a calmer network), the stamped ticks fall behind
//! the server's clock by at most [`LeadConfig::max_slowdown`] of its rate
//! until they meet it. Waiting for the server to catch up instead would
//! stop the inputs, and the predicted avatar with them, for as many ticks
//! as the lead fell (three ticks of margin given back: a 50 ms freeze at
//! 60 Hz). A rising target is taken at once. A report counts the lead
//! still being given back as gone already, so the margin does not fall
//! twice for the same excess.
//!
//! Nothing here reads a clock: times are passed in.

use inertia_protocol::control::InputReport;

use crate::clock::ServerClock;

/// How [`InputLead`] adapts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeadConfig {
    /// The margin to start with, ticks.
    pub initial_margin: f64,
    /// The least margin, ticks.
    pub min_margin: f64,
    /// The most margin, ticks.
    pub max_margin: f64,
    /// How early the worst input of a second should arrive, ticks.
    pub wanted_lead: f64,
    /// How much earlier than wanted is still fine, ticks.
    pub slack: f64,
    /// The share of the excess lead (beyond the wanted lead and the
    /// slack) a report takes off the margin, 0 to 1.
    pub ease: f64,
    /// How much slower than the server's clock the stamped ticks may run
    /// while the lead falls, a share of its rate, 0 to 1 (0.1: a tick of
    /// lead given back every 10 ticks).
    pub max_slowdown: f64,
}

impl Default for LeadConfig {
    fn default() -> Self {
        Self {
            initial_margin: 1.0,
            min_margin: 0.0,
            max_margin: 30.0,
            wanted_lead: 1.0,
            slack: 2.0,
            ease: 0.5,
            max_slowdown: 0.1,
        }
    }
}

/// The newest target and what it was made from.
#[derive(Debug, Clone, Copy)]
struct Stamp {
    /// The arrival tick it was made at (fractional).
    arrival: f64,
    /// The target, fractional (the tick returned is its ceiling).
    target: f64,
    /// How far it was above the wanted target, ticks: lead still being
    /// given back.
    pending: f64,
}

/// The tick to stamp inputs with, and the margin it keeps.
#[derive(Debug, Clone)]
pub struct InputLead {
    config: LeadConfig,
    margin: f64,
    /// The newest target returned, unrounded: targets never go backwards.
    last: Option<Stamp>,
    /// The server's newest report.
    report: Option<InputReport>,
}

impl Default for InputLead {
    fn default() -> Self {
        Self::new(LeadConfig::default())
    }
}

impl InputLead {
    /// A lead starting at `config`'s initial margin.
    pub fn new(config: LeadConfig) -> Self {
        Self {
            margin: config.initial_margin,
            config,
            last: None,
            report: None,
        }
    }

    /// The tick an input made at `local_time` (s) should be applied at;
    /// `None` before the first snapshot. Never less than the last one
    /// returned. While the server is paused the arrival timeline stands
    /// still, and so does the target.
    pub fn target_tick(&mut self, clock: &ServerClock, local_time: f64) -> Option<u64> {
        let arrival = clock.arrival_tick(local_time)?;
        let rate = clock.tick_rate().max(0.0);
        let ahead = rate * (clock.rtt().unwrap_or(0.0) + clock.jitter()) + self.margin;
        let wanted = arrival + ahead;
        let target = match self.last {
            None => wanted,
            Some(last) => {
                // The server's clock ran `arrival - last.arrival` ticks
                // since (none while paused or playing backwards).
                let ran = (arrival - last.arrival).max(0.0);
                let slowest = last.target + ran * (1.0 - self.config.max_slowdown.clamp(0.0, 1.0));
                wanted.max(slowest)
            }
        };
        self.last = Some(Stamp {
            arrival,
            target,
            pending: target - wanted,
        });
        Some(target.ceil().max(0.0) as u64)
    }

    /// Takes the server's report of how the inputs arrived.
    pub fn on_report(&mut self, report: InputReport) {
        self.report = Some(report);
        let Some(min) = report.min_lead else {
            return;
        };
        let c = self.config;
        let min = f64::from(min);
        if min < c.wanted_lead {
            self.margin += c.wanted_lead - min;
        } else {
            let pending = self.last.map_or(0.0, |l| l.pending);
            let excess = min - c.wanted_lead - c.slack - pending;
            if excess > 0.0 {
                self.margin -= c.ease * excess;
            }
        }
        self.margin = self.margin.clamp(c.min_margin, c.max_margin);
    }

    /// Forgets the last target: the server's timeline jumped (a seek, a
    /// load), and ticks may now run from elsewhere.
    pub fn restart(&mut self) {
        self.last = None;
    }

    /// The margin kept now, ticks.
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// The server's newest report of how the inputs arrived.
    pub fn report(&self) -> Option<InputReport> {
        self.report
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::SnapshotMeta;

    fn clock_at_tick_100() -> ServerClock {
        let mut clock = ServerClock::new(60.0);
        // Snapshots every 2 ticks at exactly their time: tick 100 at t = 1.
        for k in 0..=20u64 {
            let tick = 60 + 2 * k;
            let t = tick as f64 / 60.0 - 2.0 / 3.0;
            clock.observe(
                t,
                SnapshotMeta {
                    seq: Some(k as u16),
                    tick,
                    time_scale: 1.0,
                    paused: false,
                },
            );
        }
        clock.rtt_sample(0.1);
        clock
    }

    #[test]
    fn the_target_is_a_round_trip_and_a_margin_ahead_of_arrivals() {
        let clock = clock_at_tick_100();
        let mut lead = InputLead::default();
        let arrival = clock.arrival_tick(1.0).unwrap();
        assert!((arrival - 100.0).abs() < 0.5, "{arrival}");
        // 100 ms is 6 ticks at 60 Hz, then the jitter and a margin of 1.
        let target = lead.target_tick(&clock, 1.0).unwrap();
        let jitter = clock.jitter() * 60.0;
        assert!(jitter < 1.0, "{jitter}");
        assert_eq!(target, (arrival + 7.0 + jitter).ceil() as u64);
        // Never backwards, even asked about an earlier moment.
        assert_eq!(lead.target_tick(&clock, 0.9), Some(target));
    }

    #[test]
    fn issue_17_a_falling_lead_slows_the_inputs_instead_of_stopping_them() {
        let clock = clock_at_tick_100();
        let mut lead = InputLead::default();
        let report = |min_lead| InputReport {
            min_lead: Some(min_lead),
            ..InputReport::default()
        };
        lead.on_report(report(-3));
        assert_eq!(lead.margin(), 5.0);
        let mut t = 1.0;
        let mut last = lead.target_tick(&clock, t).unwrap();
        // Nine ticks early: six beyond the slack, half of it off.
        lead.on_report(report(9));
        assert_eq!(lead.margin(), 2.0);
        let mut still = 0;
        let mut longest_still = 0;
        let mut met_after = None;
        for frame in 1..=60 {
            t += 1.0 / 60.0;
            let target = lead.target_tick(&clock, t).unwrap();
            assert!(target >= last, "backwards: {last} -> {target}");
            still = if target == last { still + 1 } else { 0 };
            longest_still = longest_still.max(still);
            let ahead = 60.0 * (clock.rtt().unwrap() + clock.jitter()) + lead.margin();
            let wanted = (clock.arrival_tick(t).unwrap() + ahead).ceil() as u64;
            if target == wanted && met_after.is_none() {
                met_after = Some(frame);
            }
            last = target;
        }
        assert_eq!(
            longest_still, 1,
            "the inputs stood still for {longest_still} ticks"
        );
        let met_after = met_after.expect("the lead came down");
        assert!(
            (25..=35).contains(&met_after),
            "three ticks given back at a tenth of the rate, in {met_after} ticks"
        );

        // Asked again before the server saw any of it, a report of the
        // same early lead takes off only what is not on its way out.
        let mut lead = InputLead::default();
        lead.on_report(report(-3));
        lead.target_tick(&clock, 1.0);
        lead.on_report(report(9));
        lead.target_tick(&clock, 1.0 + 1.0 / 60.0);
        lead.on_report(report(9));
        assert!(
            (lead.margin() - 0.5).abs() < 0.1,
            "2.9 of the 3 ticks still pending: {}",
            lead.margin()
        );
    }

    #[test]
    fn late_reports_raise_the_margin_at_once_and_early_ones_lower_it_slowly() {
        let mut lead = InputLead::default();
        let report = |min_lead| InputReport {
            min_lead,
            ..InputReport::default()
        };
        lead.on_report(report(Some(-3)));
        assert_eq!(lead.margin(), 5.0, "one tick wanted, four short");
        lead.on_report(report(Some(2)));
        assert_eq!(lead.margin(), 5.0, "within the slack");
        lead.on_report(report(None));
        assert_eq!(lead.margin(), 5.0, "no inputs, no news");
        // Five ticks early at worst: two beyond the slack, half of it off.
        lead.on_report(report(Some(5)));
        assert_eq!(lead.margin(), 4.0);
        lead.on_report(report(Some(5)));
        assert_eq!(lead.margin(), 3.0);
        for _ in 0..100 {
            lead.on_report(report(Some(50)));
        }
        assert_eq!(lead.margin(), 0.0, "never below the least");
        lead.on_report(report(Some(i32::MIN)));
        assert_eq!(lead.margin(), 30.0, "never above the most");
        assert_eq!(lead.report().unwrap().min_lead, Some(i32::MIN));
    }
}
