//! The statistics of a batch's rows: distributions, rates, the Wilson interval; used by the
//! aggregate and by the grid points (it uses only `row`).

use serde::Serialize;
use vbap_mission::rundir::Percentiles;

use super::row::SeedResult;

/// A distribution over the runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Distribution {
    pub n: usize,
    pub min: f64,
    pub mean: f64,
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl Distribution {
    /// Of `values` (zeros when empty).
    pub fn of(mut values: Vec<f64>) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n as f64;
        let p = Percentiles::of(&mut values);
        Self {
            n,
            min: values[0],
            mean,
            p50: p.p50,
            p90: p.p90,
            p99: p.p99,
            max: p.max,
        }
    }
}

/// The fraction of `rows` for which `test` is true, among those where it is known.
pub fn rate_of(rows: &[&SeedResult], test: impl Fn(&SeedResult) -> Option<bool>) -> Option<f64> {
    let known: Vec<bool> = rows.iter().filter_map(|r| test(r)).collect();
    (!known.is_empty()).then(|| known.iter().filter(|b| **b).count() as f64 / known.len() as f64)
}

/// z of a two-sided 95 % normal interval: Φ⁻¹(0.975).
pub const Z95: f64 = 1.959_963_984_540_054;

/// The Wilson score interval of a proportion: `successes` of `n` trials at normal quantile
/// `z` (E. B. Wilson, 1927), as `[low, high]` in [0, 1]; `[0, 1]` when `n` is 0.
///
/// centre = (p̂ + z²/2n) / (1 + z²/n), half width = z/(1 + z²/n) · √(p̂(1 − p̂)/n + z²/4n²).
pub fn wilson(successes: usize, n: usize, z: f64) -> [f64; 2] {
    if n == 0 {
        return [0.0, 1.0];
    }
    let n = n as f64;
    let p = successes as f64 / n;
    let z2 = z * z;
    let denom = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denom;
    let half = z / denom * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    [(centre - half).max(0.0), (centre + half).min(1.0)]
}
