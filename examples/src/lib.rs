//! What a user of vbap writes to bring their own field and control law: two types that
//! implement the library's traits, and a three-line `main` (`src/bin/my_vbap.rs`). Nothing
//! in vbap's crates is edited.
//!
//! - [`LogBowl`], a [`ScalarField`]: T = A ln(1 + ½‖x − c‖²/w²), a bowl whose slopes
//!   flatten far from its bottom (‖∇T‖ ≈ 2A/‖x − c‖ there), minimum 0 at c.
//! - [`Saturated`], a [`ControlLaw`]: the paper's law (II.1) with the acceleration clipped
//!   to what the vehicle's thrusters give, ‖u‖ ≤ `u_max`.
//!
//! `my_vbap sim MISSION` runs them in vbap's in-process simulator, `my_vbap run MISSION`
//! in its multi-process system (the executable started again as field server, coordinator
//! and every agent); in lockstep both write the same run directory byte for byte.

use vbap_math::law::{ControlInputs, ControlLaw, PaperLaw};
use vbap_math::{Mat3, Vec3};
use vbap_mission::config::Goal;
use vbap_mission::field::ScalarField;

/// T = A ln(1 + q), q = ½‖x − c‖²/w² (field unit), in 2-D: a bowl with its minimum 0 at
/// `c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogBowl {
    /// The bottom c (length unit; z = 0).
    pub center: Vec3,
    /// The width w (length unit) of the bowl's steep part, > 0.
    pub width: f64,
    /// The depth scale A (field unit), > 0.
    pub depth: f64,
}

impl LogBowl {
    fn planar(&self, p: &Vec3) -> Vec3 {
        Vec3::new(p.x - self.center.x, p.y - self.center.y, 0.0)
    }
}

impl ScalarField for LogBowl {
    fn dim(&self) -> usize {
        2
    }

    fn value(&self, p: &Vec3, _t: f64) -> f64 {
        let d = self.planar(p);
        self.depth * (0.5 * d.norm_squared() / (self.width * self.width)).ln_1p()
    }

    /// ∇T = A d / (w² (1 + q)), d = x − c.
    fn gradient(&self, p: &Vec3, _t: f64) -> Vec3 {
        let d = self.planar(p);
        let w2 = self.width * self.width;
        let q = 0.5 * d.norm_squared() / w2;
        self.depth * d / (w2 * (1.0 + q))
    }

    /// ∇²T = A (P / (w² (1 + q)) − d dᵀ / (w⁴ (1 + q)²)), P the projection on the plane.
    fn hessian(&self, p: &Vec3, _t: f64) -> Mat3 {
        let d = self.planar(p);
        let w2 = self.width * self.width;
        let q = 0.5 * d.norm_squared() / w2;
        let plane = Mat3::from_diagonal(&Vec3::new(1.0, 1.0, 0.0));
        self.depth * (plane / (w2 * (1.0 + q)) - d * d.transpose() / (w2 * w2 * (1.0 + q).powi(2)))
    }

    fn optimum(&self, _t: f64, goal: Goal) -> Option<Vec3> {
        (goal == Goal::Min).then_some(self.center)
    }

    fn bounds_hint(&self) -> (Vec3, Vec3) {
        let half = Vec3::new(25.0, 25.0, 0.0);
        (self.center - half, self.center + half)
    }
}

/// The paper's law with the acceleration clipped: u = u_paper · min(1, u_max/‖u_paper‖).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Saturated {
    /// The largest acceleration the vehicle can give, length unit/s², > 0.
    pub u_max: f64,
}

impl ControlLaw for Saturated {
    fn control(&self, position: &Vec3, velocity: &Vec3, inputs: &ControlInputs<'_>) -> Vec3 {
        let u = PaperLaw.control(position, velocity, inputs);
        let norm = u.norm();
        if norm > self.u_max {
            u * (self.u_max / norm)
        } else {
            u
        }
    }
}

/// The log bowl of `my_vbap`: bottom at (18, 12), 4 wide, 10 deep.
pub const MY_FIELD: LogBowl = LogBowl {
    center: Vec3::new(18.0, 12.0, 0.0),
    width: 4.0,
    depth: 10.0,
};

/// The parts of `my_vbap`: [`MY_FIELD`] and thrusters of 4 length units/s².
pub fn my_plugins() -> vbap_cli::custom::Plugins {
    vbap_cli::custom::Plugins::default()
        .with_field(MY_FIELD)
        .with_law(Saturated { u_max: 4.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_log_bowl_derivatives_match_its_values() {
        let f = MY_FIELD;
        let h = 1e-5;
        for p in [Vec3::new(0.0, 0.0, 0.0), Vec3::new(20.0, 9.0, 0.0)] {
            let g = f.gradient(&p, 0.0);
            let hess = f.hessian(&p, 0.0);
            for i in 0..2 {
                let mut e = Vec3::zeros();
                e[i] = h;
                let fd = (f.value(&(p + e), 0.0) - f.value(&(p - e), 0.0)) / (2.0 * h);
                assert!((fd - g[i]).abs() <= 1e-7, "∂T/∂x{i} at {p:?}");
                let dg = (f.gradient(&(p + e), 0.0) - f.gradient(&(p - e), 0.0)) / (2.0 * h);
                for j in 0..2 {
                    assert!((dg[j] - hess[(j, i)]).abs() <= 1e-7, "H[{j},{i}] at {p:?}");
                }
            }
        }
        assert_eq!(f.value(&f.center, 0.0), 0.0);
        assert_eq!(f.optimum(0.0, Goal::Min), Some(f.center));
    }

    #[test]
    fn the_saturated_law_never_exceeds_its_thrust() {
        let inter = vbap_math::potential::PairPotential::new(60.0, 1.0, 1.5).unwrap();
        let leader = vbap_math::potential::PairPotential::new(60.0, 1.2, 6.0).unwrap();
        let leaders = [Vec3::new(3.0, 0.0, 0.0)];
        let inputs = ControlInputs::paper(&leaders, &[], inter, leader, 5.0);
        let law = Saturated { u_max: 4.0 };
        let (x, v) = (Vec3::zeros(), Vec3::new(0.0, 2.0, 0.0));
        let paper = PaperLaw.control(&x, &v, &inputs);
        let ours = law.control(&x, &v, &inputs);
        assert!(paper.norm() > 4.0, "the paper asks for more: {paper:?}");
        assert!((ours.norm() - 4.0).abs() <= 1e-12);
        assert!(
            (ours.normalize() - paper.normalize()).norm() <= 1e-12,
            "same direction"
        );
        // Below the limit it is the paper's law, bit for bit.
        let calm = (Vec3::new(1.8, 0.0, 0.0), Vec3::zeros());
        let p = PaperLaw.control(&calm.0, &calm.1, &inputs);
        assert!(p.norm() < 4.0);
        assert_eq!(law.control(&calm.0, &calm.1, &inputs), p);
    }
}
