//! The robust law's committed body path (beyond the paper, `vbap_math::schedule`): the
//! body never moves in a way a vehicle out of contact cannot know. The decision of a tick
//! (direction, ṡ, dk/ds) is appended at the far end of the schedule at each segment
//! boundary and takes effect a plan horizon later; the body moves by the segment in force.
//! The coordinator's view of a vehicle out of contact is its last report moved with the
//! committed body, which is what that vehicle flies.

use vbap_math::body::{BodyRates, VirtualBody};
use vbap_math::schedule::Segment;
use vbap_math::speed::information_confidence;
use vbap_math::{Mat3, Vec3};
use vbap_mission::config::{Goal, LawKind};

use super::{Planner, Report};

impl Planner {
    /// The scale the decision of tick `k` acts on: under a schedule, the scale the body
    /// will have when the decision takes effect (at the schedule's end: the adaptation
    /// (V.7) is deterministic given k, so its feedback is predicted rather than delayed);
    /// else the scale now.
    pub(super) fn decision_scale(&self, k: u64, dt: f64) -> f64 {
        match &self.schedule {
            Some(s) => {
                s.predict(k, s.end_tick(), self.body.r, self.body.scale, dt)
                    .1
            }
            None => self.body.scale,
        }
    }

    /// The gradient the decision of tick `k` acts on: under a schedule, the estimate ∇T_est
    /// at r_k carried to where the body will be when the decision takes effect, r_end:
    /// ∇T_est + Ĥ (r_end − r_k), with the online curvature estimate Ĥ once the data
    /// determine it (its posterior spread below half its size: `vbap_math::curvature`),
    /// else with a configured `formation.hessian_guess` H of (V.6) of the sign of an
    /// optimum (−H towards a maximum, +H towards a minimum). A Smith predictor for the
    /// plan's delay: without it the climb near the optimum is a loop delayed by the
    /// horizon, which overshoots (glider surfacing: 1.7 km past the peak, converged after
    /// 37 h instead of ~17 h). Without an estimate, without a schedule, or with no
    /// curvature known, ∇T_est itself: the identity that stands in for a missing guess
    /// can be far off (lossy_kill: ~50 × the true curvature), and predicting with it slows
    /// the climb (there by 45 %).
    pub(super) fn gradient_ahead(&self, grad_est: &Vec3, k: u64, dt: f64) -> Vec3 {
        let Some(sched) = &self.schedule else {
            return *grad_est;
        };
        if *grad_est == Vec3::zeros() {
            return *grad_est;
        }
        let Some(curvature) = self.known_curvature() else {
            return *grad_est;
        };
        let (r_end, _) = sched.predict(k, sched.end_tick(), self.body.r, self.body.scale, dt);
        let mut g = grad_est + curvature * (r_end - self.body.r);
        if self.params.dim == 2 {
            g.z = 0.0;
        }
        g
    }

    /// The field's Hessian where the data or the mission say it (field unit per length
    /// unit²): the online curvature estimate Ĥ once the data determine it (its posterior
    /// spread below half its size: `vbap_math::curvature`), else a configured
    /// `formation.hessian_guess` H of (V.6) with the sign of an optimum (−H towards a
    /// maximum, +H towards a minimum); None otherwise (the identity that stands in for a
    /// missing guess can be far off).
    pub(super) fn known_curvature(&self) -> Option<Mat3> {
        let sign = match self.params.goal {
            Goal::Max => -1.0,
            Goal::Min => 1.0,
        };
        let estimated = self
            .curvature
            .as_ref()
            .and_then(|c| c.hessian_if_determined(0.5));
        match estimated {
            Some(h) => Some(h),
            None if self.params.hessian_configured => Some(self.params.hessian_guess * sign),
            None => None,
        }
    }

    /// The members' last reports as the vehicles out of contact are now (None without a
    /// schedule: the reports as given). The fleet has moved each report of tick j by the
    /// body's translation since j; here it also follows the body's scale
    /// (r + (k_now / k_j)(x − r), (III.3)) and its velocity (ẋ − ṙ_j + ṙ_now).
    pub(super) fn predicted_members(
        &self,
        k: u64,
        members: &[Report],
        dt: f64,
    ) -> Option<Vec<Report>> {
        let sched = self.schedule.as_ref()?;
        let now = sched.segment_at(k);
        let r = self.body.r;
        let scale = self.body.scale;
        Some(
            members
                .iter()
                .map(|q| {
                    if q.tick >= k {
                        return *q;
                    }
                    let (scale_then, seg_then) = self.committed_at(q.tick, dt);
                    let ratio = if scale_then > 0.0 {
                        scale / scale_then
                    } else {
                        1.0
                    };
                    Report {
                        position: r + (q.position - r) * ratio,
                        velocity: q.velocity - seg_then.velocity + now.velocity,
                        ..*q
                    }
                })
                .collect(),
        )
    }

    /// The body's scale at past tick `j` and the segment then in force (the deployment
    /// plan before the oldest mark kept).
    fn committed_at(&self, j: u64, dt: f64) -> (f64, Segment) {
        match self.committed.range(..=j).next_back() {
            Some((&b, &(scale_b, seg))) => (scale_b + seg.scale_rate * ((j - b) as f64 * dt), seg),
            None => (1.0, Segment::REST),
        }
    }

    /// How much the speed law may trust its inputs at tick `k`: 1 for the paper's law;
    /// for the robust law `vbap_math::speed::information_confidence` of how far the
    /// oldest member report is older than the plan horizon H. Within H a report is as old
    /// as the links make it, and the vehicle flies the body it was committed to, so its
    /// state moved with the body is what it does; a vehicle silent for longer (a
    /// `link_down`, a death not noticed yet) is no longer known. Measured on lossy_kill
    /// with adapt = false (20 seeds): counting age from 0 instead capped the second term
    /// of (IV.4) at every tick (reports are always 0.5 s old), the body could not cruise
    /// (its V counts the fleet's kinetic energy, ≈ V_U/2 at v0) and no seed ended in
    /// formation within the mission (0/20, against 19/20 with age counted beyond H).
    pub(super) fn confidence(&self, k: u64, oldest: u64, dt: f64) -> f64 {
        if self.params.law == LawKind::Paper {
            return 1.0;
        }
        let beyond = k
            .saturating_sub(oldest)
            .saturating_sub(self.params.plan_ticks);
        information_confidence(beyond as f64 * dt, self.params.damping)
    }

    /// Tick `k` under a schedule: at a segment boundary the decision (`rates`, `sdot`, and
    /// the drift's feed-forward `drift`, length unit/s, added to its velocity) goes to the
    /// far end — its scale rate limited so the planned scale stays within
    /// [min_scale, max_scale] — and the marks older than the `oldest` report in use are
    /// forgotten. Returns the segment in force now (None without a schedule).
    pub(super) fn commit(
        &mut self,
        k: u64,
        rates: &BodyRates,
        sdot: f64,
        drift: Option<Vec3>,
        oldest: u64,
        dt: f64,
    ) -> Option<Segment> {
        let (min_scale, max_scale) = (self.params.min_scale, self.params.max_scale);
        let end_scale = self.decision_scale(k, dt);
        let sched = self.schedule.as_mut()?;
        let span = sched.seg_ticks as f64 * dt;
        let mut rate = rates.dk_ds * sdot;
        if let Some((times_k, speed)) = self.params.scale_rate_bound {
            // The envelope's bound (`vbap_math::envelope`): the slots move no faster than
            // the vehicles can follow them, nor than the slot spring's lag allows.
            let bound = (times_k / end_scale.max(f64::MIN_POSITIVE)).min(speed);
            rate = rate.clamp(-bound, bound);
        }
        let rate = rate.clamp(
            ((min_scale - end_scale) / span).min(0.0),
            ((max_scale - end_scale) / span).max(0.0),
        );
        let climb = rates.dr_ds * sdot;
        let decision = Segment {
            velocity: drift.map_or(climb, |d| climb + d),
            scale_rate: rate,
            sdot,
        };
        let in_force = if sched.roll(k, decision) {
            let seg = sched.segment_at(k);
            self.committed.insert(k, (self.body.scale, seg));
            seg
        } else {
            sched.segment_at(k)
        };
        let keep_from = self
            .committed
            .range(..=oldest)
            .next_back()
            .map_or(0, |(&b, _)| b);
        self.committed = self.committed.split_off(&keep_from);
        Some(in_force)
    }

    /// The body of the next tick moved by the segment in force `seg`: s + ṡ dt,
    /// r + dr/dt dt, k + dk/dt dt (kept within [min_scale, max_scale] against rounding),
    /// in the plane z = 0 in 2-D. The schedule's prediction (`vbap_math::schedule`) is
    /// this motion.
    pub(super) fn advanced_committed(&self, seg: &Segment, dt: f64) -> VirtualBody {
        let p = &self.params;
        let mut r: Vec3 = self.body.r + seg.velocity * dt;
        if p.dim == 2 {
            r.z = 0.0;
        }
        VirtualBody {
            s: self.body.s + seg.sdot * dt,
            r,
            rotation: self.body.rotation,
            scale: (self.body.scale + seg.scale_rate * dt).clamp(p.min_scale, p.max_scale),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::planner::{Planner, PlannerParams, Report};
    use vbap_math::Vec3;
    use vbap_mission::config::Mission;

    fn mission(extra: &str) -> Mission {
        Mission::from_toml_str(
            &format!("[mission]\nname = \"t\"\ndt = 0.1\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n{extra}"),
            "<test>",
        )
        .unwrap()
    }

    /// Reports of tick `k` around `centre`, `age` ticks old.
    fn reports(k: u64, age: u64, centre: Vec3) -> Vec<Report> {
        (0..4u32)
            .map(|id| {
                let a = f64::from(id) * std::f64::consts::FRAC_PI_2 + 0.1 * k as f64;
                Report {
                    id,
                    tick: k.saturating_sub(age),
                    position: centre + Vec3::new(1.4 * a.cos(), 1.6 * a.sin(), 0.0),
                    velocity: Vec3::new(0.3, 0.1, 0.0),
                    measurement: 1.0 + 0.2 * f64::from(id) + 0.01 * k as f64,
                }
            })
            .collect()
    }

    #[test]
    fn on_ideal_links_the_robust_planner_is_the_papers() {
        let paper = mission("[formation]\nadapt = true\n");
        let robust = mission("[formation]\nadapt = true\n[control]\nlaw = \"robust\"\n");
        assert_eq!(robust.plan_horizon_ticks(), 0);
        let ids = [0, 1, 2, 3];
        let mut a =
            Planner::new(PlannerParams::from_mission(&paper), paper.start_vec(), &ids).unwrap();
        let mut b = Planner::new(
            PlannerParams::from_mission(&robust),
            robust.start_vec(),
            &ids,
        )
        .unwrap();
        for k in 0..200 {
            let q = reports(k, 0, a.body().r);
            let ca = a.step(k, &q, &q, &[], 0.1).unwrap();
            let cb = b.step(k, &q, &q, &[], 0.1).unwrap();
            assert_eq!(ca, cb, "tick {k}");
            assert!(cb.schedule.is_none());
        }
    }

    /// The envelope's bounds (`vbap_math::envelope`): over impaired links the scale never
    /// goes below the envelope's floor nor changes faster than its rate bound allows.
    #[test]
    fn the_robust_scale_stays_within_the_envelopes_floor_and_rate() {
        // Tiny noise: adaptation wants the smallest scale. dt = 0.3 s puts the envelope's
        // step limit above min_scale = 0.1.
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\ndt = 0.3\nallow_unstable = true\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\nnoise_std = 0.001\n[vehicles]\ncount = 4\n[formation]\nadapt = true\nmin_scale = 0.1\n[links]\ndelay = 0.5\njitter = 0.2\nloss = 0.1\n[control]\nlaw = \"robust\"\n",
            "<test>",
        )
        .unwrap();
        let params = PlannerParams::from_mission(&m);
        let floor = params.min_scale;
        assert!(floor > 0.1, "the envelope raises the floor: {floor}");
        let (times_k, speed) = params.scale_rate_bound.expect("a rate bound");
        let ids = [0, 1, 2, 3];
        let mut p = Planner::new(params, m.start_vec(), &ids).unwrap();
        let mut last = p.body().scale;
        let mut shrank = false;
        for k in 0..600 {
            let q = reports(k, 5, p.body().r);
            let c = p.step(k, &q, &q, &[], 0.3).unwrap();
            let scale = c.body.scale;
            assert!(scale >= floor - 1e-12, "tick {k}: {scale} below {floor}");
            let rate = (scale - last).abs() / 0.3;
            let bound = (times_k / last.min(scale)).min(speed);
            assert!(
                rate <= bound * (1.0 + 1e-9),
                "tick {k}: |dk/dt| {rate} > {bound}"
            );
            shrank |= scale < last;
            last = scale;
        }
        assert!(shrank, "adaptation never shrank the formation");
    }

    /// Gliders turn and accelerate at limited rates: the growth of the formation, like the
    /// body's speed, starts gradually (`Planner::growth_limited`). Noisy readings make
    /// adaptation (V.7) want a larger formation at once.
    #[test]
    fn a_glider_formation_starts_to_grow_no_faster_than_its_gliders_can_follow() {
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\ndt = 0.1\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\n\
             width = 15.0\nnoise_std = 3.0\n[vehicles]\ncount = 4\nmodel = \"glider\"\n\
             max_speed = 2.0\nmax_accel = 0.4\nmax_turn_rate = 3.0\n[formation]\nadapt = true\n\
             max_scale = 3.0\n[links]\ndelay = 0.5\n[control]\nlaw = \"robust\"\n",
            "<test>",
        )
        .unwrap();
        let params = PlannerParams::from_mission(&m);
        let limits = params.body_limits.expect("gliders under the robust law");
        let reach = m.formation_design().unwrap().extent();
        let ids = [0, 1, 2, 3];
        let mut p = Planner::new(params, m.start_vec(), &ids).unwrap();
        let commands: Vec<_> = (0..400)
            .map(|k| {
                let q = reports(k, 5, p.body().r);
                p.step(k, &q, &q, &[], 0.1).unwrap()
            })
            .collect();
        let scales: Vec<f64> = commands.iter().map(|c| c.body.scale).collect();
        let rates: Vec<f64> = scales.windows(2).map(|w| (w[1] - w[0]) / 0.1).collect();
        let most_rise = rates
            .windows(2)
            .map(|w| w[1].abs() - w[0].abs())
            .fold(0.0, f64::max);
        let grew = rates.iter().fold(0.0, |a: f64, r| a.max(r.abs()));
        assert!(grew > 0.0, "the formation never changed size");
        // Under a schedule the decisions of one segment take effect together: the rise is
        // bounded per segment of the committed path.
        let seg_ticks = commands[0]
            .schedule
            .as_ref()
            .expect("a committed path")
            .seg_ticks as f64;
        let bound = limits.max_accel * 0.1 * seg_ticks / reach;
        assert!(
            most_rise <= bound * (1.0 + 1e-9),
            "|dk/dt| rose by {most_rise} in a tick, more than {bound}"
        );
    }

    #[test]
    fn the_robust_body_moves_only_as_committed_a_horizon_ahead() {
        let m = mission(
            "[formation]\nadapt = true\n[links]\ndelay = 0.5\njitter = 0.2\nloss = 0.1\n[control]\nlaw = \"robust\"\n",
        );
        let h = m.plan_horizon_ticks();
        assert_eq!(h, 14);
        let ids = [0, 1, 2, 3];
        let mut p = Planner::new(PlannerParams::from_mission(&m), m.start_vec(), &ids).unwrap();
        let mut commands = Vec::new();
        for k in 0..300 {
            let q = reports(k, 5, p.body().r);
            commands.push(p.step(k, &q, &q, &[], 0.1).unwrap());
        }
        // At rest for the horizon: the deployment plan every vehicle knows.
        assert!(commands[..h as usize]
            .iter()
            .all(|c| c.body.r == m.start_vec()));
        assert!(
            commands.last().unwrap().body.r != m.start_vec(),
            "the body climbs"
        );
        // Every command's plan predicts the body of every later tick within the horizon.
        for (c, cmd) in commands.iter().enumerate() {
            let sched = cmd.schedule.as_ref().unwrap();
            for (j, later) in commands.iter().enumerate().skip(c).take(h as usize + 1) {
                let (r, k) = sched.predict(c as u64, j as u64, cmd.body.r, cmd.body.scale, 0.1);
                assert!((r - later.body.r).norm() < 1e-9, "command {c}, tick {j}");
                assert!((k - later.body.scale).abs() < 1e-9, "command {c}, tick {j}");
            }
        }
    }
}
