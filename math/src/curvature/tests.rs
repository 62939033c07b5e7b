use super::*;
use crate::optimal::regular_shape;
use crate::rng::{keyed, Stream};
use rand::Rng;
use rand_distr::StandardNormal;

/// T(x) = 3 + gᵀx + ½ xᵀHx.
fn quad(h: &Mat3, g: &Vec3, x: &Vec3) -> f64 {
    3.0 + g.dot(x) + 0.5 * x.dot(&(h * x))
}

fn max_abs(m: &Mat3) -> f64 {
    m.iter().fold(0.0f64, |s, v| s.max(v.abs()))
}

/// A hexagon of radius `radius` whose centre travels along +x by `step` per tick for
/// `ticks` ticks, reading T with noise `sigma`: returns the estimator and the centre.
fn fly(
    est: &mut CurvatureEstimator,
    (h, g): (&Mat3, &Vec3),
    radius: f64,
    step: Vec3,
    ticks: u64,
    sigma: f64,
    memory: f64,
) -> Vec3 {
    let shape: Vec<Vec3> = regular_shape(6, 2).iter().map(|p| p * radius).collect();
    let mut r = Vec3::new(-1.0, 0.5, 0.0);
    for k in 0..ticks {
        let mut rng = keyed(13, Stream::Test, k, 0);
        let y: Vec<f64> = shape
            .iter()
            .map(|p| quad(h, g, &(r + p)) + sigma * rng.sample::<f64, _>(StandardNormal))
            .collect();
        est.update(&shape, &y, &vec![sigma * sigma; shape.len()]);
        est.shift(&step, memory);
        r += step;
    }
    r
}

#[test]
fn with_no_data_the_estimate_is_the_prior() {
    let prior = Mat3::new(2.0, 0.3, 0.0, 0.3, 0.5, 0.0, 0.0, 0.0, 0.0);
    let est = CurvatureEstimator::new(2, &prior, 1.0, 1.5).unwrap();
    assert!(max_abs(&(est.hessian() - prior)) < 1e-12);
    assert_eq!(est.gradient(), None);
    // Per-entry standard deviation σ_H·h̄₀, h̄₀ = ‖H₀‖_F/√2.
    let h_bar = (4.0f64 + 2.0 * 0.09 + 0.25).sqrt() / 2f64.sqrt();
    assert!((est.hessian_std()[(0, 1)] - h_bar).abs() < 1e-12);
    let e = CurvatureEstimator::new(2, &prior, 0.7, 1.5).unwrap();
    assert!((e.hessian_std()[(1, 1)] - 0.7 * h_bar).abs() < 1e-12);
    // Nothing outside the 2-D block.
    assert_eq!(e.hessian()[(2, 2)], 0.0);
}

#[test]
fn recovers_a_known_hessian_from_noisy_readings_of_a_moving_formation() {
    // The gentle curvature of the lossy_kill field, anisotropic, with the default prior
    // H₀ = I (about 20 × too stiff).
    let h = Mat3::new(0.05, 0.012, 0.0, 0.012, -0.02, 0.0, 0.0, 0.0, 0.0);
    let g = Vec3::new(0.3, -0.1, 0.0);
    let mut est = CurvatureEstimator::new(2, &Mat3::identity(), 1.0, 1.5).unwrap();
    // 0.05 L per tick for 800 ticks (40 L), memory 20 L; σ_M = 0.1.
    let r = fly(
        &mut est,
        (&h, &g),
        1.5,
        Vec3::new(0.05, 0.0, 0.0),
        800,
        0.1,
        20.0,
    );
    let err = est.hessian() - h;
    // The prior was off by ~1 per entry; the estimate is 70 × closer.
    assert!(max_abs(&err) < 0.015, "Ĥ = {} (true {h})", est.hessian());
    // Within 3 posterior standard deviations, entry by entry.
    let sd = est.hessian_std();
    for (i, j) in [(0, 0), (0, 1), (1, 1)] {
        assert!(
            err[(i, j)].abs() < 3.0 * sd[(i, j)] + 1e-4,
            "{i}{j}: {err} vs {sd}"
        );
    }
    // The model's gradient is the field's at the current centre.
    let g_true = g + h * r;
    assert!((est.gradient().unwrap() - g_true).norm() < 0.01);
}

#[test]
fn a_noiseless_quadratic_is_recovered_exactly_across_shifts_in_3d() {
    let h = Mat3::new(1.0, 0.2, -0.1, 0.2, 1.5, 0.3, -0.1, 0.3, 0.5);
    let g = Vec3::new(-0.2, 0.4, 0.1);
    let shape: Vec<Vec3> = regular_shape(12, 3).iter().map(|p| p * 2.0).collect();
    let mut est = CurvatureEstimator::new(3, &(Mat3::identity() * 7.0), 1.0, 2.0).unwrap();
    let mut r = Vec3::zeros();
    for k in 0..5 {
        let y: Vec<f64> = shape.iter().map(|p| quad(&h, &g, &(r + p))).collect();
        est.update(&shape, &y, &vec![1e-8; shape.len()]);
        let step = Vec3::new(0.7, -0.3 * k as f64, 0.2);
        est.shift(&step, f64::INFINITY);
        r += step;
    }
    assert!(max_abs(&(est.hessian() - h)) < 1e-5, "{}", est.hessian());
    assert!((est.gradient().unwrap() - (g + h * r)).norm() < 1e-5);
    // Determined by the data: the same Ĥ as `hessian`, its spread as `hessian_std`'s.
    assert!(est.hessian_std().norm() < 0.5 * est.hessian().norm());
    assert_eq!(est.hessian_if_determined(0.5), Some(est.hessian()));
    assert_eq!(est.hessian_if_determined(0.0), None);
}

#[test]
fn with_no_data_the_curvature_is_not_determined() {
    let est = CurvatureEstimator::new(2, &Mat3::identity(), 1.0, 1.5).unwrap();
    // The prior's spread (σ_H = 1: 100 %) is not below half of the prior itself.
    assert!(est.hessian_std().norm() >= 0.5 * est.hessian().norm());
    assert_eq!(est.hessian_if_determined(0.5), None);
}

#[test]
fn readings_on_one_circle_leave_the_trace_to_the_prior() {
    // A static hexagon cannot tell tr H from the value c: the anisotropic part is learnt,
    // the isotropic part stays where the prior put it.
    let h = Mat3::new(0.3, 0.1, 0.0, 0.1, -0.1, 0.0, 0.0, 0.0, 0.0);
    let prior = Mat3::identity() * 2.0;
    let mut est = CurvatureEstimator::new(2, &prior, 1.0, 1.0).unwrap();
    fly(
        &mut est,
        (&h, &Vec3::zeros()),
        1.0,
        Vec3::zeros(),
        200,
        0.05,
        5.0,
    );
    let e = est.hessian();
    assert!((e[(0, 0)] - e[(1, 1)] - 0.4).abs() < 0.02, "{e}");
    assert!((e[(0, 1)] - 0.1).abs() < 0.01, "{e}");
    // tr of the 2-D prior block: 4.
    assert!((e.trace() - 4.0).abs() < 1e-6, "{e}");
}

#[test]
fn forgetting_follows_a_change_of_curvature_along_the_path() {
    let h1 = Mat3::identity() * 0.1;
    let h2 = Mat3::identity() * -0.05;
    let mut est = CurvatureEstimator::new(2, &Mat3::identity(), 1.0, 1.0).unwrap();
    let step = Vec3::new(0.05, 0.0, 0.0);
    // A reading's weight in Ĥ is ∝ e^(−s/m)·|d|⁴ at s = |d| behind: it peaks 4 m back,
    // so a memory of m = 1.5 L forgets a field 20 L behind.
    fly(&mut est, (&h1, &Vec3::zeros()), 1.0, step, 400, 0.02, 1.5);
    let e = est.hessian();
    assert!(
        (e[(0, 0)] - 0.1).abs() < 0.015 && (e[(1, 1)] - 0.1).abs() < 0.015,
        "{e}"
    );
    fly(&mut est, (&h2, &Vec3::zeros()), 1.0, step, 400, 0.02, 1.5);
    let e = est.hessian();
    assert!(
        (e[(0, 0)] + 0.05).abs() < 0.015 && (e[(1, 1)] + 0.05).abs() < 0.015,
        "{e}"
    );
}

#[test]
fn the_estimate_does_not_depend_on_the_internal_length_unit() {
    let h = Mat3::new(0.05, 0.012, 0.0, 0.012, -0.02, 0.0, 0.0, 0.0, 0.0);
    let g = Vec3::new(0.3, -0.1, 0.0);
    let step = Vec3::new(0.05, 0.02, 0.0);
    let mut a = CurvatureEstimator::new(2, &Mat3::identity(), 1.0, 1.0).unwrap();
    let mut b = CurvatureEstimator::new(2, &Mat3::identity(), 1.0, 1000.0).unwrap();
    fly(&mut a, (&h, &g), 1.5, step, 100, 0.1, 10.0);
    fly(&mut b, (&h, &g), 1.5, step, 100, 0.1, 10.0);
    assert!(max_abs(&(a.hessian() - b.hessian())) < 1e-9);
}

#[test]
fn bad_parameters_are_refused() {
    let i = Mat3::identity();
    assert!(CurvatureEstimator::new(4, &i, 1.0, 1.0).is_err());
    assert!(CurvatureEstimator::new(2, &i, 0.0, 1.0).is_err());
    assert!(CurvatureEstimator::new(2, &i, 1.0, -1.0).is_err());
    assert!(CurvatureEstimator::new(2, &Mat3::zeros(), 1.0, 1.0).is_err());
    let mut nan = i;
    nan[(0, 0)] = f64::NAN;
    assert!(CurvatureEstimator::new(2, &nan, 1.0, 1.0).is_err());
}
