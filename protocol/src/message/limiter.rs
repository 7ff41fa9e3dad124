//! How fast one client may send messages: a token bucket over messages
//! and one over bytes, both refilled on the caller's clock.
//!
//! A bucket holds at most its burst and refills at its rate; a message
//! takes one message token and its length in byte tokens, and is refused
//! (taking nothing) when either bucket is short. A flood is thus refused
//! as it arrives, at a cost of a comparison, and never queued.

use std::time::Instant;

use super::{MessageRefusal, MAX_MESSAGE_BYTES};

/// The most messages and bytes a client may send, sustained and in a
/// burst. Reliable and unreliable messages share them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageLimits {
    /// Messages a second, sustained.
    pub per_second: u32,
    /// Messages at once after a quiet spell.
    pub burst: u32,
    /// Bytes a second, sustained.
    pub bytes_per_second: u32,
    /// Bytes at once after a quiet spell (at least [`MAX_MESSAGE_BYTES`],
    /// so that the longest message can pass).
    pub byte_burst: u32,
}

impl Default for MessageLimits {
    /// 30 messages and 8 KiB a second, bursts of 60 and 16 KiB: chat,
    /// votes, purchases and readiness at a human's pace, with room for a
    /// game's menu to send a handful at once.
    fn default() -> Self {
        MessageLimits {
            per_second: 30,
            burst: 60,
            bytes_per_second: 8 << 10,
            byte_burst: 16 << 10,
        }
    }
}

/// One client's two buckets.
#[derive(Debug, Clone)]
pub struct MessageLimiter {
    limits: MessageLimits,
    /// Message tokens, and byte tokens, at `at`.
    messages: f64,
    bytes: f64,
    at: Instant,
}

impl MessageLimiter {
    /// Full buckets at `now`.
    pub fn new(limits: MessageLimits, now: Instant) -> Self {
        let limits = MessageLimits {
            burst: limits.burst.max(1),
            byte_burst: limits.byte_burst.max(MAX_MESSAGE_BYTES as u32),
            ..limits
        };
        MessageLimiter {
            limits,
            messages: f64::from(limits.burst),
            bytes: f64::from(limits.byte_burst),
            at: now,
        }
    }

    /// Its limits (the bursts raised to their least).
    pub fn limits(&self) -> MessageLimits {
        self.limits
    }

    /// Takes a message of `len` bytes at `now`, or refuses it (taking
    /// nothing) when either bucket is short.
    pub fn take(&mut self, len: usize, now: Instant) -> Result<(), MessageRefusal> {
        self.refill(now);
        let len = len as f64;
        if self.messages < 1.0 || self.bytes < len {
            return Err(MessageRefusal::RateLimited {
                per_second: self.limits.per_second,
                bytes_per_second: self.limits.bytes_per_second,
            });
        }
        self.messages -= 1.0;
        self.bytes -= len;
        Ok(())
    }

    fn refill(&mut self, now: Instant) {
        let dt = now.saturating_duration_since(self.at).as_secs_f64();
        self.at = self.at.max(now);
        let l = &self.limits;
        self.messages = (self.messages + dt * f64::from(l.per_second)).min(f64::from(l.burst));
        self.bytes = (self.bytes + dt * f64::from(l.bytes_per_second)).min(f64::from(l.byte_burst));
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn a_burst_passes_a_flood_is_refused_and_the_rate_refills() {
        let t0 = Instant::now();
        let limits = MessageLimits {
            per_second: 10,
            burst: 5,
            bytes_per_second: 1000,
            byte_burst: 2000,
        };
        let mut l = MessageLimiter::new(limits, t0);
        for _ in 0..5 {
            l.take(10, t0).unwrap();
        }
        assert!(matches!(
            l.take(10, t0),
            Err(MessageRefusal::RateLimited { .. })
        ));
        // A tenth of a second brings one message back.
        let t1 = t0 + Duration::from_millis(100);
        l.take(10, t1).unwrap();
        assert!(l.take(10, t1).is_err());
        // A flood over ten seconds passes at the rate, not more.
        let mut passed = 0;
        for ms in 0..10_000 {
            if l.take(1, t1 + Duration::from_millis(ms)).is_ok() {
                passed += 1;
            }
        }
        assert!((99..=101).contains(&passed), "{passed} passed");
    }

    #[test]
    fn bytes_are_limited_too_and_a_refused_message_takes_nothing() {
        let t0 = Instant::now();
        let limits = MessageLimits {
            per_second: 1000,
            burst: 1000,
            bytes_per_second: 1024,
            byte_burst: 1024,
        };
        let mut l = MessageLimiter::new(limits, t0);
        l.take(1000, t0).unwrap();
        assert!(l.take(100, t0).is_err());
        // The refusal took nothing: 24 bytes are still there.
        l.take(24, t0).unwrap();
        // The burst is at least one whole message.
        let tight = MessageLimits {
            byte_burst: 1,
            ..limits
        };
        let mut l = MessageLimiter::new(tight, t0);
        l.take(MAX_MESSAGE_BYTES, t0).unwrap();
    }
}
