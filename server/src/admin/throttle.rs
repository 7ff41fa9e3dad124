//! Back-off for addresses whose admin hellos keep failing: the admin
//! channel's answer to credential guessing.
//!
//! Every hello refused for a wrong credential (an unknown operator, or a
//! token that is not the operator's) counts against its source address.
//! Once an address has [`ThrottleConfig::failures`] of them, the server
//! refuses every hello from it at once, without looking at the credential,
//! for [`ThrottleConfig::first_backoff`]; each further wrong credential
//! while the address is remembered blocks it again for twice the last
//! back-off, up to [`ThrottleConfig::max_backoff`]. An address is
//! forgotten once [`ThrottleConfig::window`] passes after its last failure
//! and the end of its last block with nothing new, and at once when a
//! hello from it is admitted. Version mismatches and malformed hellos do
//! not count: they guess nothing.
//!
//! Addresses are counted as hosts: an IPv4 address (an IPv4-mapped IPv6
//! address is its IPv4 address), or the /64 prefix of an IPv6 address,
//! which a single host usually has the whole of. The table holds at most
//! [`ThrottleConfig::capacity`] addresses; when a new one does not fit,
//! the ones already forgotten are dropped first, then the one that would
//! be forgotten soonest, so a flood of addresses cannot grow the server's
//! memory.
//!
//! The throttle is sans-I/O: the caller passes the time.

use std::collections::HashMap;
use std::net::{IpAddr, Ipv6Addr};
use std::time::{Duration, Instant};

/// The throttle's thresholds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ThrottleConfig {
    /// Wrong credentials from one address before it is blocked.
    pub failures: u32,
    /// Quiet time after which an address's failures are forgotten.
    pub window: Duration,
    /// The first block.
    pub first_backoff: Duration,
    /// The longest block.
    pub max_backoff: Duration,
    /// Most addresses remembered at once.
    pub capacity: usize,
}

impl Default for ThrottleConfig {
    fn default() -> Self {
        ThrottleConfig {
            failures: 5,
            window: Duration::from_secs(60),
            first_backoff: Duration::from_secs(1),
            max_backoff: Duration::from_secs(60),
            capacity: 4096,
        }
    }
}

/// What the throttle counts by: an IPv4 address, or an IPv6 /64 prefix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ThrottleKey(IpAddr);

impl ThrottleKey {
    /// The key of a source address.
    pub fn of(ip: IpAddr) -> ThrottleKey {
        match ip {
            IpAddr::V4(v4) => ThrottleKey(IpAddr::V4(v4)),
            IpAddr::V6(v6) => match v6.to_ipv4_mapped() {
                Some(v4) => ThrottleKey(IpAddr::V4(v4)),
                None => {
                    let prefix = u128::from(v6) & !((1u128 << 64) - 1);
                    ThrottleKey(IpAddr::V6(Ipv6Addr::from(prefix)))
                }
            },
        }
    }
}

/// One remembered address.
#[derive(Debug, Clone, Copy)]
struct AddressRecord {
    /// Wrong credentials since it was last forgotten.
    failures: u32,
    /// The latest one.
    last_failure: Instant,
    /// Until when its hellos are refused unread.
    blocked_until: Option<Instant>,
    /// The latest block's length (zero: not blocked yet).
    backoff: Duration,
}

impl AddressRecord {
    fn new(now: Instant) -> AddressRecord {
        AddressRecord {
            failures: 0,
            last_failure: now,
            blocked_until: None,
            backoff: Duration::ZERO,
        }
    }

    /// When it is forgotten: a window after its last failure or the end
    /// of its block, whichever is later.
    fn forgotten_at(&self, window: Duration) -> Instant {
        let last = match self.blocked_until {
            Some(b) if b > self.last_failure => b,
            _ => self.last_failure,
        };
        last + window
    }
}

/// Failed admin hellos by source address (see the module docs).
#[derive(Debug, Clone)]
pub struct HelloThrottle {
    config: ThrottleConfig,
    table: HashMap<ThrottleKey, AddressRecord>,
}

impl Default for HelloThrottle {
    fn default() -> Self {
        HelloThrottle::new(ThrottleConfig::default())
    }
}

impl HelloThrottle {
    /// An empty throttle.
    pub fn new(config: ThrottleConfig) -> HelloThrottle {
        HelloThrottle {
            config,
            table: HashMap::new(),
        }
    }

    /// Its thresholds.
    pub fn config(&self) -> &ThrottleConfig {
        &self.config
    }

    /// Whether a hello from `ip` may be read at `now`: `Err` with how long
    /// until it may, while the address is blocked.
    pub fn check(&mut self, ip: IpAddr, now: Instant) -> Result<(), Duration> {
        let key = ThrottleKey::of(ip);
        let Some(record) = self.table.get(&key) else {
            return Ok(());
        };
        if let Some(until) = record.blocked_until {
            if until > now {
                return Err(until - now);
            }
        }
        if now >= record.forgotten_at(self.config.window) {
            self.table.remove(&key);
        }
        Ok(())
    }

    /// Counts a wrong credential from `ip` at `now`. `Some` with the
    /// block's length when this failure blocked the address.
    pub fn failure(&mut self, ip: IpAddr, now: Instant) -> Option<Duration> {
        let key = ThrottleKey::of(ip);
        if !self.table.contains_key(&key) && self.table.len() >= self.config.capacity {
            self.make_room(now);
        }
        let config = self.config;
        let record = self
            .table
            .entry(key)
            .or_insert_with(|| AddressRecord::new(now));
        if now >= record.forgotten_at(config.window) {
            *record = AddressRecord::new(now);
        }
        record.failures = record.failures.saturating_add(1);
        record.last_failure = now;
        let backoff = if record.backoff > Duration::ZERO {
            (record.backoff * 2).min(config.max_backoff)
        } else if record.failures >= config.failures {
            config.first_backoff.min(config.max_backoff)
        } else {
            return None;
        };
        record.backoff = backoff;
        record.blocked_until = Some(now + backoff);
        Some(backoff)
    }

    /// Forgets `ip`: a hello from it was admitted.
    pub fn success(&mut self, ip: IpAddr) {
        self.table.remove(&ThrottleKey::of(ip));
    }

    /// Addresses remembered now.
    pub fn len(&self) -> usize {
        self.table.len()
    }

    /// True when no address is remembered.
    pub fn is_empty(&self) -> bool {
        self.table.is_empty()
    }

    /// Drops the forgotten addresses, and if none was, the one that would
    /// be forgotten soonest.
    fn make_room(&mut self, now: Instant) {
        let window = self.config.window;
        self.table.retain(|_, r| now < r.forgotten_at(window));
        if self.table.len() < self.config.capacity {
            return;
        }
        let soonest = self
            .table
            .iter()
            .min_by_key(|(_, r)| r.forgotten_at(window))
            .map(|(k, _)| *k);
        if let Some(key) = soonest {
            self.table.remove(&key);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::Ipv4Addr;

    const S: Duration = Duration::from_secs(1);

    fn ip(n: u32) -> IpAddr {
        IpAddr::V4(Ipv4Addr::from(0x0a00_0000 + n))
    }

    /// `n` wrong credentials from `addr` at `now`; the last one's verdict.
    fn fail(t: &mut HelloThrottle, addr: IpAddr, now: Instant, n: u32) -> Option<Duration> {
        (0..n).map(|_| t.failure(addr, now)).last().flatten()
    }

    #[test]
    fn issue_11_throttle_blocks_after_five_failures_and_doubles_to_its_cap() {
        let mut t = HelloThrottle::default();
        let t0 = Instant::now();
        let a = ip(1);
        for _ in 0..4 {
            assert_eq!(t.failure(a, t0), None);
            assert_eq!(t.check(a, t0), Ok(()));
        }
        assert_eq!(t.failure(a, t0), Some(S), "the fifth blocks for 1 s");
        assert_eq!(t.check(a, t0), Err(S));
        assert_eq!(t.check(a, t0 + S / 4), Err(S * 3 / 4));
        assert_eq!(t.check(a, t0 + S), Ok(()), "the block ends");
        // Each failure after that blocks again for twice as long, up to
        // a minute.
        let mut now = t0 + S;
        for expected in [2, 4, 8, 16, 32, 60, 60, 60] {
            let backoff = Duration::from_secs(expected);
            assert_eq!(t.failure(a, now), Some(backoff));
            assert_eq!(
                t.check(a, now + backoff - Duration::from_millis(1)),
                Err(Duration::from_millis(1))
            );
            now += backoff;
            assert_eq!(t.check(a, now), Ok(()));
        }
        assert_eq!(t.len(), 1);
    }

    #[test]
    fn issue_11_throttle_success_resets_and_quiet_forgets() {
        let mut t = HelloThrottle::default();
        let t0 = Instant::now();
        let a = ip(1);
        assert_eq!(fail(&mut t, a, t0, 4), None);
        t.success(a);
        assert!(t.is_empty());
        assert_eq!(fail(&mut t, a, t0, 4), None, "counting starts again");
        assert_eq!(t.failure(a, t0), Some(S));
        // Blocked, then after the block a whole quiet window: forgotten,
        // and the next failures count from zero at the first back-off.
        let forgotten = t0 + S + Duration::from_secs(60);
        assert_eq!(
            t.failure(a, forgotten - Duration::from_millis(1)),
            Some(2 * S)
        );
        let forgotten = forgotten - Duration::from_millis(1) + 2 * S + Duration::from_secs(60);
        assert_eq!(fail(&mut t, a, forgotten, 4), None);
        assert_eq!(t.failure(a, forgotten), Some(S));
        // Failures spread wider than the window never block.
        let mut t = HelloThrottle::default();
        for i in 0..20 {
            assert_eq!(t.failure(a, t0 + Duration::from_secs(61) * i), None);
        }
        // A check after the window drops the record.
        assert_eq!(t.check(a, t0 + Duration::from_secs(61) * 20), Ok(()));
        assert!(t.is_empty());
    }

    #[test]
    fn issue_11_throttle_is_per_address() {
        let mut t = HelloThrottle::default();
        let t0 = Instant::now();
        assert_eq!(fail(&mut t, ip(1), t0, 5), Some(S));
        assert_eq!(t.check(ip(1), t0), Err(S));
        assert_eq!(t.check(ip(2), t0), Ok(()));
        assert_eq!(fail(&mut t, ip(2), t0, 4), None);
        assert_eq!(t.check(ip(2), t0), Ok(()));
        // IPv6 counts by /64; an IPv4-mapped address is its IPv4 one.
        let v6 = |s: &str| IpAddr::V6(s.parse().unwrap());
        assert_eq!(fail(&mut t, v6("2001:db8:1:2::1"), t0, 5), Some(S));
        assert_eq!(t.check(v6("2001:db8:1:2:ffff::9"), t0), Err(S));
        assert_eq!(t.check(v6("2001:db8:1:3::1"), t0), Ok(()));
        assert_eq!(t.check(v6("::ffff:10.0.0.1"), t0), Err(S));
        assert_eq!(
            ThrottleKey::of(v6("::ffff:10.0.0.1")),
            ThrottleKey::of(ip(1))
        );
    }

    #[test]
    fn issue_11_throttle_table_stays_bounded() {
        let config = ThrottleConfig {
            capacity: 64,
            ..ThrottleConfig::default()
        };
        let mut t = HelloThrottle::new(config);
        let t0 = Instant::now();
        // A blocked address, then a flood of new ones, each failing once.
        assert_eq!(fail(&mut t, ip(0), t0, 5), Some(S));
        for n in 1..10_000 {
            t.failure(ip(n), t0 + Duration::from_millis(u64::from(n)));
            assert!(t.len() <= 64);
        }
        assert_eq!(t.len(), 64);
        // The newest are kept.
        assert!(t.table.contains_key(&ThrottleKey::of(ip(9_999))));
        // Forgotten addresses go first: after a quiet window the whole
        // table is free again, and a new address evicts them all at once.
        let later = t0 + Duration::from_secs(100);
        assert_eq!(t.failure(ip(20_000), later), None);
        assert_eq!(t.len(), 1);
        // The default holds 4096.
        let mut t = HelloThrottle::default();
        for n in 0..5_000 {
            t.failure(ip(n), t0);
        }
        assert_eq!(t.len(), 4096);
    }

    #[test]
    fn issue_11_throttle_evicts_what_would_be_forgotten_soonest() {
        let config = ThrottleConfig {
            capacity: 2,
            ..ThrottleConfig::default()
        };
        let mut t = HelloThrottle::new(config);
        let t0 = Instant::now();
        // A blocked address stays remembered longer than one that failed
        // once a little later.
        assert_eq!(fail(&mut t, ip(1), t0, 5), Some(S));
        t.failure(ip(2), t0 + S / 2);
        t.failure(ip(3), t0 + S / 2);
        assert_eq!(t.check(ip(1), t0 + S / 2), Err(S / 2), "still blocked");
        assert!(!t.table.contains_key(&ThrottleKey::of(ip(2))));
        assert!(t.table.contains_key(&ThrottleKey::of(ip(3))));
    }
}
