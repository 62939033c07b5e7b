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
    grid_keys(c, f, dim)?;
    bumps(c, f, dim)
}

/// Checks the keys of `kind = "grid"` (and that no other kind gives them); the file itself is
/// read when the mission is loaded (`Mission::load_grid`).
fn grid_keys(c: &Check, f: &FieldConfig, dim: usize) -> Checked {
    let grid = f.kind == FieldKind::Grid;
    let given: [(&str, bool); 10] = [
        ("file", f.file.is_some()),
        ("variable", f.variable.is_some()),
        ("x", f.x.is_some()),
        ("y", f.y.is_some()),
        ("z", f.z.is_some()),
        ("time", f.time.is_some()),
        ("geographic", f.geographic.is_some()),
        ("origin", f.origin.is_some()),
        ("land_above", f.land_above.is_some()),
        ("extent", f.extent.is_some()),
    ];
    if !grid {
        for (key, is) in given {
            c.ensure(
                !is,
                &format!("field.{key}"),
                "(given)",
                "only used by field.kind = \"grid\"; remove it",
            )?;
        }
        return Ok(());
    }
    let file = f.file.as_deref().unwrap_or("");
    c.ensure(
        !file.trim().is_empty(),
        "field.file",
        "\"\"",
        "must name a file",
    )?;
    for (key, name) in [
        ("variable", &f.variable),
        ("x", &f.x),
        ("y", &f.y),
        ("z", &f.z),
        ("time", &f.time),
    ] {
        if let Some(n) = name {
            c.ensure(
                !n.is_empty(),
                &format!("field.{key}"),
                "\"\"",
                "must not be empty",
            )?;
        }
    }
    if let Some(o) = &f.origin {
        c.vector("field.origin", o, 2)?;
        c.ensure(
            (-90.0..=90.0).contains(&o[1]) && (-360.0..=360.0).contains(&o[0]),
            "field.origin",
            vec_str(o),
            "must be [lon, lat] in degrees (lat within −90..90)",
        )?;
    }
    if let Some(a) = f.land_above {
        c.finite("field.land_above", a)?;
    }
    if let Some(e) = &f.extent {
        c.vector("field.extent", e, 2 * dim)?;
        c.ensure(
            e.chunks(2).all(|p| p[0] != p[1]),
            "field.extent",
            vec_str(e),
            "each axis's first and last coordinate must differ",
        )?;
    }
    Ok(())
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
