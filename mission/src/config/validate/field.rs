//! `[field]`: the keys each kind of field uses (and only those), and `[[field.bumps]]`.

use super::super::toml_text::{num, vec_str};
use super::super::{FieldConfig, FieldKind, MAX_BUMPS};
use super::{Check, Checked};

/// Checks `[field]` for a mission of dimension `dim`.
pub(super) fn check(c: &Check, f: &FieldConfig, dim: usize) -> Checked {
    let kind = f.kind;
    let uses_center = matches!(
        kind,
        FieldKind::Quadratic | FieldKind::Gaussian | FieldKind::Eddy
    );
    if uses_center {
        c.vector("field.center", &f.center, dim)?;
    } else {
        c.all_finite("field.center", &f.center)?;
    }
    c.finite("field.amplitude", f.amplitude)?;
    if matches!(kind, FieldKind::Gaussian | FieldKind::Eddy) {
        c.ensure(
            f.amplitude != 0.0,
            "field.amplitude",
            num(f.amplitude),
            "must be ≠ 0 (a flat field has nothing to climb)",
        )?;
    }
    c.positive("field.width", f.width)?;
    if kind == FieldKind::Quadratic {
        c.matrix("field.hessian", &f.hessian, dim)?;
    } else {
        for (i, row) in f.hessian.iter().enumerate() {
            c.all_finite(&format!("field.hessian[{i}]"), row)?;
        }
    }
    c.non_negative("field.noise_std", f.noise_std)?;
    c.finite("field.background", f.background)?;
    c.finite("field.offset", f.offset)?;
    c.kind_vector(
        "field.velocity",
        &f.velocity,
        dim,
        kind == FieldKind::Eddy,
        "\"eddy\"",
    )?;
    c.kind_vector(
        "field.normal",
        &f.normal,
        dim,
        kind == FieldKind::Front,
        "\"front\"",
    )?;
    if kind == FieldKind::Front {
        c.ensure(
            f.normal.iter().any(|x| *x != 0.0),
            "field.normal",
            vec_str(&f.normal),
            "must not be zero",
        )?;
    }
    c.finite("field.speed", f.speed)?;
    bumps(c, f, dim)
}

/// Checks `[[field.bumps]]`: how many the kind takes, then each bump.
fn bumps(c: &Check, f: &FieldConfig, dim: usize) -> Checked {
    let kind = f.kind;
    let n_bumps = f.bumps.len();
    match kind {
        FieldKind::GaussianSum => c.ensure(
            (1..=MAX_BUMPS).contains(&n_bumps),
            "field.bumps",
            format!("{n_bumps} bumps"),
            "field.kind = \"gaussian_sum\" needs 1 to 64 [[field.bumps]]",
        )?,
        FieldKind::Front => c.ensure(
            n_bumps <= 1,
            "field.bumps",
            format!("{n_bumps} bumps"),
            "field.kind = \"front\" takes at most one [[field.bumps]]",
        )?,
        _ => c.ensure(
            n_bumps == 0,
            "field.bumps",
            format!("{n_bumps} bumps"),
            "only used by field.kind = \"gaussian_sum\" or \"front\"; remove them",
        )?,
    }
    for (i, b) in f.bumps.iter().enumerate() {
        let k = format!("field.bumps[{i}]");
        c.vector(&format!("{k}.center"), &b.center, dim)?;
        c.finite(&format!("{k}.amplitude"), b.amplitude)?;
        c.ensure(
            b.amplitude != 0.0,
            &format!("{k}.amplitude"),
            num(b.amplitude),
            "must be ≠ 0",
        )?;
        c.positive(&format!("{k}.width"), b.width)?;
    }
    Ok(())
}
