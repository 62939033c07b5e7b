//! The sensed environments, with ground truth, and the keyed sensor noise.
//!
//! A [`Field`] is the scalar field T(x, t) the vehicles measure (temperature in °C, say, over
//! positions in metres and mission time in seconds, or the paper's non-dimensional units). It
//! knows its own value, gradient, Hessian and optimum analytically: that is the *ground truth*
//! the evaluator and the recorder use, never the coordinator's estimator (docs/ARCHITECTURE.md §9).
//!
//! Positions are always [`Vec3`]. A 2-D field (`dim = 2`) is a function of x and y only: the
//! z component of a query point is ignored, and the z components of the gradient and of the
//! Hessian are exactly zero.
//!
//! Sensor noise is drawn from [`vbap_math::rng::keyed`] with the key (seed, [`Stream::SensorNoise`],
//! vehicle, tick), so the same reading is noisy in exactly the same way in the in-process
//! simulator and in the multi-process system (docs/ARCHITECTURE.md §4).

use crate::config::{FieldConfig, FieldKind, Goal};
use rand_distr::{Distribution, Normal};
use vbap_math::rng::{keyed, Stream};
use vbap_math::{Mat3, Vec3};

/// One Gaussian bump: A·exp(−‖x − c‖² / (2 w²)). A negative amplitude is a trough.
#[derive(Clone, Debug, PartialEq)]
pub struct GaussianBump {
    /// Centre c of the bump (length unit; z = 0 in 2-D).
    pub center: Vec3,
    /// Peak height A (field unit); negative for a trough.
    pub amplitude: f64,
    /// Standard deviation w of the bump (length unit), > 0.
    pub width: f64,
}

impl GaussianBump {
    /// A·exp(−‖p − c‖² / (2 w²)) at `p` (field unit).
    pub fn value(&self, p: &Vec3) -> f64 {
        let d = p - self.center;
        self.amplitude * (-d.norm_squared() / (2.0 * self.width * self.width)).exp()
    }

    /// ∇ = −value · (p − c) / w² (field unit per length unit).
    pub fn gradient(&self, p: &Vec3) -> Vec3 {
        let d = p - self.center;
        -self.value(p) * d / (self.width * self.width)
    }

    /// ∇² = value · ((p − c)(p − c)ᵀ / w⁴ − I / w²) (field unit per length unit²).
    pub fn hessian(&self, p: &Vec3) -> Mat3 {
        let d = p - self.center;
        let w2 = self.width * self.width;
        self.value(p) * (d * d.transpose() / (w2 * w2) - Mat3::identity() / w2)
    }
}

/// A scalar field T(x, t) with analytic derivatives: the environment and its ground truth.
///
/// Every variant carries `dim` (2 or 3); see the module documentation for what 2-D means.
#[derive(Clone, Debug, PartialEq)]
pub enum Field {
    /// T = offset + ½ (x − c)ᵀ H (x − c); the paper's model field (Lemma 5.1, Table I).
    Quadratic {
        /// Centre c: the minimum if H is positive definite, the maximum if negative definite.
        center: Vec3,
        /// Hessian H (field unit per length unit²), symmetric; zero z row and column in 2-D.
        hessian: Mat3,
        /// Value at the centre (field unit).
        offset: f64,
        /// 2 or 3.
        dim: usize,
    },
    /// T = background + Σ bumps; a single Gaussian is a sum of one.
    GaussianSum {
        /// Value far from every bump (field unit).
        background: f64,
        /// The bumps (peaks and troughs).
        bumps: Vec<GaussianBump>,
        /// 2 or 3.
        dim: usize,
    },
    /// A Gaussian eddy drifting at constant velocity: centre c(t) = c0 + v t.
    DriftingEddy {
        /// Value far from the eddy (field unit).
        background: f64,
        /// The eddy at t = 0 (its centre is c0).
        bump: GaussianBump,
        /// Drift velocity v (length unit per second).
        velocity: Vec3,
        /// 2 or 3.
        dim: usize,
    },
    /// A moving tanh front, T = background + A·tanh((n·x − offset − speed·t) / width), plus an
    /// optional Gaussian bump so the field has an extremum.
    MovingFront {
        /// Mid-front value (field unit).
        background: f64,
        /// Half the temperature step across the front (field unit); T → background ± A.
        amplitude: f64,
        /// Unit normal n of the front, pointing to the side where T → background + A.
        normal: Vec3,
        /// Position of the front along n at t = 0 (length unit).
        offset: f64,
        /// Speed of the front along n (length unit per second).
        speed: f64,
        /// Thickness of the front (length unit), > 0.
        width: f64,
        /// Optional bump added to the front (its centre does not move).
        bump: Option<GaussianBump>,
        /// 2 or 3.
        dim: usize,
    },
    /// A gridded variable of a file, interpolated (beyond the paper; `crate::grid`).
    Grid(std::sync::Arc<crate::grid::GridField>),
}

/// `v[i]` for i < dim, zero elsewhere (missing components are zero).
fn vec3_of(v: &[f64], dim: usize) -> Vec3 {
    let mut out = Vec3::zeros();
    for (i, x) in v.iter().take(dim.min(3)).enumerate() {
        out[i] = *x;
    }
    out
}

/// The dim×dim block of `m`, symmetrised, zero elsewhere.
fn mat3_of(m: &[Vec<f64>], dim: usize) -> Mat3 {
    let mut out = Mat3::zeros();
    for (i, row) in m.iter().take(dim.min(3)).enumerate() {
        for (j, x) in row.iter().take(dim.min(3)).enumerate() {
            out[(i, j)] = *x;
        }
    }
    (out + out.transpose()) * 0.5
}

/// Eigenvalues of the dim×dim block of a symmetric matrix.
fn block_eigenvalues(h: &Mat3, dim: usize) -> Vec<f64> {
    if dim == 2 {
        let b = nalgebra::Matrix2::new(h[(0, 0)], h[(0, 1)], h[(1, 0)], h[(1, 1)]);
        b.symmetric_eigenvalues().iter().copied().collect()
    } else {
        h.symmetric_eigenvalues().iter().copied().collect()
    }
}

/// True if the dim×dim block of `h` is positive definite (relative to its largest eigenvalue).
fn block_positive_definite(h: &Mat3, dim: usize) -> bool {
    let eig = block_eigenvalues(h, dim);
    let scale = eig.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    scale > 0.0 && eig.iter().all(|e| e.is_finite() && *e > 1e-12 * scale)
}

impl Field {
    /// The field described by a mission's `[field]` section, in `dim` dimensions.
    ///
    /// Expects a validated config ([`crate::config::Mission::validate`]): vector components
    /// beyond `dim` are ignored and missing ones are zero, the Hessian is symmetrised and the
    /// front normal normalised.
    pub fn from_config(cfg: &FieldConfig, dim: usize) -> Field {
        let bump_of = |center: &[f64], amplitude: f64, width: f64| GaussianBump {
            center: vec3_of(center, dim),
            amplitude,
            width,
        };
        let main_bump = || bump_of(&cfg.center, cfg.amplitude, cfg.width);
        match cfg.kind {
            FieldKind::Quadratic => Field::Quadratic {
                center: vec3_of(&cfg.center, dim),
                hessian: mat3_of(&cfg.hessian, dim),
                offset: cfg.offset,
                dim,
            },
            FieldKind::Gaussian => Field::GaussianSum {
                background: cfg.background,
                bumps: vec![main_bump()],
                dim,
            },
            FieldKind::GaussianSum => Field::GaussianSum {
                background: cfg.background,
                bumps: cfg
                    .bumps
                    .iter()
                    .map(|b| bump_of(&b.center, b.amplitude, b.width))
                    .collect(),
                dim,
            },
            FieldKind::Eddy => Field::DriftingEddy {
                background: cfg.background,
                bump: main_bump(),
                velocity: vec3_of(&cfg.velocity, dim),
                dim,
            },
            FieldKind::Grid => Field::Grid(
                cfg.grid
                    .0
                    .clone()
                    .expect("a validated grid mission has loaded its grid (Mission::load)"),
            ),
            FieldKind::Front => {
                let n = vec3_of(&cfg.normal, dim);
                let norm = n.norm();
                Field::MovingFront {
                    background: cfg.background,
                    amplitude: cfg.amplitude,
                    normal: if norm > 0.0 { n / norm } else { n },
                    offset: cfg.offset,
                    speed: cfg.speed,
                    width: cfg.width,
                    bump: cfg
                        .bumps
                        .first()
                        .map(|b| bump_of(&b.center, b.amplitude, b.width)),
                    dim,
                }
            }
        }
    }

    /// 2 or 3: the number of spatial dimensions the field depends on.
    pub fn dim(&self) -> usize {
        match self {
            Field::Quadratic { dim, .. }
            | Field::GaussianSum { dim, .. }
            | Field::DriftingEddy { dim, .. }
            | Field::MovingFront { dim, .. } => *dim,
            Field::Grid(g) => g.dim,
        }
    }

    /// `p` with z set to 0 in 2-D.
    fn planar(&self, p: &Vec3) -> Vec3 {
        if self.dim() == 2 {
            Vec3::new(p.x, p.y, 0.0)
        } else {
            *p
        }
    }

    /// The eddy at time t (its centre moved to c0 + v t).
    fn eddy_at(bump: &GaussianBump, velocity: &Vec3, t: f64) -> GaussianBump {
        GaussianBump {
            center: bump.center + velocity * t,
            ..bump.clone()
        }
    }

    /// T(p, t) (field unit) at position `p` (length unit) and mission time `t` (s).
    pub fn value(&self, p: &Vec3, t: f64) -> f64 {
        let p = self.planar(p);
        match self {
            Field::Grid(g) => g.value(&p, t),
            Field::Quadratic {
                center,
                hessian,
                offset,
                ..
            } => {
                let d = p - center;
                offset + 0.5 * d.dot(&(hessian * d))
            }
            Field::GaussianSum {
                background, bumps, ..
            } => background + bumps.iter().map(|b| b.value(&p)).sum::<f64>(),
            Field::DriftingEddy {
                background,
                bump,
                velocity,
                ..
            } => background + Self::eddy_at(bump, velocity, t).value(&p),
            Field::MovingFront {
                background,
                amplitude,
                normal,
                offset,
                speed,
                width,
                bump,
                ..
            } => {
                let u = (normal.dot(&p) - offset - speed * t) / width;
                background + amplitude * u.tanh() + bump.as_ref().map_or(0.0, |b| b.value(&p))
            }
        }
    }

    /// ∇T(p, t) (field unit per length unit), analytic; z = 0 in 2-D.
    pub fn gradient(&self, p: &Vec3, t: f64) -> Vec3 {
        let p = self.planar(p);
        let mut g = match self {
            Field::Grid(g) => g.gradient(&p, t),
            Field::Quadratic {
                center, hessian, ..
            } => hessian * (p - center),
            Field::GaussianSum { bumps, .. } => bumps
                .iter()
                .fold(Vec3::zeros(), |acc, b| acc + b.gradient(&p)),
            Field::DriftingEddy { bump, velocity, .. } => {
                Self::eddy_at(bump, velocity, t).gradient(&p)
            }
            Field::MovingFront {
                amplitude,
                normal,
                offset,
                speed,
                width,
                bump,
                ..
            } => {
                let u = (normal.dot(&p) - offset - speed * t) / width;
                let th = u.tanh();
                let front = normal * (amplitude * (1.0 - th * th) / width);
                front + bump.as_ref().map_or(Vec3::zeros(), |b| b.gradient(&p))
            }
        };
        if self.dim() == 2 {
            g.z = 0.0;
        }
        g
    }

    /// ∇²T(p, t) (field unit per length unit²), analytic and symmetric; z row and column zero
    /// in 2-D.
    pub fn hessian(&self, p: &Vec3, t: f64) -> Mat3 {
        let p = self.planar(p);
        let mut h = match self {
            Field::Grid(g) => g.hessian(&p, t),
            Field::Quadratic { hessian, .. } => *hessian,
            Field::GaussianSum { bumps, .. } => bumps
                .iter()
                .fold(Mat3::zeros(), |acc, b| acc + b.hessian(&p)),
            Field::DriftingEddy { bump, velocity, .. } => {
                Self::eddy_at(bump, velocity, t).hessian(&p)
            }
            Field::MovingFront {
                amplitude,
                normal,
                offset,
                speed,
                width,
                bump,
                ..
            } => {
                let u = (normal.dot(&p) - offset - speed * t) / width;
                let th = u.tanh();
                let front = normal
                    * normal.transpose()
                    * (-2.0 * amplitude * (1.0 - th * th) * th / (width * width));
                front + bump.as_ref().map_or(Mat3::zeros(), |b| b.hessian(&p))
            }
        };
        if self.dim() == 2 {
            for i in 0..3 {
                h[(2, i)] = 0.0;
                h[(i, 2)] = 0.0;
            }
        }
        h
    }

    /// The true optimum at time `t` (s): the maximum (`Goal::Max`) or minimum (`Goal::Min`) the
    /// group should reach, or `None` if the field has none of that kind.
    ///
    /// Analytic where it exists: a quadratic's centre if H is positive definite (min) or negative
    /// definite (max); a single Gaussian's or an eddy's centre if the sign of its amplitude
    /// matches the goal. Sums of bumps, and fronts with a bump, are searched numerically and
    /// deterministically (damped Newton from every bump centre whose sign matches the goal, the
    /// best local optimum wins, ties to the first bump). A front without a bump has none.
    pub fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        let wanted = |amplitude: f64| match goal {
            Goal::Max => amplitude > 0.0,
            Goal::Min => amplitude < 0.0,
        };
        match self {
            Field::Quadratic {
                center,
                hessian,
                dim,
                ..
            } => {
                let h = match goal {
                    Goal::Min => *hessian,
                    Goal::Max => -hessian,
                };
                block_positive_definite(&h, *dim).then_some(*center)
            }
            Field::GaussianSum { bumps, .. } if bumps.len() == 1 => {
                wanted(bumps[0].amplitude).then_some(bumps[0].center)
            }
            Field::GaussianSum { bumps, .. } => {
                let mut best: Option<(Vec3, f64)> = None;
                for b in bumps.iter().filter(|b| wanted(b.amplitude)) {
                    if let Some(x) = self.local_optimum(b.center, t, goal, b.width) {
                        let v = goal.sign() * self.value(&x, t);
                        if best.is_none_or(|(_, bv)| v > bv) {
                            best = Some((x, v));
                        }
                    }
                }
                best.map(|(x, _)| x)
            }
            Field::DriftingEddy { bump, velocity, .. } => {
                wanted(bump.amplitude).then(|| Self::eddy_at(bump, velocity, t).center)
            }
            Field::MovingFront { bump, .. } => match bump {
                Some(b) if wanted(b.amplitude) => self.local_optimum(b.center, t, goal, b.width),
                _ => None,
            },
            Field::Grid(g) => g.optimum(t, goal),
        }
    }

    /// Damped Newton search for a local optimum of `goal` kind from `start`, at time `t`;
    /// `length` caps a step (length unit). `None` if the search does not end at a strict local
    /// optimum (gradient ≈ 0, Hessian definite with the right sign).
    fn local_optimum(&self, start: Vec3, t: f64, goal: Goal, length: f64) -> Option<Vec3> {
        let dim = self.dim();
        let sign = goal.sign();
        // Minimise phi = -sign * T.
        let phi = |x: &Vec3| -sign * self.value(x, t);
        let mut x = self.planar(&start);
        for _ in 0..500 {
            let g = -sign * self.gradient(&x, t);
            if g.norm() == 0.0 {
                break;
            }
            let mut h = -sign * self.hessian(&x, t);
            if dim == 2 {
                h[(2, 2)] = 1.0;
            }
            let newton = if block_positive_definite(&h, dim) {
                h.cholesky().map(|c| -c.solve(&g))
            } else {
                None
            };
            let mut d = newton.unwrap_or_else(|| -g / g.norm() * length);
            if d.norm() > length {
                d *= length / d.norm();
            }
            let slope = g.dot(&d);
            if slope >= 0.0 {
                break;
            }
            let f0 = phi(&x);
            let mut alpha = 1.0;
            let mut moved = false;
            for _ in 0..60 {
                let trial = x + alpha * d;
                if phi(&trial) <= f0 + 1e-4 * alpha * slope {
                    x = trial;
                    moved = true;
                    break;
                }
                alpha *= 0.5;
            }
            if !moved || (alpha * d).norm() <= 1e-13 * length {
                break;
            }
        }
        let scale = self.value_scale();
        let g = self.gradient(&x, t);
        let mut h = -sign * self.hessian(&x, t);
        if dim == 2 {
            h[(2, 2)] = 1.0;
        }
        let ok = x.iter().all(|c| c.is_finite())
            && g.norm() * length <= 1e-8 * scale
            && block_positive_definite(&h, dim);
        ok.then_some(x)
    }

    /// A typical size of the field's variations (field unit), for relative tolerances.
    fn value_scale(&self) -> f64 {
        let s = match self {
            Field::Quadratic { hessian, .. } => hessian.abs().max(),
            Field::GaussianSum { bumps, .. } => bumps.iter().map(|b| b.amplitude.abs()).sum(),
            Field::DriftingEddy { bump, .. } => bump.amplitude.abs(),
            Field::MovingFront {
                amplitude, bump, ..
            } => amplitude.abs() + bump.as_ref().map_or(0.0, |b| b.amplitude.abs()),
            Field::Grid(_) => 1.0,
        };
        if s > 0.0 {
            s
        } else {
            1.0
        }
    }

    /// A box (lower corner, upper corner; length unit) around the interesting part of the field
    /// at t = 0, for plots: ±3 widths around every bump; ±10 length units around a quadratic's
    /// centre (a quadratic has no length scale); ±5 widths around a front's mid-point without a
    /// bump. z is 0 in 2-D. Plots should union it with the tracks.
    pub fn bounds_hint(&self) -> (Vec3, Vec3) {
        let boxed = |c: &Vec3, half: f64| (c - Vec3::repeat(half), c + Vec3::repeat(half));
        let (mut lo, mut hi) = match self {
            Field::Quadratic { center, .. } => boxed(center, 10.0),
            Field::GaussianSum { bumps, .. } => {
                let mut it = bumps.iter().map(|b| boxed(&b.center, 3.0 * b.width));
                match it.next() {
                    Some(first) => it.fold(first, |(lo, hi), (l, h)| (lo.inf(&l), hi.sup(&h))),
                    None => boxed(&Vec3::zeros(), 10.0),
                }
            }
            Field::DriftingEddy { bump, .. } => boxed(&bump.center, 3.0 * bump.width),
            Field::MovingFront {
                normal,
                offset,
                width,
                bump,
                ..
            } => match bump {
                Some(b) => boxed(&b.center, 3.0 * b.width),
                None => boxed(&(normal * *offset), 5.0 * width),
            },
            Field::Grid(g) => g.bounds(),
        };
        if self.dim() == 2 {
            lo.z = 0.0;
            hi.z = 0.0;
        }
        (lo, hi)
    }
}

/// A scalar field T(x, t) with analytic derivatives: the extension point for the sensed
/// environment. The field server samples it ([`measure`]), the recorder judges the run by
/// it (true gradient, true optimum, the plot's contours); every shipped kind ([`Field`],
/// from a mission's `[field]`) implements it, and so can a user's own (a gridded data set,
/// a model's output): hand it to the simulator, the field server and the recorder instead
/// of the mission's.
///
/// Units: positions in the mission's length unit, `t` mission time in s, values in the
/// field's unit. A 2-D field ignores z and returns zero z components.
pub trait ScalarField: Send + Sync + std::fmt::Debug {
    /// 2 or 3: the number of spatial dimensions the field depends on.
    fn dim(&self) -> usize;
    /// T(p, t) (field unit).
    fn value(&self, p: &Vec3, t: f64) -> f64;
    /// ∇T(p, t) (field unit per length unit).
    fn gradient(&self, p: &Vec3, t: f64) -> Vec3;
    /// ∇²T(p, t) (field unit per length unit²), symmetric.
    fn hessian(&self, p: &Vec3, t: f64) -> Mat3;
    /// The true optimum at time `t` (the maximum for `Goal::Max`, the minimum for
    /// `Goal::Min`), or `None` if there is none (or it is not known): the verdict then
    /// judges the formation only.
    fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        let _ = (t, goal);
        None
    }
    /// A box (lower, upper corner; length unit) around the interesting part of the field
    /// at t = 0, for plots (they union it with the tracks). Default: ±10 around the origin.
    fn bounds_hint(&self) -> (Vec3, Vec3) {
        let half = Vec3::new(10.0, 10.0, if self.dim() == 3 { 10.0 } else { 0.0 });
        (-half, half)
    }
}

impl ScalarField for Field {
    fn dim(&self) -> usize {
        Field::dim(self)
    }
    fn value(&self, p: &Vec3, t: f64) -> f64 {
        Field::value(self, p, t)
    }
    fn gradient(&self, p: &Vec3, t: f64) -> Vec3 {
        Field::gradient(self, p, t)
    }
    fn hessian(&self, p: &Vec3, t: f64) -> Mat3 {
        Field::hessian(self, p, t)
    }
    fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        Field::optimum(self, t, goal)
    }
    fn bounds_hint(&self) -> (Vec3, Vec3) {
        Field::bounds_hint(self)
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

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
}
