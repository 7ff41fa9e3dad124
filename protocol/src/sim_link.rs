//! A simulated network link on a virtual clock, for testing endpoints
//! without sockets: each packet sent is lost, delayed (fixed delay plus
//! uniform jitter, so packets can overtake each other) or duplicated,
//! deterministically from a seed.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use thiserror::Error;

/// What the link does to packets. Times in seconds of the virtual clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimLinkConfig {
    /// One-way delay, s.
    pub delay: f64,
    /// Each packet's delay varies uniformly within `±jitter`, s (at most
    /// `delay`); packets sent close together can arrive out of order.
    pub jitter: f64,
    /// Probability that a packet is lost, 0 to 1.
    pub loss: f64,
    /// Probability that a delivered packet arrives twice, 0 to 1.
    pub duplicate: f64,
}

impl SimLinkConfig {
    /// A perfect link: no delay, loss or duplication.
    pub const PERFECT: SimLinkConfig = SimLinkConfig {
        delay: 0.0,
        jitter: 0.0,
        loss: 0.0,
        duplicate: 0.0,
    };
}

/// A link setting out of range.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SimLinkError {
    /// The setting and why it was refused.
    #[error("link {what}: {why}")]
    Invalid {
        /// Which setting.
        what: &'static str,
        /// Why.
        why: String,
    },
}

/// What happened to the packets so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimLinkStats {
    /// Packets handed to [`SimLink::send`].
    pub sent: u64,
    /// Packets lost.
    pub lost: u64,
    /// Extra copies made.
    pub duplicated: u64,
    /// Packets handed out by [`SimLink::receive`] (copies included).
    pub delivered: u64,
}

/// One direction of a simulated link.
#[derive(Debug)]
pub struct SimLink {
    config: SimLinkConfig,
    rng: crate::rng::SplitMix,
    /// Packets in flight by (arrival time, order sent).
    in_flight: BinaryHeap<Reverse<(Arrival, u64, Vec<u8>)>>,
    next: u64,
    stats: SimLinkStats,
}

/// An arrival time with a total order (times are finite by construction).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Arrival(f64);

impl Eq for Arrival {}

impl PartialOrd for Arrival {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Arrival {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

impl SimLink {
    /// A link that behaves as `config` says, its randomness drawn from
    /// `seed`.
    pub fn new(config: SimLinkConfig, seed: u64) -> Result<Self, SimLinkError> {
        let invalid = |what, why: String| Err(SimLinkError::Invalid { what, why });
        if !(config.delay.is_finite() && config.delay >= 0.0) {
            return invalid(
                "delay",
                format!("must be a finite time >= 0 s, got {}", config.delay),
            );
        }
        if !(config.jitter.is_finite() && (0.0..=config.delay).contains(&config.jitter)) {
            return invalid(
                "jitter",
                format!(
                    "must be between 0 and the delay ({} s), got {}",
                    config.delay, config.jitter
                ),
            );
        }
        for (what, p) in [("loss", config.loss), ("duplicate", config.duplicate)] {
            if !(0.0..=1.0).contains(&p) {
                return invalid(what, format!("must be a probability in [0, 1], got {p}"));
            }
        }
        Ok(Self {
            config,
            rng: crate::rng::SplitMix(seed),
            in_flight: BinaryHeap::new(),
            next: 0,
            stats: SimLinkStats::default(),
        })
    }

    fn enqueue(&mut self, now: f64, packet: Vec<u8>) {
        let jitter = (self.rng.uniform() * 2.0 - 1.0) * self.config.jitter;
        let at = now + self.config.delay + jitter;
        let id = self.next;
        self.next += 1;
        self.in_flight.push(Reverse((Arrival(at), id, packet)));
    }

    /// Sends `packet` at virtual time `now` (s).
    pub fn send(&mut self, now: f64, packet: Vec<u8>) {
        self.stats.sent += 1;
        if self.rng.uniform() < self.config.loss {
            self.stats.lost += 1;
            return;
        }
        if self.rng.uniform() < self.config.duplicate {
            self.stats.duplicated += 1;
            self.enqueue(now, packet.clone());
        }
        self.enqueue(now, packet);
    }

    /// Every packet that has arrived by virtual time `now` (s), in arrival
    /// order (ties in the order sent).
    pub fn receive(&mut self, now: f64) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        while self
            .in_flight
            .peek()
            .is_some_and(|Reverse((Arrival(at), _, _))| *at <= now)
        {
            if let Some(Reverse((_, _, p))) = self.in_flight.pop() {
                out.push(p);
            }
        }
        self.stats.delivered += out.len() as u64;
        out
    }

    /// Packets in flight.
    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }

    /// Counts so far.
    pub fn stats(&self) -> SimLinkStats {
        self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numbered(k: u64) -> Vec<u8> {
        k.to_le_bytes().to_vec()
    }

    fn number(p: &[u8]) -> u64 {
        u64::from_le_bytes(p.try_into().expect("8 bytes"))
    }

    #[test]
    fn a_perfect_link_delivers_everything_in_order_at_once() {
        let mut link = SimLink::new(SimLinkConfig::PERFECT, 1).unwrap();
        for k in 0..100 {
            link.send(0.0, numbered(k));
        }
        let got: Vec<u64> = link.receive(0.0).iter().map(|p| number(p)).collect();
        assert_eq!(got, (0..100).collect::<Vec<_>>());
        assert_eq!(link.in_flight(), 0);
    }

    #[test]
    fn loss_delay_jitter_and_duplicates_are_as_configured() {
        let config = SimLinkConfig {
            delay: 0.05,
            jitter: 0.01,
            loss: 0.05,
            duplicate: 0.01,
        };
        let mut link = SimLink::new(config, 7).unwrap();
        let n = 100_000u64;
        let dt = 1.0 / 60.0 / 10.0;
        let mut sent_at = Vec::new();
        let (mut arrivals, mut out_of_order, mut last) = (Vec::new(), 0, None);
        for k in 0..n {
            let now = k as f64 * dt;
            sent_at.push(now);
            link.send(now, numbered(k));
            for p in link.receive(now) {
                let id = number(&p);
                let delay = now - sent_at[id as usize];
                arrivals.push(delay);
                if last.is_some_and(|l| id < l) {
                    out_of_order += 1;
                }
                last = Some(id);
            }
        }
        let s = link.stats();
        let loss = s.lost as f64 / n as f64;
        assert!((loss - 0.05).abs() < 0.003, "loss {loss}");
        assert!(
            (s.duplicated as f64 / n as f64 - 0.0095).abs() < 0.002,
            "{s:?}"
        );
        // Received at the first tick after arrival: within a tick of the
        // delay's range.
        for d in &arrivals {
            assert!(*d >= 0.04 - 1e-12 && *d <= 0.06 + dt + 1e-12, "delay {d}");
        }
        assert!(
            out_of_order > 0,
            "jitter of 10 ms should reorder packets 1.7 ms apart"
        );
    }

    #[test]
    fn the_same_seed_gives_the_same_run() {
        let config = SimLinkConfig {
            delay: 0.03,
            jitter: 0.02,
            loss: 0.2,
            duplicate: 0.1,
        };
        let run = |seed| {
            let mut link = SimLink::new(config, seed).unwrap();
            let mut got = Vec::new();
            for k in 0..1000 {
                link.send(k as f64 * 0.001, numbered(k));
                got.extend(link.receive(k as f64 * 0.001).iter().map(|p| number(p)));
            }
            got.extend(link.receive(10.0).iter().map(|p| number(p)));
            got
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
    }

    #[test]
    fn bad_settings_are_refused() {
        let ok = SimLinkConfig {
            delay: 0.05,
            jitter: 0.01,
            loss: 0.05,
            duplicate: 0.0,
        };
        for bad in [
            SimLinkConfig { delay: -1.0, ..ok },
            SimLinkConfig {
                delay: f64::NAN,
                ..ok
            },
            SimLinkConfig { jitter: 0.1, ..ok },
            SimLinkConfig { loss: 1.5, ..ok },
            SimLinkConfig {
                duplicate: f64::NAN,
                ..ok
            },
        ] {
            assert!(
                matches!(SimLink::new(bad, 1), Err(SimLinkError::Invalid { .. })),
                "{bad:?}"
            );
        }
    }
}
