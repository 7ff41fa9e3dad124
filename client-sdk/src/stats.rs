//! Connection statistics a game can show or log.
//!
//! [`StatsRecorder`] takes small notifications (a snapshot arrived, a
//! round-trip sample, a malformed datagram, the interpolation buffer's
//! counters) and [`StatsRecorder::stats`] turns them into a
//! [`ClientStats`] that serialises to JSON. Times are seconds of the
//! client's local monotonic clock, passed in.

use std::collections::VecDeque;

use serde::Serialize;

use inertia_protocol::control::InputReport;

use crate::clock::seq_older;
use crate::interp::InterpStats;
use crate::predict::PredictionStats;

/// What the client has seen of its connection, ready to print or
/// serialise.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ClientStats {
    /// Round-trip time, smoothed (1/8 per sample), ms; 0 before a sample.
    pub rtt_ms: f64,
    /// Fraction of snapshot sequence numbers missed among the last 256
    /// (reordered arrivals count as received), 0 to 1.
    pub loss: f64,
    /// Bytes received over the last second, kbit/s (1000 bit/s).
    pub kbps: f64,
    /// Snapshots received (duplicates included).
    pub snapshots_received: u64,
    /// Bytes of snapshots received.
    pub bytes_received: u64,
    /// Snapshot time in hand ahead of the render tick, ms.
    pub buffer_ms: f64,
    /// The interpolation buffer's render delay, ms.
    pub delay_ms: f64,
    /// Times the picture held because snapshots ran out.
    pub stalls: u64,
    /// Times the picture was extrapolated past the newest snapshot.
    pub extrapolations: u64,
    /// Seeks and rewinds seen.
    pub discontinuities: u64,
    /// Datagrams dropped because they did not decode.
    pub malformed_dropped: u64,
    /// How much later than the fastest arrivals snapshots come (95th
    /// percentile of the last 64), ms.
    pub jitter_ms: f64,
    /// Bytes sent over the last second (input datagrams), kbit/s.
    pub kbps_out: f64,
    /// The tick the newest input was stamped for (0 before the first).
    pub input_tick: u64,
    /// The margin inputs are stamped ahead with, beyond the round trip
    /// and the jitter, ticks (see [`crate::lead`]).
    pub input_margin_ticks: f64,
    /// Inputs the server applied on their tick (its newest report).
    pub inputs_on_time: u64,
    /// Inputs that reached the server after their tick and were applied
    /// late (its newest report).
    pub inputs_late: u64,
    /// Inputs the server refused as too far ahead or too many (its newest
    /// report).
    pub inputs_refused: u64,
    /// With prediction on ([`crate::predict`]): the median distance
    /// between the predicted and the authoritative position of the own
    /// avatar at the same tick (recent 4096 snapshots), m; 0 without
    /// prediction.
    pub prediction_error_p50_m: f64,
    /// Its 99th percentile, m.
    pub prediction_error_p99_m: f64,
    /// The largest such distance, m.
    pub prediction_error_max_m: f64,
    /// Times the prediction was rolled back to a snapshot and replayed.
    pub prediction_corrections: u64,
    /// Corrections that snapped the picture (teleports, respawns).
    pub prediction_teleports: u64,
    /// The largest move of the drawn avatar in one tick that was not its
    /// predicted motion (corrections sliding in; teleports left out), m.
    pub prediction_snap_max_m: f64,
}

/// Sequence numbers tracked for the loss estimate.
const SEQ_WINDOW: u64 = 256;
/// The window of the received-rate estimate, s.
const RATE_WINDOW_S: f64 = 1.0;

/// Accumulates what [`ClientStats`] reports.
#[derive(Debug, Clone, Default)]
pub struct StatsRecorder {
    rtt: Option<f64>,
    /// Highest sequence number seen, unwrapped to 64 bits.
    highest: Option<u64>,
    /// The first sequence number seen, unwrapped.
    first: u64,
    /// Bit `k % 256` set when unwrapped sequence `k` arrived (for the last
    /// 256 below `highest`).
    seen: [u64; 4],
    arrivals: VecDeque<(f64, u64)>,
    window_bytes: u64,
    snapshots: u64,
    bytes: u64,
    malformed: u64,
    interp: InterpStats,
    jitter: f64,
    sent: VecDeque<(f64, u64)>,
    window_sent: u64,
    inputs: Option<InputReport>,
    input_margin: f64,
    input_tick: u64,
    prediction: PredictionStats,
}

impl StatsRecorder {
    /// Nothing recorded yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// A snapshot datagram of `bytes` bytes with sequence number `seq`
    /// arrived at `local_time` (s).
    pub fn on_snapshot(&mut self, local_time: f64, seq: u16, bytes: usize) {
        self.snapshots += 1;
        self.bytes += bytes as u64;
        self.on_bytes(local_time, bytes);
        let k = match self.highest {
            None => {
                // Start high enough that the window never underflows.
                let k = (1 << 32) + u64::from(seq);
                self.first = k;
                self.highest = Some(k);
                self.seen = [0; 4];
                k
            }
            Some(h) => {
                let h16 = h as u16;
                if seq_older(seq, h16) {
                    h - u64::from(h16.wrapping_sub(seq))
                } else {
                    let k = h + u64::from(seq.wrapping_sub(h16));
                    // Clear the bits of the sequence numbers skipped over.
                    for skipped in (h + 1).max(k.saturating_sub(SEQ_WINDOW - 1))..=k {
                        self.set_seen(skipped, false);
                    }
                    self.highest = Some(k);
                    k
                }
            }
        };
        let h = self.highest.unwrap_or(k);
        if k + SEQ_WINDOW > h && k >= self.first {
            self.set_seen(k, true);
        }
    }

    /// Other bytes received at `local_time` (s) that count towards
    /// [`ClientStats::kbps`] (control messages, say).
    pub fn on_bytes(&mut self, local_time: f64, bytes: usize) {
        self.arrivals.push_back((local_time, bytes as u64));
        self.window_bytes += bytes as u64;
        self.expire(local_time);
    }

    /// A round-trip time sample, s.
    pub fn on_rtt(&mut self, seconds: f64) {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return;
        }
        self.rtt = Some(match self.rtt {
            Some(r) => r + (seconds - r) / 8.0,
            None => seconds,
        });
    }

    /// A datagram of `bytes` bytes was sent at `local_time` (s).
    pub fn on_sent(&mut self, local_time: f64, bytes: usize) {
        self.sent.push_back((local_time, bytes as u64));
        self.window_sent += bytes as u64;
        self.expire(local_time);
    }

    /// The snapshots' arrival jitter now, s.
    pub fn on_jitter(&mut self, seconds: f64) {
        if seconds.is_finite() {
            self.jitter = seconds.max(0.0);
        }
    }

    /// The server's newest report on the inputs, the margin they are
    /// stamped ahead with (ticks) and the newest input's tick.
    pub fn on_inputs(&mut self, report: Option<InputReport>, margin: f64, tick: Option<u64>) {
        self.inputs = report;
        self.input_margin = margin;
        self.input_tick = tick.unwrap_or(0);
    }

    /// The prediction's figures ([`crate::predict::Predictor::stats`]).
    pub fn on_prediction(&mut self, stats: PredictionStats) {
        self.prediction = stats;
    }

    /// A datagram that did not decode was dropped.
    pub fn on_malformed(&mut self) {
        self.malformed += 1;
    }

    /// The interpolation buffer's latest counters
    /// ([`InterpolationBuffer::stats`](crate::interp::InterpolationBuffer::stats)).
    pub fn on_interp(&mut self, stats: InterpStats) {
        self.interp = stats;
    }

    /// Everything so far, with the received rate over the second before
    /// `local_time` (s).
    pub fn stats(&mut self, local_time: f64) -> ClientStats {
        self.expire(local_time);
        ClientStats {
            rtt_ms: self.rtt.unwrap_or(0.0) * 1000.0,
            loss: self.loss(),
            kbps: self.window_bytes as f64 * 8.0 / 1000.0 / RATE_WINDOW_S,
            snapshots_received: self.snapshots,
            bytes_received: self.bytes,
            buffer_ms: self.interp.buffer_ms,
            delay_ms: self.interp.delay_ms,
            stalls: self.interp.stalls,
            extrapolations: self.interp.extrapolations,
            discontinuities: self.interp.discontinuities,
            malformed_dropped: self.malformed,
            jitter_ms: self.jitter * 1000.0,
            kbps_out: self.window_sent as f64 * 8.0 / 1000.0 / RATE_WINDOW_S,
            input_tick: self.input_tick,
            input_margin_ticks: self.input_margin,
            inputs_on_time: self.inputs.map_or(0, |r| r.on_time),
            inputs_late: self.inputs.map_or(0, |r| r.late),
            inputs_refused: self.inputs.map_or(0, |r| r.refused),
            prediction_error_p50_m: self.prediction.error_p50,
            prediction_error_p99_m: self.prediction.error_p99,
            prediction_error_max_m: self.prediction.error_max,
            prediction_corrections: self.prediction.corrections,
            prediction_teleports: self.prediction.teleports,
            prediction_snap_max_m: self.prediction.snap_max,
        }
    }

    fn loss(&self) -> f64 {
        let Some(h) = self.highest else {
            return 0.0;
        };
        let span = (h - self.first + 1).min(SEQ_WINDOW);
        let got: u32 = self.seen.iter().map(|w| w.count_ones()).sum();
        1.0 - f64::from(got) / span as f64
    }

    fn set_seen(&mut self, k: u64, on: bool) {
        let bit = k % SEQ_WINDOW;
        let (word, mask) = ((bit / 64) as usize, 1u64 << (bit % 64));
        if on {
            self.seen[word] |= mask;
        } else {
            self.seen[word] &= !mask;
        }
    }

    fn expire(&mut self, now: f64) {
        while let Some(&(t, b)) = self.arrivals.front() {
            if t > now - RATE_WINDOW_S {
                break;
            }
            self.arrivals.pop_front();
            self.window_bytes -= b;
        }
        while let Some(&(t, b)) = self.sent.front() {
            if t > now - RATE_WINDOW_S {
                break;
            }
            self.sent.pop_front();
            self.window_sent -= b;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loss_counts_missing_sequence_numbers_across_the_wrap() {
        let mut rec = StatsRecorder::new();
        // 200 snapshots from 65400, through the wrap; every 10th lost and
        // one pair swapped.
        let mut seqs: Vec<u16> = (0..200u16)
            .filter(|k| k % 10 != 5)
            .map(|k| 65_400u16.wrapping_add(k))
            .collect();
        seqs.swap(50, 51);
        for (i, &s) in seqs.iter().enumerate() {
            rec.on_snapshot(i as f64 / 30.0, s, 100);
        }
        // A duplicate changes nothing.
        rec.on_snapshot(7.0, seqs[100], 100);
        let stats = rec.stats(7.0);
        assert!((stats.loss - 0.1).abs() < 1e-9, "loss {}", stats.loss);
        assert_eq!(stats.snapshots_received, 181);
        assert_eq!(stats.bytes_received, 18_100);
    }

    #[test]
    fn loss_looks_at_the_last_256_only() {
        let mut rec = StatsRecorder::new();
        for k in 0..100u16 {
            if k % 2 == 0 {
                rec.on_snapshot(0.0, k, 1);
            }
        }
        assert!((rec.stats(0.0).loss - 0.5).abs() < 0.01);
        for k in 100..1000u16 {
            rec.on_snapshot(0.0, k, 1);
        }
        assert_eq!(rec.stats(0.0).loss, 0.0);
        // A jump of more than the window loses the whole window but one.
        rec.on_snapshot(0.0, 2000, 1);
        assert!((rec.stats(0.0).loss - 255.0 / 256.0).abs() < 1e-9);
    }

    #[test]
    fn rate_rtt_and_json() {
        let mut rec = StatsRecorder::new();
        for k in 0..60u16 {
            rec.on_snapshot(f64::from(k) / 30.0, k, 1250);
        }
        // The last second holds 30 snapshots: 30 × 1250 B = 300 kbit.
        let stats = rec.stats(59.0 / 30.0 + 0.01);
        assert!((stats.kbps - 300.0).abs() < 1e-9, "kbps {}", stats.kbps);
        assert_eq!(rec.stats(10.0).kbps, 0.0);
        rec.on_rtt(0.1);
        rec.on_rtt(0.2);
        rec.on_malformed();
        rec.on_interp(InterpStats {
            stalls: 2,
            ..InterpStats::default()
        });
        let stats = rec.stats(10.0);
        assert!((stats.rtt_ms - 112.5).abs() < 1e-9);
        let json = serde_json::to_value(stats).unwrap();
        assert_eq!(json["malformed_dropped"], 1);
        assert_eq!(json["stalls"], 2);
        assert!(json["loss"].is_number() && json["kbps"].is_number());
    }
}
