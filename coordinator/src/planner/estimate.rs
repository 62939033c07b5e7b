//! The gradient estimate of a tick: least squares (Lemma 5.1) on the fresh readings, into
//! the Kalman filter (Lemma 5.4) with a time-varying C (Remark 5.8).
//!
//! Under `law = "robust"` with `control.curvature = "estimated"` (beyond the paper) the
//! field's Hessian Ĥ is estimated from the same readings (`vbap_math::curvature`) and
//! every reading enters least squares and the filter corrected by its curvature term,
//! `y − ½ dᵀĤd`: the affine model of Lemma 5.1 then fits what is affine, and the weights of
//! Lemma 5.4 (now from Ĥ) no longer turn the curvature into a bias of the gradient on an
//! anisotropic field.
//!
//! Not done yet: flying the anisotropic optimum of (V.7) for Ĥ (only regular polygons and
//! solids are flown, scaled by (V.7)). `vbap_math::optimal::optimal_formation` computes it
//! from [`Planner::hessian`]; a redesign to it would lower g of (V.6) by 13 % for a
//! pentagon or a hexagon on H = diag(2, 0.5) and by 32 % on diag(4, 0.25) (σ_M = σ_H = 1),
//! and not at all at the top of a round hill.

use vbap_math::curvature::CurvatureEstimator;
use vbap_math::estimate::least_squares;
use vbap_math::kalman::GradientFilter;
use vbap_math::{Mat3, Vec3};
use vbap_mission::config::{CurvatureSource, LawKind};

use super::{Planner, PlannerParams, Report};

impl Planner {
    /// The filtered gradient estimate ∇T_KF at the body centre r_k (field unit per length
    /// unit; zero before the first estimate) after tick `k`'s `fresh` readings (`dt`: the
    /// tick length, s), and whether this tick's estimate failed (rank, too few readings).
    /// Every reading counts at its true position relative to the body centre now, its
    /// variance grown by the random-walk drift of the model over its age
    /// ([`reading_variance`]). The filter's prediction moves it with the centre.
    pub(super) fn estimate(&mut self, k: u64, fresh: &[Report], dt: f64) -> (Vec3, bool) {
        let p = &self.params;
        let dim = p.dim;
        let r = self.body.r;
        let rel: Vec<Vec3> = fresh.iter().map(|q| q.position - r).collect();
        let raw: Vec<f64> = fresh.iter().map(|q| q.measurement).collect();
        let mut estimate_failed = false;
        let shift = r - self.last_r;
        self.last_r = r;
        // Under the robust law the filter carries its estimate along the body's move by
        // the known curvature (`GradientFilter::carry`), on every link: the paper's random
        // walk leaves the estimate about `v τ |H|` behind a body moving at `v` (τ the
        // filter's time constant), and on a noisy bowl the body then runs through the
        // bottom and back for the whole mission (stress seed 23: 5 of 22 failures, ideal
        // links). With no curvature known (no `formation.hessian_guess`, curvature not
        // estimated), and under `law = "paper"`, it is the paper's filter.
        let carry = (self.params.law == LawKind::Robust)
            .then(|| self.known_curvature())
            .flatten();
        if let Some(f) = self.filter.as_mut() {
            f.predict(dt, p.kalman_b, &shift);
            if let Some(h) = &carry {
                f.carry(h, &shift);
            }
        }
        let hessian = self.follow_curvature(&shift);
        let p = &self.params;
        let y: Vec<f64> = if self.curvature.is_some() {
            raw.iter()
                .zip(&rel)
                .map(|(y, d)| y - 0.5 * d.dot(&(hessian * d)))
                .collect()
        } else {
            raw.clone()
        };
        let ls = if rel.len() > dim {
            least_squares(dim, &rel, &y).ok()
        } else {
            None
        };
        if let Some(ls) = &ls {
            self.noise.observe(ls);
        }
        let sigma_m = p.sigma_m.unwrap_or_else(|| self.noise.sigma());
        if let Some(c) = self.curvature.as_mut() {
            c.update(&rel, &raw, &vec![sigma_m * sigma_m; raw.len()]);
        }
        if self.filter.is_none() {
            match &ls {
                Some(ls) => self.filter = Some(GradientFilter::new(dim, ls, p.initial_variance)),
                None => estimate_failed = true,
            }
        } else if !fresh.is_empty() {
            let var: Vec<f64> = fresh
                .iter()
                .zip(&rel)
                .map(|(q, d)| {
                    let age = k.saturating_sub(q.tick) as f64 * dt;
                    reading_variance(p, &hessian, d, age, sigma_m)
                })
                .collect();
            if let Some(f) = self.filter.as_mut() {
                if f.update(&rel, &y, &var).is_err() {
                    estimate_failed = true;
                }
            }
        } else {
            estimate_failed = true;
        }
        let grad_est = self
            .filter
            .as_ref()
            .map(|f| f.grad())
            .unwrap_or_else(Vec3::zeros);
        (grad_est, estimate_failed)
    }

    /// The Hessian of (V.6) the planner works with, field unit per length unit²: the
    /// online estimate under the robust law with `control.curvature = "estimated"`, else
    /// the configured `formation.hessian_guess` (the paper).
    pub fn hessian(&self) -> Mat3 {
        self.curvature
            .as_ref()
            .map_or(self.params.hessian_guess, |c| c.hessian())
    }

    /// Moves the curvature estimate with the body centre (`shift`, length unit), forgetting
    /// over `control.curvature_memory` design spacings of travel, starting it at the first
    /// tick when it is on; returns the Hessian to correct this tick's readings with (from
    /// the readings before this tick, so the correction does not fit their own noise).
    fn follow_curvature(&mut self, shift: &Vec3) -> Mat3 {
        let p = &self.params;
        if p.law != LawKind::Robust || p.curvature != CurvatureSource::Estimated {
            return p.hessian_guess;
        }
        let memory = p.curvature_memory * self.design.neighbour_spacing() * self.body.scale;
        if self.curvature.is_none() {
            self.curvature =
                CurvatureEstimator::new(p.dim, &p.hessian_guess, p.sigma_h, p.radius).ok();
        }
        match self.curvature.as_mut() {
            Some(c) => {
                c.shift(shift, memory);
                c.hessian()
            }
            None => p.hessian_guess,
        }
    }
}

/// The variance of one reading in the filter's update, field unit²: the sensor noise σ_M²,
/// the squared curvature error of the linear model (V.6), ½ dᵀ H d · σ_H (`hessian`: the
/// planner's H, [`Planner::hessian`]), at offset
/// `d` from the body centre (length unit), and the random-walk drift b² · age · (1 + |d|²)
/// of the filter's model (Lemma 5.4, Remark 5.8) over the reading's `age`, s.
pub(super) fn reading_variance(
    p: &PlannerParams,
    hessian: &Mat3,
    d: &Vec3,
    age: f64,
    sigma_m: f64,
) -> f64 {
    let b2 = p.kalman_b * p.kalman_b;
    let curv = 0.5 * d.dot(&(hessian * d)) * p.sigma_h;
    sigma_m * sigma_m + curv * curv + b2 * age * (1.0 + d.norm_squared())
}

#[cfg(test)]
mod tests {
    use super::*;
    use vbap_mission::config::Mission;

    fn params() -> PlannerParams {
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n",
            "<test>",
        )
        .unwrap();
        PlannerParams::from_mission(&m)
    }

    #[test]
    fn a_fresh_reading_at_the_centre_has_the_sensor_variance() {
        let p = params();
        let v = reading_variance(&p, &p.hessian_guess, &Vec3::zeros(), 0.0, 0.3);
        assert!((v - 0.09).abs() < 1e-15);
    }

    #[test]
    fn the_variance_grows_with_the_age_as_the_random_walk() {
        let mut p = params();
        p.kalman_b = 0.5;
        p.sigma_h = 0.0; // no curvature term
        let d = Vec3::new(1.0, 2.0, 0.0);
        let fresh = reading_variance(&p, &p.hessian_guess, &d, 0.0, 0.1);
        let old = reading_variance(&p, &p.hessian_guess, &d, 2.0, 0.1);
        // b² · age · (1 + |d|²) = 0.25 · 2 · 6 = 3.
        assert!((old - fresh - 3.0).abs() < 1e-12, "{old} {fresh}");
    }

    #[test]
    fn the_curvature_term_is_half_the_quadratic_form_times_sigma_h() {
        let mut p = params();
        p.hessian_guess = vbap_math::Mat3::identity() * 2.0;
        p.sigma_h = 0.5;
        let d = Vec3::new(1.0, 1.0, 0.0);
        // ½ dᵀ(2I)d · 0.5 = 1; squared: 1.
        let v = reading_variance(&p, &p.hessian_guess, &d, 0.0, 0.0);
        assert!((v - 1.0).abs() < 1e-12, "{v}");
    }
}

#[cfg(test)]
mod bias_tests;
