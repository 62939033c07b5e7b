//! The planner as an extension point: [`Plan`] is the decision of a tick as the simulator
//! ([`crate::tick::plan_tick`]) and the coordinator process drive it. [`Planner`] (least
//! squares + Kalman filter, speed law (IV.4), direction ±∇T_est, resolution adaptation,
//! redesign on membership changes) is the paper's, and the one the binaries ship.

use vbap_math::body::VirtualBody;
use vbap_math::formation::FormationDesign;
use vbap_math::kalman::GradientFilter;
use vbap_math::Vec3;
use vbap_mission::config::{LawKind, Mission};

use crate::planner::{Command, Planner, PlannerError, Report};

/// A planner: from the reports of a tick to the virtual body the agents steer by.
pub trait Plan {
    /// One tick `k` (length `dt`, s). `members`: the last known report of every vehicle in
    /// the formation, ordered by id; `fresh`: the reports delivered since the last tick, in
    /// delivery order; `joined`: the vehicles admitted back at this tick (see
    /// [`Planner::step`]).
    fn step(
        &mut self,
        k: u64,
        members: &[Report],
        fresh: &[Report],
        joined: &[u32],
        dt: f64,
    ) -> Result<Command, PlannerError>;
    /// Where the vehicles the fleet has lost were last heard of (`Fleet::hulls`, length
    /// unit), told before each [`Plan::step`]. Ignored by default.
    fn see_hulls(&mut self, hulls: &[Vec3]) {
        let _ = hulls;
    }
    /// The virtual body the next step starts from.
    fn body(&self) -> &VirtualBody;
    /// The point that moves with the body's MOTION (length unit): what a member out of
    /// contact is dead-reckoned by (`Fleet::track_body`). The body centre `r` by default;
    /// a plan that moves `r` by jumps (a bumpless redesign lays the body on the vehicles)
    /// leaves the jumps out, since no vehicle moved with them.
    fn motion_point(&self) -> Vec3 {
        self.body().r
    }
    /// The formation design in use.
    fn design(&self) -> &FormationDesign;
    /// The gradient filter, once a first estimate was made (its covariance P gives the
    /// bound of Theorem 5.1 in `summary.json`).
    fn filter(&self) -> Option<&GradientFilter>;
    /// The measurement noise σ_M in use, field unit.
    fn sigma_m(&self) -> f64;
    /// How many times the formation was redesigned.
    fn reconfigurations(&self) -> usize;
    /// The law the fleet flies (`control.law`): under [`LawKind::Robust`] the swarm
    /// snapshot carries every member's slot ([`crate::slots`]). The paper's by default.
    fn law(&self) -> LawKind {
        LawKind::Paper
    }
    /// Every member's slot for `command` under the robust law ([`crate::slots::member_slots`]);
    /// a plan that keeps its last assignment keeps it where it still holds. Assigned afresh
    /// by default.
    fn member_slots(&mut self, command: &Command, members: &[Report]) -> Vec<(u32, Vec3)> {
        let mut none = std::collections::BTreeMap::new();
        crate::slots::member_slots(self.design(), &mut none, command, members)
    }
    /// Called on a plan restored from a checkpoint, with its mission: what the checkpoint
    /// does not keep (a gridded field's land, loaded with the mission) is attached again.
    /// Nothing by default.
    fn restored(&mut self, mission: &Mission) {
        let _ = mission;
    }
    /// The planner's estimate of the field's drift, length unit/s, and whether it is
    /// significant (`vbap_math::drift`, (D.3)); None when it makes none (the default).
    fn drift(&self) -> Option<(vbap_math::Vec3, bool)> {
        None
    }
}

impl Plan for Planner {
    fn step(
        &mut self,
        k: u64,
        members: &[Report],
        fresh: &[Report],
        joined: &[u32],
        dt: f64,
    ) -> Result<Command, PlannerError> {
        Planner::step(self, k, members, fresh, joined, dt)
    }
    fn see_hulls(&mut self, hulls: &[Vec3]) {
        Planner::see_hulls(self, hulls)
    }
    fn body(&self) -> &VirtualBody {
        Planner::body(self)
    }
    fn motion_point(&self) -> Vec3 {
        Planner::motion_point(self)
    }
    fn design(&self) -> &FormationDesign {
        Planner::design(self)
    }
    fn filter(&self) -> Option<&GradientFilter> {
        Planner::filter(self)
    }
    fn sigma_m(&self) -> f64 {
        Planner::sigma_m(self)
    }
    fn reconfigurations(&self) -> usize {
        Planner::reconfigurations(self)
    }
    fn law(&self) -> LawKind {
        Planner::law(self)
    }
    fn restored(&mut self, mission: &Mission) {
        self.attach_land(mission);
    }
    fn member_slots(&mut self, command: &Command, members: &[Report]) -> Vec<(u32, Vec3)> {
        Planner::member_slots(self, command, members)
    }
    fn drift(&self) -> Option<(vbap_math::Vec3, bool)> {
        Planner::drift(self)
    }
}

impl<P: Plan + ?Sized> Plan for Box<P> {
    fn step(
        &mut self,
        k: u64,
        members: &[Report],
        fresh: &[Report],
        joined: &[u32],
        dt: f64,
    ) -> Result<Command, PlannerError> {
        (**self).step(k, members, fresh, joined, dt)
    }
    fn see_hulls(&mut self, hulls: &[Vec3]) {
        (**self).see_hulls(hulls)
    }
    fn body(&self) -> &VirtualBody {
        (**self).body()
    }
    fn design(&self) -> &FormationDesign {
        (**self).design()
    }
    fn member_slots(&mut self, command: &Command, members: &[Report]) -> Vec<(u32, Vec3)> {
        (**self).member_slots(command, members)
    }
    fn filter(&self) -> Option<&GradientFilter> {
        (**self).filter()
    }
    fn sigma_m(&self) -> f64 {
        (**self).sigma_m()
    }
    fn reconfigurations(&self) -> usize {
        (**self).reconfigurations()
    }
    fn law(&self) -> LawKind {
        (**self).law()
    }
    fn drift(&self) -> Option<(vbap_math::Vec3, bool)> {
        (**self).drift()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::PlannerParams;
    use approx::assert_relative_eq;
    use vbap_math::{Mat3, Vec3};
    use vbap_mission::config::{Goal, Mission};

    const DT: f64 = 0.05;

    /// A 2-D mission of `n` vehicles (the planner's tunables at their defaults).
    /// The paper's planner for `n` vehicles (these tests pin its behaviour).
    fn params(n: usize) -> PlannerParams {
        let m = Mission::from_toml_str(
            &format!(
                "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = {n}\n[control]\nlaw = \"paper\"\n"
            ),
            "<test>",
        )
        .unwrap();
        PlannerParams::from_mission(&m)
    }

    /// T(x) = c + g·(x − x0) + ½ (x − x0)ᵀ H (x − x0).
    struct Quadratic {
        c: f64,
        x0: Vec3,
        g: Vec3,
        h: Mat3,
    }

    impl Quadratic {
        fn value(&self, x: &Vec3) -> f64 {
            let d = x - self.x0;
            self.c + self.g.dot(&d) + 0.5 * d.dot(&(self.h * d))
        }
        fn gradient(&self, x: &Vec3) -> Vec3 {
            self.g + self.h * (x - self.x0)
        }
    }

    /// The reports of vehicles at rest in their slots around the planner's body, each
    /// reading `field` exactly.
    fn at_slots(planner: &dyn Plan, ids: &[u32], k: u64, field: &Quadratic) -> Vec<Report> {
        let r = planner.body().r;
        let scale = planner.body().scale;
        ids.iter()
            .zip(&planner.design().slots)
            .map(|(&id, slot)| {
                let position = r + slot * scale;
                Report {
                    id,
                    tick: k,
                    position,
                    velocity: Vec3::zeros(),
                    measurement: field.value(&position),
                }
            })
            .collect()
    }

    fn field() -> Quadratic {
        Quadratic {
            c: 3.0,
            x0: Vec3::new(1.0, -2.0, 0.0),
            g: Vec3::new(0.3, -0.4, 0.0),
            h: Mat3::new(-0.02, 0.005, 0.0, 0.005, -0.01, 0.0, 0.0, 0.0, 0.0),
        }
    }

    /// On a known quadratic field, noiseless readings from a centrally symmetric formation
    /// give ∇T at the body centre (the even curvature term cancels in least squares), and
    /// the body moves along +∇T_est when climbing, −∇T_est when descending.
    #[test]
    fn step_estimates_the_gradient_and_moves_along_it() {
        let ids = [0, 1, 2, 3];
        let f = field();
        for (goal, sign) in [(Goal::Max, 1.0), (Goal::Min, -1.0)] {
            let p = PlannerParams { goal, ..params(4) };
            let start = Vec3::new(2.0, 1.0, 0.0);
            let mut planner: Box<dyn Plan> = Box::new(Planner::new(p, start, &ids).unwrap());
            let reports = at_slots(planner.as_ref(), &ids, 0, &f);
            let c = planner.step(0, &reports, &reports, &[], DT).unwrap();
            let truth = f.gradient(&start);
            assert!(!c.estimate_failed && !c.holding);
            assert_relative_eq!(c.grad_est, truth, epsilon = 1e-9);
            assert!(c.sdot > 0.0, "the body moves: ṡ = {}", c.sdot);
            // |∇T| = 0.5 < grad_saturation = 1: dr/ds = ±∇T_est / grad_saturation.
            assert_relative_eq!(c.velocity, truth * (sign * c.sdot), epsilon = 1e-12);
            let moved = planner.body().r - start;
            assert_relative_eq!(moved, truth * (sign * c.sdot * DT), epsilon = 1e-12);
            assert!(sign * moved.dot(&truth) > 0.0);
        }
    }

    /// Above the saturation the direction is the unit vector of ±∇T_est: ṡ is then the
    /// body's speed, and ṡ of (IV.4) stays within [0, v0] whatever the field's slope.
    #[test]
    fn step_speed_is_bounded_by_v0_and_saturates_the_direction() {
        let ids = [0, 1, 2, 3, 4];
        for slope in [0.01, 0.5, 2.0, 50.0] {
            let f = Quadratic {
                g: Vec3::new(slope, 0.5 * slope, 0.0),
                ..field()
            };
            let p = params(5);
            let (v0, saturation) = (p.v0, p.grad_saturation);
            let mut planner = Planner::new(p, Vec3::zeros(), &ids).unwrap();
            for k in 0..20 {
                let reports = at_slots(&planner, &ids, k, &f);
                let c = planner.step(k, &reports, &reports, &[], DT).unwrap();
                assert!(
                    (0.0..=v0).contains(&c.sdot),
                    "ṡ = {} out of [0, {v0}]",
                    c.sdot
                );
                let speed = c.velocity.norm();
                let gnorm = c.grad_est.norm();
                let expected = c.sdot * gnorm / gnorm.max(saturation);
                assert_relative_eq!(speed, expected, epsilon = 1e-12, max_relative = 1e-9);
                assert!(speed <= v0 * (1.0 + 1e-12));
            }
        }
    }

    /// With fewer than dim + 1 members no gradient can be estimated: the body holds (ṡ = 0,
    /// no motion), and resumes once enough vehicles are members again.
    #[test]
    fn step_holds_with_too_few_vehicles() {
        let f = field();
        let mut planner = Planner::new(params(4), Vec3::zeros(), &[0, 1, 2, 3]).unwrap();
        let all = at_slots(&planner, &[0, 1, 2, 3], 0, &f);
        planner.step(0, &all, &all, &[], DT).unwrap();
        let two = &all[..2];
        let before = planner.body().r;
        let c = planner.step(1, two, two, &[], DT).unwrap();
        assert!(c.holding && c.reconfigured);
        assert_eq!(c.sdot, 0.0);
        assert_eq!(c.members, vec![0, 1]);
        assert_eq!(planner.body().r, before);
        assert_eq!(planner.reconfigurations(), 1);
    }
}
