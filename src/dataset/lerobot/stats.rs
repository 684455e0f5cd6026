//! Feature statistics, as LeRobot computes and aggregates them
//! (<https://github.com/huggingface/lerobot/blob/main/src/lerobot/datasets/compute_stats.py>).
//!
//! Per episode and feature, over its frames, per dimension: `min`, `max`, `mean`, `std`
//! (population, numpy's default `ddof = 0`), `count` (frames), and the quantiles `q01`, `q10`,
//! `q50`, `q90`, `q99`. Values are those stored (float32 features as float32, then computed in
//! float64). Quantiles are exact, linear interpolation between order statistics (numpy's
//! default `np.quantile`); LeRobot itself estimates them from a 5000-bin histogram, so its own
//! figures differ from these by at most a bin width.
//!
//! The dataset's `meta/stats.json` aggregates the episodes exactly as `aggregate_stats` does:
//! min of mins, max of maxes, count-weighted mean, the pooled variance
//! `Σ cᵢ (σᵢ² + (μᵢ − μ)²) / Σ cᵢ`, and for the quantiles the envelope LeRobot keeps (the
//! smallest episode value for q01..q50, the largest for q90 and q99).

/// The quantile statistics, by name.
pub const QUANTILES: [(&str, f64); 5] = [
    ("q01", 0.01),
    ("q10", 0.10),
    ("q50", 0.50),
    ("q90", 0.90),
    ("q99", 0.99),
];

/// One feature's statistics (each vector has the feature's dimension).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Stats {
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
    pub count: u64,
    /// In the order of [`QUANTILES`].
    pub quantiles: [Vec<f64>; 5],
}

impl Stats {
    /// The vector statistics by name, in the order LeRobot writes them (count aside).
    pub fn named(&self) -> Vec<(&'static str, &[f64])> {
        let mut v: Vec<(&'static str, &[f64])> = vec![
            ("min", &self.min),
            ("max", &self.max),
            ("mean", &self.mean),
            ("std", &self.std),
        ];
        for (k, (name, _)) in QUANTILES.iter().enumerate() {
            v.push((name, &self.quantiles[k]));
        }
        v
    }
}

/// `q`-quantile of sorted `v`, linear interpolation (numpy's default).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    let frac = pos - lo as f64;
    sorted[lo] + (sorted[hi] - sorted[lo]) * frac
}

/// The statistics of `frames` frames of a `dim`-dimensional feature, `values` frame-major.
pub fn episode_stats(values: &[f64], dim: usize, frames: usize) -> Stats {
    let mut s = Stats {
        count: frames as u64,
        ..Default::default()
    };
    let mut column = Vec::with_capacity(frames);
    for d in 0..dim {
        column.clear();
        column.extend((0..frames).map(|f| values[f * dim + d]));
        let n = frames.max(1) as f64;
        let mean = column.iter().sum::<f64>() / n;
        let var = column.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
        column.sort_by(f64::total_cmp);
        s.min.push(column.first().copied().unwrap_or(f64::NAN));
        s.max.push(column.last().copied().unwrap_or(f64::NAN));
        s.mean.push(mean);
        s.std.push(var.sqrt());
        for (k, (_, q)) in QUANTILES.iter().enumerate() {
            s.quantiles[k].push(if column.is_empty() {
                f64::NAN
            } else {
                quantile(&column, *q)
            });
        }
    }
    s
}

/// Episode statistics aggregated as they come (`aggregate_stats`, module doc).
#[derive(Debug, Clone, Default)]
pub struct Aggregate {
    count: u64,
    min: Vec<f64>,
    max: Vec<f64>,
    /// Σ cᵢ μᵢ and Σ cᵢ (σᵢ² + μᵢ²).
    sum_mean: Vec<f64>,
    sum_square: Vec<f64>,
    quantiles: [Vec<f64>; 5],
}

impl Aggregate {
    pub fn add(&mut self, s: &Stats) {
        if self.count == 0 && self.min.is_empty() {
            let zeros = vec![0.0; s.mean.len()];
            *self = Self {
                count: 0,
                min: s.min.clone(),
                max: s.max.clone(),
                sum_mean: zeros.clone(),
                sum_square: zeros,
                quantiles: s.quantiles.clone(),
            };
        } else {
            for d in 0..s.mean.len() {
                self.min[d] = self.min[d].min(s.min[d]);
                self.max[d] = self.max[d].max(s.max[d]);
                for (k, (_, q)) in QUANTILES.iter().enumerate() {
                    let a = &mut self.quantiles[k][d];
                    *a = if *q <= 0.5 {
                        a.min(s.quantiles[k][d])
                    } else {
                        a.max(s.quantiles[k][d])
                    };
                }
            }
        }
        let c = s.count as f64;
        for d in 0..s.mean.len() {
            self.sum_mean[d] += c * s.mean[d];
            self.sum_square[d] += c * (s.std[d] * s.std[d] + s.mean[d] * s.mean[d]);
        }
        self.count += s.count;
    }

    pub fn finish(&self) -> Stats {
        let c = self.count.max(1) as f64;
        let mean: Vec<f64> = self.sum_mean.iter().map(|m| m / c).collect();
        let std = self
            .sum_square
            .iter()
            .zip(&mean)
            .map(|(s, m)| (s / c - m * m).max(0.0).sqrt())
            .collect();
        Stats {
            min: self.min.clone(),
            max: self.max.clone(),
            mean,
            std,
            count: self.count,
            quantiles: self.quantiles.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn episode_and_aggregate_stats_match_direct_computation() {
        let a = [1.0, 10.0, 2.0, 20.0, 4.0, 40.0];
        let b = [8.0, 80.0, 16.0, 160.0];
        let (sa, sb) = (episode_stats(&a, 2, 3), episode_stats(&b, 2, 2));
        assert_eq!(sa.min, vec![1.0, 10.0]);
        assert_eq!(sa.quantiles[2], vec![2.0, 20.0]);
        assert!((sa.quantiles[0][0] - 1.02).abs() < 1e-12);
        let mut agg = Aggregate::default();
        agg.add(&sa);
        agg.add(&sb);
        let all = episode_stats(
            &[1.0, 10.0, 2.0, 20.0, 4.0, 40.0, 8.0, 80.0, 16.0, 160.0],
            2,
            5,
        );
        let g = agg.finish();
        assert_eq!(g.count, 5);
        assert_eq!((g.min.clone(), g.max.clone()), (all.min, all.max));
        for d in 0..2 {
            assert!((g.mean[d] - all.mean[d]).abs() < 1e-9);
            assert!((g.std[d] - all.std[d]).abs() < 1e-9);
        }
    }
}
