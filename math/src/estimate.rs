//! Least-squares gradient estimation and its expected error (paper Section V-A and V-D).
//!
//! The estimate is `x_T = (∇T(0)ᵀ, T(0))ᵀ` at the estimation point (the virtual-body centre),
//! from one measurement per vehicle at positions `p_i` *relative to the estimation point*.
//! In 2-D (`dim = 2`) only the x and y components of positions are used (z is ignored and the
//! returned gradient has z = 0), and only the top-left 2×2 block of a Hessian [`Mat3`] matters.
//!
//! - [`least_squares`]: Lemma 5.1, solved by an SVD of the centred, rescaled design matrix.
//! - [`expected_error`]: `g` of (V.6), with an analytic gradient used by [`super::optimal`].
//! - [`three_vehicle_g`], [`three_vehicle_optimum`]: Lemma 5.3, (V.8), (V.9).
//! - [`gradient_of_average`]: (V.13), (V.14), equal to least squares under Lemma 5.5.

use nalgebra::{DMatrix, DVector, Matrix4, Vector4};

use super::{Mat3, Vec3};

/// Failures of the gradient-estimation math (Section V). Shared by `estimate`, `optimal`,
/// `kalman`, `convergence` and `adapt`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EstimateError {
    /// The spatial dimension is not supported (must be 2 or 3; 1..=3 for `epsilon_est`).
    #[error("dimension must be 2 or 3, got {0}")]
    InvalidDim(usize),
    /// Fewer points than unknowns: least squares needs at least `dim + 1` positions.
    #[error("need at least {needed} points, got {got}")]
    TooFewPoints {
        /// Minimum number of points (dim + 1).
        needed: usize,
        /// Number given.
        got: usize,
    },
    /// Two inputs that must pair up element by element have different lengths.
    #[error("length mismatch ({what}): {left} vs {right}")]
    LengthMismatch {
        /// Which inputs.
        what: &'static str,
        /// Length of the first.
        left: usize,
        /// Length of the second.
        right: usize,
    },
    /// An input (or a computed intermediate) is NaN or infinite.
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    /// Positions are (nearly) collinear in 2-D or coplanar in 3-D: the relative thickness
    /// σ_min/σ_max of the centred positions is below [`RANK_TOLERANCE`].
    #[error("rank-deficient geometry: relative thickness {ratio:e} < {threshold:e}")]
    RankDeficient {
        /// σ_min/σ_max of the centred position matrix (0 when all points coincide).
        ratio: f64,
        /// The threshold it was compared with.
        threshold: f64,
    },
    /// A scalar parameter is outside its documented range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it was rejected.
        reason: &'static str,
    },
    /// A matrix that must be symmetric is not (relative asymmetry above 1e-9).
    #[error("{0} is not symmetric")]
    NotSymmetric(&'static str),
    /// A matrix that must be symmetric positive definite is not.
    #[error("{0} is not positive definite")]
    NotPositiveDefinite(&'static str),
    /// A matrix that must be positive semidefinite has a clearly negative eigenvalue.
    #[error("{0} is not positive semidefinite")]
    NotPositiveSemidefinite(&'static str),
    /// Matrix or vector sizes do not fit together.
    #[error("shape mismatch: {0}")]
    ShapeMismatch(&'static str),
    /// The optimisation problem has no minimiser (the infimum is approached at a degenerate
    /// size, e.g. σ_H = 0 makes g decrease forever as the formation grows).
    #[error("no minimiser: {0}")]
    NoMinimum(&'static str),
    /// A numerical routine failed (singular matrix, no convergence, non-finite result).
    #[error("numerical failure: {0}")]
    Numerical(&'static str),
}

/// Relative thickness below which a formation counts as collinear (2-D) or coplanar (3-D):
/// the ratio σ_min/σ_max of the singular values of the centred N×dim position matrix.
/// Scale- and translation-free; 1e-8 means the formation is 10⁸ times longer than thick.
pub const RANK_TOLERANCE: f64 = 1e-8;

/// A least-squares estimate of `x_T = (∇T(0), T(0))`, Lemma 5.1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsEstimate {
    /// Estimated gradient ∇T at the estimation point (field unit per length unit); z = 0 in 2-D.
    pub grad: Vec3,
    /// Estimated field value T at the estimation point (field unit).
    pub value: f64,
    /// Residual sum of squares ‖y − C x_LS‖² (field unit²).
    pub residual_ss: f64,
    /// Degrees of freedom of the residual, N − (dim + 1).
    pub dof: usize,
}

pub(crate) fn check_dim(dim: usize) -> Result<(), EstimateError> {
    if dim == 2 || dim == 3 {
        Ok(())
    } else {
        Err(EstimateError::InvalidDim(dim))
    }
}

/// Positions projected to the mission dimension (z := 0 in 2-D).
pub(crate) fn project(dim: usize, p: &Vec3) -> Vec3 {
    if dim == 2 {
        Vec3::new(p.x, p.y, 0.0)
    } else {
        *p
    }
}

pub(crate) fn check_finite_positions(pos: &[Vec3]) -> Result<(), EstimateError> {
    if pos.iter().all(|p| p.iter().all(|v| v.is_finite())) {
        Ok(())
    } else {
        Err(EstimateError::NonFinite("positions"))
    }
}

/// Relative thickness σ_min/σ_max of the centred positions (0 if they all coincide).
pub fn relative_thickness(dim: usize, rel_positions: &[Vec3]) -> Result<f64, EstimateError> {
    check_dim(dim)?;
    check_finite_positions(rel_positions)?;
    let n = rel_positions.len();
    if n == 0 {
        return Ok(0.0);
    }
    let centroid = rel_positions
        .iter()
        .fold(Vec3::zeros(), |a, p| a + project(dim, p))
        / n as f64;
    let m = DMatrix::from_fn(n, dim, |i, j| {
        project(dim, &rel_positions[i])[j] - centroid[j]
    });
    let sv = m.singular_values();
    let max = sv.max();
    if max <= 0.0 || n < dim {
        return Ok(0.0);
    }
    Ok(sv.min() / max)
}

/// Check the common preconditions of Lemma 5.1: dim, count, finiteness, full rank of C.
pub(crate) fn check_geometry(dim: usize, rel_positions: &[Vec3]) -> Result<(), EstimateError> {
    check_dim(dim)?;
    if rel_positions.len() < dim + 1 {
        return Err(EstimateError::TooFewPoints {
            needed: dim + 1,
            got: rel_positions.len(),
        });
    }
    let ratio = relative_thickness(dim, rel_positions)?;
    if ratio.is_nan() || ratio < RANK_TOLERANCE {
        return Err(EstimateError::RankDeficient {
            ratio,
            threshold: RANK_TOLERANCE,
        });
    }
    Ok(())
}

/// Least-squares estimate of gradient and value, Lemma 5.1: `x_LS = (CᵀC)⁻¹Cᵀy` with rows
/// `(p_iᵀ, 1)` of C.
///
/// `rel_positions` are relative to the estimation point (length unit), `measurements` the
/// field values there. Solved without normal equations: positions are centred on their
/// centroid and rescaled to unit RMS spread (making the columns of C orthogonal to the ones
/// column and well scaled), then solved by SVD; the result is mapped back exactly.
///
/// Errors: `InvalidDim`, `LengthMismatch`, `TooFewPoints` (N < dim + 1), `NonFinite`,
/// `RankDeficient` (relative thickness < [`RANK_TOLERANCE`]), `Numerical`.
pub fn least_squares(
    dim: usize,
    rel_positions: &[Vec3],
    measurements: &[f64],
) -> Result<LsEstimate, EstimateError> {
    check_dim(dim)?;
    if rel_positions.len() != measurements.len() {
        return Err(EstimateError::LengthMismatch {
            what: "positions vs measurements",
            left: rel_positions.len(),
            right: measurements.len(),
        });
    }
    if !measurements.iter().all(|v| v.is_finite()) {
        return Err(EstimateError::NonFinite("measurements"));
    }
    check_geometry(dim, rel_positions)?;
    let n = rel_positions.len();
    let pts: Vec<Vec3> = rel_positions.iter().map(|p| project(dim, p)).collect();
    let centroid = pts.iter().fold(Vec3::zeros(), |a, p| a + p) / n as f64;
    let spread = (pts
        .iter()
        .map(|p| (p - centroid).norm_squared())
        .sum::<f64>()
        / n as f64)
        .sqrt();
    let c = DMatrix::from_fn(n, dim + 1, |i, j| {
        if j < dim {
            (pts[i][j] - centroid[j]) / spread
        } else {
            1.0
        }
    });
    let y = DVector::from_column_slice(measurements);
    let svd = c.clone().svd(true, true);
    let xs = svd
        .solve(&y, 0.0)
        .map_err(|_| EstimateError::Numerical("SVD solve failed"))?;
    let residual = &y - &c * &xs;
    let mut grad = Vec3::zeros();
    for j in 0..dim {
        grad[j] = xs[j] / spread;
    }
    // xs[dim] is the value at the centroid; move it to the estimation point (origin).
    let value = xs[dim] - grad.dot(&centroid);
    let est = LsEstimate {
        grad,
        value,
        residual_ss: residual.norm_squared(),
        dof: n - (dim + 1),
    };
    if !(est.grad.iter().all(|v| v.is_finite())
        && est.value.is_finite()
        && est.residual_ss.is_finite())
    {
        return Err(EstimateError::Numerical("non-finite least-squares result"));
    }
    Ok(est)
}

/// Evaluator of g (V.6) and its gradient in a possibly rescaled length unit.
///
/// With positions `x` in the working unit, `g = Σ_i s_i c_iᵀ A W A c_i`, `c_i = (x_i, 1)`
/// (padded to 4 components; in 2-D the z slot of `M = Σ c cᵀ` gets a 1 so that `M` stays
/// invertible without touching the result), `A = M⁻¹`, `W = diag(w, w, w, 1)` and
/// `s_i = (½ x_iᵀ H x_i)² σ_H² + σ_M²`. With the working unit L (`x = p / L`), passing
/// `h = L² H` and `w = 1/L²` gives exactly g of the physical positions.
#[derive(Clone, Debug)]
pub(crate) struct Cost {
    pub dim: usize,
    pub h: Mat3,
    pub sh2: f64,
    pub sm2: f64,
    pub w: f64,
}

impl Cost {
    /// Cost in physical units for a Hessian `hessian` (symmetrised, projected to dim).
    pub(crate) fn new(dim: usize, hessian: &Mat3, sigma_h: f64, sigma_m: f64, unit: f64) -> Self {
        let mut h = (hessian + hessian.transpose()) * 0.5;
        if dim == 2 {
            for k in 0..3 {
                h[(2, k)] = 0.0;
                h[(k, 2)] = 0.0;
            }
        }
        Cost {
            dim,
            h: h * (unit * unit),
            sh2: sigma_h * sigma_h,
            sm2: sigma_m * sigma_m,
            w: 1.0 / (unit * unit),
        }
    }

    fn c(&self, p: &Vec3) -> Vector4<f64> {
        if self.dim == 2 {
            Vector4::new(p.x, p.y, 0.0, 1.0)
        } else {
            Vector4::new(p.x, p.y, p.z, 1.0)
        }
    }

    /// g at positions `x` (working unit), and its gradient w.r.t. `x` into `grad` if given.
    /// `None` when M is singular or the result is not finite.
    pub(crate) fn eval(&self, x: &[Vec3], grad: Option<&mut [Vec3]>) -> Option<f64> {
        let mut m = Matrix4::zeros();
        let mut b = Matrix4::zeros();
        let mut s = Vec::with_capacity(x.len());
        let mut q = Vec::with_capacity(x.len());
        for p in x {
            let c = self.c(p);
            let qi = 0.5 * p.dot(&(self.h * p));
            let si = qi * qi * self.sh2 + self.sm2;
            let cc = c * c.transpose();
            m += cc;
            b += cc * si;
            s.push(si);
            q.push(qi);
        }
        if self.dim == 2 {
            m[(2, 2)] += 1.0;
        }
        let a = m.cholesky()?.inverse();
        let wv = Vector4::new(self.w, self.w, self.w, 1.0);
        let wd = Matrix4::from_diagonal(&wv);
        let awa = a * wd * a;
        let mut g = 0.0;
        let mut kii = Vec::with_capacity(x.len());
        for (p, si) in x.iter().zip(&s) {
            let c = self.c(p);
            let k = c.dot(&(awa * c));
            kii.push(k);
            g += si * k;
        }
        if !g.is_finite() {
            return None;
        }
        if let Some(grad) = grad {
            let wab = wd * a * b;
            let gm = a * (wab + wab.transpose()) * a;
            for (i, p) in x.iter().enumerate() {
                let c = self.c(p);
                let row = -2.0 * (gm * c) + 2.0 * s[i] * (awa * c);
                let hp = self.h * p;
                let mut d = Vec3::zeros();
                for j in 0..self.dim {
                    d[j] = row[j] + kii[i] * 2.0 * q[i] * self.sh2 * hp[j];
                }
                grad[i] = d;
            }
            if !grad.iter().all(|d| d.iter().all(|v| v.is_finite())) {
                return None;
            }
        }
        Some(g)
    }
}

pub(crate) fn check_sigmas(sigma_h: f64, sigma_m: f64) -> Result<(), EstimateError> {
    if !(sigma_h.is_finite() && sigma_h >= 0.0) {
        return Err(EstimateError::InvalidParameter {
            name: "sigma_h",
            reason: "must be finite and >= 0",
        });
    }
    if !(sigma_m.is_finite() && sigma_m >= 0.0) {
        return Err(EstimateError::InvalidParameter {
            name: "sigma_m",
            reason: "must be finite and >= 0",
        });
    }
    Ok(())
}

/// Root-mean-square distance of the positions to the estimation point (length unit).
pub(crate) fn rms_radius(dim: usize, pos: &[Vec3]) -> f64 {
    (pos.iter()
        .map(|p| project(dim, p).norm_squared())
        .sum::<f64>()
        / pos.len().max(1) as f64)
        .sqrt()
}

/// Expected squared error `g = E[‖x_T − x_LS‖²]` of (V.6), Lemma 5.2:
/// `g = Σ_i (½ p_iᵀ H p_i)² K_ii σ_H² + tr(K) σ_M²`, `K = C(CᵀC)⁻¹(CᵀC)⁻¹Cᵀ`.
///
/// `sigma_h`, `sigma_m` are *standard deviations* (of ε_Hi, dimensionless, and of the
/// measurement noise, field unit). H need not be definite. The norm mixes gradient and
/// value errors as in the paper (units: field² / length² + field²).
///
/// Errors: as [`least_squares`] for the geometry; `InvalidParameter` for negative σ;
/// `NonFinite` for a non-finite Hessian; `Numerical` if the evaluation overflows.
pub fn expected_error(
    dim: usize,
    rel_positions: &[Vec3],
    hessian: &Mat3,
    sigma_h: f64,
    sigma_m: f64,
) -> Result<f64, EstimateError> {
    let (cost, x, _) = normalised_cost(dim, rel_positions, hessian, sigma_h, sigma_m)?;
    cost.eval(&x, None)
        .ok_or(EstimateError::Numerical("g (V.6) is not finite"))
}

/// Gradient of g (V.6) with respect to each position (same units as g per length unit);
/// z components are 0 in 2-D. Used by the optimiser and checked against finite differences.
pub fn expected_error_gradient(
    dim: usize,
    rel_positions: &[Vec3],
    hessian: &Mat3,
    sigma_h: f64,
    sigma_m: f64,
) -> Result<(f64, Vec<Vec3>), EstimateError> {
    let (cost, x, unit) = normalised_cost(dim, rel_positions, hessian, sigma_h, sigma_m)?;
    let mut grad = vec![Vec3::zeros(); x.len()];
    let g = cost
        .eval(&x, Some(&mut grad))
        .ok_or(EstimateError::Numerical("g (V.6) is not finite"))?;
    Ok((g, grad.into_iter().map(|d| d / unit).collect()))
}

/// The cost g (V.6) of `rel_positions` after checking its inputs, with the positions
/// projected to `dim` and divided by their RMS radius `unit` (returned with them), so the
/// optimiser works on numbers near 1.
fn normalised_cost(
    dim: usize,
    rel_positions: &[Vec3],
    hessian: &Mat3,
    sigma_h: f64,
    sigma_m: f64,
) -> Result<(Cost, Vec<Vec3>, f64), EstimateError> {
    check_geometry(dim, rel_positions)?;
    check_sigmas(sigma_h, sigma_m)?;
    if !hessian.iter().all(|v| v.is_finite()) {
        return Err(EstimateError::NonFinite("hessian"));
    }
    let unit = rms_radius(dim, rel_positions);
    let cost = Cost::new(dim, hessian, sigma_h, sigma_m, unit);
    let x: Vec<Vec3> = rel_positions
        .iter()
        .map(|p| project(dim, p) / unit)
        .collect();
    Ok((cost, x, unit))
}

/// (V.8), Lemma 5.3: g for three vehicles at `(l1, 0)`, `(0, l2)`, `(0, 0)` with
/// `H = diag(h11, h22)`: `¼σ_H²(l1²h11² + l2²h22²) + σ_M²(2/l1² + 2/l2² + 1)`.
///
/// Lengths `l1`, `l2` in the length unit (non-zero; zero gives +∞), σ's are standard
/// deviations.
pub fn three_vehicle_g(l1: f64, l2: f64, h11: f64, h22: f64, sigma_h: f64, sigma_m: f64) -> f64 {
    0.25 * sigma_h * sigma_h * (l1 * l1 * h11 * h11 + l2 * l2 * h22 * h22)
        + sigma_m * sigma_m * (2.0 / (l1 * l1) + 2.0 / (l2 * l2) + 1.0)
}

/// (V.9), Lemma 5.3: the minimising `(l1, l2)` of (V.8),
/// `l_j = sqrt(2√2 σ_M / (|h_jj| σ_H))`.
///
/// With no curvature along an axis (`h_jj σ_H = 0`) the optimum is unbounded and `l_j` is
/// `+∞`; with `σ_M = 0` it is 0. Inputs are assumed finite and σ's ≥ 0 (otherwise NaN).
pub fn three_vehicle_optimum(h11: f64, h22: f64, sigma_h: f64, sigma_m: f64) -> (f64, f64) {
    let one = |h: f64| {
        if sigma_m == 0.0 {
            0.0
        } else {
            (2.0 * std::f64::consts::SQRT_2 * sigma_m / (h.abs() * sigma_h)).sqrt()
        }
    };
    (one(h11), one(h22))
}

/// Gradient-of-the-average estimate: (V.13) in 2-D, `2/(N h0²) Σ T_m(p_i) p_i`, and (V.14)
/// in 3-D, `3/(N h0²) Σ T_m(p_i) p_i` (field unit per length unit).
///
/// `h0` is the radius of the disc/ball (length unit, > 0). Under the hypotheses of Lemma 5.5
/// (balanced formation on the circle/sphere of radius h0) this equals the least-squares
/// gradient. Errors: `InvalidDim`, `LengthMismatch`, `TooFewPoints` (N = 0), `NonFinite`,
/// `InvalidParameter` (h0 not finite and > 0).
pub fn gradient_of_average(
    dim: usize,
    rel_positions: &[Vec3],
    measurements: &[f64],
    h0: f64,
) -> Result<Vec3, EstimateError> {
    check_dim(dim)?;
    if rel_positions.len() != measurements.len() {
        return Err(EstimateError::LengthMismatch {
            what: "positions vs measurements",
            left: rel_positions.len(),
            right: measurements.len(),
        });
    }
    if rel_positions.is_empty() {
        return Err(EstimateError::TooFewPoints { needed: 1, got: 0 });
    }
    check_finite_positions(rel_positions)?;
    if !measurements.iter().all(|v| v.is_finite()) {
        return Err(EstimateError::NonFinite("measurements"));
    }
    if !(h0.is_finite() && h0 > 0.0) {
        return Err(EstimateError::InvalidParameter {
            name: "h0",
            reason: "must be finite and > 0",
        });
    }
    let n = rel_positions.len() as f64;
    let sum = rel_positions
        .iter()
        .zip(measurements)
        .fold(Vec3::zeros(), |a, (p, t)| a + project(dim, p) * *t);
    Ok(sum * (dim as f64 / (n * h0 * h0)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimal::regular_shape;
    use crate::rng::{keyed, Stream};
    use approx::assert_relative_eq;
    use rand::Rng;
    use rand_distr::StandardNormal;

    fn polygon(n: usize, r: f64, phase: f64) -> Vec<Vec3> {
        (0..n)
            .map(|i| {
                let a = phase + 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                Vec3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect()
    }

    #[test]
    fn least_squares_recovers_affine_field_exactly() {
        let pts = vec![
            Vec3::new(10.3, -4.0, 0.0),
            Vec3::new(11.0, -3.1, 0.0),
            Vec3::new(9.5, -2.7, 0.0),
            Vec3::new(10.1, -3.5, 0.0),
        ];
        let (g, t0) = (Vec3::new(0.7, -1.3, 0.0), 2.5);
        let y: Vec<f64> = pts.iter().map(|p| t0 + g.dot(p)).collect();
        let e = least_squares(2, &pts, &y).unwrap();
        assert_relative_eq!(e.grad, g, epsilon = 1e-11);
        assert_relative_eq!(e.value, t0, epsilon = 1e-9);
        assert!(e.residual_ss < 1e-20);
        assert_eq!(e.dof, 1);
        // 3-D with a far-away, tiny formation (scale-free solve).
        let pts3: Vec<Vec3> = regular_shape(6, 3)
            .iter()
            .map(|p| p * 1e-3 + Vec3::new(5.0, 1.0, -2.0))
            .collect();
        let g3 = Vec3::new(1.0, 2.0, -0.5);
        let y3: Vec<f64> = pts3.iter().map(|p| -1.0 + g3.dot(p)).collect();
        let e3 = least_squares(3, &pts3, &y3).unwrap();
        assert_relative_eq!(e3.grad, g3, epsilon = 1e-8);
        assert_relative_eq!(e3.value, -1.0, epsilon = 1e-7);
        assert_eq!(e3.dof, 2);
    }

    #[test]
    fn least_squares_matches_normal_equations_and_residual() {
        let mut rng = keyed(1, Stream::Test, 0, 0);
        let pts: Vec<Vec3> = (0..7)
            .map(|_| {
                Vec3::new(
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    0.0,
                )
            })
            .collect();
        let y: Vec<f64> = (0..7).map(|_| rng.random_range(-1.0..1.0)).collect();
        let e = least_squares(2, &pts, &y).unwrap();
        let c = DMatrix::from_fn(7, 3, |i, j| if j < 2 { pts[i][j] } else { 1.0 });
        let yv = DVector::from_column_slice(&y);
        let x = (c.transpose() * &c).try_inverse().unwrap() * c.transpose() * &yv;
        assert_relative_eq!(e.grad.x, x[0], epsilon = 1e-12);
        assert_relative_eq!(e.grad.y, x[1], epsilon = 1e-12);
        assert_relative_eq!(e.value, x[2], epsilon = 1e-12);
        assert_relative_eq!(e.residual_ss, (yv - c * x).norm_squared(), epsilon = 1e-12);
    }

    #[test]
    fn least_squares_errors() {
        let tri = polygon(3, 1.0, 0.0);
        assert!(matches!(
            least_squares(2, &tri[..2], &[1.0, 2.0]),
            Err(EstimateError::TooFewPoints { needed: 3, got: 2 })
        ));
        assert!(matches!(
            least_squares(2, &tri, &[1.0, 2.0]),
            Err(EstimateError::LengthMismatch { .. })
        ));
        assert!(matches!(
            least_squares(2, &tri, &[1.0, f64::NAN, 0.0]),
            Err(EstimateError::NonFinite(_))
        ));
        let mut bad = tri.clone();
        bad[1].x = f64::INFINITY;
        assert!(matches!(
            least_squares(2, &bad, &[1.0, 2.0, 3.0]),
            Err(EstimateError::NonFinite(_))
        ));
        assert!(matches!(
            least_squares(4, &tri, &[1.0, 2.0, 3.0]),
            Err(EstimateError::InvalidDim(4))
        ));
        // Collinear, at any scale.
        for scale in [1e-6, 1.0, 1e6] {
            let line: Vec<Vec3> = (0..5)
                .map(|i| Vec3::new(i as f64, 2.0 * i as f64, 0.0) * scale)
                .collect();
            assert!(matches!(
                least_squares(2, &line, &[0.0; 5]),
                Err(EstimateError::RankDeficient { .. })
            ));
        }
        // Nearly collinear but thick enough relative to its size: fine at any scale.
        for scale in [1e-6, 1.0, 1e6] {
            let thin = [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.5, 1e-6, 0.0),
            ]
            .map(|p| p * scale);
            assert!(least_squares(2, &thin, &[0.0, 1.0, 2.0]).is_ok());
        }
        // Coplanar in 3-D.
        let plane: Vec<Vec3> = polygon(5, 1.0, 0.3)
            .iter()
            .map(|p| p + Vec3::new(0.0, 0.0, 2.0))
            .collect();
        assert!(matches!(
            least_squares(3, &plane, &[0.0; 5]),
            Err(EstimateError::RankDeficient { .. })
        ));
        // All at one point.
        assert!(matches!(
            least_squares(2, &[Vec3::new(1.0, 1.0, 0.0); 3], &[0.0; 3]),
            Err(EstimateError::RankDeficient { .. })
        ));
    }

    #[test]
    fn three_vehicle_lemma_5_3() {
        let (l1, l2, h11, h22, sh, sm) = (0.7, 1.9, 2.0, 0.5, 0.8, 0.3);
        let pts = [
            Vec3::new(l1, 0.0, 0.0),
            Vec3::new(0.0, l2, 0.0),
            Vec3::zeros(),
        ];
        let h = Mat3::from_diagonal(&Vec3::new(h11, h22, 7.0));
        // (V.8) equals (V.6) for this geometry.
        assert_relative_eq!(
            three_vehicle_g(l1, l2, h11, h22, sh, sm),
            expected_error(2, &pts, &h, sh, sm).unwrap(),
            max_relative = 1e-12
        );
        // The LS estimate is the finite-difference formula.
        let y = [3.0, -1.0, 0.5];
        let e = least_squares(2, &pts, &y).unwrap();
        assert_relative_eq!(e.grad.x, (y[0] - y[2]) / l1, epsilon = 1e-12);
        assert_relative_eq!(e.grad.y, (y[1] - y[2]) / l2, epsilon = 1e-12);
        assert_relative_eq!(e.value, y[2], epsilon = 1e-12);
        // (V.9) minimises (V.8): zero derivative and lower than a grid around it.
        let (o1, o2) = three_vehicle_optimum(h11, h22, sh, sm);
        let f = |a: f64, b: f64| three_vehicle_g(a, b, h11, h22, sh, sm);
        let d = 1e-6;
        assert!(((f(o1 + d, o2) - f(o1 - d, o2)) / (2.0 * d)).abs() < 1e-6);
        assert!(((f(o1, o2 + d) - f(o1, o2 - d)) / (2.0 * d)).abs() < 1e-6);
        let best = f(o1, o2);
        for i in -10..=10 {
            for j in -10..=10 {
                if i != 0 || j != 0 {
                    let v = f(o1 * (1.0 + 0.03 * i as f64), o2 * (1.0 + 0.03 * j as f64));
                    assert!(v > best);
                }
            }
        }
    }

    #[test]
    fn analytic_gradient_of_g_matches_finite_differences() {
        let h = Mat3::new(2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.5);
        for (dim, pts) in [
            (
                2,
                vec![
                    Vec3::new(1.0, 0.2, 0.0),
                    Vec3::new(-0.4, 1.1, 0.0),
                    Vec3::new(-0.8, -0.9, 0.0),
                    Vec3::new(0.3, -0.2, 0.0),
                ],
            ),
            (
                3,
                vec![
                    Vec3::new(1.0, 0.2, 0.1),
                    Vec3::new(-0.4, 1.1, -0.3),
                    Vec3::new(-0.8, -0.9, 0.2),
                    Vec3::new(0.3, -0.2, 1.2),
                    Vec3::new(0.1, 0.3, -0.9),
                ],
            ),
        ] {
            let (g, grad) = expected_error_gradient(dim, &pts, &h, 0.7, 0.4).unwrap();
            assert_relative_eq!(
                g,
                expected_error(dim, &pts, &h, 0.7, 0.4).unwrap(),
                max_relative = 1e-14
            );
            for i in 0..pts.len() {
                for j in 0..dim {
                    let step = 1e-6;
                    let mut a = pts.clone();
                    let mut b = pts.clone();
                    a[i][j] += step;
                    b[i][j] -= step;
                    let fd = (expected_error(dim, &a, &h, 0.7, 0.4).unwrap()
                        - expected_error(dim, &b, &h, 0.7, 0.4).unwrap())
                        / (2.0 * step);
                    assert_relative_eq!(grad[i][j], fd, epsilon = 1e-7, max_relative = 1e-6);
                }
            }
        }
    }

    #[test]
    fn gradient_of_average_equals_least_squares_lemma_5_5() {
        let mut rng = keyed(5, Stream::Test, 1, 0);
        for n in 3..=8 {
            let h0 = 1.7;
            let pts = polygon(n, h0, 0.37 * n as f64);
            let y: Vec<f64> = (0..n).map(|_| rng.random_range(-3.0..3.0)).collect();
            let ls = least_squares(2, &pts, &y).unwrap();
            let avg = gradient_of_average(2, &pts, &y, h0).unwrap();
            assert_relative_eq!(avg, ls.grad, epsilon = 1e-12);
        }
        for n in [4, 6, 8] {
            let h0 = 0.6;
            let pts: Vec<Vec3> = regular_shape(n, 3).iter().map(|p| p * h0).collect();
            let y: Vec<f64> = (0..n).map(|_| rng.random_range(-3.0..3.0)).collect();
            let ls = least_squares(3, &pts, &y).unwrap();
            let avg = gradient_of_average(3, &pts, &y, h0).unwrap();
            assert_relative_eq!(avg, ls.grad, epsilon = 1e-12);
        }
        // Not equal on an unbalanced formation (the test can fail).
        let pts = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
        ];
        let y = [1.0, 2.0, 0.5];
        let ls = least_squares(2, &pts, &y).unwrap();
        let avg = gradient_of_average(2, &pts, &y, 1.0).unwrap();
        assert!((ls.grad - avg).norm() > 0.1);
        assert!(gradient_of_average(2, &pts, &y, 0.0).is_err());
    }

    /// Monte-Carlo check of (V.6). Field: T(p) = T0 + gᵀp + ½ pᵀ H p. Two honest set-ups:
    /// (a) the stochastic model of Lemma 5.2 itself: y_i = T0 + gᵀp_i + ½p_iᵀHp_i ε_Hi + ε_Mi
    ///     with ε_Hi ~ N(0, σ_H²), ε_Mi ~ N(0, σ_M²): the mean squared error of the LS
    ///     (gradient, value) must match (V.6);
    /// (b) σ_H = 0 in (V.6) but a true deterministic curvature: the MSE must match
    ///     ‖C⁺ e_H‖² (bias², computed exactly) + σ_M² tr(K) = (V.6 with σ_H = 0) + bias².
    #[test]
    fn monte_carlo_mean_squared_error_matches_v6() {
        let h = Mat3::new(1.5, 0.4, 0.0, 0.4, 0.8, 0.0, 0.0, 0.0, 0.0);
        let (g_true, t0) = (Vec3::new(0.3, -0.7, 0.0), 1.2);
        let pts = vec![
            Vec3::new(1.1, 0.1, 0.0),
            Vec3::new(-0.3, 1.2, 0.0),
            Vec3::new(-0.9, -0.4, 0.0),
            Vec3::new(0.4, -1.0, 0.0),
            Vec3::new(0.2, 0.3, 0.0),
        ];
        let (sh, sm) = (0.9, 0.25);
        let draws = 4000;
        let quad: Vec<f64> = pts.iter().map(|p| 0.5 * p.dot(&(h * p))).collect();
        let mse = |stochastic: bool| {
            let mut acc = 0.0;
            for k in 0..draws {
                let mut rng = keyed(11, Stream::Test, k, stochastic as u64);
                let y: Vec<f64> = pts
                    .iter()
                    .zip(&quad)
                    .map(|(p, q)| {
                        let eh: f64 = rng.sample(StandardNormal);
                        let em: f64 = rng.sample(StandardNormal);
                        let curv = if stochastic { q * eh * sh } else { *q };
                        t0 + g_true.dot(p) + curv + em * sm
                    })
                    .collect();
                let e = least_squares(2, &pts, &y).unwrap();
                acc += (e.grad - g_true).norm_squared() + (e.value - t0).powi(2);
            }
            acc / draws as f64
        };
        let predicted = expected_error(2, &pts, &h, sh, sm).unwrap();
        let measured = mse(true);
        assert_relative_eq!(measured, predicted, max_relative = 0.1);
        // (b): exact curvature bias from a noise-free LS solve of the curvature term alone.
        let bias = least_squares(2, &pts, &quad).unwrap();
        let bias2 = bias.grad.norm_squared() + bias.value.powi(2);
        let predicted_b = expected_error(2, &pts, &h, 0.0, sm).unwrap() + bias2;
        assert!(
            bias2 > 0.1 * predicted_b,
            "bias must matter for the check to mean something"
        );
        assert_relative_eq!(mse(false), predicted_b, max_relative = 0.1);
    }
}
