//! Unit tests of [`World::sample`] and [`Sensors::read`]: keyed noise, the truth beneath.

use std::sync::Arc;

use vbap_math::{Mat3, Vec3};
use vbap_mission::config::{Goal, Mission};
use vbap_mission::field::ScalarField;

use crate::{Sensors, World};

/// The paper's mission (Table I) shipped with the repository; `noise`: its σ_M instead.
fn paper_mission(noise: Option<f64>) -> Mission {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions/paper.toml");
    let mut mission = Mission::load(std::path::Path::new(path)).expect("a valid mission");
    if let Some(sigma) = noise {
        mission.field.noise_std = sigma;
    }
    mission
}

/// A field of our own: the plane T = 3 + 2x − y (no optimum).
#[derive(Debug)]
struct Plane;

impl ScalarField for Plane {
    fn dim(&self) -> usize {
        2
    }
    fn value(&self, p: &Vec3, _t: f64) -> f64 {
        3.0 + 2.0 * p.x - p.y
    }
    fn gradient(&self, _p: &Vec3, _t: f64) -> Vec3 {
        Vec3::new(2.0, -1.0, 0.0)
    }
    fn hessian(&self, _p: &Vec3, _t: f64) -> Mat3 {
        Mat3::zeros()
    }
}

#[test]
fn the_same_key_gives_the_same_reading_and_another_key_another() {
    let world = World::new(&paper_mission(None));
    let p = Vec3::new(1.5, -2.0, 0.0);
    let a = world.sample(2, 40, 2.0, &p).unwrap();
    assert_eq!(
        world.sample(2, 40, 2.0, &p),
        Some(a),
        "same (seed, vehicle, tick)"
    );
    // A second world of the same mission (another process) reads the same.
    assert_eq!(
        World::new(&paper_mission(None)).sample(2, 40, 2.0, &p),
        Some(a)
    );
    assert_ne!(world.sample(3, 40, 2.0, &p), Some(a), "another vehicle");
    assert_ne!(world.sample(2, 41, 2.0, &p), Some(a), "another tick");
}

#[test]
fn without_noise_a_reading_is_the_truth_of_the_field() {
    // The paper's bowl T = ½ |x − c|², c = (20, 10), H = I.
    let world = World::new(&paper_mission(Some(0.0)));
    for (p, truth) in [
        (Vec3::new(20.0, 10.0, 0.0), 0.0),
        (Vec3::new(0.0, 0.0, 0.0), 0.5 * (400.0 + 100.0)),
        (Vec3::new(23.0, 14.0, 0.0), 0.5 * (9.0 + 16.0)),
    ] {
        let v = world.sample(0, 7, 0.35, &p).unwrap();
        assert!((v - truth).abs() <= 1e-12, "T{p:?} = {v}, truth {truth}");
    }
    // A user's own field plugs in the same way.
    let plane = World::with_field(&paper_mission(Some(0.0)), Arc::new(Plane));
    let v = plane.sample(1, 3, 0.15, &Vec3::new(2.0, 5.0, 0.0)).unwrap();
    assert_eq!(v, 3.0 + 4.0 - 5.0);
    assert_eq!(plane.field().optimum(0.0, Goal::Min), None);
}

#[test]
fn the_noise_is_centred_on_the_truth_with_the_missions_sigma() {
    // σ_M = 1 (Table I): over 4000 ticks the mean error is within 4σ/√n and the sample
    // standard deviation within 5 % of σ_M.
    let world = World::with_field(&paper_mission(None), Arc::new(Plane));
    let p = Vec3::new(1.0, 1.0, 0.0);
    let truth = Plane.value(&p, 0.0);
    let n = 4000;
    let errors: Vec<f64> = (0..n)
        .map(|k| world.sample(0, k, 0.0, &p).unwrap() - truth)
        .collect();
    let mean = errors.iter().sum::<f64>() / n as f64;
    let var = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    assert!(mean.abs() <= 4.0 / (n as f64).sqrt(), "mean error {mean}");
    assert!((var.sqrt() - 1.0).abs() <= 0.05, "σ = {}", var.sqrt());
}

#[test]
fn a_reading_at_a_non_finite_place_or_time_is_refused() {
    let world = World::new(&paper_mission(None));
    assert_eq!(
        world.sample(0, 1, 0.05, &Vec3::new(f64::NAN, 0.0, 0.0)),
        None
    );
    assert_eq!(world.sample(0, 1, f64::INFINITY, &Vec3::zeros()), None);
    let mut sensors = Sensors::new(&paper_mission(None));
    assert_eq!(
        sensors.read(99, 1, 0.05, &Vec3::zeros()),
        None,
        "no vehicle 99"
    );
    assert!(sensors.read(3, 1, 0.05, &Vec3::zeros()).is_some());
}
