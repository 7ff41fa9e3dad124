//! Whether the tick loop is alive, judged once a health period from how
//! many loops it has run: the decision behind each Agones health ping
//! (sans-IO: the caller reads the count and sends the ping).
//!
//! The tick thread counts every turn of its loop, paused or not
//! ([`crate::sim::SimStats::loops`]; a paused loop still wakes every
//! 50 ms). A count that has not moved since the last look means the loop
//! is stuck inside a tick, a command or an admin call: no ping is sent, so
//! Agones marks the game server Unhealthy after its failure threshold,
//! while `/healthz` (which cannot see a stall, only a stop) keeps
//! answering. Looked at every half period, pings stop at most one period
//! after the loop stalls.

/// What one look at the loop count found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Beat {
    /// The loop has moved since the last look (or this is the first):
    /// ping.
    Alive,
    /// It has moved again after a stall: ping, and say so.
    Recovered,
    /// It has not moved: no ping. `first` on the first look of a stall.
    Stalled { first: bool },
}

impl Beat {
    /// Whether a health ping is due.
    pub fn ping(self) -> bool {
        !matches!(self, Beat::Stalled { .. })
    }
}

/// The last loop count seen, and whether the loop was stalled then.
#[derive(Debug, Clone, Default)]
pub struct Heartbeat {
    last: Option<u64>,
    stalled: bool,
}

impl Heartbeat {
    /// No look yet.
    pub fn new() -> Heartbeat {
        Heartbeat::default()
    }

    /// Looks at the loop count `loops` (monotonic).
    pub fn look(&mut self, loops: u64) -> Beat {
        let moved = self.last.is_none_or(|last| loops != last);
        self.last = Some(loops);
        match (moved, self.stalled) {
            (true, false) => Beat::Alive,
            (true, true) => {
                self.stalled = false;
                Beat::Recovered
            }
            (false, stalled) => {
                self.stalled = true;
                Beat::Stalled { first: !stalled }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_loop_that_stops_counting_stops_the_pings_until_it_counts_again() {
        let mut h = Heartbeat::new();
        assert_eq!(h.look(7), Beat::Alive);
        assert_eq!(h.look(9), Beat::Alive);
        assert_eq!(h.look(9), Beat::Stalled { first: true });
        assert_eq!(h.look(9), Beat::Stalled { first: false });
        assert!(!h.look(9).ping());
        assert_eq!(h.look(10), Beat::Recovered);
        assert!(h.look(11).ping());
    }
}
