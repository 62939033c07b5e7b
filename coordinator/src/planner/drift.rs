//! Tracking a moving field (beyond the paper, `body.track_drift`): the field's drift v_f
//! is estimated from the planner's own estimates at the body centre
//! (`vbap_math::drift`), and once it is significant it is fed forward into the body's
//! velocity, dr/dt = dr/ds·ṡ + v̂_f (IV.4 plus the drift), so that at the optimum, where
//! dr/ds of Sec. V vanishes, the body still moves with the field instead of settling a
//! formation radius behind it. Under a committed path the drift goes into the segment
//! with the rest of the decision. Off (None) under the paper's law, on fields that cannot
//! move (`Mission::field_may_move`) and with `body.track_drift = false`: the planner is then
//! the paper's bit for bit.

use vbap_math::drift::{DriftEstimator, DriftParams, DriftSample, CHI2_2_999, CHI2_3_999};
use vbap_math::{Mat3, Vec3};
use vbap_mission::config::Goal;

use super::{Planner, PlannerParams};

/// The estimator's tunables for a planner: baseline τ = max(radius / v0, 10 dt) (the time
/// the body crosses a formation radius at cruise speed, s), prior σ₀ = v0, random walk
/// q = (0.1 v0)² / (20 τ) (the drift may change by a tenth of v0 over 20 baselines), the
/// quadratic model of (D.2) within 3 radii, the gate at 5 σ, χ² at 0.999, a restart
/// after 3 baselines in a row with a discarded observation ((D.4)).
pub(super) fn drift_params(p: &PlannerParams, dt: f64) -> DriftParams {
    let baseline = (p.radius / p.v0).max(10.0 * dt);
    DriftParams {
        baseline,
        process: (0.1 * p.v0).powi(2) / (20.0 * baseline),
        prior: p.v0,
        reach: 3.0 * p.radius,
        gate: 5.0,
        chi2: if p.dim == 3 { CHI2_3_999 } else { CHI2_2_999 },
        restart_after: 3,
    }
}

/// The largest λ in [0, 1] such that |climb + λ ff| ≤ max(budget, |climb|): the drift's
/// share of the speed the body has left (the climb itself is never cut).
pub(super) fn budget_share(climb: &Vec3, ff: &Vec3, budget: f64) -> f64 {
    let cap = budget.max(climb.norm());
    let a = ff.norm_squared();
    if a == 0.0 {
        return 0.0;
    }
    // |c + λ f|² = a λ² + 2 b λ + c² ≤ cap².
    let b = climb.dot(ff);
    let c = climb.norm_squared() - cap * cap;
    if a + 2.0 * b + c <= 0.0 {
        return 1.0;
    }
    let disc = (b * b - a * c).max(0.0);
    ((-b + disc.sqrt()) / a).clamp(0.0, 1.0)
}

impl Planner {
    /// The estimator's current estimate of the drift, length unit/s (None when tracking is
    /// off), and whether it is significant by (D.3).
    pub fn drift(&self) -> Option<(Vec3, bool)> {
        self.drift
            .as_ref()
            .map(|d| (d.velocity(), d.significant().is_some()))
    }

    /// Gives the estimator tick `k`'s estimates at the body centre (`dt`: the tick length,
    /// s), starting it at the first tick when tracking is on.
    pub(super) fn observe_drift(&mut self, k: u64, dt: f64) {
        if !self.params.track_drift {
            return;
        }
        if self.drift.is_none() {
            self.drift = DriftEstimator::new(self.params.dim, drift_params(&self.params, dt)).ok();
        }
        let Some(f) = self.filter.as_ref() else {
            return;
        };
        let dim = self.params.dim;
        let p = f.covariance();
        let mut grad_cov = Mat3::zeros();
        for i in 0..dim {
            for j in 0..dim {
                grad_cov[(i, j)] = p[(i, j)];
            }
        }
        let hessian = match self
            .curvature
            .as_ref()
            .and_then(|c| c.hessian_if_determined(0.5))
        {
            Some(h) => Some(h),
            None if self.params.hessian_configured => Some(self.params.hessian_guess),
            None => None,
        };
        let sample = DriftSample {
            t: k as f64 * dt,
            r: self.body.r,
            value: f.value(),
            value_var: p[(dim, dim)],
            grad: f.grad(),
            grad_cov,
            hessian,
        };
        let sign = match self.params.goal {
            Goal::Max => 1.0,
            Goal::Min => -1.0,
        };
        if let Some(d) = self.drift.as_mut() {
            d.observe(sample, sign);
        }
    }

    /// The drift to add to the body's velocity, length unit/s, given the climb `climb` =
    /// dr/ds·ṡ: None when tracking is off; zero when holding, settling after a redesign, or
    /// while the estimate is not significant; else v̂_f within the speed budget (|v̂_f| ≤
    /// budget, and |climb + v̂_f| ≤ max(budget, |climb|), [`budget_share`]).
    pub(super) fn drift_feed_forward(&self, climb: &Vec3, holding: bool) -> Option<Vec3> {
        let d = self.drift.as_ref()?;
        let budget = self.params.speed_budget;
        let v = match d.significant() {
            Some(v) if !holding && !self.settling && budget > 0.0 => v,
            _ => return Some(Vec3::zeros()),
        };
        let v = if v.norm() > budget {
            v * (budget / v.norm())
        } else {
            v
        };
        Some(v * budget_share(climb, &v, budget))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_drift_takes_only_the_speed_the_climb_leaves() {
        let x = Vec3::new(1.0, 0.0, 0.0);
        let y = Vec3::new(0.0, 1.0, 0.0);
        // At the optimum (no climb) the whole drift, up to the budget.
        assert_eq!(budget_share(&Vec3::zeros(), &(x * 0.3), 0.5), 1.0);
        // Climbing at the full budget along the drift: nothing left.
        assert_eq!(budget_share(&(x * 0.5), &(x * 0.3), 0.5), 0.0);
        // Climbing at 0.3 across a drift of 0.4: |(λ 0.4, 0.3)| = 0.5 at λ = 1.
        let l = budget_share(&(y * 0.3), &(x * 0.4), 0.5);
        assert!((l - 1.0).abs() < 1e-12, "{l}");
        let l = budget_share(&(y * 0.4), &(x * 0.4), 0.5);
        assert!(((y * 0.4 + x * 0.4 * l).norm() - 0.5).abs() < 1e-12, "{l}");
        // Against the climb the drift only slows it.
        assert_eq!(budget_share(&(x * 0.5), &(x * -0.2), 0.5), 1.0);
    }
}
