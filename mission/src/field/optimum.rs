//! A [`Field`]'s true optimum: analytic where it exists, else a deterministic damped
//! Newton search.

use crate::config::Goal;
use vbap_math::{Mat3, Vec3};

use super::Field;

/// Eigenvalues of the dim×dim block of a symmetric matrix.
fn block_eigenvalues(h: &Mat3, dim: usize) -> Vec<f64> {
    if dim == 2 {
        let b = nalgebra::Matrix2::new(h[(0, 0)], h[(0, 1)], h[(1, 0)], h[(1, 1)]);
        b.symmetric_eigenvalues().iter().copied().collect()
    } else {
        h.symmetric_eigenvalues().iter().copied().collect()
    }
}

/// True if the dim×dim block of `h` is positive definite (relative to its largest eigenvalue).
fn block_positive_definite(h: &Mat3, dim: usize) -> bool {
    let eig = block_eigenvalues(h, dim);
    let scale = eig.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    scale > 0.0 && eig.iter().all(|e| e.is_finite() && *e > 1e-12 * scale)
}

impl Field {
    /// The true optimum at time `t` (s): the maximum (`Goal::Max`) or minimum (`Goal::Min`) the
    /// group should reach, or `None` if the field has none of that kind.
    ///
    /// Analytic where it exists: a quadratic's centre if H is positive definite (min) or negative
    /// definite (max); a single Gaussian's or an eddy's centre if the sign of its amplitude
    /// matches the goal. Sums of bumps, and fronts with a bump, are searched numerically and
    /// deterministically (damped Newton from every bump centre whose sign matches the goal, the
    /// best local optimum wins, ties to the first bump). A front without a bump has none.
    pub fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        let wanted = |amplitude: f64| match goal {
            Goal::Max => amplitude > 0.0,
            Goal::Min => amplitude < 0.0,
        };
        match self {
            Field::Quadratic {
                center,
                hessian,
                dim,
                ..
            } => {
                let h = match goal {
                    Goal::Min => *hessian,
                    Goal::Max => -hessian,
                };
                block_positive_definite(&h, *dim).then_some(*center)
            }
            Field::GaussianSum { bumps, .. } if bumps.len() == 1 => {
                wanted(bumps[0].amplitude).then_some(bumps[0].center)
            }
            Field::GaussianSum { bumps, .. } => {
                let mut best: Option<(Vec3, f64)> = None;
                for b in bumps.iter().filter(|b| wanted(b.amplitude)) {
                    if let Some(x) = self.local_optimum(b.center, t, goal, b.width) {
                        let v = goal.sign() * self.value(&x, t);
                        if best.is_none_or(|(_, bv)| v > bv) {
                            best = Some((x, v));
                        }
                    }
                }
                best.map(|(x, _)| x)
            }
            Field::DriftingEddy { bump, velocity, .. } => {
                wanted(bump.amplitude).then(|| Self::eddy_at(bump, velocity, t).center)
            }
            Field::MovingFront { bump, .. } => match bump {
                Some(b) if wanted(b.amplitude) => self.local_optimum(b.center, t, goal, b.width),
                _ => None,
            },
            Field::Grid(g) => g.optimum(t, goal),
        }
    }

    /// Damped Newton search for a local optimum of `goal` kind from `start`, at time `t`;
    /// `length` caps a step (length unit). `None` if the search does not end at a strict local
    /// optimum (gradient ≈ 0, Hessian definite with the right sign).
    fn local_optimum(&self, start: Vec3, t: f64, goal: Goal, length: f64) -> Option<Vec3> {
        let dim = self.dim();
        let sign = goal.sign();
        // Minimise phi = -sign * T.
        let phi = |x: &Vec3| -sign * self.value(x, t);
        let mut x = self.planar(&start);
        for _ in 0..500 {
            let g = -sign * self.gradient(&x, t);
            if g.norm() == 0.0 {
                break;
            }
            let mut h = -sign * self.hessian(&x, t);
            if dim == 2 {
                h[(2, 2)] = 1.0;
            }
            let newton = if block_positive_definite(&h, dim) {
                h.cholesky().map(|c| -c.solve(&g))
            } else {
                None
            };
            let mut d = newton.unwrap_or_else(|| -g / g.norm() * length);
            if d.norm() > length {
                d *= length / d.norm();
            }
            let slope = g.dot(&d);
            if slope >= 0.0 {
                break;
            }
            let f0 = phi(&x);
            let mut alpha = 1.0;
            let mut moved = false;
            for _ in 0..60 {
                let trial = x + alpha * d;
                if phi(&trial) <= f0 + 1e-4 * alpha * slope {
                    x = trial;
                    moved = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !moved || (alpha * d).norm() <= 1e-13 * length {
                break;
            }
        }
        let scale = self.value_scale();
        let g = self.gradient(&x, t);
        let mut h = -sign * self.hessian(&x, t);
        if dim == 2 {
            h[(2, 2)] = 1.0;
        }
        let ok = x.iter().all(|c| c.is_finite())
            && g.norm() * length <= 1e-8 * scale
            && block_positive_definite(&h, dim);
        ok.then_some(x)
    }

    /// A typical size of the field's variations (field unit), for relative tolerances.
    fn value_scale(&self) -> f64 {
        let s = match self {
            Field::Quadratic { hessian, .. } => hessian.abs().max(),
            Field::GaussianSum { bumps, .. } => bumps.iter().map(|b| b.amplitude.abs()).sum(),
            Field::DriftingEddy { bump, .. } => bump.amplitude.abs(),
            Field::MovingFront {
                amplitude, bump, ..
            } => amplitude.abs() + bump.as_ref().map_or(0.0, |b| b.amplitude.abs()),
            Field::Grid(_) => 1.0,
        };
        if s > 0.0 {
            s
        } else {
            1.0
        }
    }
}
