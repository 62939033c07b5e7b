//! [`Mission::validate`]: every value and every constraint between values, section by
//! section, in file order; the first violation is returned naming the file, the dotted key
//! and the reason. Each section's checks are in their own file; [`Check`] holds the helpers
//! they share.

mod acoustic;
mod control;
mod faults;
mod field;
mod fleet;
mod links;
mod mission;
mod motion;

pub use acoustic::MAX_ACOUSTIC_VEHICLES;

use std::fmt;

use super::toml_text::{mat_str, num, vec_str};
use super::{ConfigError, Mission};

impl Mission {
    /// Checks every value and every constraint between values; the first violation is
    /// returned, naming `self.origin`, the dotted key and the reason.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let c = Check {
            origin: &self.origin,
        };
        let dim = self.mission.dim;
        mission::check(&c, &self.mission)?;
        field::check(&c, &self.field, dim)?;
        fleet::vehicles(&c, &self.vehicles, dim)?;
        fleet::formation(&c, &self.formation, dim)?;
        fleet::design_fits(&c, self)?;
        fleet::body(&c, &self.body)?;
        fleet::estimator(&c, &self.estimator)?;
        links::links(&c, &self.links)?;
        links::restart(&c, &self.restart)?;
        acoustic::check(&c, self)?;
        control::check(&c, &self.control)?;
        motion::model(&c, &self.vehicles)?;
        motion::dive(&c, &self.vehicles, dim)?;
        motion::current(&c, &self.current, dim)?;
        motion::land(&c, &self.land, dim, &self.vehicles.start)?;
        self.check_stability(&c)?;
        self.check_envelope(&c)?;
        faults::check(&c, self)
    }
}

/// Validation helpers: each names the origin and the key.
pub(super) struct Check<'a> {
    /// The file (or other origin) named in every error.
    pub(super) origin: &'a str,
}

pub(super) type Checked = Result<(), ConfigError>;

impl Check<'_> {
    /// An [`ConfigError::Invalid`] naming the origin, `key`, `value` and `reason`.
    pub(super) fn fail(
        &self,
        key: &str,
        value: impl fmt::Display,
        reason: impl Into<String>,
    ) -> ConfigError {
        ConfigError::Invalid {
            origin: self.origin.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    /// `reason` about `key` = `value` unless `ok`.
    fn ensure(&self, ok: bool, key: &str, value: impl fmt::Display, reason: &str) -> Checked {
        if ok {
            Ok(())
        } else {
            Err(self.fail(key, value, reason))
        }
    }

    /// `x` is a finite number.
    fn finite(&self, key: &str, x: f64) -> Checked {
        self.ensure(x.is_finite(), key, num(x), "must be a finite number")
    }

    /// `x` is finite and > 0.
    fn positive(&self, key: &str, x: f64) -> Checked {
        self.finite(key, x)?;
        self.ensure(x > 0.0, key, num(x), "must be > 0")
    }

    /// `x` is finite and ≥ 0.
    fn non_negative(&self, key: &str, x: f64) -> Checked {
        self.finite(key, x)?;
        self.ensure(x >= 0.0, key, num(x), "must be ≥ 0")
    }

    /// `x` is a probability that is not certain: finite, in [0, 1) (`why`: what 1 would
    /// mean, or empty).
    fn probability_below_one(&self, key: &str, x: f64, why: &str) -> Checked {
        self.finite(key, x)?;
        self.ensure(
            (0.0..1.0).contains(&x),
            key,
            num(x),
            &format!("must be in [0, 1){why}"),
        )
    }

    /// `x` (of `key`) is at least `floor`, the value of `floor_key`.
    fn at_least(&self, key: &str, x: f64, floor_key: &str, floor: f64) -> Checked {
        self.ensure(
            x >= floor,
            key,
            num(x),
            &format!("must be ≥ {floor_key} = {}", num(floor)),
        )
    }

    /// Every component of `v` is finite (named `key[i]`).
    fn all_finite(&self, key: &str, v: &[f64]) -> Checked {
        for (i, x) in v.iter().enumerate() {
            self.finite(&format!("{key}[{i}]"), *x)?;
        }
        Ok(())
    }

    /// `v` has `dim` finite components.
    fn vector(&self, key: &str, v: &[f64], dim: usize) -> Checked {
        self.ensure(
            v.len() == dim,
            key,
            vec_str(v),
            &format!("must have {dim} components (mission.dim = {dim})"),
        )?;
        self.all_finite(key, v)
    }

    /// A dim×dim symmetric matrix of finite numbers.
    fn matrix(&self, key: &str, m: &[Vec<f64>], dim: usize) -> Checked {
        let square = m.len() == dim && m.iter().all(|r| r.len() == dim);
        self.ensure(
            square,
            key,
            mat_str(m),
            &format!("must be a {dim}×{dim} matrix (mission.dim = {dim})"),
        )?;
        for (i, row) in m.iter().enumerate() {
            self.all_finite(&format!("{key}[{i}]"), row)?;
        }
        let scale = m.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
        for i in 0..dim {
            for j in 0..i {
                self.ensure(
                    (m[i][j] - m[j][i]).abs() <= 1e-12 * scale,
                    key,
                    mat_str(m),
                    &format!("must be symmetric ([{i}][{j}] ≠ [{j}][{i}])"),
                )?;
            }
        }
        Ok(())
    }

    /// A vector only some field kinds use: required there, empty elsewhere.
    fn kind_vector(&self, key: &str, v: &[f64], dim: usize, used: bool, by: &str) -> Checked {
        if used {
            self.vector(key, v, dim)
        } else {
            self.ensure(
                v.is_empty(),
                key,
                vec_str(v),
                &format!("only used by field.kind = {by}; remove it"),
            )
        }
    }
}
