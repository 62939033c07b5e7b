//! Speed of traversal of the virtual body (Sec. IV): `ṡ` of (IV.4) with the bump `h(V)`
//! of Remark 4.2, which keeps `V ≤ V_U` (Theorem 4.1).

use super::lyapunov::LyapunovTerms;

/// The bump `h(V)` of Remark 4.2, 1/s:
/// `h(V) = ½ v0 (1 + cos(2π V / V_U))` for `|V| ≤ V_U/2`, else 0.
///
/// `v0`: nominal formation speed `ṡ` (1/s); `v_u`: the bound `V_U` (energy per unit mass,
/// positive). Continuous, `h(0) = v0`, support `|V| ≤ V_U/2`. Returns 0 if `V` or `V_U` is not
/// finite or `V_U ≤ 0`.
pub fn h_bump(v: f64, v0: f64, v_u: f64) -> f64 {
    if !(v.is_finite() && v_u.is_finite() && v_u > 0.0) || v.abs() > 0.5 * v_u {
        return 0.0;
    }
    0.5 * v0 * (1.0 + (std::f64::consts::TAU * v / v_u).cos())
}

/// The formation speed `ṡ` of (IV.4), 1/s:
///
/// `ṡ = min{ v0, h(V) + (−(∂V/∂x)ᵀẋ (δ + V_U)) / (δ + |∂V/∂s| (δ + V)) }`
///
/// with `h` = [`h_bump`], `v0` the nominal speed (1/s), `v_u = V_U > 0` and `delta = δ > 0`
/// small (energy per unit mass).
///
/// Guarantees `0 ≤ ṡ ≤ max(v0, 0)` and finite:
/// - `V` enters the denominator as `max(V, 0)` so it stays ≥ δ² > 0;
/// - if the bracket `h + (…)` is negative — only possible when `(∂V/∂x)ᵀẋ > 0`, which the
///   closed loop never gives (it is `−K Σ|ẋ_i|²`), but a caller could pass — `ṡ = 0`: the
///   body stops, the choice that lets `V` grow least, and the one the proof (which assumes
///   `ṡ ≥ 0`) covers;
/// - any non-finite input or intermediate (e.g. `V = +∞` for colliding vehicles) gives
///   `ṡ = 0`.
///
/// The endpoint rule of Theorem 4.1 (`ṡ = 0` once `s ≥ s_f`) is the caller's.
pub fn formation_speed(terms: &LyapunovTerms, v0: f64, v_u: f64, delta: f64) -> f64 {
    let LyapunovTerms {
        v,
        dv_ds,
        dv_dx_xdot,
    } = *terms;
    if ![v, dv_ds, dv_dx_xdot, v0, v_u, delta]
        .iter()
        .all(|c| c.is_finite())
        || v_u <= 0.0
        || delta <= 0.0
    {
        return 0.0;
    }
    let bracket = -dv_dx_xdot * (delta + v_u) / (delta + dv_ds.abs() * (delta + v.max(0.0)));
    let sdot = v0.min(h_bump(v, v0, v_u) + bracket);
    if sdot.is_finite() && sdot > 0.0 {
        sdot
    } else {
        0.0
    }
}

/// Confidence in [0, 1] in the velocities the coordinator knows, when the oldest of them
/// is `max_age` s old (beyond the paper): exp(−max_age·damping). A vehicle's velocity
/// forgets itself over the damping time 1/K of (II.1), so information that old says
/// little about the velocity now. 1 exactly for fresh information (`max_age` = 0).
pub fn information_confidence(max_age: f64, damping: f64) -> f64 {
    if max_age <= 0.0 {
        return 1.0;
    }
    let c = (-max_age * damping.max(0.0)).exp();
    if c.is_finite() {
        c.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The formation speed of (IV.4) for inputs of confidence `confidence` in [0, 1] (beyond
/// the paper: [`information_confidence`]), 1/s:
///
/// `ṡ = min{ v0, h(V) + min(B, h(V)) + c·max(B − h(V), 0) }`, B the second term of (IV.4).
///
/// The second term B lets the body move while V ≥ V_U/2 because the formation is seen to
/// dissipate energy (−(∂V/∂x)ᵀẋ = K Σ|ẋ_i|²). That dissipation is computed from the
/// vehicles' velocities, which are what a stale report knows least: with stale inputs
/// (c → 0) B never counts for more than h(V), so at V ≥ V_U/2 the body stops, and only
/// fresh information (c = 1) gives the paper's law. For c ≥ 1 this is exactly
/// [`formation_speed`].
pub fn formation_speed_informed(
    terms: &LyapunovTerms,
    v0: f64,
    v_u: f64,
    delta: f64,
    confidence: f64,
) -> f64 {
    let paper = formation_speed(terms, v0, v_u, delta);
    if confidence >= 1.0 || paper <= 0.0 {
        return paper;
    }
    // paper > 0: every input is finite and V_U, δ > 0 (see [`formation_speed`]).
    let LyapunovTerms {
        v,
        dv_ds,
        dv_dx_xdot,
    } = *terms;
    let h = h_bump(v, v0, v_u);
    let b = -dv_dx_xdot * (delta + v_u) / (delta + dv_ds.abs() * (delta + v.max(0.0)));
    let c = if confidence.is_finite() {
        confidence.max(0.0)
    } else {
        0.0
    };
    let sdot = v0.min(h + b.min(h) + c * (b - h).max(0.0));
    if sdot.is_finite() && sdot > 0.0 {
        sdot
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::{BodyRates, VirtualBody};
    use crate::control::{control_law, integrate};
    use crate::formation::design_regular;
    use crate::lyapunov::lyapunov_terms;
    use crate::Vec3;
    use approx::assert_relative_eq;

    #[test]
    fn bump_of_remark_4_2() {
        let (v0, vu) = (0.5, 2.0);
        assert_eq!(h_bump(0.0, v0, vu), v0);
        assert_relative_eq!(h_bump(0.5, v0, vu), 0.25, max_relative = 1e-12);
        assert_relative_eq!(h_bump(-0.5, v0, vu), 0.25, max_relative = 1e-12);
        assert!(h_bump(1.0, v0, vu).abs() < 1e-16);
        for v in [1.0 + 1e-12, 1.5, 2.0, 10.0, f64::INFINITY, f64::NAN] {
            assert_eq!(h_bump(v, v0, vu), 0.0);
        }
        // Decreasing on [0, V_U/2].
        let mut last = v0;
        for i in 1..=100 {
            let h = h_bump(f64::from(i) / 100.0, v0, vu);
            assert!(h <= last && h >= 0.0);
            last = h;
        }
    }

    #[test]
    fn speed_law_bounds() {
        let (v0, vu, delta) = (0.5, 1.0, 1e-3);
        // At equilibrium and at rest: ṡ = h(0) = v0.
        assert_eq!(
            formation_speed(&LyapunovTerms::default(), v0, vu, delta),
            v0
        );
        for v in [0.0, 0.1, 0.4, 0.6, 1.0, 3.0] {
            for dv_ds in [-2.0, 0.0, 0.3, 5.0] {
                for dv_dx in [0.0, -1e-3, -0.2, -10.0] {
                    let t = LyapunovTerms {
                        v,
                        dv_ds,
                        dv_dx_xdot: dv_dx,
                    };
                    let s = formation_speed(&t, v0, vu, delta);
                    assert!((0.0..=v0).contains(&s), "{t:?} -> {s}");
                }
            }
        }
        // By hand: h(0.1) + 0.2·1.001/(0.001 + 0.3·0.101).
        let t = LyapunovTerms {
            v: 0.1,
            dv_ds: 0.3,
            dv_dx_xdot: -0.002,
        };
        let expect = h_bump(0.1, 5.0, vu) + 0.002 * 1.001 / (0.001 + 0.3 * 0.101);
        assert_relative_eq!(
            formation_speed(&t, 5.0, vu, delta),
            expect,
            max_relative = 1e-14
        );
        // Beyond V_U/2 at rest the body waits; a positive (∂V/∂x)ᵀẋ stops it.
        assert_eq!(
            formation_speed(
                &LyapunovTerms {
                    v: 0.7,
                    dv_ds: 1.0,
                    dv_dx_xdot: 0.0
                },
                v0,
                vu,
                delta
            ),
            0.0
        );
        assert_eq!(
            formation_speed(
                &LyapunovTerms {
                    v: 0.7,
                    dv_ds: 1.0,
                    dv_dx_xdot: 0.5
                },
                v0,
                vu,
                delta
            ),
            0.0
        );
        // Non-finite anything: 0.
        assert_eq!(
            formation_speed(
                &LyapunovTerms {
                    v: f64::INFINITY,
                    dv_ds: 0.0,
                    dv_dx_xdot: 0.0
                },
                v0,
                vu,
                delta
            ),
            0.0
        );
        assert_eq!(
            formation_speed(
                &LyapunovTerms {
                    v: 0.0,
                    dv_ds: f64::NAN,
                    dv_dx_xdot: 0.0
                },
                v0,
                vu,
                delta
            ),
            0.0
        );
        assert_eq!(formation_speed(&LyapunovTerms::default(), v0, vu, 0.0), 0.0);
    }

    /// Theorem 4.1: N = 4 vehicles in 2-D, body translating with dr/ds = x̂ at the speed of
    /// (IV.4) up to s_f = 6, started with V close to V_U. V must stay ≤ V_U at every step (up
    /// to a discretisation tolerance of 1e-3 V_U for dt = 5 ms) while s increases, and after
    /// s_f the formation must settle at x_eq(s_f) (V → 0). Returns (max V, s after 10 s).
    fn theorem_4_1_run(v0: f64) -> (f64, f64) {
        let (vu, delta, damping, dt, s_f) = (1.0, 1e-3, 1.0, 0.005, 6.0);
        // Potential strengths such that one broken neighbour pair costs V_U and one vehicle
        // escaping the centre leader 4 V_U (plateaus are proportional to alpha).
        let unit = design_regular(4, 2, 1.5, 1.0, 1.0).unwrap();
        let design = design_regular(
            4,
            2,
            1.5,
            vu / unit.inter.plateau(),
            4.0 * vu / unit.leader.plateau(),
        )
        .unwrap();
        let rates = BodyRates::translation(Vec3::x());
        let mut body = VirtualBody::at(Vec3::zeros());
        // Start: slots pushed out and in and moving, so V ≈ 0.94 V_U.
        let mut x: Vec<Vec3> = design
            .slots
            .iter()
            .enumerate()
            .map(|(i, p)| p * if i % 2 == 0 { 1.2 } else { 0.84 })
            .collect();
        let mut v: Vec<Vec3> = (0..4)
            .map(|i| Vec3::new(0.0, if i < 2 { 0.3 } else { -0.3 }, 0.0))
            .collect();
        let t0 = lyapunov_terms(&x, &v, &body, &rates, &design, damping);
        assert!(t0.v > 0.9 * vu && t0.v <= vu, "start V = {}", t0.v);
        let mut max_v: f64 = 0.0;
        let mut s_at_10s = 0.0;
        for step in 0..(60.0 / dt) as usize {
            let t = lyapunov_terms(&x, &v, &body, &rates, &design, damping);
            assert!(t.v <= vu * (1.0 + 1e-3), "V = {} > V_U at step {step}", t.v);
            max_v = max_v.max(t.v);
            let sdot = if body.s < s_f {
                formation_speed(&t, v0, vu, delta)
            } else {
                0.0
            };
            assert!((0.0..=v0).contains(&sdot));
            let leaders = body.leader_positions(&design);
            let (inter, leader) = (body.scaled_inter(&design), body.scaled_leader(&design));
            let u: Vec<Vec3> = (0..4)
                .map(|i| {
                    let others: Vec<Vec3> = x
                        .iter()
                        .enumerate()
                        .filter(|(j, _)| *j != i)
                        .map(|(_, p)| *p)
                        .collect();
                    control_law(&x[i], &v[i], &others, &leaders, &inter, &leader, damping)
                })
                .collect();
            for i in 0..4 {
                (x[i], v[i]) = integrate(&x[i], &v[i], &u[i], dt);
            }
            let last_s = body.s;
            body = body.advance(&rates, (sdot * dt).min(s_f - body.s).max(0.0));
            assert!(body.s >= last_s);
            if step == (10.0 / dt) as usize {
                s_at_10s = body.s;
            }
        }
        assert_eq!(body.s, s_f);
        let t = lyapunov_terms(&x, &v, &body, &rates, &design, damping);
        assert!(t.v < 1e-6 * vu, "final V = {}", t.v);
        for p in &x {
            assert_relative_eq!((p - body.r).norm(), 1.5, max_relative = 1e-3);
        }
        (max_v, s_at_10s)
    }

    #[test]
    fn theorem_4_1_v_stays_below_v_u() {
        // Nominal speed reachable within V_U: the body runs at v0 once the start transient
        // has decayed below the bound.
        let (max_v, s10) = theorem_4_1_run(0.5);
        assert!(max_v > 0.9);
        assert!(s10 > 4.0, "s(10 s) = {s10}");
        // Nominal speed far too high (kinetic energy alone would be 8 V_U): the law throttles
        // ṡ and the formation rides just below V_U.
        let (max_v, s10) = theorem_4_1_run(2.0);
        assert!(max_v > 0.99, "max V = {max_v}");
        assert!(s10 > 1.0 && s10 < 6.0, "s(10 s) = {s10}");
    }

    #[test]
    fn stale_inputs_never_let_the_second_term_outweigh_the_bump() {
        let (v0, vu, delta) = (0.5, 1.0, 0.01);
        let cases = [
            (0.1, 0.3, -0.002),
            (0.45, 0.1, -0.5),
            (0.6, 0.2, -0.3),
            (0.9, 0.05, -2.0),
            (0.0, 0.0, 0.0),
        ];
        for (v, dv_ds, dv_dx) in cases {
            let t = LyapunovTerms {
                v,
                dv_ds,
                dv_dx_xdot: dv_dx,
            };
            let paper = formation_speed(&t, v0, vu, delta);
            assert_eq!(formation_speed_informed(&t, v0, vu, delta, 1.0), paper);
            let h = h_bump(v, v0, vu);
            let blind = formation_speed_informed(&t, v0, vu, delta, 0.0);
            assert!(
                blind <= (2.0 * h).min(v0) + 1e-15,
                "{t:?}: {blind} vs h {h}"
            );
            assert!(blind <= paper + 1e-15);
            // Monotone in the confidence, from blind to the paper's.
            let mut last = blind;
            for c in [0.1, 0.5, 0.9, 0.999] {
                let s = formation_speed_informed(&t, v0, vu, delta, c);
                assert!(s + 1e-15 >= last && s <= paper + 1e-15, "{t:?} c {c}");
                last = s;
            }
        }
        // V ≥ V_U/2 with a strongly dissipating formation: the paper moves, blind stops.
        let t = LyapunovTerms {
            v: 0.6,
            dv_ds: 0.2,
            dv_dx_xdot: -0.3,
        };
        assert!(formation_speed(&t, v0, vu, delta) > 0.4);
        assert_eq!(formation_speed_informed(&t, v0, vu, delta, 0.0), 0.0);
    }

    #[test]
    fn confidence_decays_with_age_over_the_damping_time() {
        assert_eq!(information_confidence(0.0, 1.0), 1.0);
        assert!((information_confidence(1.0, 1.0) - (-1.0f64).exp()).abs() < 1e-15);
        assert!((information_confidence(7200.0, 0.01) - (-72.0f64).exp()).abs() < 1e-40);
        assert_eq!(information_confidence(f64::INFINITY, 1.0), 0.0);
    }
}
