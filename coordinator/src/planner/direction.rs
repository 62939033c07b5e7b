//! The body's rates per unit of s: its direction of motion (Sec. V) and the resolution
//! adaptation of its scale (V.7).

use vbap_math::adapt::dk_ds;
use vbap_math::optimal::optimal_scale;
use vbap_math::Vec3;
use vbap_mission::config::Goal;

use super::Planner;

/// Direction of motion dr/ds (Sec. V), length unit per unit of s: ±∇T_est (`+` to a
/// maximum, `−` to a minimum), divided by max(|∇T_est|, `grad_saturation`), so it is a
/// unit vector above the saturation and v0 is a speed in length unit/s. Zero when holding
/// or without an estimate.
pub(super) fn direction(grad_est: &Vec3, goal: Goal, grad_saturation: f64, holding: bool) -> Vec3 {
    let sign = match goal {
        Goal::Max => 1.0,
        Goal::Min => -1.0,
    };
    let gnorm = grad_est.norm();
    if holding || gnorm == 0.0 {
        Vec3::zeros()
    } else {
        grad_est * (sign / gnorm.max(grad_saturation))
    }
}

impl Planner {
    /// Resolution adaptation dk/ds = −a(k d̄0 − Δd) (V.7), 1 per unit of s, with the
    /// target spacing Δd = k* d̄0 of the optimal scale k* (clamped to [min_scale,
    /// max_scale]) for the σ_M and the Hessian in use ([`Planner::hessian`]), at the body scale `scale` (the scale now, or under
    /// a committed path the scale when the decision takes effect); 0 when adaptation is
    /// off, when holding, or without a finite k*.
    pub(super) fn scale_rate(&self, holding: bool, scale: f64) -> f64 {
        let p = &self.params;
        if !p.adapt || holding {
            return 0.0;
        }
        let sigma_m = self.sigma_m();
        match optimal_scale(
            &self.design.slots,
            p.dim,
            &self.hessian(),
            p.sigma_h,
            sigma_m,
        ) {
            Ok((k_star, _g)) if k_star.is_finite() => {
                let d0_bar = self.design.neighbour_spacing();
                let target = k_star.clamp(p.min_scale, p.max_scale) * d0_bar;
                dk_ds(scale, d0_bar, target, p.adapt_gain)
            }
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direction_is_a_unit_vector_above_the_saturation_and_signed_by_the_goal() {
        let g = Vec3::new(3.0, 4.0, 0.0);
        let up = direction(&g, Goal::Max, 1.0, false);
        assert!((up.norm() - 1.0).abs() < 1e-12);
        assert!((up - Vec3::new(0.6, 0.8, 0.0)).norm() < 1e-12);
        let down = direction(&g, Goal::Min, 1.0, false);
        assert!((down + up).norm() < 1e-12);
    }

    #[test]
    fn direction_shrinks_below_the_saturation_and_is_zero_when_holding() {
        // |∇T| = 0.5 below the saturation 2: dr/ds = ∇T / 2.
        let g = Vec3::new(0.0, 0.5, 0.0);
        let d = direction(&g, Goal::Max, 2.0, false);
        assert!((d - Vec3::new(0.0, 0.25, 0.0)).norm() < 1e-12);
        assert_eq!(direction(&g, Goal::Max, 2.0, true), Vec3::zeros());
        assert_eq!(
            direction(&Vec3::zeros(), Goal::Max, 2.0, false),
            Vec3::zeros()
        );
    }
}
