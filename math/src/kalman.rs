//! Kalman filtering of the gradient estimate: Lemma 5.4, (V.10), (V.11), Remark 5.8.
//!
//! State `x_T = (∇T, T)` of size `dim + 1` at the estimation point (virtual-body centre),
//! random-walk model `ẋ_T = b v`, `v ~ N(0, I)`, measurements `y = C x_T + D w` with rows
//! `(p_iᵀ, 1)` of C. [`GradientFilter`] is the discrete filter with a time-varying C
//! (Remark 5.8); [`steady_state_covariance`] is P of (V.10) for a constant C.
//!
//! Matrices are `nalgebra::DMatrix` of size `dim + 1`: index `0..dim` is the gradient,
//! index `dim` the value.

use nalgebra::{DMatrix, DVector};

use super::estimate::{check_dim, check_finite_positions, project, EstimateError, LsEstimate};
use super::{Mat3, Vec3};

/// Discrete Kalman filter of `x_T = (∇T, T)` with a time-varying measurement matrix
/// (Lemma 5.4, Remark 5.8).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GradientFilter {
    dim: usize,
    /// State (∇T, T), size dim + 1.
    x: DVector<f64>,
    /// Error covariance, (dim + 1)².
    p: DMatrix<f64>,
}

fn symmetrize(p: &mut DMatrix<f64>) {
    let t = p.transpose();
    *p += t;
    *p *= 0.5;
}

impl GradientFilter {
    /// A filter started at a least-squares estimate with covariance `p0 · I`.
    ///
    /// `p0` is the initial variance of every state component (field² / length² for the
    /// gradient, field² for the value).
    ///
    /// # Panics
    /// If `dim` is not 2 or 3 or `p0` is not finite and ≥ 0 (see [`Self::try_new`]).
    pub fn new(dim: usize, initial: &LsEstimate, p0: f64) -> Self {
        Self::try_new(dim, initial.grad, initial.value, p0)
            .expect("GradientFilter::new: dim must be 2 or 3, p0 finite >= 0, state finite")
    }

    /// A filter started at `(grad, value)` with covariance `p0 · I`; errors instead of
    /// panicking (`InvalidDim`, `InvalidParameter`, `NonFinite`).
    pub fn try_new(dim: usize, grad: Vec3, value: f64, p0: f64) -> Result<Self, EstimateError> {
        check_dim(dim)?;
        if !(p0.is_finite() && p0 >= 0.0) {
            return Err(EstimateError::InvalidParameter {
                name: "p0",
                reason: "must be finite and >= 0",
            });
        }
        if !(grad.iter().all(|v| v.is_finite()) && value.is_finite()) {
            return Err(EstimateError::NonFinite("initial state"));
        }
        let mut x = DVector::zeros(dim + 1);
        for j in 0..dim {
            x[j] = grad[j];
        }
        x[dim] = value;
        Ok(GradientFilter {
            dim,
            x,
            p: DMatrix::identity(dim + 1, dim + 1) * p0,
        })
    }

    /// Restore a filter from its state `(∇T, T)` and covariance (e.g. a checkpoint).
    /// Errors: `InvalidDim`, `ShapeMismatch`, `NonFinite`, `NotSymmetric`.
    pub fn from_parts(
        dim: usize,
        state: DVector<f64>,
        covariance: DMatrix<f64>,
    ) -> Result<Self, EstimateError> {
        check_dim(dim)?;
        if state.len() != dim + 1 || covariance.nrows() != dim + 1 || covariance.ncols() != dim + 1
        {
            return Err(EstimateError::ShapeMismatch(
                "state must be dim+1, covariance (dim+1)²",
            ));
        }
        if !(state.iter().all(|v| v.is_finite()) && covariance.iter().all(|v| v.is_finite())) {
            return Err(EstimateError::NonFinite("filter state"));
        }
        let scale = covariance.amax();
        if (&covariance - covariance.transpose()).amax() > 1e-9 * scale {
            return Err(EstimateError::NotSymmetric("covariance"));
        }
        let mut p = covariance;
        symmetrize(&mut p);
        Ok(GradientFilter { dim, x: state, p })
    }

    /// Spatial dimension (2 or 3).
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Estimated gradient ∇T (field unit per length unit); z = 0 in 2-D.
    pub fn grad(&self) -> Vec3 {
        let mut g = Vec3::zeros();
        for j in 0..self.dim {
            g[j] = self.x[j];
        }
        g
    }

    /// Estimated value T at the estimation point (field unit).
    pub fn value(&self) -> f64 {
        self.x[self.dim]
    }

    /// State `(∇T, T)`, size dim + 1.
    pub fn state(&self) -> DVector<f64> {
        self.x.clone()
    }

    /// Error covariance P, (dim + 1)×(dim + 1), gradient block first, value last.
    pub fn covariance(&self) -> DMatrix<f64> {
        self.p.clone()
    }

    /// The dim×dim gradient block Σ of P (Definition 5.1).
    pub fn grad_covariance(&self) -> DMatrix<f64> {
        self.p.view((0, 0), (self.dim, self.dim)).into_owned()
    }

    /// Time update, random walk `ẋ_T = b v` over `dt` (s) with `Q = b² dt I`, while the
    /// estimation point moves by `shift` (length unit; z ignored in 2-D): `A = [[I, 0],
    /// [shiftᵀ, 1]]`, so `T ← T + ∇T·shift` and `P ← A P Aᵀ + Q`.
    ///
    /// Invalid input (non-finite, `dt < 0`) leaves the state unchanged; use
    /// [`Self::try_predict`] to get the error.
    pub fn predict(&mut self, dt: f64, b: f64, shift: &Vec3) {
        let _ = self.try_predict(dt, b, shift);
    }

    /// [`Self::predict`] with errors (`NonFinite`, `InvalidParameter`); state unchanged on error.
    pub fn try_predict(&mut self, dt: f64, b: f64, shift: &Vec3) -> Result<(), EstimateError> {
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(EstimateError::InvalidParameter {
                name: "dt",
                reason: "must be finite and >= 0",
            });
        }
        if !b.is_finite() {
            return Err(EstimateError::NonFinite("b"));
        }
        if !shift.iter().all(|v| v.is_finite()) {
            return Err(EstimateError::NonFinite("shift"));
        }
        let n = self.dim + 1;
        let s = project(self.dim, shift);
        let mut a = DMatrix::identity(n, n);
        for j in 0..self.dim {
            a[(self.dim, j)] = s[j];
        }
        let x = &a * &self.x;
        let mut p = &a * &self.p * a.transpose() + DMatrix::identity(n, n) * (b * b * dt);
        symmetrize(&mut p);
        if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            return Err(EstimateError::Numerical("prediction overflowed"));
        }
        self.x = x;
        self.p = p;
        Ok(())
    }

    /// Carries the state along a move of the estimation point by `shift` (length unit; z
    /// ignored in 2-D) through a field of Hessian `hessian` (field unit per length unit²),
    /// on top of [`Self::predict`] (beyond the paper, whose model has ∇T constant between
    /// readings): `∇T ← ∇T + H·shift`, `T ← T + ½ shiftᵀ H shift`, exact on a quadratic
    /// field. A known input: `P` is unchanged. Without it a body moving at `v` sees its
    /// estimate lag the gradient by the filter's time constant τ, an error `|H| v τ`; the
    /// climb then overshoots the optimum by about `v τ`. Non-finite input leaves the state
    /// unchanged.
    pub fn carry(&mut self, hessian: &Mat3, shift: &Vec3) {
        let s = project(self.dim, shift);
        let hs = hessian * s;
        let half = 0.5 * s.dot(&hs);
        if !(hs.iter().all(|v| v.is_finite()) && half.is_finite()) {
            return;
        }
        for j in 0..self.dim {
            self.x[j] += hs[j];
        }
        self.x[self.dim] += half;
    }

    /// Measurement update with the time-varying C of Remark 5.8: rows `(p_iᵀ, 1)`
    /// (`rel_positions` relative to the estimation point, z ignored in 2-D), `R =
    /// diag(meas_var)` (field unit², the variances, e.g. the diagonal of DDᵀ of Lemma 5.4).
    /// Joseph form `P ← (I − KC) P (I − KC)ᵀ + K R Kᵀ`, `K = P Cᵀ (C P Cᵀ + R)⁻¹` (Cholesky).
    /// Any number of measurements is allowed (0: no-op).
    ///
    /// Errors (state unchanged): `LengthMismatch`, `NonFinite`, `InvalidParameter` (negative
    /// variance), `Numerical` (innovation covariance not positive definite).
    pub fn update(
        &mut self,
        rel_positions: &[Vec3],
        measurements: &[f64],
        meas_var: &[f64],
    ) -> Result<(), EstimateError> {
        let m = rel_positions.len();
        if measurements.len() != m {
            return Err(EstimateError::LengthMismatch {
                what: "positions vs measurements",
                left: m,
                right: measurements.len(),
            });
        }
        if meas_var.len() != m {
            return Err(EstimateError::LengthMismatch {
                what: "positions vs meas_var",
                left: m,
                right: meas_var.len(),
            });
        }
        check_finite_positions(rel_positions)?;
        if !measurements.iter().all(|v| v.is_finite()) {
            return Err(EstimateError::NonFinite("measurements"));
        }
        if !meas_var.iter().all(|v| v.is_finite()) {
            return Err(EstimateError::NonFinite("meas_var"));
        }
        if meas_var.iter().any(|v| *v < 0.0) {
            return Err(EstimateError::InvalidParameter {
                name: "meas_var",
                reason: "variances must be >= 0",
            });
        }
        if m == 0 {
            return Ok(());
        }
        // R is diagonal (independent readings), so the batch update equals m scalar
        // updates in turn: O(m·n²) instead of the O(m³) factorisation of the m×m
        // innovation covariance (a surfacing glider delivers hundreds of readings at once).
        // Each scalar update is in Joseph form.
        if self.dim < SMALL {
            return self.update_small(rel_positions, measurements, meas_var);
        }
        self.update_dynamic(rel_positions, measurements, meas_var)
    }

    /// [`Self::update`]'s scalar updates on heap matrices (any state size); the reference
    /// [`Self::update_small`] equals bit for bit.
    fn update_dynamic(
        &mut self,
        rel_positions: &[Vec3],
        measurements: &[f64],
        meas_var: &[f64],
    ) -> Result<(), EstimateError> {
        let m = rel_positions.len();
        let n = self.dim + 1;
        let c = measurement_matrix(self.dim, rel_positions);
        let mut x = self.x.clone();
        let mut p = self.p.clone();
        let identity = DMatrix::<f64>::identity(n, n);
        for i in 0..m {
            let h = c.row(i).clone_owned();
            let ph = &p * h.transpose();
            let s = (&h * &ph)[(0, 0)] + meas_var[i];
            if s.is_nan() || s <= 0.0 {
                return Err(EstimateError::Numerical("innovation variance not positive"));
            }
            let k = ph / s;
            let innov = measurements[i] - (&h * &x)[(0, 0)];
            x += &k * innov;
            let ikh = &identity - &k * &h;
            p = &ikh * &p * ikh.transpose() + &k * k.transpose() * meas_var[i];
            symmetrize(&mut p);
        }
        if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            return Err(EstimateError::Numerical(
                "update produced non-finite values",
            ));
        }
        self.x = x;
        self.p = p;
        Ok(())
    }

    /// [`Self::update_dynamic`] for a state of at most [`SMALL`] components, on arrays
    /// instead of heap matrices: the same operations in the same order (every sum of
    /// products `Σ_k a_k b_k` from `k = 0` up, its first term not added to a zero, as
    /// nalgebra's products of small matrices take them), so the same bits.
    #[allow(clippy::needless_range_loop)] // matrices by their indices, as written on paper
    fn update_small(
        &mut self,
        rel_positions: &[Vec3],
        measurements: &[f64],
        meas_var: &[f64],
    ) -> Result<(), EstimateError> {
        let n = self.dim + 1;
        let mut x = [0.0; SMALL];
        let mut p = [[0.0; SMALL]; SMALL];
        for r in 0..n {
            x[r] = self.x[r];
            for c in 0..n {
                p[r][c] = self.p[(r, c)];
            }
        }
        for (rel, (&z, &var)) in rel_positions.iter().zip(measurements.iter().zip(meas_var)) {
            let at = project(self.dim, rel);
            let mut h = [1.0; SMALL];
            h[..self.dim].copy_from_slice(&at.as_slice()[..self.dim]);
            let mut ph = [0.0; SMALL];
            for (r, v) in ph.iter_mut().enumerate().take(n) {
                *v = dot_in_order(n, |k| p[r][k], |k| h[k]);
            }
            let s = dot_in_order(n, |k| h[k], |k| ph[k]) + var;
            if s.is_nan() || s <= 0.0 {
                return Err(EstimateError::Numerical("innovation variance not positive"));
            }
            let mut k = [0.0; SMALL];
            for r in 0..n {
                k[r] = ph[r] / s;
            }
            let innov = z - dot_in_order(n, |j| h[j], |j| x[j]);
            for r in 0..n {
                x[r] += k[r] * innov;
            }
            let mut ikh = [[0.0; SMALL]; SMALL];
            for r in 0..n {
                for c in 0..n {
                    let id = if r == c { 1.0 } else { 0.0 };
                    ikh[r][c] = id - k[r] * h[c];
                }
            }
            let mut ikhp = [[0.0; SMALL]; SMALL];
            for r in 0..n {
                for c in 0..n {
                    ikhp[r][c] = dot_in_order(n, |j| ikh[r][j], |j| p[j][c]);
                }
            }
            let mut next = [[0.0; SMALL]; SMALL];
            for r in 0..n {
                for c in 0..n {
                    let joseph = dot_in_order(n, |j| ikhp[r][j], |j| ikh[c][j]);
                    next[r][c] = joseph + k[r] * k[c] * var;
                }
            }
            // Symmetrised: (P + Pᵀ) · ½.
            for r in 0..n {
                for c in 0..n {
                    p[r][c] = (next[r][c] + next[c][r]) * 0.5;
                }
            }
        }
        let finite = (0..n).all(|r| x[r].is_finite() && (0..n).all(|c| p[r][c].is_finite()));
        if !finite {
            return Err(EstimateError::Numerical(
                "update produced non-finite values",
            ));
        }
        for r in 0..n {
            self.x[r] = x[r];
            for c in 0..n {
                self.p[(r, c)] = p[r][c];
            }
        }
        Ok(())
    }
}

/// The largest state (gradient and value: `dim + 1`) [`GradientFilter::update`] works on
/// in arrays on the stack.
const SMALL: usize = 4;

/// `Σ_k a(k) · b(k)` over `k < n` (`n ≥ 1`), summed from `k = 0` up, the first product
/// not added to a zero (a −0 product stays −0).
#[inline(always)]
fn dot_in_order(n: usize, a: impl Fn(usize) -> f64, b: impl Fn(usize) -> f64) -> f64 {
    let mut acc = a(0) * b(0);
    for k in 1..n {
        acc += a(k) * b(k);
    }
    acc
}

/// C of Lemma 5.1: rows `(p_iᵀ, 1)`, N×(dim+1) (z ignored in 2-D).
pub fn measurement_matrix(dim: usize, rel_positions: &[Vec3]) -> DMatrix<f64> {
    DMatrix::from_fn(rel_positions.len(), dim + 1, |i, j| {
        if j < dim {
            project(dim, &rel_positions[i])[j]
        } else {
            1.0
        }
    })
}

/// DDᵀ of Lemma 5.4, N×N diagonal: `(½ p_iᵀ H p_i σ_H)² + σ_M²` (field unit²), with
/// `D = [diag(½ p_iᵀ H p_i σ_H), σ_M I_N]`; σ's are standard deviations. In 2-D pass
/// positions with z = 0 (then only the top-left 2×2 of H matters).
pub fn noise_matrix_ddt(
    rel_positions: &[Vec3],
    hessian: &Mat3,
    sigma_h: f64,
    sigma_m: f64,
) -> DMatrix<f64> {
    let d = DVector::from_iterator(
        rel_positions.len(),
        rel_positions.iter().map(|p| {
            let q = 0.5 * p.dot(&(hessian * p)) * sigma_h;
            q * q + sigma_m * sigma_m
        }),
    );
    DMatrix::from_diagonal(&d)
}

/// Steady-state P of (V.10): the symmetric positive semidefinite square root of
/// `b² (Cᵀ (DDᵀ)⁻¹ C)⁻¹`, i.e. the solution of `0 = −P Cᵀ(DDᵀ)⁻¹C P + b² I` (the CARE with
/// A = 0, B = bI). Computed as `|b| F^{-1/2}` from the symmetric eigen-decomposition of
/// `F = Cᵀ(DDᵀ)⁻¹C` (DDᵀ by Cholesky).
///
/// Errors: `ShapeMismatch`, `NonFinite`, `InvalidParameter` (b < 0), `NotPositiveDefinite`
/// (DDᵀ, or F: C not of full column rank, relative eigenvalue below 1e-13).
pub fn steady_state_covariance(
    c: &DMatrix<f64>,
    ddt: &DMatrix<f64>,
    b: f64,
) -> Result<DMatrix<f64>, EstimateError> {
    if ddt.nrows() != c.nrows() || ddt.ncols() != c.nrows() {
        return Err(EstimateError::ShapeMismatch(
            "DDᵀ must be N×N for an N-row C",
        ));
    }
    if c.ncols() == 0 || c.nrows() < c.ncols() {
        return Err(EstimateError::ShapeMismatch(
            "C must have at least as many rows as columns",
        ));
    }
    if !(c.iter().all(|v| v.is_finite()) && ddt.iter().all(|v| v.is_finite())) {
        return Err(EstimateError::NonFinite("C or DDᵀ"));
    }
    if !(b.is_finite() && b >= 0.0) {
        return Err(EstimateError::InvalidParameter {
            name: "b",
            reason: "must be finite and >= 0",
        });
    }
    let mut r = ddt.clone();
    symmetrize(&mut r);
    let chol = r
        .cholesky()
        .ok_or(EstimateError::NotPositiveDefinite("DDᵀ"))?;
    let mut f = c.transpose() * chol.solve(c);
    symmetrize(&mut f);
    let eig = f.symmetric_eigen();
    let max = eig.eigenvalues.max();
    if max.is_nan() || max <= 0.0 || eig.eigenvalues.min() <= 1e-13 * max {
        return Err(EstimateError::NotPositiveDefinite("Cᵀ(DDᵀ)⁻¹C"));
    }
    let d = eig.eigenvalues.map(|l| b / l.sqrt());
    let mut p = &eig.eigenvectors * DMatrix::from_diagonal(&d) * eig.eigenvectors.transpose();
    symmetrize(&mut p);
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::least_squares;
    use crate::rng::{keyed, Stream};
    use approx::assert_relative_eq;
    use rand::Rng;

    #[test]
    fn the_small_update_is_the_dynamic_one_bit_for_bit() {
        let mut rng = keyed(5, Stream::Test, 3, 0);
        for trial in 0..2000 {
            let dim = 2 + trial % 2;
            let m = rng.random_range(0..12usize);
            let scale = 10f64.powi(rng.random_range(-3..4));
            let pos: Vec<Vec3> = (0..m)
                .map(|_| {
                    Vec3::new(
                        rng.random_range(-2.0..2.0) * scale,
                        rng.random_range(-2.0..2.0) * scale,
                        if trial % 5 == 0 {
                            -0.0
                        } else {
                            rng.random_range(-2.0..2.0)
                        },
                    )
                })
                .collect();
            let z: Vec<f64> = (0..m).map(|_| rng.random_range(-50.0..50.0)).collect();
            let var: Vec<f64> = (0..m)
                .map(|_| {
                    if trial % 7 == 0 {
                        0.0
                    } else {
                        rng.random_range(0.0..2.0)
                    }
                })
                .collect();
            let grad = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                0.3,
            );
            let p0 = if trial % 11 == 0 {
                0.0
            } else {
                rng.random_range(0.01..5.0)
            };
            let start = GradientFilter::try_new(dim, grad, 1.5, p0).unwrap();
            let (mut a, mut b) = (start.clone(), start.clone());
            // Three updates in turn: the later ones start from a full covariance.
            for round in 0..3 {
                let ra = a.update_small(
                    &pos[round * m / 3..],
                    &z[round * m / 3..],
                    &var[round * m / 3..],
                );
                let rb = b.update_dynamic(
                    &pos[round * m / 3..],
                    &z[round * m / 3..],
                    &var[round * m / 3..],
                );
                assert_eq!(ra.is_ok(), rb.is_ok(), "trial {trial}");
            }
            let bits = |f: &GradientFilter| {
                (
                    f.x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    f.p.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                )
            };
            assert_eq!(bits(&a), bits(&b), "trial {trial}");
        }
    }

    fn formation() -> Vec<Vec3> {
        vec![
            Vec3::new(1.0, 0.1, 0.0),
            Vec3::new(-0.4, 1.2, 0.0),
            Vec3::new(-0.9, -0.6, 0.0),
            Vec3::new(0.5, -1.1, 0.0),
        ]
    }

    #[test]
    fn steady_state_solves_the_riccati_equation() {
        let pts = formation();
        let c = measurement_matrix(2, &pts);
        let h = Mat3::new(2.0, 0.3, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0, 0.0);
        let ddt = noise_matrix_ddt(&pts, &h, 0.5, 0.2);
        for i in 0..4 {
            let q = 0.5 * pts[i].dot(&(h * pts[i])) * 0.5;
            assert_relative_eq!(ddt[(i, i)], q * q + 0.04, max_relative = 1e-15);
        }
        let b = 0.3;
        let p = steady_state_covariance(&c, &ddt, b).unwrap();
        let f = c.transpose() * ddt.clone().try_inverse().unwrap() * &c;
        let res = -&p * &f * &p + DMatrix::identity(3, 3) * (b * b);
        assert!(res.amax() <= 1e-9 * b * b, "{res}");
        // P² = b² F⁻¹, P symmetric positive definite.
        assert_relative_eq!(
            &p * &p,
            f.try_inverse().unwrap() * (b * b),
            max_relative = 1e-9,
            epsilon = 1e-12
        );
        assert_relative_eq!(p.clone(), p.transpose(), epsilon = 1e-15);
        assert!(p.clone().cholesky().is_some());
        // Rank-deficient C is an error.
        let line: Vec<Vec3> = (0..4).map(|i| Vec3::new(i as f64, 0.0, 0.0)).collect();
        let cl = measurement_matrix(2, &line);
        assert!(steady_state_covariance(&cl, &DMatrix::identity(4, 4), b).is_err());
    }

    #[test]
    fn simple_noise_gain_drives_towards_least_squares_v11() {
        let pts = formation();
        let c = measurement_matrix(2, &pts);
        let (d, b) = (0.4, 0.7);
        let ddt = DMatrix::identity(4, 4) * (d * d);
        let p = steady_state_covariance(&c, &ddt, b).unwrap();
        let k = &p * c.transpose() / (d * d);
        let mut rng = keyed(3, Stream::Test, 0, 0);
        for _ in 0..5 {
            let y: Vec<f64> = (0..4).map(|_| rng.random_range(-2.0..2.0)).collect();
            let x = DVector::from_fn(3, |_, _| rng.random_range(-2.0..2.0));
            let ls = least_squares(2, &pts, &y).unwrap();
            let xls = DVector::from_vec(vec![ls.grad.x, ls.grad.y, ls.value]);
            let lhs = &k * (DVector::from_column_slice(&y) - &c * &x);
            let rhs = p.clone().try_inverse().unwrap() * (xls - &x) * (b * b);
            assert_relative_eq!(lhs, rhs, max_relative = 1e-9, epsilon = 1e-12);
        }
    }

    /// Continuous-time limit: measurements every dt with discrete variance DDᵀ/dt and
    /// Q = b² dt I. The discrete posterior covariance converges to P of (V.10) with an
    /// error O(b dt ‖F^{1/2}‖) (measured 1e-3 here); with dt = 1e-3 the relative (Frobenius)
    /// error after 8 s (≈ 20 filter time constants) must be below 0.5 %.
    #[test]
    fn discrete_filter_converges_to_steady_state() {
        let pts = formation();
        let c = measurement_matrix(2, &pts);
        let h = Mat3::identity();
        let ddt = noise_matrix_ddt(&pts, &h, 0.5, 0.3);
        let b = 0.5;
        let p_ss = steady_state_covariance(&c, &ddt, b).unwrap();
        let dt = 1e-3;
        let init = least_squares(2, &pts, &[0.0; 4]).unwrap();
        let mut f = GradientFilter::new(2, &init, 10.0);
        let var: Vec<f64> = (0..4).map(|i| ddt[(i, i)] / dt).collect();
        for _ in 0..8_000 {
            f.predict(dt, b, &Vec3::zeros());
            f.update(&pts, &[0.0; 4], &var).unwrap();
        }
        let err = (f.covariance() - &p_ss).norm() / p_ss.norm();
        assert!(err < 5e-3, "relative error {err}");
        assert_eq!(
            f.grad_covariance(),
            f.covariance().view((0, 0), (2, 2)).into_owned()
        );
    }

    /// On a quadratic field T(x) = ½ (x − c)ᵀ H (x − c), a filter started exact at the
    /// origin and only predicted and carried along a path (no reading) holds the exact
    /// gradient H (x − c) and value at every point of it; predicted alone it keeps the
    /// gradient of the start (the lag the carry removes).
    #[test]
    fn carry_follows_a_quadratic_field_exactly_along_a_path() {
        let h = Mat3::new(2.0, 0.5, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0);
        let c = Vec3::new(3.0, -1.0, 0.0);
        let field = |x: &Vec3| 0.5 * (x - c).dot(&(h * (x - c)));
        let grad = |x: &Vec3| h * (x - c);
        let start = LsEstimate {
            grad: grad(&Vec3::zeros()),
            value: field(&Vec3::zeros()),
            residual_ss: 0.0,
            dof: 1,
        };
        let mut carried = GradientFilter::new(2, &start, 1.0);
        let mut plain = GradientFilter::new(2, &start, 1.0);
        let mut x = Vec3::zeros();
        for i in 0..200 {
            let step = Vec3::new(0.03 * (i as f64 * 0.1).cos(), 0.02, 0.0);
            carried.predict(0.05, 0.1, &step);
            carried.carry(&h, &step);
            plain.predict(0.05, 0.1, &step);
            x += step;
        }
        assert_relative_eq!(carried.grad(), grad(&x), epsilon = 1e-12);
        assert_relative_eq!(carried.value(), field(&x), epsilon = 1e-12);
        assert_eq!(plain.grad(), grad(&Vec3::zeros()));
        assert!((plain.grad() - grad(&x)).norm() > 1.0);
        // A non-finite move changes nothing.
        let before = carried.state();
        carried.carry(&h, &Vec3::new(f64::NAN, 0.0, 0.0));
        assert_eq!(carried.state(), before);
    }

    #[test]
    fn predict_shifts_value_and_filter_tracks_a_plane() {
        let init = LsEstimate {
            grad: Vec3::new(1.0, 2.0, 0.0),
            value: 3.0,
            residual_ss: 0.0,
            dof: 1,
        };
        let mut f = GradientFilter::new(2, &init, 1.0);
        f.predict(0.1, 0.0, &Vec3::new(0.5, -1.0, 9.0));
        assert_relative_eq!(f.value(), 3.0 + 0.5 - 2.0, epsilon = 1e-15);
        assert_eq!(f.grad(), Vec3::new(1.0, 2.0, 0.0));
        // P = A P Aᵀ with A = [[I,0],[sᵀ,1]]: P_TT = 1 + |s|².
        assert_relative_eq!(f.covariance()[(2, 2)], 1.0 + 0.25 + 1.0, epsilon = 1e-15);
        assert_relative_eq!(f.covariance()[(2, 0)], 0.5, epsilon = 1e-15);
        // Noisy plane, moving centre: the filter converges to the true gradient/value.
        let (g, t0) = (Vec3::new(-0.4, 0.9, 0.0), 1.0);
        let mut f = GradientFilter::try_new(2, Vec3::zeros(), 0.0, 100.0).unwrap();
        let mut centre = Vec3::zeros();
        for k in 0..400u64 {
            let shift = Vec3::new(0.05, 0.02, 0.0);
            centre += shift;
            f.predict(0.1, 1e-3, &shift);
            let pts = formation();
            let mut rng = keyed(2, Stream::Test, k, 0);
            let y: Vec<f64> = pts
                .iter()
                .map(|p| t0 + g.dot(&(centre + p)) + 0.1 * rng.random_range(-1.7..1.7))
                .collect();
            f.update(&pts, &y, &[0.01; 4]).unwrap();
        }
        assert!((f.grad() - g).norm() < 0.02, "{}", f.grad());
        assert!((f.value() - (t0 + g.dot(&centre))).abs() < 0.02);
    }

    #[test]
    fn bad_input_leaves_state_unchanged() {
        let mut f = GradientFilter::try_new(3, Vec3::new(1.0, 2.0, 3.0), 4.0, 1.0).unwrap();
        let before = f.clone();
        let pts = vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        assert!(f.update(&pts, &[1.0, f64::NAN], &[1.0, 1.0]).is_err());
        assert!(f.update(&pts, &[1.0, 2.0], &[1.0]).is_err());
        assert!(f.update(&pts, &[1.0, 2.0], &[1.0, -1.0]).is_err());
        f.predict(f64::NAN, 1.0, &Vec3::zeros());
        f.predict(0.1, 1.0, &Vec3::new(f64::INFINITY, 0.0, 0.0));
        assert!(f.try_predict(-1.0, 1.0, &Vec3::zeros()).is_err());
        assert_eq!(f, before);
        // A perfectly known state with noise-free measurements: S singular → error.
        let mut exact = GradientFilter::try_new(3, Vec3::zeros(), 0.0, 0.0).unwrap();
        assert!(exact.update(&pts, &[0.0, 0.0], &[0.0, 0.0]).is_err());
        assert!(GradientFilter::try_new(4, Vec3::zeros(), 0.0, 1.0).is_err());
        assert!(GradientFilter::try_new(2, Vec3::zeros(), 0.0, -1.0).is_err());
        // One measurement is enough for a Kalman update (no rank requirement).
        assert!(f.update(&pts[..1], &[1.0], &[0.5]).is_ok());
        assert!(f.covariance()[(0, 0)] < 1.0);
    }
}
