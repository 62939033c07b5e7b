//! Online estimate of the field's Hessian from the readings (beyond the paper).
//!
//! The paper takes the Hessian H of (V.6) as "a very rough estimate" given in advance; a
//! wrong guess sizes the formation wrongly through (V.7) (H = I on a field whose curvature
//! is 0.04 shrinks the formation several times below its optimum). Here the readings fit
//! a local quadratic model around the virtual-body centre r,
//!
//! `T(r + d) ≈ c + gᵀd + ½ dᵀHd`,
//!
//! by recursive least squares over the recent readings of all vehicles, in information
//! form: the state θ = (c, g, vech H) has `1 + l + l(l+1)/2` components (6 in 2-D, 10 in
//! 3-D), a reading y at offset d is a row φ(d) = (1, dᵀ, ½d₁², d₁d₂, ½d₂², …) of weight
//! 1/var, and the information (J, b) of the data moves exactly with the centre: a quadratic
//! re-expanded at r + δ has `c' = φ(δ)·θ, g' = g + Hδ, H' = H`, a linear map A(δ) with
//! inverse A(−δ), so `J ← A(−δ)ᵀ J A(−δ)`, `b ← A(−δ)ᵀ b`. Old readings thus count at their
//! true offsets from the current centre, and as the formation travels they see the field at
//! other distances from the centre: the isotropic part of H (tr H), which readings on one
//! circle cannot tell from c, becomes observable from the motion (and from changes of
//! scale). The data are forgotten with distance travelled, `J, b ← e^(−|δ|/L_mem) (J, b)`:
//! a quadratic model holds only locally, and a static field needs no forgetting in time.
//! A reading's leverage on Ĥ grows as |d|⁴ while its weight decays as e^(−s/L_mem) over
//! the s travelled since (|d| ≈ s on a straight path): its influence peaks about 4 L_mem
//! behind the body, so L_mem is a quarter of the stretch of path the estimate averages.
//!
//! The configured Hessian H₀ is a prior on vech H, never forgotten: independent entries of
//! mean H₀ and standard deviation `σ_H h̄₀` (h̄₀ = ‖H₀‖_F / √l, the RMS eigenvalue), i.e. the
//! paper's model εH₀ of the curvature error with ε ~ N(0, σ_H). With no data the estimate
//! is H₀; with data from a moving formation the readings dominate.
//!
//! Internally lengths are divided by a length unit `ell` (e.g. the design radius), so that
//! the information matrix stays well conditioned in any unit system.

use nalgebra::{DMatrix, DVector};

use super::estimate::{check_dim, project, EstimateError};
use super::{Mat3, Vec3};

/// Number of entries of vech H in dimension `dim`.
fn n_hess(dim: usize) -> usize {
    dim * (dim + 1) / 2
}

/// The (i, j) pairs (i ≤ j) of vech H, in state order.
fn pairs(dim: usize) -> Vec<(usize, usize)> {
    let mut v = Vec::with_capacity(n_hess(dim));
    for i in 0..dim {
        for j in i..dim {
            v.push((i, j));
        }
    }
    v
}

/// The regressor φ(d) = (1, dᵀ, vech-weighted ½ d dᵀ) of the quadratic model, so that
/// φ(d)·θ = c + gᵀd + ½ dᵀHd.
fn regressor(dim: usize, d: &Vec3) -> DVector<f64> {
    let mut phi = DVector::zeros(1 + dim + n_hess(dim));
    phi[0] = 1.0;
    for j in 0..dim {
        phi[1 + j] = d[j];
    }
    for (k, (i, j)) in pairs(dim).into_iter().enumerate() {
        phi[1 + dim + k] = if i == j {
            0.5 * d[i] * d[i]
        } else {
            d[i] * d[j]
        };
    }
    phi
}

/// A(δ): the map of the model's parameters at r to those at r + δ (module doc).
fn shift_map(dim: usize, delta: &Vec3) -> DMatrix<f64> {
    let n = 1 + dim + n_hess(dim);
    let mut a = DMatrix::identity(n, n);
    let phi = regressor(dim, delta);
    for k in 1..n {
        a[(0, k)] = phi[k];
    }
    for (k, (i, j)) in pairs(dim).into_iter().enumerate() {
        // g'_i += H_ij δ_j and g'_j += H_ji δ_i.
        a[(1 + i, 1 + dim + k)] += delta[j];
        if i != j {
            a[(1 + j, 1 + dim + k)] += delta[i];
        }
    }
    a
}

/// Recursive least-squares estimate of the local quadratic model of the field, with the
/// configured Hessian as a prior (module doc).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CurvatureEstimator {
    dim: usize,
    /// Length unit of the internal frame, length unit.
    ell: f64,
    /// Information of the data, J (scaled frame).
    info: DMatrix<f64>,
    /// Information vector of the data, b (scaled frame).
    vec: DVector<f64>,
    /// Prior mean of vech H (scaled frame).
    prior_mean: DVector<f64>,
    /// Prior information of each entry of vech H (scaled frame).
    prior_info: f64,
}

impl CurvatureEstimator {
    /// An estimator with no data, the prior H₀ = `prior` (field unit per length unit²,
    /// symmetric on the dim block) of per-entry standard deviation `sigma_h · h̄₀`, working
    /// in the length unit `ell` (> 0, length unit).
    ///
    /// Errors: `InvalidDim`; `NonFinite` for a non-finite prior; `InvalidParameter` when
    /// `ell` or `sigma_h` is not finite and > 0, or the prior is zero.
    pub fn new(dim: usize, prior: &Mat3, sigma_h: f64, ell: f64) -> Result<Self, EstimateError> {
        check_dim(dim)?;
        if !prior.iter().all(|v| v.is_finite()) {
            return Err(EstimateError::NonFinite("hessian prior"));
        }
        for (name, v) in [("ell", ell), ("sigma_h", sigma_h)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(EstimateError::InvalidParameter {
                    name,
                    reason: "must be finite and > 0",
                });
            }
        }
        let ps = pairs(dim);
        let scale = ell * ell;
        let prior_mean = DVector::from_iterator(
            ps.len(),
            ps.iter()
                .map(|&(i, j)| 0.5 * (prior[(i, j)] + prior[(j, i)]) * scale),
        );
        let mut frob = 0.0;
        for i in 0..dim {
            for j in 0..dim {
                frob += prior[(i, j)] * prior[(i, j)];
            }
        }
        let h_bar = (frob / dim as f64).sqrt() * scale;
        if h_bar == 0.0 {
            return Err(EstimateError::InvalidParameter {
                name: "hessian prior",
                reason: "must not be zero",
            });
        }
        let n = 1 + dim + ps.len();
        Ok(Self {
            dim,
            ell,
            info: DMatrix::zeros(n, n),
            vec: DVector::zeros(n),
            prior_mean,
            prior_info: 1.0 / (sigma_h * h_bar).powi(2),
        })
    }

    /// Move the expansion point by `delta` (length unit; z ignored in 2-D), exact for a
    /// quadratic field, and forget the data by `exp(−|δ| / memory)` (`memory`: length unit,
    /// > 0; infinite = never forget). Non-finite `delta` is ignored.
    pub fn shift(&mut self, delta: &Vec3, memory: f64) {
        let d = project(self.dim, delta) / self.ell;
        if !d.iter().all(|v| v.is_finite()) {
            return;
        }
        if d.norm() > 0.0 {
            let back = shift_map(self.dim, &(-d));
            self.info = back.transpose() * &self.info * &back;
            self.vec = back.transpose() * &self.vec;
        }
        if memory > 0.0 && memory.is_finite() {
            let lambda = (-(delta.norm()) / memory).exp();
            self.info *= lambda;
            self.vec *= lambda;
        }
    }

    /// Add readings `y` (field unit) taken at offsets `rel_positions` from the current
    /// expansion point (length unit), each of variance `var` (field unit², > 0). Readings
    /// with a non-finite value, offset or variance are skipped.
    pub fn update(&mut self, rel_positions: &[Vec3], y: &[f64], var: &[f64]) {
        for ((d, &yi), &vi) in rel_positions.iter().zip(y).zip(var) {
            let d = project(self.dim, d) / self.ell;
            if !(yi.is_finite() && vi.is_finite() && vi > 0.0 && d.iter().all(|v| v.is_finite())) {
                continue;
            }
            let phi = regressor(self.dim, &d);
            self.info.ger(1.0 / vi, &phi, &phi, 1.0);
            self.vec.axpy(yi / vi, &phi, 1.0);
        }
    }

    /// The posterior information matrix and vector (data plus prior), scaled frame.
    fn posterior(&self) -> (DMatrix<f64>, DVector<f64>) {
        let h0 = 1 + self.dim;
        let mut j = self.info.clone();
        let mut b = self.vec.clone();
        for k in 0..self.prior_mean.len() {
            j[(h0 + k, h0 + k)] += self.prior_info;
            b[h0 + k] += self.prior_info * self.prior_mean[k];
        }
        (j, b)
    }

    /// The posterior mean of θ (scaled frame); None while c and g are not yet determined
    /// by the data (fewer than dim + 1 independent readings).
    fn solve(&self) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let (j, b) = self.posterior();
        let chol = j.cholesky()?;
        let theta = chol.solve(&b);
        theta
            .iter()
            .all(|v| v.is_finite())
            .then(|| (theta, chol.inverse()))
    }

    /// The estimated Hessian Ĥ (field unit per length unit², symmetric, zero outside the dim
    /// block): the posterior mean, the prior while the data cannot determine the model.
    pub fn hessian(&self) -> Mat3 {
        let h0 = 1 + self.dim;
        let vech = match self.solve() {
            Some((theta, _)) => theta.rows(h0, self.prior_mean.len()).into_owned(),
            None => self.prior_mean.clone(),
        };
        self.unvech(&vech)
    }

    /// The posterior standard deviation of each entry of Ĥ (field unit per length unit²,
    /// zero outside the dim block); the prior's while the data cannot determine the model.
    pub fn hessian_std(&self) -> Mat3 {
        let h0 = 1 + self.dim;
        let n = self.prior_mean.len();
        let var = match self.solve() {
            Some((_, cov)) => DVector::from_iterator(n, (0..n).map(|k| cov[(h0 + k, h0 + k)])),
            None => DVector::from_element(n, 1.0 / self.prior_info),
        };
        self.unvech(&var.map(|v| v.max(0.0).sqrt()))
    }

    /// Ĥ ([`CurvatureEstimator::hessian`]) when the data determine it: the Frobenius norm
    /// of its posterior standard deviation ([`CurvatureEstimator::hessian_std`]) below
    /// `max_spread` × its own; None otherwise. One solve for both.
    pub fn hessian_if_determined(&self, max_spread: f64) -> Option<Mat3> {
        let h0 = 1 + self.dim;
        let n = self.prior_mean.len();
        let (vech, var) = match self.solve() {
            Some((theta, cov)) => (
                theta.rows(h0, n).into_owned(),
                DVector::from_iterator(n, (0..n).map(|k| cov[(h0 + k, h0 + k)])),
            ),
            None => (
                self.prior_mean.clone(),
                DVector::from_element(n, 1.0 / self.prior_info),
            ),
        };
        let h = self.unvech(&vech);
        let spread = self.unvech(&var.map(|v| v.max(0.0).sqrt()));
        (spread.norm() < max_spread * h.norm()).then_some(h)
    }

    /// The gradient g of the fitted model at the expansion point (field unit per length
    /// unit), None while undetermined.
    pub fn gradient(&self) -> Option<Vec3> {
        let (theta, _) = self.solve()?;
        let mut g = Vec3::zeros();
        for j in 0..self.dim {
            g[j] = theta[1 + j] / self.ell;
        }
        Some(g)
    }

    /// The matrix of a vech in the scaled frame, back in the caller's units.
    fn unvech(&self, vech: &DVector<f64>) -> Mat3 {
        let scale = self.ell * self.ell;
        let mut h = Mat3::zeros();
        for (k, (i, j)) in pairs(self.dim).into_iter().enumerate() {
            h[(i, j)] = vech[k] / scale;
            h[(j, i)] = vech[k] / scale;
        }
        h
    }
}

#[cfg(test)]
mod tests;
