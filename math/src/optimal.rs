//! Optimal formation geometry for gradient estimation: problem (V.7), Table I, and the
//! cheap optimal scale of a given shape (resolution adaptation, Section V intro).
//!
//! The objective is g of (V.6) ([`super::estimate::expected_error`]). The search works in the
//! natural length unit `L = sqrt(2√2 σ_M / (σ_H h̄))` (h̄ the mean eigenvalue of H, cf. (V.9)),
//! from regular starts (polygon / Platonic solid / Fibonacci sphere, plain and stretched by
//! H^{-1/2}, with and without a vehicle at the centre) and seeded random starts, each refined by
//! a hand-written BFGS with an Armijo backtracking line search and the analytic gradient of g.
//! Everything is deterministic: same inputs and seed, bit-identical result.

use nalgebra::DMatrix;
use rand::Rng;

use super::estimate::{
    check_dim, check_geometry, check_sigmas, project, rms_radius, Cost, EstimateError,
};
use super::{Mat3, Vec3};
use crate::rng::{keyed, Stream};

/// A local optimum of (V.7).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OptimalFormation {
    /// g (V.6) at the optimum (field² / length² + field²).
    pub g: f64,
    /// Vehicle positions relative to the estimation point (length unit; z = 0 in 2-D).
    pub positions: Vec<Vec3>,
    /// Mean distance of the vehicles to the estimation point (length unit).
    pub radius: f64,
    /// Second moments (1/N) Σ p pᵀ (length unit²).
    pub second_moments: Mat3,
}

/// Tuning of the multi-start search of [`optimal_formation_with`].
#[derive(Clone, Debug, PartialEq)]
pub struct SearchOptions {
    /// Number of random starts in addition to the regular ones.
    pub random_starts: usize,
    /// BFGS iteration cap per start.
    pub max_iterations: usize,
    /// Stop when ‖∇g‖∞ (in the natural length unit) ≤ this × g.
    pub gradient_tolerance: f64,
    /// Also start from the regular shapes (polygon / Platonic, stretched, with a centre
    /// vehicle). Off only to test that random starts alone find the optimum.
    pub regular_starts: bool,
}

impl Default for SearchOptions {
    fn default() -> Self {
        SearchOptions {
            random_starts: 12,
            max_iterations: 2000,
            gradient_tolerance: 1e-10,
            regular_starts: true,
        }
    }
}

/// Unit-radius regular shape of `n` points centred on the origin: the regular n-gon in 2-D
/// (first vertex on +x); in 3-D the Platonic solid for n ∈ {4, 6, 8, 12, 20}, otherwise a
/// Fibonacci-sphere point set. Returns an empty vector for n = 0 or a dim other than 2, 3.
pub fn regular_shape(n: usize, dim: usize) -> Vec<Vec3> {
    use std::f64::consts::PI;
    match dim {
        2 => (0..n)
            .map(|i| {
                let a = 2.0 * PI * i as f64 / n as f64;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect(),
        3 => {
            let phi = (1.0 + 5f64.sqrt()) / 2.0;
            let raw: Vec<Vec3> = match n {
                4 => vec![
                    Vec3::new(1.0, 1.0, 1.0),
                    Vec3::new(1.0, -1.0, -1.0),
                    Vec3::new(-1.0, 1.0, -1.0),
                    Vec3::new(-1.0, -1.0, 1.0),
                ],
                6 => vec![
                    Vec3::x(),
                    -Vec3::x(),
                    Vec3::y(),
                    -Vec3::y(),
                    Vec3::z(),
                    -Vec3::z(),
                ],
                8 => cube_vertices(),
                12 => {
                    let mut v = Vec::new();
                    for &a in &[1.0, -1.0] {
                        for &b in &[phi, -phi] {
                            v.push(Vec3::new(0.0, a, b));
                            v.push(Vec3::new(a, b, 0.0));
                            v.push(Vec3::new(b, 0.0, a));
                        }
                    }
                    v
                }
                20 => {
                    let mut v = cube_vertices();
                    for &a in &[1.0 / phi, -1.0 / phi] {
                        for &b in &[phi, -phi] {
                            v.push(Vec3::new(0.0, a, b));
                            v.push(Vec3::new(a, b, 0.0));
                            v.push(Vec3::new(b, 0.0, a));
                        }
                    }
                    v
                }
                _ => {
                    let golden = PI * (3.0 - 5f64.sqrt());
                    (0..n)
                        .map(|i| {
                            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                            let r = (1.0 - z * z).max(0.0).sqrt();
                            let a = golden * i as f64;
                            Vec3::new(r * a.cos(), r * a.sin(), z)
                        })
                        .collect()
                }
            };
            raw.into_iter().map(|p| p.normalize()).collect()
        }
        _ => Vec::new(),
    }
}

/// Validate H for (V.7): finite, symmetric (relative 1e-9), positive definite on the dim block.
fn check_spd(dim: usize, hessian: &Mat3) -> Result<Mat3, EstimateError> {
    if !hessian.iter().all(|v| v.is_finite()) {
        return Err(EstimateError::NonFinite("hessian"));
    }
    let scale = hessian.abs().max();
    let mut h = Mat3::zeros();
    for i in 0..dim {
        for j in 0..dim {
            if (hessian[(i, j)] - hessian[(j, i)]).abs() > 1e-9 * scale {
                return Err(EstimateError::NotSymmetric("hessian"));
            }
            h[(i, j)] = 0.5 * (hessian[(i, j)] + hessian[(j, i)]);
        }
    }
    let block = DMatrix::from_fn(dim, dim, |i, j| h[(i, j)]);
    let eig = block.symmetric_eigenvalues();
    if scale == 0.0 || eig.min() <= 1e-12 * eig.max().abs() {
        return Err(EstimateError::NotPositiveDefinite("hessian"));
    }
    Ok(h)
}

fn check_sigmas_positive(sigma_h: f64, sigma_m: f64) -> Result<(), EstimateError> {
    check_sigmas(sigma_h, sigma_m)?;
    if sigma_h == 0.0 {
        return Err(EstimateError::NoMinimum(
            "sigma_h = 0: g decreases without bound as the formation grows",
        ));
    }
    if sigma_m == 0.0 {
        return Err(EstimateError::NoMinimum(
            "sigma_m = 0: g tends to 0 as the formation shrinks to a point",
        ));
    }
    Ok(())
}

/// The scale factor `k* > 0` minimising `g(k · shape)` (V.6) and that minimal g.
///
/// Exact and cheap: with `C⁺ e_i = (u_i, v_i)` for the shape, `g(k) = βk⁴ + αk² + γ/k² + δ`
/// (α = σ_H² Σ‖u_i‖² q_i², β = σ_H² Σ v_i² q_i², γ = σ_M² Σ‖u_i‖², δ = σ_M² Σ v_i², q_i =
/// ½ p_iᵀHp_i), minimised at the unique positive root u = k² of `2βu³ + αu² − γ = 0` (Newton
/// from above, monotone). H need not be definite.
///
/// Errors: geometry as [`super::estimate::least_squares`]; `InvalidParameter` for negative σ;
/// `NoMinimum` if σ_M = 0 (k* → 0) or there is no curvature term (k* → ∞).
pub fn optimal_scale(
    shape: &[Vec3],
    dim: usize,
    hessian: &Mat3,
    sigma_h: f64,
    sigma_m: f64,
) -> Result<(f64, f64), EstimateError> {
    check_geometry(dim, shape)?;
    check_sigmas(sigma_h, sigma_m)?;
    if !hessian.iter().all(|v| v.is_finite()) {
        return Err(EstimateError::NonFinite("hessian"));
    }
    let unit = rms_radius(dim, shape);
    let pts: Vec<Vec3> = shape.iter().map(|p| project(dim, p) / unit).collect();
    // M = Σ c cᵀ in the unit where the shape has RMS radius 1 (padded in 2-D, as in Cost).
    let mut m = nalgebra::Matrix4::zeros();
    let cs: Vec<nalgebra::Vector4<f64>> = pts
        .iter()
        .map(|p| nalgebra::Vector4::new(p.x, p.y, p.z, 1.0))
        .collect();
    for c in &cs {
        m += c * c.transpose();
    }
    if dim == 2 {
        m[(2, 2)] += 1.0;
    }
    let a = m
        .cholesky()
        .ok_or(EstimateError::Numerical("CᵀC not invertible"))?
        .inverse();
    let hs = (hessian + hessian.transpose()) * 0.5;
    let (mut alpha, mut beta, mut gamma, mut delta) = (0.0, 0.0, 0.0, 0.0);
    for (p, c) in shape.iter().zip(&cs) {
        let p = project(dim, p);
        let w = a * c;
        // Back to the shape's own unit: u scales by 1/unit, v unchanged.
        let uu = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) / (unit * unit);
        let vv = w[3] * w[3];
        let q = 0.5 * p.dot(&(hs * p));
        let cq = q * q * sigma_h * sigma_h;
        alpha += uu * cq;
        beta += vv * cq;
        gamma += sigma_m * sigma_m * uu;
        delta += sigma_m * sigma_m * vv;
    }
    if gamma <= 0.0 {
        return Err(EstimateError::NoMinimum(
            "sigma_m = 0: g tends to its infimum as k → 0",
        ));
    }
    if alpha <= 0.0 && beta <= 0.0 {
        return Err(EstimateError::NoMinimum(
            "no curvature term: g decreases as k → ∞",
        ));
    }
    let f = |u: f64| 2.0 * beta * u * u * u + alpha * u * u - gamma;
    let df = |u: f64| 6.0 * beta * u * u + 2.0 * alpha * u;
    let mut u = f64::INFINITY;
    if alpha > 0.0 {
        u = u.min((gamma / alpha).sqrt());
    }
    if beta > 0.0 {
        u = u.min((gamma / (2.0 * beta)).cbrt());
    }
    for _ in 0..200 {
        let step = f(u) / df(u);
        let next = u - step;
        if !(next.is_finite() && next > 0.0) {
            break;
        }
        let done = (u - next).abs() <= 1e-15 * u;
        u = next;
        if done {
            break;
        }
    }
    let g = beta * u * u + alpha * u + gamma / u + delta;
    if !(u.is_finite() && u > 0.0 && g.is_finite()) {
        return Err(EstimateError::Numerical("optimal scale did not converge"));
    }
    Ok((u.sqrt(), g))
}

/// BFGS on g over positions in the working unit of `cost`. Returns (g, positions).
fn bfgs(cost: &Cost, dim: usize, start: &[Vec3], opts: &SearchOptions) -> Option<(f64, Vec<Vec3>)> {
    let n = start.len();
    let nv = n * dim;
    let unpack = |v: &[f64]| -> Vec<Vec3> {
        (0..n)
            .map(|i| {
                let mut p = Vec3::zeros();
                for j in 0..dim {
                    p[j] = v[i * dim + j];
                }
                p
            })
            .collect()
    };
    let eval = |v: &[f64], grad: &mut Vec<f64>| -> Option<f64> {
        let pos = unpack(v);
        let mut gp = vec![Vec3::zeros(); n];
        let f = cost.eval(&pos, Some(&mut gp))?;
        for i in 0..n {
            for j in 0..dim {
                grad[i * dim + j] = gp[i][j];
            }
        }
        Some(f)
    };
    let mut x: Vec<f64> = (0..nv).map(|k| start[k / dim][k % dim]).collect();
    let mut gx = vec![0.0; nv];
    let mut f = eval(&x, &mut gx)?;
    let mut hinv = DMatrix::<f64>::identity(nv, nv);
    let mut first = true;
    let mut xn = vec![0.0; nv];
    let mut gn = vec![0.0; nv];
    for _ in 0..opts.max_iterations {
        let gmax = gx.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if gmax <= opts.gradient_tolerance * f {
            break;
        }
        let gv = nalgebra::DVector::from_column_slice(&gx);
        let mut d = -(&hinv * &gv);
        let mut slope = d.dot(&gv);
        if slope.is_nan() || slope >= 0.0 {
            hinv = DMatrix::identity(nv, nv);
            first = true;
            d = -gv.clone();
            slope = d.dot(&gv);
        }
        // Cap the trial step at 0.5 working units per coordinate.
        let dmax = d.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let mut alpha = if dmax > 0.5 { 0.5 / dmax } else { 1.0 };
        let mut accepted = None;
        while alpha > 1e-20 {
            for k in 0..nv {
                xn[k] = x[k] + alpha * d[k];
            }
            if let Some(fnew) = eval(&xn, &mut gn) {
                if fnew <= f + 1e-4 * alpha * slope {
                    accepted = Some(fnew);
                    break;
                }
            }
            alpha *= 0.5;
        }
        let Some(fnew) = accepted else { break };
        let s = nalgebra::DVector::from_fn(nv, |k, _| xn[k] - x[k]);
        let y = nalgebra::DVector::from_fn(nv, |k, _| gn[k] - gx[k]);
        let sy = s.dot(&y);
        if sy > 1e-300 && sy > 1e-12 * s.norm() * y.norm() {
            if first {
                hinv = DMatrix::identity(nv, nv) * (sy / y.dot(&y));
                first = false;
            }
            let rho = 1.0 / sy;
            let hy = &hinv * &y;
            let yhy = y.dot(&hy);
            // H ← H − ρ(H y sᵀ + s yᵀ H) + (ρ² yᵀHy + ρ) s sᵀ
            hinv -= (&hy * s.transpose() + &s * hy.transpose()) * rho;
            hinv += (&s * s.transpose()) * (rho * rho * yhy + rho);
        }
        let improvement = f - fnew;
        std::mem::swap(&mut x, &mut xn);
        std::mem::swap(&mut gx, &mut gn);
        f = fnew;
        if improvement <= 1e-16 * f && s.amax() <= 1e-13 {
            break;
        }
    }
    Some((f, unpack(&x)))
}

/// Optimal formation of (V.7) with the default [`SearchOptions`]; see
/// [`optimal_formation_with`].
pub fn optimal_formation(
    n: usize,
    dim: usize,
    hessian: &Mat3,
    sigma_h: f64,
    sigma_m: f64,
    seed: u64,
) -> Result<OptimalFormation, EstimateError> {
    optimal_formation_with(
        n,
        dim,
        hessian,
        sigma_h,
        sigma_m,
        seed,
        &SearchOptions::default(),
    )
}

/// Multi-start local minimisation of g (V.6) over the N positions, problem (V.7).
///
/// `hessian` must be symmetric positive definite on the dim block (the rough Hessian of
/// Lemma 5.2, field unit per length unit²); `sigma_h` (dimensionless) and `sigma_m` (field
/// unit) are standard deviations and must both be > 0 (otherwise g has no minimiser:
/// `NoMinimum`). Random starts come from `keyed(seed, Stream::FormationSearch, start_idx, 0)`.
/// The result is the lowest local minimum found (the first one on ties); for N ≥ 6 in 2-D
/// the minimiser is not unique, only g is meaningful to compare. With H = I, σ_H = σ_M = 1
/// it reproduces Table I.
pub fn optimal_formation_with(
    n: usize,
    dim: usize,
    hessian: &Mat3,
    sigma_h: f64,
    sigma_m: f64,
    seed: u64,
    opts: &SearchOptions,
) -> Result<OptimalFormation, EstimateError> {
    check_dim(dim)?;
    if n < dim + 1 {
        return Err(EstimateError::TooFewPoints {
            needed: dim + 1,
            got: n,
        });
    }
    let h = check_spd(dim, hessian)?;
    check_sigmas_positive(sigma_h, sigma_m)?;
    let hbar = h.trace() / dim as f64;
    let unit = (2.0 * std::f64::consts::SQRT_2 * sigma_m / (sigma_h * hbar)).sqrt();
    if !(unit.is_finite() && unit > 0.0) {
        return Err(EstimateError::Numerical(
            "natural length unit is not finite",
        ));
    }
    let cost = Cost::new(dim, &h, sigma_h, sigma_m, unit);
    let search = Search {
        n,
        dim,
        h,
        hbar,
        sigma_h,
        sigma_m,
        unit,
        opts,
    };
    let mut starts = search.regular_starts();
    for k in 0..opts.random_starts {
        starts.push(search.random_start(seed, k));
    }
    let pos = search.best_minimum(&cost, &starts)?;
    let positions: Vec<Vec3> = pos.iter().map(|p| project(dim, &(p * unit))).collect();
    let g = super::estimate::expected_error(dim, &positions, &h, sigma_h, sigma_m)?;
    let radius = positions.iter().map(|p| p.norm()).sum::<f64>() / n as f64;
    let second_moments = positions
        .iter()
        .fold(Mat3::zeros(), |a, p| a + p * p.transpose())
        / n as f64;
    Ok(OptimalFormation {
        g,
        positions,
        radius,
        second_moments,
    })
}

/// Problem (V.7) as the multi-start search of [`optimal_formation_with`] sees it.
struct Search<'a> {
    /// Number of vehicles N.
    n: usize,
    /// 2 or 3.
    dim: usize,
    /// The Hessian H, checked symmetric positive definite on the dim block (field unit per
    /// length unit²).
    h: Mat3,
    /// h̄ = tr H / dim, the mean eigenvalue of H.
    hbar: f64,
    /// σ_H (dimensionless).
    sigma_h: f64,
    /// σ_M (field unit).
    sigma_m: f64,
    /// The natural length unit L of the search (length unit).
    unit: f64,
    opts: &'a SearchOptions,
}

impl Search<'_> {
    /// The regular starts (when `opts.regular_starts`), each at its optimal physical scale
    /// expressed in the working unit: the regular shape, stretched by (H/h̄)^{-1/2} unless H
    /// is isotropic, and (for N > dim + 1) the regular shape of N − 1 with a vehicle at the
    /// centre, stretched and plain.
    fn regular_starts(&self) -> Vec<Vec<Vec3>> {
        let (n, dim, opts) = (self.n, self.dim, self.opts);
        // Stretch by (H/h̄)^{-1/2} on the dim block.
        let block = DMatrix::from_fn(dim, dim, |i, j| self.h[(i, j)] / self.hbar);
        let eig = block.clone().symmetric_eigen();
        let isotropic = eig.eigenvalues.iter().all(|l| (l - 1.0).abs() < 1e-12);
        let inv_sqrt = &eig.eigenvectors
            * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| 1.0 / l.sqrt()))
            * eig.eigenvectors.transpose();
        let stretch = |p: &Vec3| stretched(dim, &inv_sqrt, p);

        let mut starts: Vec<Vec<Vec3>> = Vec::new();
        let regular = regular_shape(n, dim);
        if opts.regular_starts {
            starts.push(self.scaled(regular.clone()));
        }
        if opts.regular_starts && !isotropic {
            starts.push(self.scaled(regular.iter().map(&stretch).collect()));
        }
        if opts.regular_starts && n > dim + 1 {
            let mut centred = regular_shape(n - 1, dim);
            centred.push(Vec3::zeros());
            if !isotropic {
                starts.push(self.scaled(centred.iter().map(&stretch).collect()));
            }
            starts.push(self.scaled(centred));
        }
        starts
    }

    /// `shape` at its optimal physical scale ([`optimal_scale`]), expressed in the working
    /// unit (unscaled if it has none).
    fn scaled(&self, shape: Vec<Vec3>) -> Vec<Vec3> {
        let k = optimal_scale(&shape, self.dim, &self.h, self.sigma_h, self.sigma_m)
            .map(|(k, _)| k / self.unit)
            .unwrap_or(1.0);
        shape.iter().map(|p| p * k).collect()
    }

    /// Random start `k`: N points uniform in the ball of radius 1.5 (working unit, by
    /// rejection), from `keyed(seed, Stream::FormationSearch, k, 0)`.
    fn random_start(&self, seed: u64, k: usize) -> Vec<Vec3> {
        let mut rng = keyed(seed, Stream::FormationSearch, k as u64, 0);
        (0..self.n)
            .map(|_| loop {
                let mut p = Vec3::zeros();
                for j in 0..self.dim {
                    p[j] = rng.random_range(-1.5..1.5);
                }
                if p.norm() <= 1.5 {
                    break p;
                }
            })
            .collect()
    }

    /// The lowest local minimum of `cost` that BFGS reaches from `starts` (the first one on
    /// ties), positions in the working unit.
    fn best_minimum(&self, cost: &Cost, starts: &[Vec<Vec3>]) -> Result<Vec<Vec3>, EstimateError> {
        let mut best: Option<(f64, Vec<Vec3>)> = None;
        for start in starts {
            if let Some((g, pos)) = bfgs(cost, self.dim, start, self.opts) {
                if best.as_ref().is_none_or(|(bg, _)| g < *bg) {
                    best = Some((g, pos));
                }
            }
        }
        let (_, pos) = best.ok_or(EstimateError::Numerical("every start of the search failed"))?;
        Ok(pos)
    }
}

/// `inv_sqrt` (dim × dim) applied to the dim block of `p`; zero elsewhere.
fn stretched(dim: usize, inv_sqrt: &DMatrix<f64>, p: &Vec3) -> Vec3 {
    let mut q = Vec3::zeros();
    for i in 0..dim {
        for j in 0..dim {
            q[i] += inv_sqrt[(i, j)] * p[j];
        }
    }
    q
}

/// The eight vertices (±1, ±1, ±1) of the cube, in a fixed order.
fn cube_vertices() -> Vec<Vec3> {
    let mut v = Vec::with_capacity(8);
    for &x in &[1.0, -1.0] {
        for &y in &[1.0, -1.0] {
            for &z in &[1.0, -1.0] {
                v.push(Vec3::new(x, y, z));
            }
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::expected_error;
    use approx::assert_relative_eq;

    #[test]
    fn table_i_is_reproduced() {
        let table = [1.910, 1.432, 1.146, 0.955, 0.818, 0.716];
        let h = Mat3::identity();
        for (k, n) in (3..=8).enumerate() {
            let f = optimal_formation(n, 2, &h, 1.0, 1.0, 1).unwrap();
            assert!((f.g - table[k]).abs() < 5e-4, "N = {n}: g = {}", f.g);
            // The regular polygon value 3 g_3 / N (g_3 from u³ + 2u² − 8 = 0) is the optimum.
            assert_relative_eq!(
                f.g,
                3.0 * 1.909_677_179_326_977 / n as f64,
                max_relative = 1e-7
            );
            assert_relative_eq!(
                f.g,
                expected_error(2, &f.positions, &h, 1.0, 1.0).unwrap(),
                max_relative = 1e-12
            );
            assert!(f.positions.iter().all(|p| p.z == 0.0));
        }
    }

    #[test]
    fn random_starts_alone_find_the_regular_optimum() {
        let opts = SearchOptions {
            random_starts: 6,
            regular_starts: false,
            ..SearchOptions::default()
        };
        for (n, dim, g) in [
            (5, 2, 1.145_806_307_596_186_2),
            (7, 2, 0.818_433_076_854_418_7),
        ] {
            let f = optimal_formation_with(n, dim, &Mat3::identity(), 1.0, 1.0, 4, &opts).unwrap();
            assert_relative_eq!(f.g, g, max_relative = 1e-7);
        }
    }

    #[test]
    fn three_d_four_vehicles_is_a_regular_tetrahedron() {
        let f = optimal_formation(4, 3, &Mat3::identity(), 1.0, 1.0, 3).unwrap();
        let mut d = Vec::new();
        for i in 0..4 {
            for j in i + 1..4 {
                d.push((f.positions[i] - f.positions[j]).norm());
            }
        }
        let mean = d.iter().sum::<f64>() / 6.0;
        for v in d {
            assert_relative_eq!(v, mean, max_relative = 1e-3);
        }
        // Centred on the estimation point.
        let c = f.positions.iter().fold(Vec3::zeros(), |a, p| a + p) / 4.0;
        assert!(c.norm() < 1e-3 * f.radius);
    }

    #[test]
    fn anisotropic_hessian_stretches_along_low_curvature() {
        let h = Mat3::from_diagonal(&Vec3::new(4.0, 1.0, 0.0));
        let opts = SearchOptions {
            random_starts: 4,
            ..SearchOptions::default()
        };
        let f = optimal_formation_with(4, 2, &h, 1.0, 1.0, 2, &opts).unwrap();
        assert!(
            f.second_moments[(1, 1)] > 1.5 * f.second_moments[(0, 0)],
            "{:?}",
            f.second_moments
        );
        // And no random start finds anything better than what the full search reports.
        let f2 = optimal_formation(4, 2, &h, 1.0, 1.0, 9).unwrap();
        assert_relative_eq!(f.g, f2.g, max_relative = 1e-6);
    }

    #[test]
    fn deterministic_and_scales_with_sigmas() {
        let h = Mat3::identity();
        let a = optimal_formation(5, 2, &h, 1.0, 1.0, 7).unwrap();
        let b = optimal_formation(5, 2, &h, 1.0, 1.0, 7).unwrap();
        assert_eq!(a, b);
        // Rule of thumb (Remark 5.4): more noise → larger formation.
        let noisy = optimal_formation(5, 2, &h, 1.0, 4.0, 7).unwrap();
        assert!(noisy.radius > 1.3 * a.radius);
    }

    #[test]
    fn rejects_bad_problems() {
        let h = Mat3::identity();
        assert!(matches!(
            optimal_formation(2, 2, &h, 1.0, 1.0, 0),
            Err(EstimateError::TooFewPoints { .. })
        ));
        assert!(matches!(
            optimal_formation(
                4,
                2,
                &Mat3::from_diagonal(&Vec3::new(1.0, -1.0, 0.0)),
                1.0,
                1.0,
                0
            ),
            Err(EstimateError::NotPositiveDefinite(_))
        ));
        let mut asym = Mat3::identity();
        asym[(0, 1)] = 0.5;
        assert!(matches!(
            optimal_formation(4, 2, &asym, 1.0, 1.0, 0),
            Err(EstimateError::NotSymmetric(_))
        ));
        assert!(matches!(
            optimal_formation(4, 2, &h, 0.0, 1.0, 0),
            Err(EstimateError::NoMinimum(_))
        ));
        assert!(matches!(
            optimal_formation(4, 2, &h, 1.0, 0.0, 0),
            Err(EstimateError::NoMinimum(_))
        ));
        assert!(matches!(
            optimal_formation(4, 2, &h, -1.0, 1.0, 0),
            Err(EstimateError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn optimal_scale_regular_triangle() {
        let tri = regular_shape(3, 2);
        let (k, g) = optimal_scale(&tri, 2, &Mat3::identity(), 1.0, 1.0).unwrap();
        assert!((g - 1.910).abs() < 5e-4);
        assert_relative_eq!(k * k, 1.509_755_332_493_385_4, max_relative = 1e-12);
        // g(k*) agrees with (V.6), and k* is a minimum of g(k · shape).
        let at = |k: f64| {
            let p: Vec<Vec3> = tri.iter().map(|p| p * k).collect();
            expected_error(2, &p, &Mat3::identity(), 1.0, 1.0).unwrap()
        };
        assert_relative_eq!(g, at(k), max_relative = 1e-12);
        assert!(at(k * 1.01) > g && at(k * 0.99) > g);
        // A shape not centred on the estimation point, anisotropic H, 3-D.
        let shape: Vec<Vec3> = regular_shape(5, 3)
            .iter()
            .map(|p| p + Vec3::new(0.1, -0.2, 0.05))
            .collect();
        let h = Mat3::new(2.0, 0.3, 0.0, 0.3, 1.0, 0.1, 0.0, 0.1, 0.5);
        let (k, g) = optimal_scale(&shape, 3, &h, 0.5, 0.2).unwrap();
        let at = |k: f64| {
            let p: Vec<Vec3> = shape.iter().map(|p| p * k).collect();
            expected_error(3, &p, &h, 0.5, 0.2).unwrap()
        };
        assert_relative_eq!(g, at(k), max_relative = 1e-12);
        assert!(at(k * 1.001) > g && at(k * 0.999) > g);
        assert!(matches!(
            optimal_scale(&tri, 2, &Mat3::identity(), 0.0, 1.0),
            Err(EstimateError::NoMinimum(_))
        ));
    }
}
