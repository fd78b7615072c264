//! Order statistics of per-frame times in bounded memory: the median, mean and 95th percentile the
//! summary reports, exact for short runs and within half a percent beyond. It owns the accuracy
//! of those numbers; it must never grow with the number of frames, nor return NaN, because a
//! summary is JSON and JSON has no NaN.

use serde::{Deserialize, Serialize};

/// Median, mean and 95th percentile.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Spread {
    pub median: f64,
    pub mean: f64,
    pub p95: f64,
}

/// Order statistics of a stream of non-negative values (milliseconds) in bounded memory: exact
/// for the first `EXACT_VALUES` values, so short runs and the benchmark's runs are exact; beyond,
/// every value goes into a histogram of logarithmic bins `BIN_RATIO` wide, and a median or p95 is
/// the geometric middle of its bin, within 0.5% of a value of that rank (for values between
/// `LOWEST_MS` and `HIGHEST_MS`; beyond, the extremes seen stand in). The mean is always exact.
#[derive(Debug, Clone, Default)]
pub(super) struct Quantiles {
    values: Vec<f64>,
    bins: Vec<u64>,
    count: u64,
    pub(super) sum: f64,
    min: f64,
    max: f64,
}

impl Quantiles {
    /// 512 KiB of values.
    const EXACT_VALUES: usize = 1 << 16;
    const BIN_RATIO: f64 = 1.01;
    /// A nanosecond to eleven days: 3472 bins, 27 KiB.
    const LOWEST_MS: f64 = 1e-6;
    const HIGHEST_MS: f64 = 1e9;

    pub(super) fn add(&mut self, value: f64) {
        (self.min, self.max) =
            if self.count == 0 { (value, value) } else { (self.min.min(value), self.max.max(value)) };
        self.count += 1;
        self.sum += value;
        if self.bins.is_empty() {
            self.values.push(value);
            if self.values.len() == Self::EXACT_VALUES {
                self.bins = vec![0; Self::bin_count()];
                for value in std::mem::take(&mut self.values) {
                    self.bins[Self::bin(value)] += 1;
                }
            }
        } else {
            self.bins[Self::bin(value)] += 1;
        }
    }

    fn bin(value: f64) -> usize {
        let bin = ((value / Self::LOWEST_MS).ln() / Self::BIN_RATIO.ln()).floor();
        // NaN and values below the lowest (0 too) go to the first bin.
        if bin > 0.0 {
            (bin as usize).min(Self::bin_count() - 1)
        } else {
            0
        }
    }

    fn bin_count() -> usize {
        ((Self::HIGHEST_MS / Self::LOWEST_MS).ln() / Self::BIN_RATIO.ln()).floor() as usize + 1
    }

    /// The value of nearest rank `rank` (1-based): the smallest with at least `rank` values at
    /// or below it.
    fn ranked(&self, sorted: &[f64], rank: u64) -> f64 {
        if self.bins.is_empty() {
            return sorted[rank as usize - 1];
        }
        let mut seen = 0;
        for (bin, &count) in self.bins.iter().enumerate() {
            seen += count;
            if seen >= rank {
                // The end bins also hold what lies beyond the range: the extremes seen stand in.
                return match bin {
                    0 => self.min,
                    _ if bin == self.bins.len() - 1 => self.max,
                    _ => (Self::LOWEST_MS * Self::BIN_RATIO.powf(bin as f64 + 0.5)).clamp(self.min, self.max),
                };
            }
        }
        self.max
    }

    /// All zero for no values, so a summary never holds NaN.
    pub(super) fn spread(&self) -> Spread {
        let n = self.count;
        if n == 0 {
            return Spread::default();
        }
        let mut sorted = self.values.clone();
        sorted.sort_unstable_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            self.ranked(&sorted, n / 2 + 1)
        } else {
            0.5 * (self.ranked(&sorted, n / 2) + self.ranked(&sorted, n / 2 + 1))
        };
        // Nearest rank: the smallest value with at least 95% of the values at or below it.
        let rank = ((0.95 * n as f64).ceil() as u64).clamp(1, n);
        Spread { median, mean: self.sum / n as f64, p95: self.ranked(&sorted, rank) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spread_of(values: impl Iterator<Item = f64>) -> Spread {
        let mut quantiles = Quantiles::default();
        values.for_each(|v| quantiles.add(v));
        quantiles.spread()
    }

    #[test]
    fn spread_uses_nearest_rank_and_never_nan() {
        let s = spread_of((1..=20).map(f64::from));
        assert_eq!((s.median, s.mean, s.p95), (10.5, 10.5, 19.0));
        let empty = spread_of(std::iter::empty());
        assert_eq!((empty.median, empty.mean, empty.p95), (0.0, 0.0, 0.0));
    }

    #[test]
    fn long_streams_keep_bounded_memory_and_half_a_percent() {
        // Ten times more values than are kept exactly, spread over six decades, shuffled.
        let n = 10 * Quantiles::EXACT_VALUES as u64;
        let value = |i: u64| 1e-3 * 10f64.powf(6.0 * ((i * 7919) % n) as f64 / n as f64);
        let mut quantiles = Quantiles::default();
        (0..n).for_each(|i| quantiles.add(value(i)));
        assert!(quantiles.values.capacity() == 0 && quantiles.bins.len() == Quantiles::bin_count());
        let mut sorted: Vec<f64> = (0..n).map(value).collect();
        sorted.sort_unstable_by(f64::total_cmp);
        let s = quantiles.spread();
        let exact_mean = sorted.iter().sum::<f64>() / n as f64;
        assert!((s.mean - exact_mean).abs() <= 1e-9 * exact_mean);
        for (estimate, rank) in [(s.median, n / 2), (s.p95, (0.95 * n as f64).ceil() as u64)] {
            let exact = sorted[rank as usize - 1];
            assert!((estimate / exact - 1.0).abs() <= 0.005, "{estimate} vs {exact}");
        }
        // Values beyond the bins' range (zero too) come back as the extremes seen.
        let mut edges = Quantiles::default();
        for i in 0..Quantiles::EXACT_VALUES as u64 + 11 {
            edges.add(if i % 2 == 0 { 0.0 } else { 1e12 });
        }
        let s = edges.spread();
        assert_eq!((s.median, s.p95), (0.0, 1e12));
    }
}
