//! The fleet: `[vehicles]`, `[formation]`, `[body]` and `[estimator]`.

use super::super::toml_text::{mat_str, num};
use super::super::{
    BodySection, EstimatorSection, FormationSection, Mission, VehiclesSection, MAX_VEHICLES,
};
use super::{Check, Checked};
use vbap_wire::msg::MAX_LEADERS;

/// Checks `[vehicles]` for a mission of dimension `dim`.
pub(super) fn vehicles(c: &Check, v: &VehiclesSection, dim: usize) -> Checked {
    c.ensure(
        v.count > dim && v.count <= MAX_VEHICLES,
        "vehicles.count",
        v.count,
        &format!(
            "must be between mission.dim + 1 = {} (least squares, Lemma 5.1) and {MAX_VEHICLES}",
            dim + 1
        ),
    )?;
    c.vector("vehicles.start", &v.start, dim)?;
    c.non_negative("vehicles.start_spread", v.start_spread)?;
    c.positive("vehicles.damping", v.damping)?;
    Ok(())
}

/// Checks `[formation]` for a mission of dimension `dim`.
pub(super) fn formation(c: &Check, fo: &FormationSection, dim: usize) -> Checked {
    c.positive("formation.radius", fo.radius)?;
    c.non_negative("formation.adapt_gain", fo.adapt_gain)?;
    if fo.adapt {
        c.ensure(
            fo.adapt_gain > 0.0,
            "formation.adapt_gain",
            num(fo.adapt_gain),
            "must be > 0 when formation.adapt = true",
        )?;
    }
    c.positive("formation.alpha", fo.alpha)?;
    c.positive("formation.min_scale", fo.min_scale)?;
    c.ensure(
        fo.min_scale <= 1.0,
        "formation.min_scale",
        num(fo.min_scale),
        "must be ≤ 1 (the formation starts at scale 1)",
    )?;
    c.finite("formation.max_scale", fo.max_scale)?;
    c.ensure(
        fo.max_scale >= 1.0,
        "formation.max_scale",
        num(fo.max_scale),
        "must be ≥ 1 (the formation starts at scale 1)",
    )?;
    c.positive("formation.sigma_h", fo.sigma_h)?;
    if let Some(h) = &fo.hessian_guess {
        c.matrix("formation.hessian_guess", h, dim)?;
        c.ensure(
            h.iter().flatten().any(|x| *x != 0.0),
            "formation.hessian_guess",
            mat_str(h),
            "must not be zero (the optimal formation (V.7) would be infinitely large)",
        )?;
    }
    Ok(())
}

/// Checks that the formation designed for the mission's vehicles fits one body command:
/// a per-slot design has `dim + 1` virtual leaders per vehicle (3-D spheres of other than
/// 4, 6 or 12 vehicles), and a command carries at most [`MAX_LEADERS`]. Designs for fewer
/// vehicles (after losses) have no more leaders. Silent if the formation cannot be
/// designed ([`formation`] and the stability check name why).
pub(super) fn design_fits(c: &Check, m: &Mission) -> Checked {
    let dim = m.formation_dim();
    let Ok(design) = m.formation_design() else {
        return Ok(());
    };
    // What a vehicle is told may be rounded, never by a tenth of the smallest spacing.
    let spacing = design.inter.d0 * m.formation.min_scale;
    let q = m.links.position_quantum;
    c.ensure(
        q <= 0.1 * spacing,
        "links.position_quantum",
        num(q),
        &format!(
            "must be at most a tenth of the smallest neighbour spacing (d0 × formation.min_scale \
             = {}): rounded positions would move the vehicles' neighbours by a visible part \
             of a spacing",
            num(spacing)
        ),
    )?;
    let n_l = design.leaders.len();
    c.ensure(
        n_l <= MAX_LEADERS,
        "vehicles.count",
        m.vehicles.count,
        &format!(
            "a {dim}-D formation of {} vehicles has {n_l} virtual leaders ({} per vehicle), \
             more than the {MAX_LEADERS} one body command carries: fly at most {} vehicles \
             in {dim}-D, or 4, 6 or 12 (one central leader)",
            m.vehicles.count,
            dim + 1,
            MAX_LEADERS / (dim + 1)
        ),
    )
}

/// Checks `[body]`.
pub(super) fn body(c: &Check, b: &BodySection) -> Checked {
    c.positive("body.v0", b.v0)?;
    c.positive("body.v_u", b.v_u)?;
    c.positive("body.delta", b.delta)?;
    c.positive("body.grad_saturation", b.grad_saturation)?;
    Ok(())
}

/// Checks `[estimator]`.
pub(super) fn estimator(c: &Check, e: &EstimatorSection) -> Checked {
    c.positive("estimator.kalman_b", e.kalman_b)?;
    c.finite("estimator.confidence", e.confidence)?;
    c.ensure(
        e.confidence > 0.0 && e.confidence < 1.0,
        "estimator.confidence",
        num(e.confidence),
        "must be strictly between 0 and 1",
    )?;
    if let Some(d) = e.delta_m {
        c.non_negative("estimator.delta_m", d)?;
    }
    if let Some(s) = e.sigma_m {
        c.positive("estimator.sigma_m", s)?;
    }
    c.positive("estimator.initial_variance", e.initial_variance)?;
    Ok(())
}
