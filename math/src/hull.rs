//! Keeping clear of the hulls of lost vehicles (beyond the paper; the robust law).
//!
//! A vehicle whose process died stays where it was (its hull), and a restarted process
//! comes back there. The formation flies on meanwhile, and its slots can sweep over that
//! spot: in random missions a member carried over a hull was 0.02–0.09 spacing from the
//! restarted vehicle when it came back (a near collision, and a repulsion that threw both
//! apart at 10–100 spacings per second). The coordinator tells every vehicle where each
//! lost vehicle's hull is (its last report, dead-reckoned with the body to the loss), and
//! the robust law keeps each vehicle off each hull with the soft barrier of
//! [`super::barrier`], reach [`HULL_REACH`] of the scaled spacing `d0`.
//!
//! The hull is exactly where the coordinator last knew it and does not move, so there is
//! no delay to beat, only the formation's pull to resist: a member held by springs of the
//! formation's stiffness towards a slot sitting on a hull settles a fraction of the reach
//! from it (test below). The reach is short so that survivors keep their slots round the
//! hull of a vehicle lost for ever: a `1/x` wall of half a spacing pushed members out of
//! their slots for good (tried: 4 missions in 1000 lost).

use super::barrier::Barrier;
use super::potential::PairPotential;
use super::Vec3;

/// Reach of the barrier round a hull, in neighbour spacings `d0` (scaled).
pub const HULL_REACH: f64 = 0.25;

/// Adds to `u` (length/s²) the barriers round the hulls `hulls` (length unit) felt by a
/// vehicle at `x`, for the scaled inter-vehicle potential `inter`.
pub fn add_hull_barriers(u: &mut Vec3, x: &Vec3, hulls: &[Vec3], inter: &PairPotential) {
    if hulls.is_empty() {
        return;
    }
    let barrier = Barrier::of(inter, HULL_REACH);
    for h in hulls {
        barrier.push(u, x, h, 1.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vehicle held by a spring of the formation's stiffness (two neighbours and a slot
    /// spring as strong) to a slot on the hull settles beyond a near collision (a tenth of
    /// a spacing) and within "in formation" (a quarter).
    #[test]
    fn a_slot_on_a_hull_keeps_its_vehicle_in_formation_and_off_the_hull() {
        let p = PairPotential::new(50.0, 2.0, 4.0).unwrap();
        let omega2 = 3.0 * p.alpha / (p.d0 * p.d0);
        let hull = Vec3::zeros();
        let (mut x, mut v) = (Vec3::new(0.02, 0.01, 0.0), Vec3::zeros());
        let (dt, damping) = (0.01, 6.0);
        for _ in 0..5000 {
            let mut u = -omega2 * x - damping * v;
            add_hull_barriers(&mut u, &x, &[hull], &p);
            v += dt * u;
            x += dt * v;
        }
        let r = x.norm() / p.d0;
        let b = Barrier::of(&p, HULL_REACH);
        approx::assert_relative_eq!(
            x.norm(),
            b.kappa * b.reach / (b.kappa + omega2),
            max_relative = 1e-6
        );
        assert!(
            r > crate::fit::NEAR_COLLISION && r < crate::fit::IN_FORMATION,
            "{r}"
        );
    }
}
