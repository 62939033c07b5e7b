//! Resolution adaptation (Section V, introduction): the expansion law
//! `dk/ds = −a(k d̄0 − Δd)` and an online estimate of the measurement noise σ_M that feeds
//! the optimal spacing ((V.9) or [`super::optimal::optimal_scale`]).
//!
//! # Curvature bias of the noise estimate
//! The least-squares residual sees everything the affine model misses: with a true Hessian
//! H, `E[RSS] = σ_M² (N − dim − 1) + ‖(I − C C⁺) e_H‖²`, `e_H,i = ½ p_iᵀ H p_i`
//! ([`curvature_residual_ss`] computes the second term exactly for any formation). So
//! [`NoiseEstimator::sigma`]² converges to `σ_M² + ‖(I − C C⁺) e_H‖² / (N − dim − 1)`, an
//! overestimate. Only the anisotropic part `A = H − (tr H / l) I` contributes for balanced
//! formations (the isotropic part is absorbed into the fitted value). For points on a sphere
//! of radius r forming a spherical 4-design (2-D: regular N-gons with N ≥ 5; 3-D: icosahedron,
//! dodecahedron) the bias term is exactly `N r⁴ tr(A²) / (2 l (l + 2))`; in 2-D that is
//! `N r⁴ ((h11 − h22)² + 4 h12²) / 32`, i.e. σ̂² → σ_M² + N r⁴((h11 − h22)² + 4h12²) /
//! (32 (N − 3)). With H = I (any N, regular formation) there is no bias at all.

use super::estimate::{least_squares, EstimateError, LsEstimate};
use super::{Mat3, Vec3};

/// Expansion law of the formation scale: `dk/ds = −a (k d̄0 − Δd)`.
///
/// `k` scale factor (dimensionless), `d0_bar` the initial inter-vehicle equilibrium distance
/// (length unit), `delta_d` the desired distance Δd (length unit), `a > 0` the rate (per unit
/// of s per length unit). Drives `k d̄0` exponentially to Δd.
pub fn dk_ds(k: f64, d0_bar: f64, delta_d: f64, a: f64) -> f64 {
    -a * (k * d0_bar - delta_d)
}

/// Exact curvature part of the least-squares residual sum of squares,
/// `‖(I − C C⁺) e_H‖²` with `e_H,i = ½ p_iᵀ H p_i` (field unit², for H in field unit per
/// length unit²): the expected inflation of `residual_ss` by a true Hessian H (module doc).
/// Errors as [`least_squares`].
pub fn curvature_residual_ss(
    dim: usize,
    rel_positions: &[Vec3],
    hessian: &Mat3,
) -> Result<f64, EstimateError> {
    if !hessian.iter().all(|v| v.is_finite()) {
        return Err(EstimateError::NonFinite("hessian"));
    }
    let quad: Vec<f64> = rel_positions
        .iter()
        .map(|p| {
            let p = super::estimate::project(dim, p);
            0.5 * p.dot(&(hessian * p))
        })
        .collect();
    Ok(least_squares(dim, rel_positions, &quad)?.residual_ss)
}

/// Online estimate of the measurement-noise standard deviation σ_M from least-squares
/// residuals: `σ̂² = (w₀ σ₀² + Σ RSS_j) / (w₀ + Σ dof_j)` (pooled residual variance with a
/// prior worth `w₀` degrees of freedom), optionally with exponential forgetting of old
/// observations. Deterministic: running sums, no time. Biased upwards by curvature (module
/// doc).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NoiseEstimator {
    prior_var: f64,
    prior_weight: f64,
    rss_sum: f64,
    dof_sum: f64,
    forgetting: f64,
}

impl NoiseEstimator {
    /// Start from a prior σ₀ (`prior_sigma`, field unit) worth `weight_of_prior` degrees of
    /// freedom.
    ///
    /// # Panics
    /// If either value is negative or not finite (see [`Self::try_new`]).
    pub fn new(prior_sigma: f64, weight_of_prior: f64) -> Self {
        Self::try_new(prior_sigma, weight_of_prior)
            .expect("NoiseEstimator::new: prior_sigma and weight_of_prior must be finite and >= 0")
    }

    /// [`Self::new`] returning `InvalidParameter` instead of panicking.
    pub fn try_new(prior_sigma: f64, weight_of_prior: f64) -> Result<Self, EstimateError> {
        if !(prior_sigma.is_finite() && prior_sigma >= 0.0) {
            return Err(EstimateError::InvalidParameter {
                name: "prior_sigma",
                reason: "must be finite and >= 0",
            });
        }
        if !(weight_of_prior.is_finite() && weight_of_prior >= 0.0) {
            return Err(EstimateError::InvalidParameter {
                name: "weight_of_prior",
                reason: "must be finite and >= 0",
            });
        }
        Ok(NoiseEstimator {
            prior_var: prior_sigma * prior_sigma,
            prior_weight: weight_of_prior,
            rss_sum: 0.0,
            dof_sum: 0.0,
            forgetting: 1.0,
        })
    }

    /// Multiply the accumulated data by `factor ∈ (0, 1]` before each new observation
    /// (1 = plain running sums, the default); the effective memory is about
    /// `1 / (1 − factor)` observations. Values outside (0, 1] are clamped into it.
    pub fn with_forgetting(mut self, factor: f64) -> Self {
        self.forgetting = if factor.is_nan() {
            1.0
        } else {
            factor.clamp(f64::MIN_POSITIVE, 1.0)
        };
        self
    }

    /// Add one least-squares fit: uses `residual_ss` and `dof`; ignored when `dof = 0` or the
    /// residual is not finite and ≥ 0.
    pub fn observe(&mut self, est: &LsEstimate) {
        self.observe_residual(est.residual_ss, est.dof);
    }

    /// Add a residual sum of squares (field unit²) with its degrees of freedom (same rules
    /// as [`Self::observe`]).
    pub fn observe_residual(&mut self, residual_ss: f64, dof: usize) {
        if dof == 0 || !(residual_ss.is_finite() && residual_ss >= 0.0) {
            return;
        }
        self.rss_sum = self.rss_sum * self.forgetting + residual_ss;
        self.dof_sum = self.dof_sum * self.forgetting + dof as f64;
    }

    /// Current estimate of σ_M (field unit); the prior σ₀ before any data (or with no weight
    /// at all).
    pub fn sigma(&self) -> f64 {
        let w = self.prior_weight + self.dof_sum;
        if w > 0.0 {
            ((self.prior_weight * self.prior_var + self.rss_sum) / w).sqrt()
        } else {
            self.prior_var.sqrt()
        }
    }

    /// Degrees of freedom of data accumulated so far (after forgetting).
    pub fn dof(&self) -> f64 {
        self.dof_sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimal::regular_shape;
    use crate::rng::{keyed, Stream};
    use approx::assert_relative_eq;
    use rand::Rng;
    use rand_distr::StandardNormal;

    #[test]
    fn expansion_law_converges_to_desired_spacing() {
        assert_eq!(dk_ds(1.0, 2.0, 2.0, 0.5), 0.0);
        assert!(dk_ds(1.0, 2.0, 3.0, 0.5) > 0.0);
        assert!(dk_ds(2.0, 2.0, 3.0, 0.5) < 0.0);
        let (mut k, ds) = (1.0, 1e-3);
        for _ in 0..20_000 {
            k += dk_ds(k, 2.0, 3.0, 0.5) * ds;
        }
        assert_relative_eq!(k * 2.0, 3.0, max_relative = 1e-3);
    }

    #[test]
    fn noise_estimate_converges_on_a_linear_field() {
        let sigma_m = 0.3;
        let pts: Vec<Vec3> = regular_shape(6, 2).iter().map(|p| p * 2.0).collect();
        let mut est = NoiseEstimator::new(1.0, 2.0);
        assert_eq!(est.sigma(), 1.0);
        let grad = Vec3::new(0.5, -0.2, 0.0);
        for k in 0..3000u64 {
            let mut rng = keyed(4, Stream::Test, k, 0);
            let y: Vec<f64> = pts
                .iter()
                .map(|p| 2.0 + grad.dot(p) + sigma_m * rng.sample::<f64, _>(StandardNormal))
                .collect();
            est.observe(&least_squares(2, &pts, &y).unwrap());
        }
        assert_relative_eq!(est.sigma(), sigma_m, max_relative = 0.05);
        assert_relative_eq!(est.dof(), 9000.0);
        // dof = 0 (three vehicles in 2-D) is ignored.
        let before = est.clone();
        est.observe(&LsEstimate {
            grad,
            value: 0.0,
            residual_ss: 5.0,
            dof: 0,
        });
        assert_eq!(est, before);
    }

    #[test]
    fn forgetting_tracks_a_change_of_noise() {
        let mut est = NoiseEstimator::new(0.0, 0.0).with_forgetting(0.99);
        for _ in 0..2000 {
            est.observe_residual(3.0 * 4.0, 3); // σ² = 4
        }
        for _ in 0..2000 {
            est.observe_residual(3.0 * 0.25, 3); // σ² = 0.25
        }
        assert_relative_eq!(est.sigma(), 0.5, max_relative = 1e-6);
    }

    #[test]
    fn curvature_bias_formula_for_regular_formations() {
        let h = Mat3::new(2.0, 0.7, 0.0, 0.7, -0.5, 0.0, 0.0, 0.0, 0.0);
        let r = 1.3;
        for n in 5..=8 {
            let a = 0.3 * n as f64;
            let pts: Vec<Vec3> = regular_shape(n, 2)
                .iter()
                .map(|p| {
                    Vec3::new(
                        p.x * a.cos() - p.y * a.sin(),
                        p.x * a.sin() + p.y * a.cos(),
                        0.0,
                    ) * r
                })
                .collect();
            let exact = curvature_residual_ss(2, &pts, &h).unwrap();
            let formula =
                n as f64 * r.powi(4) * ((h[(0, 0)] - h[(1, 1)]).powi(2) + 4.0 * h[(0, 1)].powi(2))
                    / 32.0;
            assert_relative_eq!(exact, formula, max_relative = 1e-10);
        }
        // Isotropic Hessian: no bias.
        let iso = Mat3::identity() * 3.0;
        assert!(curvature_residual_ss(2, &regular_shape(6, 2), &iso).unwrap() < 1e-20);
        // 3-D icosahedron (a spherical 5-design): N r⁴ tr(A²) / 30.
        let h3 = Mat3::new(2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.5);
        let pts: Vec<Vec3> = regular_shape(12, 3).iter().map(|p| p * r).collect();
        let a = h3 - Mat3::identity() * (h3.trace() / 3.0);
        let formula = 12.0 * r.powi(4) * (a * a).trace() / 30.0;
        assert_relative_eq!(
            curvature_residual_ss(3, &pts, &h3).unwrap(),
            formula,
            max_relative = 1e-10
        );
        // And the estimator indeed converges to σ² + bias/dof on a curved noiseless field.
        let pts: Vec<Vec3> = regular_shape(6, 2).iter().map(|p| p * r).collect();
        let bias = curvature_residual_ss(2, &pts, &h).unwrap();
        let mut est = NoiseEstimator::new(0.0, 0.0);
        let y: Vec<f64> = pts.iter().map(|p| 0.5 * p.dot(&(h * p))).collect();
        est.observe(&least_squares(2, &pts, &y).unwrap());
        assert_relative_eq!(est.sigma().powi(2), bias / 3.0, max_relative = 1e-10);
    }
}
