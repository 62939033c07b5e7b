//! The vehicle model keys of `[vehicles]`, `[current]` and `[land]`.

use super::super::toml_text::{num, vec_str};
use super::super::{CurrentKind, CurrentSection, LandKind, LandSection, VehiclesSection};
use super::{Check, Checked};

/// Checks the glider keys of `[vehicles]`: each > 0 when given, and only with
/// `model = "glider"`.
pub(super) fn model(c: &Check, v: &VehiclesSection) -> Checked {
    for (key, value) in [
        ("vehicles.max_speed", v.max_speed),
        ("vehicles.max_accel", v.max_accel),
        ("vehicles.max_turn_rate", v.max_turn_rate),
        ("vehicles.fix_period", v.fix_period),
    ] {
        if let Some(x) = value {
            c.positive(key, x)?;
            c.ensure(
                !v.model.is_ideal(),
                key,
                num(x),
                "only used by vehicles.model = \"glider\"; remove it or set the model",
            )?;
        }
    }
    c.ensure(
        v.current_estimate != Some(true) || !v.model.is_ideal(),
        "vehicles.current_estimate",
        "true",
        "only used by vehicles.model = \"glider\"; remove it or set the model",
    )?;
    Ok(())
}

/// Checks the dive keys of `[vehicles]`: a glider in a 3-D mission without `fix_period`
/// (the fix is at the top of each dive), a rate below the largest speed.
pub(super) fn dive(c: &Check, v: &VehiclesSection, dim: usize) -> Checked {
    if let Some(r) = v.dive_rate {
        c.positive("vehicles.dive_rate", r)?;
        c.ensure(
            v.dive_depth.is_some(),
            "vehicles.dive_rate",
            num(r),
            "only used with vehicles.dive_depth; remove it or set the depth",
        )?;
    }
    let Some(d) = v.dive_depth else {
        return Ok(());
    };
    let key = "vehicles.dive_depth";
    c.ensure(
        d.is_finite() && d != 0.0,
        key,
        num(d),
        "must be finite and not 0",
    )?;
    c.ensure(
        !v.model.is_ideal(),
        key,
        num(d),
        "only used by vehicles.model = \"glider\"; remove it or set the model",
    )?;
    c.ensure(
        dim == 3,
        key,
        num(d),
        "a dive needs a 3-D mission (mission.dim = 3)",
    )?;
    c.ensure(
        v.fix_period.is_none(),
        key,
        num(d),
        "a diving glider gets its fix at the top of each dive: remove vehicles.fix_period",
    )?;
    let rate = v
        .dive_rate
        .unwrap_or(super::super::motion::DEFAULT_DIVE_RATE);
    let max = v
        .max_speed
        .unwrap_or(super::super::motion::DEFAULT_MAX_SPEED);
    c.ensure(
        rate < max,
        "vehicles.dive_rate",
        num(rate),
        "must be below vehicles.max_speed (the speed through the water includes the dive)",
    )
}

/// Checks `[current]` for a mission of dimension `dim`.
pub(super) fn current(c: &Check, cur: &CurrentSection, dim: usize) -> Checked {
    let k = cur.kind;
    c.non_negative("current.period", cur.period)?;
    if k == CurrentKind::Grid {
        return c.ensure(
            cur.file.is_some(),
            "current.file",
            "(absent)",
            "current.kind = \"grid\" needs the file of its u and v variables",
        );
    }
    for (key, given) in [
        ("current.file", &cur.file),
        ("current.u", &cur.u),
        ("current.v", &cur.v),
    ] {
        if let Some(g) = given {
            return Err(c.fail(
                key,
                format!("{g:?}"),
                "only used by current.kind = \"grid\"; remove it or set the kind",
            ));
        }
    }
    let none = k == CurrentKind::None;
    if none {
        for (key, v) in [
            ("current.velocity", &cur.velocity),
            ("current.center", &cur.center),
        ] {
            c.ensure(
                v.is_empty(),
                key,
                vec_str(v),
                "unused with current.kind = \"none\"; remove it or set the kind",
            )?;
        }
        return Ok(());
    }
    if k == CurrentKind::Uniform || !cur.velocity.is_empty() {
        c.vector("current.velocity", &cur.velocity, dim)?;
    }
    if matches!(k, CurrentKind::Eddy | CurrentKind::Shear) {
        c.vector("current.center", &cur.center, dim)?;
        c.positive("current.width", cur.width)?;
        c.finite("current.strength", cur.strength)?;
    } else {
        c.ensure(
            cur.center.is_empty(),
            "current.center",
            vec_str(&cur.center),
            "only used by current.kind = \"eddy\" or \"shear\"; remove it",
        )?;
    }
    Ok(())
}

/// Checks `[land]` for a mission of dimension `dim` starting its body at `start`.
pub(super) fn land(c: &Check, l: &LandSection, dim: usize, start: &[f64]) -> Checked {
    if let Some(d) = l.avoid_distance {
        c.positive("land.avoid_distance", d)?;
    }
    if let Some(g) = l.avoid_gain {
        c.non_negative("land.avoid_gain", g)?;
    }
    let at = |p: &[f64], i: usize| p.get(i).copied().unwrap_or(0.0);
    match l.kind {
        LandKind::None => Ok(()),
        LandKind::Coast => {
            c.vector("land.point", &l.point, dim)?;
            c.vector("land.normal", &l.normal, dim)?;
            let n: f64 = l.normal.iter().map(|x| x * x).sum::<f64>().sqrt();
            c.ensure(
                n > 0.0,
                "land.normal",
                vec_str(&l.normal),
                "must not be zero",
            )?;
            let side: f64 = (0..dim)
                .map(|i| (at(start, i) - l.point[i]) * l.normal[i])
                .sum();
            c.ensure(
                side > 0.0,
                "land.point",
                vec_str(&l.point),
                "puts vehicles.start on land (land is where (x − point)·normal < 0)",
            )
        }
        LandKind::Island => {
            c.vector("land.center", &l.center, dim)?;
            c.positive("land.radius", l.radius)?;
            let d: f64 = (0..dim)
                .map(|i| (at(start, i) - l.center[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            c.ensure(
                d > l.radius,
                "land.radius",
                num(l.radius),
                "puts vehicles.start on the island",
            )
        }
    }
}
