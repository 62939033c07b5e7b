//! The mission figures of `summary.json`: the outcome of the run, judged from the true
//! field and the true states.

use vbap_math::convergence::{default_delta_m, theorem_5_1_bound};
use vbap_mission::acoustic::AcousticModel;
use vbap_mission::link::LinkModel;
use vbap_mission::rundir::{AcousticTotals, Summary};

use super::Recorder;
use crate::plan::Plan;
use crate::truth::{self, BodyOutcome, LocalOptimum, Tracking};
use vbap_math::Vec3;

impl Recorder {
    /// The mission figures of `summary.json` (message counts, latency and wall time are
    /// filled in by the caller).
    pub fn summary(&self, planner: &impl Plan, mode: &str) -> Summary {
        let m = &self.mission;
        let t = self.stats.last_t;
        let r = self.stats.last_r;
        let optimum = self.optimum(t);
        let distance = optimum.map(|o| (r - o).norm());
        let dt = m.mission.dt;
        let tail = &self.stats.tail;
        let moving = match (optimum, self.optimum(t - dt)) {
            (Some(now), Some(before)) if self.stats.optimum_moved => Some(Tracking {
                from_t: tail.from_t.unwrap_or(t),
                ticks: tail.ticks,
                mean_lag: tail.sum / tail.ticks.max(1) as f64,
                max_lag: tail.max,
                true_drift: (now - before) / dt,
                estimated: planner.drift(),
            }),
            _ => None,
        };
        let (verdict, mut reasons) = truth::verdict(
            &self.stats.truth,
            &BodyOutcome {
                ticks: self.stats.ticks,
                planned: m.ticks(),
                distance,
                tolerance: m.mission.tolerance,
                t,
                unit: m.mission.length_unit.clone(),
                local_optima: m.grid().map_or(0, |g| g.local_optima(m.mission.goal)),
                local_optimum: self.local_optimum(optimum, distance),
                moving,
            },
        );
        // Converged: the body within tolerance AND every live vehicle in formation.
        let converged = truth::is_converged(&verdict);
        let time_to_converge_s = if converged {
            Some(
                self.stats
                    .last_outside
                    .map_or(0.0, |t_out| t_out + m.mission.dt),
            )
        } else {
            None
        };
        let final_grad_norm = self.field.gradient(&r, t).norm();
        let bound = planner.filter().and_then(|f| {
            let eps = theorem_5_1_bound(
                m.estimator.confidence,
                &f.covariance(),
                m.formation_dim(),
                0.0,
            )
            .ok()?;
            Some(eps + m.estimator.delta_m.unwrap_or_else(|| default_delta_m(eps)))
        });
        if let (Some((floor, by)), held) = (self.scale_floor, self.stats.scale_held_ticks) {
            if held > 0 {
                reasons.push(format!(
                    "the scale was held at k = {floor:.3} by the stability envelope (set by \
                     {by}; links {}; formation.min_scale = {}) for {:.1}% of ticks",
                    m.links_in_words(),
                    m.formation.min_scale,
                    100.0 * held as f64 / self.stats.ticks.max(1) as f64
                ));
            }
        }
        Summary {
            mission: m.mission.name.clone(),
            mode: mode.to_string(),
            seed: m.mission.seed,
            converged,
            final_distance_to_optimum: distance,
            final_grad_norm,
            theorem_5_1_bound: bound,
            in_set_m: bound.map(|b| final_grad_norm <= b),
            time_to_converge_s,
            vehicles_started: self.stats.vehicles_started,
            vehicles_lost: self.stats.vehicles_lost,
            vehicles_rejoined: self.stats.vehicles_rejoined,
            reconfigurations: planner.reconfigurations(),
            // The TRUE figure (from the vehicles' true states); the coordinator's own is
            // `formation.max_V_seen_over_VU`.
            max_v_over_vu: self.stats.truth.max_v_true,
            ticks: self.stats.ticks,
            final_time_s: t,
            final_body_position: [r.x, r.y, r.z],
            final_scale: self.stats.last_scale,
            optimum: optimum.map(|o| [o.x, o.y, o.z]),
            estimated_sigma_m: Some(planner.sigma_m()),
            holding_ticks: self.stats.holding_ticks,
            scale_held_ticks: self.stats.scale_held_ticks,
            verdict,
            reasons,
            formation: Some(truth::summary(&self.stats.truth)),
            link_bytes: Some(self.stats.links.summary(
                self.stats.vehicles_started,
                t + dt,
                &LinkModel::new(&self.mission),
            )),
            // The receptions are counted by the vehicles (`vbap sim`'s tally, the analysis of
            // the agents' message records after `vbap run`); the frame's size is the mission's.
            acoustic: AcousticModel::new(&self.mission).map(|c| AcousticTotals {
                frame_b: c.frame_bytes(),
                ..AcousticTotals::default()
            }),
            ..Summary::default()
        }
    }

    /// The local optimum, other than the global one `optimum`, that a noise-free climb of the
    /// true field reaches from where the body ended (`distance` from `optimum`), when the body
    /// ended outside the tolerance of a still field's optimum (not for diving gliders, whose
    /// formation is horizontal over a 3-D field). Steps of a twentieth of the tolerance
    /// ([`vbap_math::ascent::local_optimum`]).
    fn local_optimum(&self, optimum: Option<Vec3>, distance: Option<f64>) -> Option<LocalOptimum> {
        let m = &self.mission;
        let tolerance = m.mission.tolerance;
        let (o, d) = optimum.zip(distance)?;
        if d <= tolerance || self.stats.optimum_moved || m.diving() {
            return None;
        }
        let (r, t) = (self.stats.last_r, self.stats.last_t);
        let at = vbap_math::ascent::local_optimum(
            |x| self.field.gradient(x, t),
            &r,
            m.mission.goal.sign(),
            tolerance / 20.0,
            100_000,
        );
        let from_global = (at - o).norm();
        (from_global > tolerance).then(|| LocalOptimum {
            at,
            distance: (r - at).norm(),
            reach: tolerance.max(m.formation.radius * self.stats.last_scale),
            from_global,
        })
    }
}
