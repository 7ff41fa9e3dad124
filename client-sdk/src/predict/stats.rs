//! Figures of how well prediction agrees with the server.

/// Correction errors kept for the percentiles.
const ERRORS_KEPT: usize = 4096;

/// How well the prediction has matched the server so far.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PredictionStats {
    /// Authoritative states of the avatar compared with the prediction.
    pub compared: u64,
    /// Median distance between the predicted and the authoritative
    /// position at the same tick (the correction error), over the last
    /// 4096 compared, m.
    pub error_p50: f64,
    /// Its 99th percentile, m.
    pub error_p99: f64,
    /// Its largest ever, m.
    pub error_max: f64,
    /// Times the prediction was rolled back and replayed.
    pub corrections: u64,
    /// Corrections so large (teleports, respawns) that the picture
    /// snapped.
    pub teleports: u64,
    /// The largest move of the drawn avatar in one tick that was not its
    /// predicted motion (smoothing of corrections; teleports left out), m.
    pub snap_max: f64,
}

/// Collects [`PredictionStats`].
#[derive(Debug, Clone, Default)]
pub(crate) struct StatsCollector {
    errors: std::collections::VecDeque<f64>,
    pub stats: PredictionStats,
}

impl StatsCollector {
    pub fn on_error(&mut self, error: f64) {
        self.stats.compared += 1;
        self.stats.error_max = self.stats.error_max.max(error);
        if self.errors.len() == ERRORS_KEPT {
            self.errors.pop_front();
        }
        self.errors.push_back(error);
    }

    pub fn on_visual_step(&mut self, step: f64) {
        self.stats.snap_max = self.stats.snap_max.max(step);
    }

    pub fn stats(&self) -> PredictionStats {
        let mut sorted: Vec<f64> = self.errors.iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        let at = |q: f64| {
            if sorted.is_empty() {
                0.0
            } else {
                sorted[((sorted.len() - 1) as f64 * q).round() as usize]
            }
        };
        PredictionStats {
            error_p50: at(0.5),
            error_p99: at(0.99),
            ..self.stats
        }
    }
}
