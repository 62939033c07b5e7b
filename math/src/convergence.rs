//! Convergence of gradient climbing: ε_est of Definition 5.1 and the set M of Theorem 5.1.
//!
//! `ε_est(c, Σ)` is the radius of the centred ball holding probability `c` of `x ~ N(0, Σ)`.
//! With `Σ = V Λ Vᵀ` and `x = V Λ^{1/2} ρ ω` (ρ² ~ χ²_l, ω uniform on the unit sphere,
//! independent), `P(‖x‖ ≤ ε) = E_ω[F_{χ²_l}(ε² / ωᵀΛω)]`. The expectation over directions is
//! a fixed composite Gauss–Legendre rule on one quadrant (2-D) or octant (3-D, pole on the
//! largest eigenvalue), with more panels for more anisotropic Σ; ε is then found by a
//! safeguarded Newton iteration. The fixed rule makes the probability exactly monotone in ε,
//! so ε_est is unique and monotone in c, and deterministic.

use nalgebra::DMatrix;

use super::estimate::{check_dim, EstimateError};

const FRAC_2_SQRT_PI: f64 = std::f64::consts::FRAC_2_SQRT_PI;

/// Σ_{n ≥ n0} s·(2s²)ⁿ/(2n+1)!!, so that erf(s) = 2/√π e^{−s²} × (this with n0 = 0).
fn erf_series(s: f64, n0: usize) -> f64 {
    let x2 = 2.0 * s * s;
    let mut term = s;
    let mut sum = if n0 == 0 { s } else { 0.0 };
    let mut n = 1usize;
    loop {
        term *= x2 / (2 * n + 1) as f64;
        if n >= n0 {
            sum += term;
        }
        if term <= 1e-17 * sum || n > 500 {
            break;
        }
        n += 1;
    }
    sum
}

/// erfc(s) for s ≥ 3 by its continued fraction (backward evaluation, 80 levels).
fn erfc_cf(s: f64) -> f64 {
    let mut r = s;
    for k in (1..=80).rev() {
        r = s + (k as f64 / 2.0) / r;
    }
    (-s * s).exp() / (std::f64::consts::PI.sqrt() * r)
}

/// erf(s) for s ≥ 0 (absolute error ~1e-16).
pub(crate) fn erf(s: f64) -> f64 {
    if s < 3.0 {
        FRAC_2_SQRT_PI * (-s * s).exp() * erf_series(s, 0)
    } else {
        1.0 - erfc_cf(s)
    }
}

/// CDF of χ²_l at t ≥ 0, l ∈ 1..=3 (+∞ gives 1).
fn chi2_cdf(l: usize, t: f64) -> f64 {
    if t.is_infinite() {
        return 1.0;
    }
    let s = (0.5 * t).sqrt();
    match l {
        1 => erf(s),
        2 => -(-0.5 * t).exp_m1(),
        _ => {
            if s < 3.0 {
                FRAC_2_SQRT_PI * (-s * s).exp() * erf_series(s, 1)
            } else {
                1.0 - erfc_cf(s) - FRAC_2_SQRT_PI * s * (-s * s).exp()
            }
        }
    }
}

/// Density of χ²_l at t > 0, l ∈ 1..=3.
fn chi2_pdf(l: usize, t: f64) -> f64 {
    if t.is_nan() || t <= 0.0 || t.is_infinite() {
        return 0.0;
    }
    match l {
        1 => (-0.5 * t).exp() / (2.0 * std::f64::consts::PI * t).sqrt(),
        2 => 0.5 * (-0.5 * t).exp(),
        _ => (t / (2.0 * std::f64::consts::PI)).sqrt() * (-0.5 * t).exp(),
    }
}

/// n-point Gauss–Legendre nodes and weights on [−1, 1].
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = vec![(0.0, 0.0); n];
    for i in 0..n.div_ceil(2) {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out[i] = (x, w);
        out[n - 1 - i] = (-x, w);
    }
    out
}

/// Composite Gauss–Legendre on [a, b]: `panels` × 16 nodes, weights summing to b − a.
fn composite(a: f64, b: f64, panels: usize) -> Vec<(f64, f64)> {
    let gl = gauss_legendre(16);
    let h = (b - a) / panels as f64;
    let mut out = Vec::with_capacity(panels * 16);
    for k in 0..panels {
        let mid = a + h * (k as f64 + 0.5);
        for &(x, w) in &gl {
            out.push((mid + 0.5 * h * x, 0.5 * h * w));
        }
    }
    out
}

/// Direction rule: (q(ω) = ωᵀΛω, weight) with weights summing to 1.
struct DirectionRule {
    l: usize,
    nodes: Vec<(f64, f64)>,
}

impl DirectionRule {
    /// `lam`: positive eigenvalues normalised to max 1, ascending (1 to 3 of them).
    fn new(lam: &[f64]) -> Self {
        let kappa = (1.0 / lam[0]).sqrt();
        let panels = match lam.len() {
            2 => (kappa / 6.0).ceil().clamp(4.0, 128.0) as usize,
            _ => (kappa / 6.0).ceil().clamp(2.0, 32.0) as usize,
        };
        Self::with_panels(lam, panels)
    }

    /// The rule with `panels` × 16 Gauss–Legendre nodes per angular coordinate.
    fn with_panels(lam: &[f64], panels: usize) -> Self {
        let l = lam.len();
        let half_pi = std::f64::consts::FRAC_PI_2;
        let nodes = match l {
            1 => vec![(lam[0], 1.0)],
            2 => composite(0.0, half_pi, panels)
                .into_iter()
                .map(|(th, w)| {
                    let (s, c) = th.sin_cos();
                    (lam[0] * c * c + lam[1] * s * s, w / half_pi)
                })
                .collect(),
            _ => {
                // Smallest eigenvalue on x, largest on the pole z (see module doc).
                let phis = composite(0.0, half_pi, panels);
                let mus = composite(0.0, 1.0, panels);
                let mut v = Vec::with_capacity(phis.len() * mus.len());
                for &(phi, wp) in &phis {
                    let (s, c) = phi.sin_cos();
                    for &(mu, wm) in &mus {
                        let r2 = 1.0 - mu * mu;
                        let q = r2 * (lam[0] * c * c + lam[1] * s * s) + lam[2] * mu * mu;
                        v.push((q, wp * wm / half_pi));
                    }
                }
                v
            }
        };
        DirectionRule { l, nodes }
    }

    /// P(‖x‖² ≤ t) and its derivative in t (for the normalised Σ).
    fn prob(&self, t: f64) -> (f64, f64) {
        let (mut p, mut d) = (0.0, 0.0);
        for &(q, w) in &self.nodes {
            if q > 0.0 {
                p += w * chi2_cdf(self.l, t / q);
                d += w * chi2_pdf(self.l, t / q) / q;
            } else {
                p += w;
            }
        }
        (p.min(1.0), d)
    }
}

/// Eigenvalues (ascending, max > 0) normalised to max 1, dropping those below
/// [`ZERO_EIGENVALUE`]: x then lives in the subspace of the others, exactly (up to a change of
/// ‖x‖² of 1e-12 λ_max).
fn reduced(lam: &[f64]) -> Vec<f64> {
    let max = lam[lam.len() - 1];
    lam.iter()
        .map(|v| v / max)
        .filter(|v| *v > ZERO_EIGENVALUE)
        .collect()
}

/// Relative size below which an eigenvalue of Σ counts as zero in [`epsilon_est`].
pub const ZERO_EIGENVALUE: f64 = 1e-12;

/// Validate Σ (square, 1..=3, finite, symmetric, PSD) and return its eigenvalues ascending,
/// negatives from round-off clamped to 0.
fn eigenvalues(sigma: &DMatrix<f64>) -> Result<Vec<f64>, EstimateError> {
    let l = sigma.nrows();
    if sigma.ncols() != l {
        return Err(EstimateError::ShapeMismatch("Σ must be square"));
    }
    if !(1..=3).contains(&l) {
        return Err(EstimateError::InvalidDim(l));
    }
    if !sigma.iter().all(|v| v.is_finite()) {
        return Err(EstimateError::NonFinite("Σ"));
    }
    let scale = sigma.amax();
    if (sigma - sigma.transpose()).amax() > 1e-9 * scale {
        return Err(EstimateError::NotSymmetric("Σ"));
    }
    let sym = (sigma + sigma.transpose()) * 0.5;
    let mut lam: Vec<f64> = sym.symmetric_eigenvalues().iter().cloned().collect();
    lam.sort_by(f64::total_cmp);
    let max = lam[l - 1];
    if lam[0] < -1e-10 * max.abs().max(f64::MIN_POSITIVE) {
        return Err(EstimateError::NotPositiveSemidefinite("Σ"));
    }
    Ok(lam.into_iter().map(|v| v.max(0.0)).collect())
}

/// P(‖x‖ ≤ eps) for x ~ N(0, Σ), Σ of size 1..=3 (the integral of Definition 5.1).
/// Errors as [`epsilon_est`]; `InvalidParameter` for a negative or NaN `eps`.
pub fn gaussian_ball_probability(eps: f64, sigma: &DMatrix<f64>) -> Result<f64, EstimateError> {
    if eps.is_nan() || eps < 0.0 {
        return Err(EstimateError::InvalidParameter {
            name: "eps",
            reason: "must be >= 0",
        });
    }
    let lam = eigenvalues(sigma)?;
    let max = *lam.last().unwrap_or(&0.0);
    if max == 0.0 {
        return Ok(1.0);
    }
    Ok(DirectionRule::new(&reduced(&lam)).prob(eps * eps / max).0)
}

/// ε_est(c, Σ) of Definition 5.1: the radius ε (length of a gradient, field unit per length
/// unit) with `P(‖x‖ ≤ ε) = c` for `x ~ N(0, Σ)`, where Σ is the l×l gradient block of the
/// covariance P (l = 1..=3; pass e.g. [`super::kalman::GradientFilter::grad_covariance`]).
///
/// `c ∈ [0, 1)` is the confidence level (c = 0 gives 0). Monotone in c and scales as √k
/// under Σ → kΣ (Remark 5.6). Probability error ~1e-13 for isotropic Σ and below ~1e-9 up to
/// an eigenvalue ratio λ_max/λ_min of 10⁴ (coarser, but still monotone, beyond; eigenvalues
/// below 1e-12 λ_max are treated as 0, reducing the dimension exactly).
///
/// Errors: `InvalidParameter` (c outside [0, 1)), `ShapeMismatch`, `InvalidDim`,
/// `NonFinite`, `NotSymmetric`, `NotPositiveSemidefinite`, `Numerical` (no convergence).
pub fn epsilon_est(c: f64, sigma: &DMatrix<f64>) -> Result<f64, EstimateError> {
    if !(0.0..1.0).contains(&c) {
        return Err(EstimateError::InvalidParameter {
            name: "c",
            reason: "confidence level must be in [0, 1)",
        });
    }
    let lam = eigenvalues(sigma)?;
    let max = *lam.last().unwrap_or(&0.0);
    if c == 0.0 || max == 0.0 {
        return Ok(0.0);
    }
    let norm = reduced(&lam);
    let rule = DirectionRule::new(&norm);
    // Bracket t = ε²/λ_max.
    let mut lo = 0.0;
    let mut hi = norm.len() as f64;
    let mut guard = 0;
    while rule.prob(hi).0 < c {
        lo = hi;
        hi *= 2.0;
        guard += 1;
        if guard > 200 {
            return Err(EstimateError::Numerical("epsilon_est: no bracket"));
        }
    }
    let mut t = 0.5 * (lo + hi);
    for _ in 0..300 {
        let (p, d) = rule.prob(t);
        if p < c {
            lo = t;
        } else {
            hi = t;
        }
        let newton = t - (p - c) / d;
        let next = if d > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        let done = (next - t).abs() <= 1e-15 * t || hi - lo <= 1e-15 * hi;
        t = next;
        if done {
            let eps = (t * max).sqrt();
            return if eps.is_finite() {
                Ok(eps)
            } else {
                Err(EstimateError::Numerical("epsilon_est: non-finite"))
            };
        }
    }
    Err(EstimateError::Numerical("epsilon_est did not converge"))
}

/// The bound of Theorem 5.1: `ε_est(c, P) + δ_M`, the radius in gradient norm of the set M
/// the virtual body converges to (field unit per length unit).
///
/// `p` is the (dim+1)×(dim+1) covariance P itself, i.e. the (V.10) matrix square root of
/// `b²(Cᵀ(DDᵀ)⁻¹C)⁻¹` ([`super::kalman::steady_state_covariance`]) or, with a time-varying C,
/// an upper bound of P(t) (Remark 5.8); its dim×dim gradient block is used.
/// `delta_m ≥ 0` (the paper's arbitrary small positive δ_M).
///
/// Errors: `InvalidDim`, `ShapeMismatch`, `InvalidParameter` (δ_M), and those of
/// [`epsilon_est`].
pub fn theorem_5_1_bound(
    c: f64,
    p: &DMatrix<f64>,
    dim: usize,
    delta_m: f64,
) -> Result<f64, EstimateError> {
    check_dim(dim)?;
    if p.nrows() != dim + 1 || p.ncols() != dim + 1 {
        return Err(EstimateError::ShapeMismatch("P must be (dim+1)×(dim+1)"));
    }
    if !(delta_m.is_finite() && delta_m >= 0.0) {
        return Err(EstimateError::InvalidParameter {
            name: "delta_m",
            reason: "must be finite and >= 0",
        });
    }
    let sigma = p.view((0, 0), (dim, dim)).into_owned();
    Ok(epsilon_est(c, &sigma)? + delta_m)
}

/// The default δ_M of Theorem 5.1 when the mission sets none: 1 % of `ε_est` (field unit
/// per length unit). The theorem holds for any δ_M > 0 ("arbitrarily small"); a fixed
/// fraction of `ε_est` is positive whenever the covariance is, carries the field's and the
/// mission's units without tuning, and widens the set M by a margin far below the
/// estimate's own uncertainty.
pub fn default_delta_m(epsilon_est: f64) -> f64 {
    0.01 * epsilon_est
}

/// Whether the true gradient norm lies within the set M of Theorem 5.1
/// (`‖∇T(r)‖ ≤ bound`).
pub fn in_set_m(true_grad_norm: f64, bound: f64) -> bool {
    true_grad_norm <= bound
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{keyed, Stream};
    use approx::assert_relative_eq;
    use rand::Rng;
    use rand_distr::StandardNormal;

    #[test]
    fn erf_and_chi2_against_known_values() {
        assert_relative_eq!(erf(0.5), 0.520_499_877_813_046_5, max_relative = 1e-15);
        assert_relative_eq!(erf(1.0), 0.842_700_792_949_714_9, max_relative = 1e-15);
        assert_relative_eq!(
            1.0 - erf(2.0),
            0.004_677_734_981_047_266,
            max_relative = 1e-12
        );
        assert_relative_eq!(erfc_cf(3.0), 2.209_049_699_858_544e-5, max_relative = 1e-13);
        assert_relative_eq!(
            erfc_cf(4.5),
            1.966_160_441_542_887e-10,
            max_relative = 1e-13
        );
        // Continuity of the two branches of χ²_3 at s = 3.
        assert_relative_eq!(
            chi2_cdf(3, 18.0 - 1e-12),
            chi2_cdf(3, 18.0 + 1e-12),
            epsilon = 1e-14
        );
        // Derivative of the CDF is the density.
        for l in 1..=3 {
            for t in [0.3, 2.0, 7.0, 20.0] {
                let fd = (chi2_cdf(l, t + 1e-6) - chi2_cdf(l, t - 1e-6)) / 2e-6;
                assert_relative_eq!(fd, chi2_pdf(l, t), epsilon = 1e-9, max_relative = 1e-7);
            }
        }
    }

    #[test]
    fn rayleigh_maxwell_and_normal_radii() {
        let s = 0.7;
        for c in [0.1, 0.5, 0.9, 0.999] {
            let sig2 = DMatrix::identity(2, 2) * (s * s);
            assert_relative_eq!(
                epsilon_est(c, &sig2).unwrap(),
                s * (-2.0 * (1.0f64 - c).ln()).sqrt(),
                max_relative = 1e-12
            );
        }
        // Maxwell: ε² / σ² is the χ²_3 quantile (tabulated values).
        for (c, q) in [
            (0.5, 2.365_973_884_375_338),
            (0.95, 7.814_727_903_251_178),
            (0.999, 16.266_236_196_238_13),
        ] {
            let sig3 = DMatrix::identity(3, 3) * (s * s);
            assert_relative_eq!(
                epsilon_est(c, &sig3).unwrap(),
                s * f64::sqrt(q),
                max_relative = 1e-10
            );
        }
        assert_relative_eq!(
            epsilon_est(0.95, &DMatrix::from_element(1, 1, s * s)).unwrap(),
            s * 1.959_963_984_540_054,
            max_relative = 1e-12
        );
        // Degenerate 2-D and 3-D Σ of rank 1: the 1-D normal quantile (quadrature check).
        let deg2 = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![s * s, 0.0]));
        assert_relative_eq!(
            epsilon_est(0.95, &deg2).unwrap(),
            s * 1.959_963_984_540_054,
            max_relative = 1e-6
        );
        let deg3 = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.0, s * s, 0.0]));
        assert_relative_eq!(
            epsilon_est(0.95, &deg3).unwrap(),
            s * 1.959_963_984_540_054,
            max_relative = 1e-5
        );
        // Rank 2 in 3-D: the Rayleigh radius.
        let deg32 = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![s * s, 0.0, s * s]));
        assert_relative_eq!(
            epsilon_est(0.9, &deg32).unwrap(),
            s * (-2.0 * 0.1f64.ln()).sqrt(),
            max_relative = 1e-6
        );
    }

    #[test]
    fn monotone_in_c_and_in_scale_remark_5_6() {
        let sigma = DMatrix::from_row_slice(3, 3, &[2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.4]);
        let mut prev = 0.0;
        for c in [0.0, 0.01, 0.2, 0.5, 0.8, 0.95, 0.999] {
            let e = epsilon_est(c, &sigma).unwrap();
            assert!(e > prev || (c == 0.0 && e == 0.0));
            prev = e;
            let p = gaussian_ball_probability(e, &sigma).unwrap();
            assert_relative_eq!(p, c, epsilon = 1e-12);
        }
        let e1 = epsilon_est(0.9, &sigma).unwrap();
        let e4 = epsilon_est(0.9, &(&sigma * 4.0)).unwrap();
        assert_relative_eq!(e4, 2.0 * e1, max_relative = 1e-12);
        assert!(epsilon_est(0.9, &(&sigma * 1.01)).unwrap() > e1);
    }

    #[test]
    fn anisotropic_radius_matches_monte_carlo() {
        let n = 40_000u64;
        for (k, sigma) in [
            DMatrix::from_row_slice(2, 2, &[3.0, 1.1, 1.1, 0.5]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1e-3]),
            DMatrix::from_row_slice(3, 3, &[2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.3]),
        ]
        .into_iter()
        .enumerate()
        {
            let c = 0.9;
            let eps = epsilon_est(c, &sigma).unwrap();
            let l = sigma.nrows();
            let chol = sigma.clone().cholesky().unwrap().l();
            let mut rng = keyed(21, Stream::Test, k as u64, 0);
            let mut inside = 0u64;
            for _ in 0..n {
                let z = nalgebra::DVector::from_fn(l, |_, _| rng.sample::<f64, _>(StandardNormal));
                if (&chol * z).norm() <= eps {
                    inside += 1;
                }
            }
            let frac = inside as f64 / n as f64;
            let sd = (c * (1.0 - c) / n as f64).sqrt();
            assert!((frac - c).abs() < 4.0 * sd, "case {k}: {frac} vs {c}");
        }
    }

    /// The adaptive panel count keeps the probability within 1e-8 of a much finer rule up
    /// to an eigenvalue ratio of 1e4 (2-D and 3-D), also for small confidence levels where
    /// the integrand is sharpest.
    #[test]
    fn quadrature_is_accurate_for_anisotropic_sigma() {
        for (lam, cs) in [
            (vec![1e-4, 1.0], &[0.001, 0.01, 0.5, 0.99][..]),
            (vec![0.01, 1.0], &[0.01, 0.5, 0.99][..]),
            (vec![1e-4, 1e-4, 1.0], &[0.01, 0.9][..]),
            (vec![0.01, 0.1, 1.0], &[0.01, 0.9][..]),
        ] {
            let sigma = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(lam.clone()));
            let fine = DirectionRule::with_panels(&lam, if lam.len() == 2 { 1000 } else { 40 });
            for &c in cs {
                let eps = epsilon_est(c, &sigma).unwrap();
                let p = fine.prob(eps * eps).0;
                assert!((p - c).abs() < 1e-8, "{lam:?} c = {c}: {p}");
            }
        }
    }

    #[test]
    fn rotation_invariant_and_errors() {
        let a = 0.6f64;
        let r = DMatrix::from_row_slice(2, 2, &[a.cos(), -a.sin(), a.sin(), a.cos()]);
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![2.0, 0.3]));
        let rot = &r * &d * r.transpose();
        assert_relative_eq!(
            epsilon_est(0.9, &rot).unwrap(),
            epsilon_est(0.9, &d).unwrap(),
            max_relative = 1e-10
        );
        assert!(epsilon_est(1.0, &d).is_err());
        assert!(epsilon_est(-0.1, &d).is_err());
        assert!(epsilon_est(f64::NAN, &d).is_err());
        let neg = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, -0.5]));
        assert!(matches!(
            epsilon_est(0.9, &neg),
            Err(EstimateError::NotPositiveSemidefinite(_))
        ));
        let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
        assert!(matches!(
            epsilon_est(0.9, &asym),
            Err(EstimateError::NotSymmetric(_))
        ));
        assert!(epsilon_est(0.9, &DMatrix::identity(4, 4)).is_err());
        assert_eq!(epsilon_est(0.9, &DMatrix::zeros(2, 2)).unwrap(), 0.0);
    }

    #[test]
    fn theorem_bound_uses_the_gradient_block_of_p() {
        let p = DMatrix::from_row_slice(3, 3, &[0.04, 0.0, 0.01, 0.0, 0.04, 0.0, 0.01, 0.0, 9.0]);
        let bound = theorem_5_1_bound(0.99, &p, 2, 0.05).unwrap();
        assert_relative_eq!(
            bound,
            0.2 * (-2.0 * 0.01f64.ln()).sqrt() + 0.05,
            max_relative = 1e-12
        );
        assert!(in_set_m(bound - 1e-9, bound));
        assert!(!in_set_m(bound + 1e-9, bound));
        assert!(theorem_5_1_bound(0.99, &p, 3, 0.05).is_err());
        assert!(theorem_5_1_bound(0.99, &p, 2, -1.0).is_err());
    }
}
