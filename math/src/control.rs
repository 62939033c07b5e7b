//! The decentralised control law (II.1) and the double-integrator step `ẍ_i = u_i`.

use super::potential::PairPotential;
use super::Vec3;

/// Control acceleration `u_i` of vehicle `i` (II.1), length/s²:
///
/// `u_i = − Σ_j f_I(|x_ij|) x_ij/|x_ij| − Σ_l f_h(|h_il|) h_il/|h_il| − K ẋ_i`,
/// with `x_ij = x_i − x_j`, `h_il = x_i − b_l` and `K = damping · I`.
///
/// - `x_i`, `v_i`: position (length) and velocity (length/s) of vehicle `i`;
/// - `neighbours`: positions of all OTHER vehicles (those at or beyond `inter.d1` add
///   nothing, through the potential);
/// - `leaders`: virtual-leader positions `b_l(s)` (III.3);
/// - `inter`, `leader`: `V_I` with `d_i(s)` and `V_h` with `h_i(s)`, i.e. already scaled
///   by `k(s)` (see `VirtualBody::scaled_inter`);
/// - `damping`: the gain of `K = damping · I`, 1/s, > 0.
///
/// Terms are summed in the given order (bit-identical results for identical inputs). A
/// neighbour or leader exactly at `x_i` (distance 0, no direction) is skipped rather than
/// producing NaN. Inputs are assumed finite.
pub fn control_law(
    x_i: &Vec3,
    v_i: &Vec3,
    neighbours: &[Vec3],
    leaders: &[Vec3],
    inter: &PairPotential,
    leader: &PairPotential,
    damping: f64,
) -> Vec3 {
    let mut u = Vec3::zeros();
    accumulate(&mut u, x_i, neighbours, inter);
    accumulate(&mut u, x_i, leaders, leader);
    u - damping * v_i
}

/// Adds `− Σ f(|x − p|) (x − p)/|x − p|` over `others` to `u`.
fn accumulate(u: &mut Vec3, x: &Vec3, others: &[Vec3], pot: &PairPotential) {
    for p in others {
        let d = x - p;
        let dist = d.norm();
        if dist <= 0.0 || dist >= pot.d1 {
            continue;
        }
        *u -= (pot.force(dist) / dist) * d;
    }
}

/// One semi-implicit (symplectic) Euler step of `ẍ_i = u_i` over `dt` seconds:
/// `v' = v + u dt`, `x' = x + v' dt`. Returns `(x', v')`.
pub fn integrate(x: &Vec3, v: &Vec3, u: &Vec3, dt: f64) -> (Vec3, Vec3) {
    let v_next = v + u * dt;
    (x + v_next * dt, v_next)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn pots() -> (PairPotential, PairPotential) {
        (
            PairPotential::new(1.0, 1.0, 1.5).unwrap(),
            PairPotential::new(2.0, 2.0, 8.0).unwrap(),
        )
    }

    #[test]
    fn forces_point_the_right_way() {
        let (inter, leader) = pots();
        let x = Vec3::new(0.0, 0.0, 0.0);
        let v = Vec3::zeros();
        // Neighbour too close on +x: repelled towards −x.
        let u = control_law(
            &x,
            &v,
            &[Vec3::new(0.8, 0.0, 0.0)],
            &[],
            &inter,
            &leader,
            1.0,
        );
        assert!(u.x < 0.0 && u.y == 0.0 && u.z == 0.0);
        assert_relative_eq!(u.x, inter.force(0.8), max_relative = 1e-15);
        // Neighbour a bit far on +y: attracted towards +y.
        let u = control_law(
            &x,
            &v,
            &[Vec3::new(0.0, 1.2, 0.0)],
            &[],
            &inter,
            &leader,
            1.0,
        );
        assert!(u.y > 0.0 && u.x == 0.0);
        // Beyond the cut-off: nothing.
        let u = control_law(
            &x,
            &v,
            &[Vec3::new(0.0, 1.6, 0.0)],
            &[],
            &inter,
            &leader,
            1.0,
        );
        assert_eq!(u, Vec3::zeros());
        // Leader at 3 (> h0 = 2): attracted.
        let u = control_law(
            &x,
            &v,
            &[],
            &[Vec3::new(0.0, 0.0, 3.0)],
            &inter,
            &leader,
            1.0,
        );
        assert_relative_eq!(u.z, leader.force(3.0), max_relative = 1e-15);
    }

    #[test]
    fn damping_and_equilibrium() {
        let (inter, leader) = pots();
        let x = Vec3::new(2.0, 0.0, 0.0);
        let nb = [Vec3::new(2.0, 1.0, 0.0)];
        let lead = [Vec3::zeros()];
        let u = control_law(&x, &Vec3::zeros(), &nb, &lead, &inter, &leader, 0.7);
        assert!(u.norm() < 1e-15, "{u}");
        let v = Vec3::new(0.1, -0.2, 0.3);
        let u = control_law(&x, &v, &nb, &lead, &inter, &leader, 0.7);
        assert_relative_eq!(u, -0.7 * v, epsilon = 1e-15);
    }

    #[test]
    fn coincident_positions_are_skipped_not_nan() {
        let (inter, leader) = pots();
        let x = Vec3::new(1.0, 2.0, 0.0);
        let u = control_law(&x, &Vec3::zeros(), &[x], &[x], &inter, &leader, 1.0);
        assert_eq!(u, Vec3::zeros());
    }

    #[test]
    fn semi_implicit_euler() {
        let (x, v) = integrate(
            &Vec3::new(1.0, 0.0, 0.0),
            &Vec3::new(0.0, 1.0, 0.0),
            &Vec3::new(0.0, 0.0, 2.0),
            0.5,
        );
        assert_eq!(v, Vec3::new(0.0, 1.0, 1.0));
        assert_eq!(x, Vec3::new(1.0, 0.5, 0.5));
    }
}
