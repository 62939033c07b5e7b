//! The Lyapunov function `V(x, s)` of (II.2) extended to the moving virtual body (Sec. IV,
//! with `b_l(s)`, `d_i(s)`, `h_i(s)` from (III.3)), and the two derivatives the speed law
//! (IV.4) needs.

use super::body::{BodyRates, VirtualBody};
use super::formation::FormationDesign;
pub use super::potential::potential_energy;
use super::Vec3;

/// `V` and the terms of (IV.4) at one instant.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct LyapunovTerms {
    /// `V(x, s)` (II.2), shifted so that it is 0 at the designed equilibrium and clamped at
    /// 0 from below; energy per unit mass, length²/s².
    pub v: f64,
    /// `∂V/∂s` along the body rates (`dr/ds`, `dR/ds`, `dk/ds`), length²/s² per unit `s`.
    pub dv_ds: f64,
    /// `(∂V/∂x)ᵀ ẋ` with `ẋ = (v_i, u_i)` and `u_i` the control law (II.1), length²/s³;
    /// always ≤ 0.
    pub dv_dx_xdot: f64,
}

/// `V(x, s)` and the terms of (IV.4) for vehicles at `positions` with `velocities`
/// (length, length/s; same length, any number ≥ 0 of vehicles), the virtual body `body`
/// moving along `rates`, the design `design` and damping gain `damping` (1/s, `K = damping
/// I` in (II.1)).
///
/// - `v = max(0, ½ Σ|ẋ_i|² + Σ_{i<j} V_I,k(|x_ij|) + Σ_{i,l} V_h,k(|x_i − b_l(s)|) − E_n)`,
///   with the potentials scaled by `k(s)` and `E_n = design.equilibrium_energy(n)` the
///   potential energy of an equilibrium of the `n = positions.len()` vehicles (the design's
///   `v_eq` when `n = N`; `E_n` is scale invariant). So `V(x_eq(s), s) = 0`.
///
///   Keeping `V ≥ 0`: near the designed equilibrium (a local minimum of the potential
///   energy, see `formation`) the shifted function is ≥ 0 by itself. Far from it, a
///   configuration with lower potential energy may exist (the plateau of every pair
///   beyond `d1` counts, so e.g. vehicles bunching up, or a lost vehicle's gap in a ring,
///   can shift the balance by a few plateaus); there the value is clamped at 0. The clamp
///   keeps `V` non-increasing along the closed loop at fixed `s` (the max of a
///   non-increasing function and 0) and never acts where the proof of `V ≤ V_U` works
///   (`V ≥ V_U > 0`). Lower-energy arrangements appear when the inter-vehicle wells
///   outweigh the leader's: in damped simulations from random starts, polygons up to
///   `N = 8` with `alpha_inter ≤ alpha_leader` never went below the design, while with
///   `alpha_inter = 5 alpha_leader` an octagon bunched up to `−0.27` below it.
///   Sublevel sets `{V ≤ c}` are bounded as long as `c` is below the energy needed to take
///   a vehicle out of reach of all leaders (for a central design roughly the leader
///   plateau `design.leader.plateau()`); the mission's `V_U` must respect that.
/// - `dv_ds = Σ_{i<j} ∂_k V_I,k(d_ij) k' + Σ_{i,l} [∂_k V_h,k(h_il) k'
///   − f_h,k(h_il) (x_i − b_l)/h_il · db_l/ds]`, with `∂_k V_k(x) = −(x/k) f_k(x)`
///   (scale invariance) and `db_l/ds = k' R b̄_l + k ω × (R b̄_l) + dr/ds`. It is the
///   derivative of the unclamped function.
/// - `dv_dx_xdot = Σ_i (∂V/∂x_i · v_i + v_i · u_i)`; with `u_i = −∂V/∂x_i − damping v_i`
///   from (II.1) this is exactly `−damping Σ_i |v_i|²`, which is what is returned (closed
///   form, ≤ 0 without rounding noise).
///
/// Coincident positions (distance exactly 0) make `v = +∞` and are skipped in the
/// derivatives, as the control law skips them.
///
/// # Panics
/// If `positions` and `velocities` differ in length (a programming error).
pub fn lyapunov_terms(
    positions: &[Vec3],
    velocities: &[Vec3],
    body: &VirtualBody,
    rates: &BodyRates,
    design: &FormationDesign,
    damping: f64,
) -> LyapunovTerms {
    assert_eq!(
        positions.len(),
        velocities.len(),
        "one velocity per position"
    );
    let k = body.scale;
    let inter = body.scaled_inter(design);
    let leader = body.scaled_leader(design);
    let (leaders, db_ds) = leader_motion(body, rates, design);

    let mut kinetic = 0.0;
    for v in velocities {
        kinetic += v.norm_squared();
    }
    let mut potential = 0.0;
    let mut dv_ds = 0.0;
    let plateau = inter.plateau();
    for (i, x) in positions.iter().enumerate() {
        for y in &positions[i + 1..] {
            let d = (x - y).norm();
            potential += inter.value_or_plateau(d, plateau);
            if d > 0.0 && d < inter.d1 {
                dv_ds += inter.d_value_d_scale(d) / k * rates.dk_ds;
            }
        }
        for (b, db) in leaders.iter().zip(&db_ds) {
            let h = x - b;
            let dist = h.norm();
            potential += leader.value(dist);
            if dist > 0.0 && dist < leader.d1 {
                dv_ds += leader.d_value_d_scale(dist) / k * rates.dk_ds;
                dv_ds -= leader.force(dist) / dist * h.dot(db);
            }
        }
    }
    let raw = 0.5 * kinetic + potential - design.equilibrium_energy(positions.len());
    LyapunovTerms {
        v: raw.max(0.0),
        dv_ds,
        dv_dx_xdot: -damping * kinetic,
    }
}

/// The virtual leaders `b_l(s) = k R b̄_l + r` (III.3) of `design` moved by `body`, and
/// their rates along the body's motion, `db_l/ds = k' R b̄_l + k ω × (R b̄_l) + dr/ds`
/// (length unit, length unit per unit `s`).
pub fn leader_motion(
    body: &VirtualBody,
    rates: &BodyRates,
    design: &FormationDesign,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let k = body.scale;
    let rotated: Vec<Vec3> = design.leaders.iter().map(|b| body.rotation * b).collect();
    let leaders = rotated.iter().map(|rb| k * rb + body.r).collect();
    let db_ds = rotated
        .iter()
        .map(|rb| rates.dk_ds * rb + k * rates.omega_ds.cross(rb) + rates.dr_ds)
        .collect();
    (leaders, db_ds)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::control_law;
    use crate::formation::{design_for_shape, design_regular};
    use crate::rng::{keyed, Stream};
    use approx::assert_relative_eq;
    use nalgebra::Rotation3;
    use rand::Rng;

    fn rvec(rng: &mut impl Rng, amp: f64, dim: usize) -> Vec3 {
        let mut v = Vec3::new(
            rng.random_range(-amp..amp),
            rng.random_range(-amp..amp),
            rng.random_range(-amp..amp),
        );
        if dim == 2 {
            v.z = 0.0;
        }
        v
    }

    /// Unclamped V (the smooth function whose derivatives are reported).
    fn raw_v(x: &[Vec3], v: &[Vec3], body: &VirtualBody, design: &FormationDesign) -> f64 {
        let kinetic: f64 = v.iter().map(|w| 0.5 * w.norm_squared()).sum();
        kinetic
            + potential_energy(
                x,
                &body.leader_positions(design),
                &body.scaled_inter(design),
                &body.scaled_leader(design),
            )
            - design.equilibrium_energy(x.len())
    }

    struct Case {
        design: FormationDesign,
        body: VirtualBody,
        rates: BodyRates,
        x: Vec<Vec3>,
        v: Vec<Vec3>,
    }

    fn cases() -> Vec<Case> {
        let designs = vec![
            design_regular(3, 2, 1.0, 1.0, 1.0).unwrap(),
            design_regular(4, 2, 1.5, 0.7, 2.0).unwrap(),
            design_regular(6, 2, 1.0, 1.0, 1.0).unwrap(),
            design_regular(4, 3, 1.0, 1.0, 1.0).unwrap(),
            design_regular(6, 3, 2.0, 1.0, 3.0).unwrap(),
            design_regular(5, 3, 1.0, 1.0, 1.0).unwrap(),
            design_for_shape(
                &[
                    Vec3::new(1.2, 0.0, 0.0),
                    Vec3::new(0.0, 0.7, 0.0),
                    Vec3::zeros(),
                ],
                2,
                1.0,
                1.0,
            )
            .unwrap(),
        ];
        let mut out = Vec::new();
        for (c, design) in designs.into_iter().enumerate() {
            for trial in 0..6u64 {
                let mut rng = keyed(5, Stream::Test, c as u64, trial);
                let dim = design.dim;
                let scale = rng.random_range(0.6..1.8);
                let rotation = if dim == 2 {
                    Rotation3::from_axis_angle(&Vec3::z_axis(), rng.random_range(-3.0..3.0))
                } else {
                    Rotation3::new(rvec(&mut rng, 2.0, 3))
                };
                let body = VirtualBody {
                    s: 1.0,
                    r: rvec(&mut rng, 3.0, dim),
                    rotation,
                    scale,
                };
                let mut omega = rvec(&mut rng, 1.0, 3);
                if dim == 2 {
                    omega = Vec3::new(0.0, 0.0, omega.z);
                }
                let rates = BodyRates {
                    dr_ds: rvec(&mut rng, 1.0, dim),
                    omega_ds: omega,
                    dk_ds: rng.random_range(-0.5..0.5),
                };
                // Vehicles near their slots (some in the tapers), and sometimes one lost.
                let mut x: Vec<Vec3> = body
                    .slot_positions(&design)
                    .iter()
                    .map(|p| p + rvec(&mut rng, 0.3 * scale * design.neighbour_spacing(), dim))
                    .collect();
                if trial == 5 {
                    x.pop();
                }
                let v: Vec<Vec3> = x.iter().map(|_| rvec(&mut rng, 0.3, dim)).collect();
                out.push(Case {
                    design: design.clone(),
                    body,
                    rates,
                    x,
                    v,
                });
            }
        }
        out
    }

    #[test]
    fn dv_ds_matches_central_differences() {
        for (n, c) in cases().iter().enumerate() {
            let t = lyapunov_terms(&c.x, &c.v, &c.body, &c.rates, &c.design, 1.0);
            let h = 1e-6;
            let plus = raw_v(&c.x, &c.v, &c.body.advance(&c.rates, h), &c.design);
            let minus = raw_v(&c.x, &c.v, &c.body.advance(&c.rates, -h), &c.design);
            let fd = (plus - minus) / (2.0 * h);
            assert_relative_eq!(t.dv_ds, fd, epsilon = 1e-6, max_relative = 1e-6);
            assert!(t.dv_ds != 0.0, "case {n} exercises nothing");
        }
    }

    #[test]
    fn dv_dx_xdot_matches_central_differences_along_the_flow() {
        for c in cases() {
            let damping = 0.8;
            let t = lyapunov_terms(&c.x, &c.v, &c.body, &c.rates, &c.design, damping);
            let leaders = c.body.leader_positions(&c.design);
            let inter = c.body.scaled_inter(&c.design);
            let leader = c.body.scaled_leader(&c.design);
            let u: Vec<Vec3> = (0..c.x.len())
                .map(|i| {
                    let others: Vec<Vec3> =
                        c.x.iter()
                            .enumerate()
                            .filter(|(j, _)| *j != i)
                            .map(|(_, p)| *p)
                            .collect();
                    control_law(
                        &c.x[i], &c.v[i], &others, &leaders, &inter, &leader, damping,
                    )
                })
                .collect();
            let h = 1e-6;
            let shifted = |e: f64| {
                let x: Vec<Vec3> = c.x.iter().zip(&c.v).map(|(p, w)| p + e * w).collect();
                let v: Vec<Vec3> = c.v.iter().zip(&u).map(|(w, a)| w + e * a).collect();
                raw_v(&x, &v, &c.body, &c.design)
            };
            let fd = (shifted(h) - shifted(-h)) / (2.0 * h);
            assert_relative_eq!(t.dv_dx_xdot, fd, epsilon = 1e-6, max_relative = 1e-6);
            assert!(t.dv_dx_xdot < 0.0);
        }
    }

    #[test]
    fn zero_at_equilibrium_positive_nearby_and_scale_invariant() {
        for design in [
            design_regular(5, 2, 1.0, 1.0, 1.0).unwrap(),
            design_regular(9, 3, 1.0, 1.0, 1.0).unwrap(),
        ] {
            let n = design.n();
            for scale in [0.5, 1.0, 2.0] {
                let body = VirtualBody {
                    scale,
                    ..VirtualBody::at(Vec3::new(1.0, -2.0, 0.0))
                };
                let x = body.slot_positions(&design);
                let still = vec![Vec3::zeros(); n];
                let t = lyapunov_terms(
                    &x,
                    &still,
                    &body,
                    &BodyRates::translation(Vec3::x()),
                    &design,
                    1.0,
                );
                assert!(t.v.abs() < 1e-12, "{}", t.v);
                assert_eq!(t.dv_dx_xdot, 0.0);
                let mut y = x.clone();
                y[0].x += 0.05 * scale;
                let t2 = lyapunov_terms(&y, &still, &body, &BodyRates::zero(), &design, 1.0);
                assert!(t2.v > 1e-6);
                assert_eq!(t2.dv_ds, 0.0);
                // Equal to the unscaled value for the same shape (scale invariance).
                let body1 = VirtualBody::at(body.r);
                let y1: Vec<Vec3> = y.iter().map(|p| body.r + (p - body.r) / scale).collect();
                let t1 = lyapunov_terms(&y1, &still, &body1, &BodyRates::zero(), &design, 1.0);
                assert_relative_eq!(t1.v, t2.v, max_relative = 1e-9);
            }
        }
    }

    #[test]
    fn any_number_of_vehicles_and_coincident_ones() {
        let design = design_regular(4, 2, 1.0, 1.0, 1.0).unwrap();
        let body = VirtualBody::at(Vec3::zeros());
        let rates = BodyRates::translation(Vec3::x());
        let t = lyapunov_terms(&[], &[], &body, &rates, &design, 1.0);
        assert_eq!(t, LyapunovTerms::default());
        let x = body.slot_positions(&design);
        let t = lyapunov_terms(&x[..2], &[Vec3::zeros(); 2], &body, &rates, &design, 1.0);
        assert!(t.v.abs() < 1e-12);
        let y = [x[0], x[0]];
        let t = lyapunov_terms(&y, &[Vec3::zeros(); 2], &body, &rates, &design, 1.0);
        assert_eq!(t.v, f64::INFINITY);
        assert!(t.dv_ds.is_finite());
    }
}
