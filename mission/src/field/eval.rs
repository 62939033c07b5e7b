//! A [`Field`]'s value, gradient and Hessian at a point and time, analytic.

use vbap_math::{Mat3, Vec3};

use super::{Field, GaussianBump};

impl Field {
    /// `p` with z set to 0 in 2-D.
    pub(super) fn planar(&self, p: &Vec3) -> Vec3 {
        if self.dim() == 2 {
            Vec3::new(p.x, p.y, 0.0)
        } else {
            *p
        }
    }

    /// The eddy at time t (its centre moved to c0 + v t).
    pub(super) fn eddy_at(bump: &GaussianBump, velocity: &Vec3, t: f64) -> GaussianBump {
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
}
