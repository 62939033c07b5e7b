//! The Lyapunov function of a tick and what it leaves of the formation speed (IV.4).

use vbap_math::body::BodyRates;
use vbap_math::lyapunov::{lyapunov_terms, LyapunovTerms};
use vbap_math::rejoin::{blended_lyapunov_terms, waiting_factor, Homing};
use vbap_math::Vec3;

use super::{Planner, Report};

impl Planner {
    /// V of (II.2), ∂V/∂s and (∂V/∂x)ᵀẋ from the `members`' last known states (ordered by
    /// id) for the body moving at `rates`, and the factor in [0, 1] by which the body
    /// waits for the vehicles `rejoining` (id, slot; 1 when none). With vehicles
    /// rejoining, those fly the blended law of `vbap_math::rejoin`: V, its rates and the
    /// power are those of that loop.
    pub(super) fn lyapunov(
        &self,
        members: &[Report],
        rejoining: &[(u32, Vec3)],
        rates: &BodyRates,
    ) -> (LyapunovTerms, f64) {
        let p = &self.params;
        let positions: Vec<Vec3> = members.iter().map(|q| q.position).collect();
        let velocities: Vec<Vec3> = members.iter().map(|q| q.velocity).collect();
        if rejoining.is_empty() {
            let terms = lyapunov_terms(
                &positions,
                &velocities,
                &self.body,
                rates,
                &self.design,
                p.damping,
            );
            return (terms, 1.0);
        }
        let spacing = self.body.scale * self.design.neighbour_spacing();
        let homings: Vec<Option<(Homing, Vec3)>> = members
            .iter()
            .map(|q| {
                rejoining.iter().find(|(id, _)| *id == q.id).map(|(_, t)| {
                    let others: Vec<Vec3> = members
                        .iter()
                        .filter(|o| o.id != q.id)
                        .map(|o| o.position)
                        .collect();
                    let h = Homing::around(
                        &q.position,
                        t,
                        &others,
                        spacing,
                        &self.last_velocity,
                        p.damping,
                        p.v0,
                    );
                    (h, *t)
                })
            })
            .collect();
        let waiting = waiting_factor(&homings);
        let terms = blended_lyapunov_terms(
            &positions,
            &velocities,
            &homings,
            &self.body,
            rates,
            &self.design,
            p.damping,
        );
        (terms, waiting)
    }
}
