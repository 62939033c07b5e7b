//! The keyed sensor noise and a sensor reading (docs/ARCHITECTURE.md §4).

use rand_distr::{Distribution, Normal};
use vbap_math::rng::{keyed, Stream};
use vbap_math::Vec3;

use super::ScalarField;

/// Sensor noise ε ~ N(0, σ²) of `vehicle` at `tick` (field unit), drawn from
/// `rng::keyed(seed, Stream::SensorNoise, vehicle, tick)`: the same key gives the same number.
///
/// `sigma` (σ_M of Lemma 5.2) must be finite and ≥ 0, which the mission validator guarantees;
/// any other value gives 0 (no noise) rather than NaN.
pub fn sensor_noise(seed: u64, vehicle: u32, tick: u64, sigma: f64) -> f64 {
    if !(sigma.is_finite() && sigma > 0.0) {
        return 0.0;
    }
    match Normal::new(0.0, sigma) {
        Ok(normal) => normal.sample(&mut keyed(seed, Stream::SensorNoise, vehicle as u64, tick)),
        Err(_) => 0.0,
    }
}

/// One sensor reading T_m = T(p, t) + ε (Lemma 5.1), with ε from [`sensor_noise`].
pub fn measure(
    field: &(impl ScalarField + ?Sized),
    p: &Vec3,
    t: f64,
    seed: u64,
    vehicle: u32,
    tick: u64,
    sigma: f64,
) -> f64 {
    field.value(p, t) + sensor_noise(seed, vehicle, tick, sigma)
}
