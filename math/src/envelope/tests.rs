use super::*;
use crate::formation::design_regular;

fn inputs(
    design: &FormationDesign,
    ages: Option<(f64, f64)>,
    law: EnvelopeLaw,
) -> EnvelopeInputs<'_> {
    EnvelopeInputs {
        design,
        dim: 2,
        damping: 1.0,
        dt: 0.1,
        ages,
        law,
        speed_budget: None,
        max_scale: 5.0,
        v0: 0.5,
    }
}

const ROBUST: EnvelopeLaw = EnvelopeLaw::Robust { memory: None };

/// Six vehicles of radius 1.5, α = 1, K = 1 (`lossy_kill.toml`).
fn hexagon() -> FormationDesign {
    design_regular(6, 2, 1.5, 1.0, 1.0).expect("design")
}

#[test]
fn on_ideal_links_only_the_step_limits_the_scale() {
    let d = hexagon();
    let inp = inputs(&d, None, EnvelopeLaw::Paper);
    let env = envelope(&inp);
    assert_eq!(env.limit, ScaleLimit::Step);
    assert_eq!(env.gain_at_one, 0.0);
    assert!((env.step_at_min - STEP_LIMIT).abs() < 1e-3, "{env:?}");
}

#[test]
fn the_paper_law_needs_a_larger_formation_as_the_links_slow() {
    let d = hexagon();
    let mut last = 0.0;
    for delay in [0.2, 0.5, 1.0, 2.0] {
        let env = envelope(&inputs(
            &d,
            Some((2.0 * delay, 2.0 * delay + 0.3)),
            EnvelopeLaw::Paper,
        ));
        assert_eq!(env.limit, ScaleLimit::Links, "delay {delay}: {env:?}");
        assert!(
            env.min_scale > last,
            "delay {delay}: {} after {last}",
            env.min_scale
        );
        last = env.min_scale;
    }
}

#[test]
fn the_paper_law_cannot_hold_lossy_kills_smallest_scale_the_robust_law_can() {
    // 0.5 ± 0.2 s each way, losses: neighbours 0.7–1.9 s old. lossy_kill flies down to
    // k = 0.2: the paper's law breaks there (its formation is judged broken), the robust
    // law holds it.
    let d = hexagon();
    let ages = Some((0.7, 1.9));
    let paper = envelope(&inputs(&d, ages, EnvelopeLaw::Paper));
    let robust = envelope(&inputs(&d, ages, ROBUST));
    assert!(paper.min_scale > 0.2, "{paper:?}");
    assert!(robust.min_scale < 0.2, "{robust:?}");
    assert!(robust.min_scale < paper.min_scale);
}

#[test]
fn the_loop_gain_is_zero_with_fresh_neighbours_and_grows_with_their_age() {
    let d = hexagon();
    let lin = linearise(&d, 2);
    let fresh = inputs(&d, Some((0.0, 0.0)), EnvelopeLaw::Paper);
    assert_eq!(loop_gain(&lin, &fresh, 1.0), 0.0);
    let young = loop_gain(&lin, &inputs(&d, Some((0.1, 0.1)), EnvelopeLaw::Paper), 1.0);
    let old = loop_gain(&lin, &inputs(&d, Some((1.0, 1.0)), EnvelopeLaw::Paper), 1.0);
    assert!(young > 0.0 && old > young, "{young} {old}");
}

#[test]
fn the_linearisation_of_a_polygon_has_its_rotation_free_and_its_coupling_bounded() {
    let d = hexagon();
    let lin = linearise(&d, 2);
    let whole = &lin.inter + &lin.leader;
    let mu = SymmetricEigen::new(whole).eigenvalues;
    let smallest = mu.iter().fold(f64::INFINITY, |a, v| a.min(v.abs()));
    assert!(smallest < 1e-9, "a central polygon turns freely: {mu}");
    // Two neighbours at d0 each, κ_I = α/d0²: the coupling is at most 2 κ_I.
    let kappa = 1.0 / (1.5 * 1.5);
    assert!(
        lin.coupling > 0.0 && lin.coupling <= 2.0 * kappa + 1e-9,
        "{}",
        lin.coupling
    );
    assert!((lin.slot - kappa).abs() < 1e-12);
}

#[test]
fn the_adaptation_rate_is_bounded_by_the_lag_and_by_the_speed_budget() {
    let d = hexagon();
    let mut inp = inputs(&d, Some((0.7, 1.9)), ROBUST);
    let env = envelope(&inp);
    assert!(env.scale_rate_times_k.is_finite() && env.scale_rate_times_k > 0.0);
    assert_eq!(env.max_body_speed, f64::INFINITY);
    // Without a speed budget the growth moves the slots no faster than the body cruises:
    // |k̇| R̄ ≤ v0, below the lag's bound (which grows as 1/k) at small scales.
    assert_eq!(env.slot_speed, inp.v0);
    let small = 0.01;
    assert!(env.scale_rate_times_k / small > inp.v0 / 1.5);
    assert!((env.max_scale_rate(small, 1.5) - inp.v0 / 1.5).abs() < 1e-12);
    for k in [0.01, 0.1, 1.0, 5.0] {
        let lag = env.scale_rate_times_k / k;
        assert!((env.max_scale_rate(k, 1.5) - lag.min(inp.v0 / 1.5)).abs() < 1e-12);
    }
    inp.speed_budget = Some(0.6);
    let env = envelope(&inp);
    assert_eq!(env.max_body_speed, 0.6);
    // 0.6 − v0 = 0.1 L/s for the slot at radius 1.5: |k̇| ≤ 0.1/1.5, the bound at small
    // scales (the lag's bound grows as 1/k).
    for k in [0.01, 0.1, 1.0, 5.0] {
        assert!(env.max_scale_rate(k, 1.5) <= 0.1 / 1.5 + 1e-12, "k = {k}");
    }
    assert!((env.max_scale_rate(0.01, 1.5) - 0.1 / 1.5).abs() < 1e-12);
}
