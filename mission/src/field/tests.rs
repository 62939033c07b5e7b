use super::*;
use crate::config::Goal;
use approx::assert_relative_eq;
use vbap_math::{Mat3, Vec3};

fn bump(c: [f64; 3], a: f64, w: f64) -> GaussianBump {
    GaussianBump {
        center: Vec3::new(c[0], c[1], c[2]),
        amplitude: a,
        width: w,
    }
}

/// One field of every kind, in `dim` dimensions (z components dropped in 2-D).
fn zoo(dim: usize) -> Vec<Field> {
    let z = if dim == 3 { 1.0 } else { 0.0 };
    let h = Mat3::new(
        2.0,
        0.3,
        0.1 * z,
        0.3,
        1.0,
        -0.2 * z,
        0.1 * z,
        -0.2 * z,
        1.5 * z,
    );
    vec![
        Field::Quadratic {
            center: Vec3::new(1.0, -2.0, 0.5 * z),
            hessian: h,
            offset: 3.0,
            dim,
        },
        Field::GaussianSum {
            background: 12.0,
            bumps: vec![
                bump([1.0, 2.0, z], 2.0, 3.0),
                bump([-2.0, 1.0, -z], -1.0, 2.0),
            ],
            dim,
        },
        Field::DriftingEddy {
            background: 1.0,
            bump: bump([0.5, 0.5, 0.2 * z], 4.0, 2.5),
            velocity: Vec3::new(0.3, -0.1, 0.05 * z),
            dim,
        },
        Field::MovingFront {
            background: 10.0,
            amplitude: 1.5,
            normal: Vec3::new(0.6, 0.8 * (1.0 - z * 0.5), 0.0 + z * 0.4).normalize(),
            offset: 0.7,
            speed: 0.2,
            width: 2.0,
            bump: Some(bump([1.0, 1.0, 0.3 * z], 2.0, 1.5)),
            dim,
        },
    ]
}

/// Central differences of `value` and `gradient`, step `h`.
fn fd_gradient(f: &Field, p: &Vec3, t: f64, h: f64) -> Vec3 {
    Vec3::from_fn(|i, _| {
        let mut e = Vec3::zeros();
        e[i] = h;
        (f.value(&(p + e), t) - f.value(&(p - e), t)) / (2.0 * h)
    })
}

fn fd_hessian(f: &Field, p: &Vec3, t: f64, h: f64) -> Mat3 {
    let mut m = Mat3::zeros();
    for j in 0..3 {
        let mut e = Vec3::zeros();
        e[j] = h;
        let col = (f.gradient(&(p + e), t) - f.gradient(&(p - e), t)) / (2.0 * h);
        m.set_column(j, &col);
    }
    m
}

#[test]
fn gradient_and_hessian_match_finite_differences_in_2d_and_3d() {
    let points = [
        Vec3::new(0.3, -0.7, 0.4),
        Vec3::new(2.0, 1.5, -0.6),
        Vec3::new(-1.2, 0.4, 1.1),
    ];
    for dim in [2, 3] {
        for f in zoo(dim) {
            for p in &points {
                for t in [0.0, 3.7] {
                    let g = f.gradient(p, t);
                    let g_fd = fd_gradient(&f, p, t, 1e-5);
                    assert!(
                        (g - g_fd).norm() <= 1e-7 * (1.0 + g.norm()),
                        "{f:?} {g} {g_fd}"
                    );
                    let h = f.hessian(p, t);
                    let h_fd = fd_hessian(&f, p, t, 1e-5);
                    assert!(
                        (h - h_fd).norm() <= 1e-6 * (1.0 + h.norm()),
                        "{f:?} {h} {h_fd}"
                    );
                    assert_relative_eq!(h, h.transpose(), epsilon = 1e-14);
                }
            }
        }
    }
}

#[test]
fn two_dimensional_fields_ignore_z() {
    for f in zoo(2) {
        let p = Vec3::new(0.4, -0.3, 0.0);
        let q = Vec3::new(0.4, -0.3, 5.0);
        assert_eq!(f.value(&p, 1.0), f.value(&q, 1.0));
        let g = f.gradient(&q, 1.0);
        let h = f.hessian(&q, 1.0);
        assert_eq!(g.z, 0.0);
        for i in 0..3 {
            assert_eq!(h[(2, i)], 0.0);
            assert_eq!(h[(i, 2)], 0.0);
        }
        assert_ne!(g.norm(), 0.0);
        let (lo, hi) = f.bounds_hint();
        assert_eq!((lo.z, hi.z), (0.0, 0.0));
        assert!(lo.x < hi.x && lo.y < hi.y);
    }
}

#[test]
fn known_values() {
    // Quadratic: T = 3 + 0.5 * (1, 1) diag(2, 4) (1, 1)^T = 6.
    let q = Field::Quadratic {
        center: Vec3::zeros(),
        hessian: Mat3::from_diagonal(&Vec3::new(2.0, 4.0, 0.0)),
        offset: 3.0,
        dim: 2,
    };
    assert_relative_eq!(
        q.value(&Vec3::new(1.0, 1.0, 0.0), 0.0),
        6.0,
        epsilon = 1e-15
    );
    // Gaussian one width from its centre: A e^{-1/2}.
    let g = Field::GaussianSum {
        background: 12.0,
        bumps: vec![bump([0.0, 0.0, 0.0], 2.0, 3.0)],
        dim: 2,
    };
    assert_relative_eq!(
        g.value(&Vec3::new(3.0, 0.0, 0.0), 0.0),
        12.0 + 2.0 * (-0.5f64).exp(),
        epsilon = 1e-14
    );
    // Front: at the mid-plane T = background; far ahead background + A.
    let f = Field::MovingFront {
        background: 10.0,
        amplitude: 1.5,
        normal: Vec3::x(),
        offset: 1.0,
        speed: 0.5,
        width: 2.0,
        bump: None,
        dim: 2,
    };
    assert_relative_eq!(
        f.value(&Vec3::new(3.0, 7.0, 0.0), 4.0),
        10.0,
        epsilon = 1e-15
    );
    assert_relative_eq!(
        f.value(&Vec3::new(1e3, 0.0, 0.0), 4.0),
        11.5,
        epsilon = 1e-12
    );
}

#[test]
fn quadratic_optimum_depends_on_definiteness_and_goal() {
    let c = Vec3::new(20.0, 10.0, 0.0);
    let q = |h: Mat3| Field::Quadratic {
        center: c,
        hessian: h,
        offset: 0.0,
        dim: 2,
    };
    let pd = q(Mat3::from_diagonal(&Vec3::new(1.0, 2.0, 0.0)));
    assert_eq!(pd.optimum(0.0, Goal::Min), Some(c));
    assert_eq!(pd.optimum(0.0, Goal::Max), None);
    let nd = q(Mat3::from_diagonal(&Vec3::new(-1.0, -2.0, 0.0)));
    assert_eq!(nd.optimum(0.0, Goal::Max), Some(c));
    assert_eq!(nd.optimum(0.0, Goal::Min), None);
    let saddle = q(Mat3::from_diagonal(&Vec3::new(1.0, -2.0, 0.0)));
    assert_eq!(saddle.optimum(0.0, Goal::Min), None);
    assert_eq!(saddle.optimum(0.0, Goal::Max), None);
    let valley = q(Mat3::from_diagonal(&Vec3::new(1.0, 0.0, 0.0)));
    assert_eq!(valley.optimum(0.0, Goal::Min), None);
    // 3-D: a positive definite 3x3 Hessian; a 2x2-definite one with z = 0 is not enough.
    let q3 = Field::Quadratic {
        center: Vec3::new(1.0, 2.0, 3.0),
        hessian: Mat3::from_diagonal(&Vec3::new(1.0, 2.0, 0.5)),
        offset: 0.0,
        dim: 3,
    };
    assert_eq!(q3.optimum(0.0, Goal::Min), Some(Vec3::new(1.0, 2.0, 3.0)));
    let flat_z = Field::Quadratic {
        center: Vec3::zeros(),
        hessian: Mat3::from_diagonal(&Vec3::new(1.0, 2.0, 0.0)),
        offset: 0.0,
        dim: 3,
    };
    assert_eq!(flat_z.optimum(0.0, Goal::Min), None);
}

#[test]
fn gaussian_and_eddy_optimum_follow_the_sign_and_the_drift() {
    let peak = Field::GaussianSum {
        background: 0.0,
        bumps: vec![bump([3.0, 4.0, 0.0], 2.0, 1.0)],
        dim: 2,
    };
    assert_eq!(peak.optimum(0.0, Goal::Max), Some(Vec3::new(3.0, 4.0, 0.0)));
    assert_eq!(peak.optimum(0.0, Goal::Min), None);
    let eddy = Field::DriftingEddy {
        background: 12.0,
        bump: bump([1.0, 2.0, 0.0], -1.0, 5.0),
        velocity: Vec3::new(0.5, -0.25, 0.0),
        dim: 2,
    };
    assert_eq!(eddy.optimum(4.0, Goal::Min), Some(Vec3::new(3.0, 1.0, 0.0)));
    assert_eq!(eddy.optimum(4.0, Goal::Max), None);
    let grad = eddy.gradient(&Vec3::new(3.0, 1.0, 0.0), 4.0);
    assert!(grad.norm() < 1e-15);
}

#[test]
fn sum_of_bumps_optimum_is_the_best_local_optimum() {
    // Two overlapping peaks: the global maximum is shifted from both centres.
    let f = Field::GaussianSum {
        background: 5.0,
        bumps: vec![
            bump([0.0, 0.0, 0.0], 1.0, 2.0),
            bump([3.0, 1.0, 0.0], 1.5, 1.5),
            bump([-4.0, 0.0, 0.0], -3.0, 1.0),
        ],
        dim: 2,
    };
    let x = f.optimum(0.0, Goal::Max).expect("a maximum");
    assert!(f.gradient(&x, 0.0).norm() < 1e-10);
    assert_eq!(x.z, 0.0);
    // It is the best of a dense grid search.
    let mut best = f64::NEG_INFINITY;
    for i in -60..=60 {
        for j in -60..=60 {
            let p = Vec3::new(i as f64 * 0.1, j as f64 * 0.1, 0.0);
            best = best.max(f.value(&p, 0.0));
        }
    }
    assert!(f.value(&x, 0.0) >= best - 1e-12);
    assert!(
        (x - Vec3::new(3.0, 1.0, 0.0)).norm() > 1e-3,
        "shifted from the bump centre"
    );
    // The minimum is near the trough.
    let m = f.optimum(0.0, Goal::Min).expect("a minimum");
    assert!((m - Vec3::new(-4.0, 0.0, 0.0)).norm() < 0.5);
    assert!(f.gradient(&m, 0.0).norm() < 1e-10);
    // Deterministic.
    assert_eq!(f.optimum(0.0, Goal::Max), Some(x));
    // Only troughs: no maximum.
    let troughs = Field::GaussianSum {
        background: 0.0,
        bumps: vec![
            bump([0.0, 0.0, 0.0], -1.0, 1.0),
            bump([5.0, 0.0, 0.0], -1.0, 1.0),
        ],
        dim: 2,
    };
    assert_eq!(troughs.optimum(0.0, Goal::Max), None);
}

#[test]
fn sum_optimum_in_3d() {
    let f = Field::GaussianSum {
        background: 0.0,
        bumps: vec![
            bump([0.0, 0.0, 0.0], 1.0, 2.0),
            bump([1.0, 1.0, 1.0], 1.0, 2.0),
        ],
        dim: 3,
    };
    let x = f.optimum(0.0, Goal::Max).expect("a maximum");
    assert_relative_eq!(x, Vec3::new(0.5, 0.5, 0.5), epsilon = 1e-9);
}

#[test]
fn front_has_an_optimum_only_with_a_bump() {
    let mut f = Field::MovingFront {
        background: 10.0,
        amplitude: 0.5,
        normal: Vec3::x(),
        offset: 0.0,
        speed: 0.1,
        width: 5.0,
        bump: None,
        dim: 2,
    };
    assert_eq!(f.optimum(0.0, Goal::Max), None);
    assert_eq!(f.optimum(0.0, Goal::Min), None);
    if let Field::MovingFront { bump, .. } = &mut f {
        *bump = Some(GaussianBump {
            center: Vec3::new(2.0, 1.0, 0.0),
            amplitude: 2.0,
            width: 1.0,
        });
    }
    let x0 = f.optimum(0.0, Goal::Max).expect("a maximum");
    let x1 = f.optimum(30.0, Goal::Max).expect("a maximum");
    for (x, t) in [(x0, 0.0), (x1, 30.0)] {
        assert!(f.gradient(&x, t).norm() < 1e-10);
        assert!((x - Vec3::new(2.0, 1.0, 0.0)).norm() < 0.5);
    }
    assert_ne!(x0, x1, "the front moves, so does the maximum");
    assert_eq!(f.optimum(0.0, Goal::Min), None);
}

#[test]
fn front_too_steep_for_its_bump_has_no_maximum() {
    let f = Field::MovingFront {
        background: 0.0,
        amplitude: 50.0,
        normal: Vec3::x(),
        offset: 0.0,
        speed: 0.0,
        width: 1.0,
        bump: Some(bump([0.0, 0.0, 0.0], 0.1, 1.0)),
        dim: 2,
    };
    assert_eq!(f.optimum(0.0, Goal::Max), None);
}

#[test]
fn from_config_builds_every_kind() {
    use crate::config::{BumpConfig, FieldConfig, FieldKind};
    let base = FieldConfig {
        center: vec![20.0, 10.0],
        amplitude: 10.0,
        width: 15.0,
        background: 1.0,
        ..FieldConfig::default()
    };
    let g = Field::from_config(&base, 2);
    assert_eq!(
        g,
        Field::GaussianSum {
            background: 1.0,
            bumps: vec![bump([20.0, 10.0, 0.0], 10.0, 15.0)],
            dim: 2
        }
    );
    let q = Field::from_config(
        &FieldConfig {
            kind: FieldKind::Quadratic,
            center: vec![1.0, 2.0, 3.0],
            hessian: vec![
                vec![1.0, 0.5, 0.0],
                vec![0.5, 2.0, 0.0],
                vec![0.0, 0.0, 3.0],
            ],
            offset: 4.0,
            ..FieldConfig::default()
        },
        3,
    );
    assert_relative_eq!(q.value(&Vec3::new(1.0, 2.0, 3.0), 0.0), 4.0);
    assert_relative_eq!(q.hessian(&Vec3::zeros(), 0.0)[(0, 1)], 0.5);
    let e = Field::from_config(
        &FieldConfig {
            kind: FieldKind::Eddy,
            velocity: vec![1.0, 0.0],
            ..base.clone()
        },
        2,
    );
    assert_eq!(e.optimum(2.0, Goal::Max), Some(Vec3::new(22.0, 10.0, 0.0)));
    let f = Field::from_config(
        &FieldConfig {
            kind: FieldKind::Front,
            normal: vec![0.0, 2.0],
            bumps: vec![BumpConfig {
                center: vec![1.0, 1.0],
                amplitude: 1.0,
                width: 1.0,
            }],
            ..base.clone()
        },
        2,
    );
    match f {
        Field::MovingFront { normal, bump, .. } => {
            assert_eq!(normal, Vec3::y());
            assert!(bump.is_some());
        }
        other => panic!("not a front: {other:?}"),
    }
    let s = Field::from_config(
        &FieldConfig {
            kind: FieldKind::GaussianSum,
            bumps: vec![
                BumpConfig {
                    center: vec![1.0, 1.0],
                    amplitude: 1.0,
                    width: 1.0,
                },
                BumpConfig {
                    center: vec![-1.0, 1.0],
                    amplitude: -1.0,
                    width: 2.0,
                },
            ],
            ..base
        },
        2,
    );
    match s {
        Field::GaussianSum { bumps, .. } => assert_eq!(bumps.len(), 2),
        other => panic!("not a sum: {other:?}"),
    }
}

#[test]
fn sensor_noise_is_keyed_and_has_the_right_moments() {
    let sigma = 0.3;
    assert_eq!(
        sensor_noise(7, 2, 100, sigma),
        sensor_noise(7, 2, 100, sigma)
    );
    assert_ne!(
        sensor_noise(7, 2, 100, sigma),
        sensor_noise(7, 2, 101, sigma)
    );
    assert_ne!(
        sensor_noise(7, 2, 100, sigma),
        sensor_noise(7, 3, 100, sigma)
    );
    assert_ne!(
        sensor_noise(7, 2, 100, sigma),
        sensor_noise(8, 2, 100, sigma)
    );
    let n = 20_000;
    let xs: Vec<f64> = (0..n).map(|k| sensor_noise(42, 1, k, sigma)).collect();
    let mean = xs.iter().sum::<f64>() / n as f64;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0);
    // Standard error of the mean sigma/sqrt(n) = 0.0021: allow 5 of them.
    assert!(mean.abs() < 5.0 * sigma / (n as f64).sqrt(), "mean {mean}");
    // Standard error of the std is about sigma/sqrt(2n) = 0.0015: allow 5 of them.
    assert!((var.sqrt() - sigma).abs() < 5.0 * sigma / (2.0 * n as f64).sqrt());
    assert_eq!(sensor_noise(42, 1, 5, 0.0), 0.0);
    assert_eq!(sensor_noise(42, 1, 5, f64::NAN), 0.0);
}

#[test]
fn every_shipped_kind_is_the_same_field_through_the_trait() {
    for dim in [2, 3] {
        for f in zoo(dim) {
            let dynamic: &dyn ScalarField = &f;
            let p = Vec3::new(0.7, -0.3, if dim == 3 { 0.4 } else { 0.0 });
            for t in [0.0, 2.5] {
                assert_eq!(dynamic.dim(), f.dim());
                assert_eq!(dynamic.value(&p, t), f.value(&p, t));
                assert_eq!(dynamic.gradient(&p, t), f.gradient(&p, t));
                assert_eq!(dynamic.hessian(&p, t), f.hessian(&p, t));
                for goal in [Goal::Min, Goal::Max] {
                    assert_eq!(dynamic.optimum(t, goal), f.optimum(t, goal));
                }
            }
            assert_eq!(dynamic.bounds_hint(), f.bounds_hint());
        }
    }
}

#[test]
fn measure_is_value_plus_keyed_noise() {
    let f = &zoo(2)[1];
    let p = Vec3::new(0.5, 0.5, 0.0);
    let m = measure(f, &p, 2.0, 9, 3, 40, 0.1);
    assert_eq!(m, f.value(&p, 2.0) + sensor_noise(9, 3, 40, 0.1));
    assert_eq!(measure(f, &p, 2.0, 9, 3, 40, 0.0), f.value(&p, 2.0));
}
