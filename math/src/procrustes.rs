//! The pose of a formation design laid on the vehicles: the similarity (translation,
//! proper rotation, scale) that carries model points (the design's slots in the body frame)
//! onto measured points (the vehicles) with the least sum of squared distances, a
//! Procrustes fit (Umeyama's closed form). Beyond the paper: used when the formation is
//! redesigned, so that the new design starts where the vehicles are (`bumpless`).
//!
//! With centred points `X_i = x_i − x̄`, `P_i = p_i − p̄`, the cost
//! `Σ|x_i − (k R p_i + t)|² = Σ|X_i|² − 2k ⟨M, R⟩ + k² Σ|P_i|² + n |x̄ − k R p̄ − t|²`,
//! `M = Σ X_i P_iᵀ`, is minimised by
//!
//! - `R` maximising `⟨M, R⟩` over proper rotations (det R = +1, no reflection): in 3-D
//!   `R = U diag(1, 1, det(U Vᵀ)) Vᵀ` from the SVD `M = U Σ Vᵀ`; in 2-D a turn about z by
//!   `θ = atan2(Σ P_i × X_i, Σ P_i · X_i)`. It does not depend on `k > 0`;
//! - `k = ⟨M, R⟩ / Σ|P_i|²`, clamped to `[k_min, k_max]` (the cost is a parabola in `k`,
//!   so the clamped value is the constrained optimum);
//! - `t = x̄ − k R p̄`.
//!
//! Where the data do not fix the rotation (one point, all model points equal, or in 3-D
//! points on one line: `M` of rank ≤ 1), the prior's rotation is kept, turned the least
//! that aligns the one direction the data fix; where they do not fix the scale
//! (`Σ|P_i|² = 0`), the prior's scale (clamped) is kept.

use nalgebra::{Rotation3, Unit};

use super::{Mat3, Vec3};

/// A similarity transform `p ↦ k R p + t` of the body frame into the inertial frame
/// (the pose `(r, R, k)` of a virtual body, (III.3)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Translation `t` (the body centre `r`), length unit.
    pub translation: Vec3,
    /// Proper rotation `R`.
    pub rotation: Rotation3<f64>,
    /// Scale `k > 0`, dimensionless.
    pub scale: f64,
}

impl Similarity {
    /// `k R p + t`, length unit.
    pub fn apply(&self, p: &Vec3) -> Vec3 {
        self.scale * (self.rotation * p) + self.translation
    }
}

/// Relative size below which a singular value (or the 2-D moment) counts as zero.
const DEGENERATE: f64 = 1e-10;

/// The similarity minimising `Σ_i |points[i] − (k R model[i] + t)|²` (pairs in order;
/// length unit) with `k ∈ [scale_range.0, scale_range.1]` (0 < min ≤ max) and `R` a proper
/// rotation, about z only when `dim == 2`; see the module docs (where the data leave the
/// rotation or scale free, `prior`'s are kept). `None` when the lists differ in length, are
/// empty, or hold a non-finite coordinate, or the scale range is not as said.
pub fn fit_similarity(
    points: &[Vec3],
    model: &[Vec3],
    dim: usize,
    scale_range: (f64, f64),
    prior: &Similarity,
) -> Option<Similarity> {
    let n = points.len();
    let (k_min, k_max) = scale_range;
    if n == 0
        || model.len() != n
        || !(k_min > 0.0 && k_min <= k_max && k_max.is_finite())
        || points
            .iter()
            .chain(model)
            .any(|v| !v.iter().all(|c| c.is_finite()))
    {
        return None;
    }
    let x_bar = points.iter().sum::<Vec3>() / n as f64;
    let p_bar = model.iter().sum::<Vec3>() / n as f64;
    let mut m = Mat3::zeros();
    let mut p_sq = 0.0;
    for (x, p) in points.iter().zip(model) {
        let (xc, pc) = (x - x_bar, p - p_bar);
        m += xc * pc.transpose();
        p_sq += pc.norm_squared();
    }
    let rotation = if dim == 2 {
        rotation_2d(&m, &prior.rotation)
    } else {
        rotation_3d(&m, &prior.rotation)
    };
    let scale = if p_sq > 0.0 {
        (m.component_mul(rotation.matrix()).sum() / p_sq).clamp(k_min, k_max)
    } else {
        prior.scale.clamp(k_min, k_max)
    };
    Some(Similarity {
        translation: x_bar - scale * (rotation * p_bar),
        rotation,
        scale,
    })
}

/// The proper rotation `R` minimising `Σ_i |points[i] − R model[i]|²` (pairs in order,
/// about the origin: no translation or scale), about z only when `dim == 2`; `prior` where
/// the data leave it free (module docs). `None` when the lists differ in length or hold a
/// non-finite coordinate.
pub fn fit_rotation(
    points: &[Vec3],
    model: &[Vec3],
    dim: usize,
    prior: &Rotation3<f64>,
) -> Option<Rotation3<f64>> {
    if model.len() != points.len()
        || points
            .iter()
            .chain(model)
            .any(|v| !v.iter().all(|c| c.is_finite()))
    {
        return None;
    }
    let m: Mat3 = points
        .iter()
        .zip(model)
        .map(|(x, p)| x * p.transpose())
        .sum();
    Some(if dim == 2 {
        rotation_2d(&m, prior)
    } else {
        rotation_3d(&m, prior)
    })
}

/// The turn about z maximising `⟨M, R⟩` (only the xy block of `M` counts); `prior` when
/// the block is (nearly) zero.
fn rotation_2d(m: &Mat3, prior: &Rotation3<f64>) -> Rotation3<f64> {
    let a = m[(0, 0)] + m[(1, 1)];
    let b = m[(1, 0)] - m[(0, 1)];
    let size = m.fixed_view::<2, 2>(0, 0).norm();
    if size == 0.0 || a.hypot(b) <= DEGENERATE * size {
        return *prior;
    }
    Rotation3::from_axis_angle(&Vec3::z_axis(), b.atan2(a))
}

/// The proper rotation maximising `⟨M, R⟩` (Kabsch with the reflection excluded); for `M`
/// of rank ≤ 1 the least turn of `prior` that carries the right singular direction onto
/// the left one, and `prior` itself for `M = 0`.
fn rotation_3d(m: &Mat3, prior: &Rotation3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return *prior;
    };
    let mut order = [0usize, 1, 2];
    let sv = svd.singular_values;
    order.sort_by(|&i, &j| sv[j].total_cmp(&sv[i]));
    let (s0, s1) = (sv[order[0]], sv[order[1]]);
    if s0.is_nan() || s0 <= 0.0 {
        return *prior;
    }
    if s1 <= DEGENERATE * s0 {
        let to = u.column(order[0]).into_owned();
        let from = prior * v_t.row(order[0]).transpose();
        let turn = Rotation3::rotation_between(&from, &to).unwrap_or_else(|| {
            // Antiparallel: half a turn about any axis normal to `from`.
            let normal = from.cross(&Vec3::x()).try_normalize(1e-6);
            let axis = normal.unwrap_or_else(|| from.cross(&Vec3::y()).normalize());
            Rotation3::from_axis_angle(&Unit::new_unchecked(axis), std::f64::consts::PI)
        });
        return turn * prior;
    }
    let d = (u * v_t).determinant().signum();
    let mut diag = Vec3::new(1.0, 1.0, 1.0);
    diag[order[2]] = d;
    let r = u * Mat3::from_diagonal(&diag) * v_t;
    Rotation3::from_matrix_unchecked(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{keyed, Stream};
    use approx::assert_relative_eq;
    use rand::Rng;

    fn identity() -> Similarity {
        Similarity {
            translation: Vec3::zeros(),
            rotation: Rotation3::identity(),
            scale: 1.0,
        }
    }

    fn random_points(rng: &mut impl Rng, n: usize, dim: usize) -> Vec<Vec3> {
        (0..n)
            .map(|_| {
                let z = if dim == 3 {
                    rng.random_range(-2.0..2.0)
                } else {
                    0.0
                };
                Vec3::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0), z)
            })
            .collect()
    }

    #[test]
    fn a_known_pose_is_recovered_exactly() {
        let mut rng = keyed(3, Stream::Test, 1, 0);
        for trial in 0..200 {
            let dim = 2 + trial % 2;
            let model = random_points(&mut rng, 3 + trial % 5, dim);
            let rotation = if dim == 2 {
                Rotation3::from_axis_angle(&Vec3::z_axis(), rng.random_range(-3.1..3.1))
            } else {
                Rotation3::from_scaled_axis(Vec3::new(
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                ))
            };
            let truth = Similarity {
                translation: Vec3::new(rng.random_range(-9.0..9.0), 4.0, 0.0),
                rotation,
                scale: rng.random_range(0.3..3.0),
            };
            let points: Vec<Vec3> = model.iter().map(|p| truth.apply(p)).collect();
            let fit = fit_similarity(&points, &model, dim, (0.1, 10.0), &identity()).unwrap();
            assert_relative_eq!(fit.scale, truth.scale, max_relative = 1e-10);
            assert_relative_eq!(fit.translation, truth.translation, epsilon = 1e-9);
            assert_relative_eq!(
                fit.rotation.matrix(),
                truth.rotation.matrix(),
                epsilon = 1e-10
            );
        }
    }

    #[test]
    fn a_mirror_image_is_fitted_by_a_proper_rotation() {
        // The model's mirror image (z → −z) cannot be reached by a rotation: the fit is a
        // proper rotation (det +1) and no reflection, and no other rotation does better.
        let mut rng = keyed(4, Stream::Test, 1, 0);
        let model = random_points(&mut rng, 6, 3);
        let points: Vec<Vec3> = model.iter().map(|p| Vec3::new(p.x, p.y, -p.z)).collect();
        let fit = fit_similarity(&points, &model, 3, (1.0, 1.0), &identity()).unwrap();
        assert_relative_eq!(fit.rotation.matrix().determinant(), 1.0, epsilon = 1e-12);
        let cost = |s: &Similarity| -> f64 {
            points
                .iter()
                .zip(&model)
                .map(|(x, p)| (x - s.apply(p)).norm_squared())
                .sum()
        };
        let best = cost(&fit);
        assert!(
            best > 1e-3,
            "a reflection would fit exactly, a rotation cannot"
        );
        for _ in 0..2000 {
            let r = Rotation3::from_scaled_axis(Vec3::new(
                rng.random_range(-3.2..3.2),
                rng.random_range(-3.2..3.2),
                rng.random_range(-3.2..3.2),
            ));
            let mut other = fit;
            other.rotation = r;
            let p_bar = model.iter().sum::<Vec3>() / 6.0;
            let x_bar = points.iter().sum::<Vec3>() / 6.0;
            other.translation = x_bar - r * p_bar;
            assert!(cost(&other) >= best - 1e-9);
        }
    }

    #[test]
    fn a_rotation_about_the_origin_is_recovered() {
        let model = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let r = Rotation3::from_scaled_axis(Vec3::new(0.3, -1.2, 0.5));
        let points: Vec<Vec3> = model.iter().map(|p| r * p).collect();
        let fit = fit_rotation(&points, &model, 3, &Rotation3::identity()).unwrap();
        assert_relative_eq!(fit.matrix(), r.matrix(), epsilon = 1e-12);
        let turn = Rotation3::from_axis_angle(&Vec3::z_axis(), -2.0);
        let points: Vec<Vec3> = model[..2].iter().map(|p| turn * p).collect();
        let fit = fit_rotation(&points, &model[..2], 2, &Rotation3::identity()).unwrap();
        assert_relative_eq!(fit.matrix(), turn.matrix(), epsilon = 1e-12);
        assert!(fit_rotation(&points, &model, 2, &Rotation3::identity()).is_none());
    }

    #[test]
    fn the_scale_is_clamped_and_stays_optimal_within_its_range() {
        let model = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let points: Vec<Vec3> = model
            .iter()
            .map(|p| 4.0 * p + Vec3::new(1.0, 2.0, 0.0))
            .collect();
        let fit = fit_similarity(&points, &model, 2, (0.5, 2.0), &identity()).unwrap();
        assert_eq!(fit.scale, 2.0);
        // The translation is still optimal for the clamped scale: the centroids coincide.
        let p_bar = model.iter().sum::<Vec3>() / 3.0;
        let x_bar = points.iter().sum::<Vec3>() / 3.0;
        assert_relative_eq!(fit.apply(&p_bar), x_bar, epsilon = 1e-12);
        assert_relative_eq!(fit.rotation.angle(), 0.0, epsilon = 1e-12);
    }

    #[test]
    fn what_the_data_leave_free_comes_from_the_prior() {
        let prior = Similarity {
            translation: Vec3::zeros(),
            rotation: Rotation3::from_axis_angle(&Vec3::z_axis(), 0.7),
            scale: 1.5,
        };
        // One point: rotation and scale from the prior, translation exact.
        let fit = fit_similarity(
            &[Vec3::new(3.0, 1.0, 0.0)],
            &[Vec3::new(1.0, 0.0, 0.0)],
            2,
            (0.5, 2.0),
            &prior,
        )
        .unwrap();
        assert_eq!(fit.rotation, prior.rotation);
        assert_eq!(fit.scale, 1.5);
        assert_relative_eq!(
            fit.apply(&Vec3::new(1.0, 0.0, 0.0)),
            Vec3::new(3.0, 1.0, 0.0),
            epsilon = 1e-12
        );
        // 3-D, two points: the line is matched exactly, the turn about it is the prior's.
        let model = [Vec3::new(1.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0)];
        let points = [Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -2.0)];
        let fit = fit_similarity(&points, &model, 3, (0.5, 2.0), &prior).unwrap();
        for (x, p) in points.iter().zip(&model) {
            assert_relative_eq!(fit.apply(p), *x, epsilon = 1e-12);
        }
        assert_relative_eq!(fit.rotation.matrix().determinant(), 1.0, epsilon = 1e-12);
        // The prior's y axis (normal to the x–z plane of the turn) is kept.
        let y = prior.rotation * Vec3::y();
        assert_relative_eq!(fit.rotation * Vec3::y(), y, epsilon = 1e-12);
        assert!(fit_similarity(&[], &[], 2, (0.5, 2.0), &prior).is_none());
        assert!(fit_similarity(&points, &model[..1], 3, (0.5, 2.0), &prior).is_none());
        assert!(fit_similarity(&points, &model, 3, (0.0, 2.0), &prior).is_none());
    }
}
