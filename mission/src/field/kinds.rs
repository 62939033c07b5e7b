//! The shipped kinds of field ([`Field`], [`GaussianBump`]) and building one from a
//! mission's `[field]`.

use crate::config::{FieldConfig, FieldKind};
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
}
