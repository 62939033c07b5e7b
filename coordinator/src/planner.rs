//! The coordinator's pure step.

use std::collections::BTreeMap;
use vbap_math::adapt::{dk_ds, NoiseEstimator};
use vbap_math::body::{BodyRates, VirtualBody};
use vbap_math::estimate::least_squares;
use vbap_math::formation::{design_regular, FormationDesign, FormationError};
use vbap_math::kalman::GradientFilter;
use vbap_math::lyapunov::{lyapunov_terms, LyapunovTerms};
use vbap_math::optimal::optimal_scale;
use vbap_math::potential::PairPotential;
use vbap_math::rejoin::{
    blended_lyapunov_terms, choose_slot, clearance, fit_turn, homing_weight, is_central,
    turned_slots, waiting_factor, Homing,
};
use vbap_math::speed::formation_speed;
use vbap_math::{Mat3, Vec3};
use vbap_mission::config::{Goal, Mission};

/// One vehicle's report for a tick, as the coordinator received it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Report {
    /// Vehicle id.
    pub id: u32,
    /// Tick at which the state and the reading were taken (possibly older than the
    /// planner's tick when links delay it).
    pub tick: u64,
    /// Position x_i at the tick, length unit.
    pub position: Vec3,
    /// Velocity, length unit/s.
    pub velocity: Vec3,
    /// Sensor reading T_m(x_i), field unit.
    pub measurement: f64,
}

/// The planner's tunables, taken from the mission file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlannerParams {
    pub dim: usize,
    pub goal: Goal,
    pub radius: f64,
    pub alpha: f64,
    pub damping: f64,
    pub adapt: bool,
    pub adapt_gain: f64,
    pub min_scale: f64,
    pub max_scale: f64,
    pub sigma_h: f64,
    pub hessian_guess: Mat3,
    pub v0: f64,
    pub v_u: f64,
    pub delta: f64,
    pub grad_saturation: f64,
    pub kalman_b: f64,
    pub sigma_m: Option<f64>,
    pub sigma_m_prior: f64,
    pub initial_variance: f64,
}

impl PlannerParams {
    /// The planner's view of a mission (no ground truth in here).
    pub fn from_mission(m: &Mission) -> Self {
        Self {
            dim: m.mission.dim,
            goal: m.mission.goal,
            radius: m.formation.radius,
            alpha: m.formation.alpha,
            damping: m.vehicles.damping,
            adapt: m.formation.adapt,
            adapt_gain: m.formation.adapt_gain,
            min_scale: m.formation.min_scale,
            max_scale: m.formation.max_scale,
            sigma_h: m.formation.sigma_h,
            hessian_guess: m.hessian_guess_mat(),
            v0: m.body.v0,
            v_u: m.body.v_u,
            delta: m.body.delta,
            grad_saturation: m.body.grad_saturation,
            kalman_b: m.estimator.kalman_b,
            sigma_m: m.estimator.sigma_m,
            sigma_m_prior: m.field.noise_std,
            initial_variance: m.estimator.initial_variance,
        }
    }
}

/// What the planner decided for one tick: the virtual body the agents steer by for the
/// step from this tick to the next, and what the run directory records.
#[derive(Clone, Debug, PartialEq)]
pub struct Command {
    /// The virtual body at this tick (s_k, r_k, R_k, k_k).
    pub body: VirtualBody,
    /// Formation speed ṡ (IV.4); 0 when holding.
    pub sdot: f64,
    /// Velocity of the virtual body centre, dr/ds·ṡ, length unit/s: vehicles out of
    /// contact dead-reckon the body with it.
    pub velocity: Vec3,
    /// Virtual leader positions b_l(s_k) (III.3).
    pub leaders: Vec<Vec3>,
    /// Scaled inter-vehicle potential.
    pub inter: PairPotential,
    /// Scaled vehicle–leader potential.
    pub leader: PairPotential,
    /// Damping gain of (II.1), 1/s.
    pub damping: f64,
    /// V, ∂V/∂s, (∂V/∂x)ᵀẋ at this tick.
    pub terms: LyapunovTerms,
    /// The filtered gradient estimate ∇T_KF at r_k (zero before the first estimate).
    pub grad_est: Vec3,
    /// Trace of the Kalman covariance P (0 before the first estimate).
    pub p_trace: f64,
    /// True when the body holds position (fewer than dim + 1 vehicles).
    pub holding: bool,
    /// True when the least-squares estimate of this tick failed (rank, too few).
    pub estimate_failed: bool,
    /// True when the formation was redesigned at this tick.
    pub reconfigured: bool,
    /// Vehicles in the formation at this tick, ordered by id.
    pub members: Vec<u32>,
    /// The members still rejoining at this tick and the slot each flies to (inertial,
    /// length unit), ordered by id (`vbap_math::rejoin`).
    pub rejoining: Vec<(u32, Vec3)>,
}

/// Errors of the planner.
#[derive(Debug, thiserror::Error)]
pub enum PlannerError {
    /// No formation could be designed for the vehicles left.
    #[error("formation design for {n} vehicles: {source}")]
    Design { n: usize, source: FormationError },
}

/// The coordinator's state: virtual body, formation design, filter.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Planner {
    params: PlannerParams,
    design: FormationDesign,
    members: Vec<u32>,
    body: VirtualBody,
    filter: Option<GradientFilter>,
    noise: NoiseEstimator,
    last_r: Vec3,
    reconfigurations: usize,
    /// Members that joined after the start and are not yet in their slot: vehicle → the
    /// index of its slot in the design (None: to be chosen).
    #[serde(default)]
    rejoining: BTreeMap<u32, Option<usize>>,
    /// Turn of the slots about the body's z axis (rad) that follows the settled members of
    /// a 2-D central design (`vbap_math::rejoin::fit_turn`).
    #[serde(default)]
    turn: f64,
    /// Velocity of the body centre in the last command, length unit/s: the feed-forward
    /// of the rejoining vehicles' homing as the planner models it.
    #[serde(default = "Vec3::zeros")]
    last_velocity: Vec3,
}

impl Planner {
    /// A planner with the virtual body at `start`, for the vehicles `ids`.
    pub fn new(params: PlannerParams, start: Vec3, ids: &[u32]) -> Result<Self, PlannerError> {
        let design = design_regular(
            ids.len(),
            params.dim,
            params.radius,
            params.alpha,
            params.alpha,
        )
        .map_err(|source| PlannerError::Design {
            n: ids.len(),
            source,
        })?;
        let noise = NoiseEstimator::new(params.sigma_m_prior, 10.0);
        Ok(Self {
            params,
            design,
            members: ids.to_vec(),
            body: VirtualBody {
                s: 0.0,
                r: start,
                rotation: nalgebra::Rotation3::identity(),
                scale: 1.0,
            },
            filter: None,
            noise,
            last_r: start,
            reconfigurations: 0,
            rejoining: BTreeMap::new(),
            turn: 0.0,
            last_velocity: Vec3::zeros(),
        })
    }

    /// The current virtual body.
    pub fn body(&self) -> &VirtualBody {
        &self.body
    }
    /// The current formation design.
    pub fn design(&self) -> &FormationDesign {
        &self.design
    }
    /// The gradient filter, once the first estimate was made.
    pub fn filter(&self) -> Option<&GradientFilter> {
        self.filter.as_ref()
    }
    /// The σ_M in use (configured, or estimated online from residuals).
    pub fn sigma_m(&self) -> f64 {
        self.params.sigma_m.unwrap_or_else(|| self.noise.sigma())
    }
    /// How many times the formation was redesigned.
    pub fn reconfigurations(&self) -> usize {
        self.reconfigurations
    }
    /// The members still rejoining, with the index of their slot in the design.
    pub fn rejoining(&self) -> &BTreeMap<u32, Option<usize>> {
        &self.rejoining
    }

    /// Brings the rejoining members up to date at this tick (`vbap_math::rejoin`):
    /// every vehicle that became a member after the start rejoins until its last known
    /// position is within the capture radius of its slot. Its slot is chosen once (when it
    /// joins, or again when the formation is redesigned): the nearest free slot of the
    /// design; the slots move with the body and, for a 2-D central design, follow the
    /// settled members as they turn about the centre (`turn`). Returns the slots
    /// (inertial), by id.
    fn update_rejoining(
        rejoining: &mut BTreeMap<u32, Option<usize>>,
        turn: &mut f64,
        design: &FormationDesign,
        body: &VirtualBody,
        members: &[Report],
    ) -> Vec<(u32, Vec3)> {
        if rejoining.is_empty() {
            return Vec::new();
        }
        let spacing = body.scale * design.neighbour_spacing();
        let settled: Vec<Vec3> = members
            .iter()
            .filter(|q| !rejoining.contains_key(&q.id))
            .map(|q| q.position)
            .collect();
        *turn = fit_turn(design, body, &settled, *turn);
        let slots = turned_slots(design, body, *turn);
        let mut occupants = settled;
        occupants.extend(rejoining.values().flatten().filter_map(|m| slots.get(*m)));
        // Slots are given out nearest first: the vehicles closest to a slot choose first
        // (ties by id), so a vehicle already in a slot keeps it.
        let mut unassigned: Vec<(f64, u32, Vec3)> = members
            .iter()
            .filter(|q| rejoining.get(&q.id).is_some_and(|s| s.is_none()))
            .map(|q| (clearance(&q.position, &slots), q.id, q.position))
            .collect();
        unassigned.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (_, id, x) in unassigned {
            if let Some(m) = choose_slot(&slots, &occupants, &x, spacing) {
                occupants.push(slots[m]);
                rejoining.insert(id, Some(m));
            }
        }
        let mut targets = Vec::new();
        for q in members {
            let Some(slot) = rejoining.get(&q.id) else {
                continue;
            };
            let Some(target) = slot.and_then(|m| slots.get(m).copied()) else {
                continue;
            };
            if homing_weight((q.position - target).norm(), spacing) == 0.0 {
                // Captured: an ordinary member from now on.
                rejoining.remove(&q.id);
                continue;
            }
            targets.push((q.id, target));
        }
        targets
    }

    /// One tick `k`. `members` holds the last known report of every vehicle in the
    /// formation, ordered by id (the formation, the Lyapunov function and the swarm
    /// snapshot use them); `fresh` the reports delivered since the last tick, in delivery
    /// order, each with its own position and time (the estimator uses them: Remark 5.8).
    /// With ideal links both are this tick's reports. `joined` lists the vehicles admitted
    /// back at this tick (members from now on, at their restore state, even when they were
    /// lost at this very tick): each rejoins (`vbap_math::rejoin`). `dt` is the tick
    /// length, s.
    pub fn step(
        &mut self,
        k: u64,
        members: &[Report],
        fresh: &[Report],
        joined: &[u32],
        dt: f64,
    ) -> Result<Command, PlannerError> {
        let p = &self.params;
        let dim = p.dim;
        let ids: Vec<u32> = members.iter().map(|r| r.id).collect();
        let mut reconfigured = false;
        let rejoined = joined.iter().any(|id| ids.contains(id));
        if ids != self.members || rejoined {
            // A vehicle that becomes a member after the start, or is admitted back (also
            // when lost at this very tick), comes back from wherever it is: it rejoins.
            // Every slot is chosen again.
            for id in &ids {
                if !self.members.contains(id) || joined.contains(id) {
                    self.rejoining.insert(*id, None);
                }
            }
            self.rejoining.retain(|id, _| ids.contains(id));
            for slot in self.rejoining.values_mut() {
                *slot = None;
            }
            if !members.is_empty() {
                self.design = design_regular(ids.len(), dim, p.radius, p.alpha, p.alpha).map_err(
                    |source| PlannerError::Design {
                        n: ids.len(),
                        source,
                    },
                )?;
            }
            self.members = ids.clone();
            self.reconfigurations += 1;
            reconfigured = true;
            if !self.rejoining.is_empty() && !is_central(&self.design) {
                // A design with a leader group per slot holds each vehicle only near its
                // own slot: when a vehicle comes back, the others (arranged for the old
                // design) are given slots of the new one too; those already in one are
                // captured at once and fly (II.1) as before.
                for id in &ids {
                    self.rejoining.insert(*id, None);
                }
            }
        }

        // A member out of every leader's reach (thrown out by a near-collision, or adrift
        // with stale guidance) feels no force of (II.1) at all: it is brought back the way
        // a returning vehicle is.
        let leaders = self.body.leader_positions(&self.design);
        let reach = self.body.scaled_leader(&self.design).d1;
        for q in members {
            if !self.rejoining.contains_key(&q.id)
                && leaders.iter().all(|b| (q.position - b).norm() >= reach)
            {
                self.rejoining.insert(q.id, None);
            }
        }

        let r = self.body.r;
        let holding = members.len() < dim + 1;
        let rejoining = Self::update_rejoining(
            &mut self.rejoining,
            &mut self.turn,
            &self.design,
            &self.body,
            members,
        );
        // A rejoining vehicle samples far from the formation the estimator's error model
        // (V.6) assumes: its readings wait until it is in its slot.
        let kept: Vec<Report>;
        let fresh = if rejoining.is_empty() {
            fresh
        } else {
            kept = fresh
                .iter()
                .filter(|q| !self.rejoining.contains_key(&q.id))
                .copied()
                .collect();
            &kept[..]
        };

        // Gradient estimate: least squares (Lemma 5.1) on the fresh readings, into the
        // Kalman filter (Lemma 5.4) with a time-varying C (Remark 5.8): every reading at its
        // true position relative to the body centre now, its variance grown by the
        // random-walk drift of the model over its age.
        let rel: Vec<Vec3> = fresh.iter().map(|q| q.position - r).collect();
        let y: Vec<f64> = fresh.iter().map(|q| q.measurement).collect();
        let mut estimate_failed = false;
        let shift = r - self.last_r;
        self.last_r = r;
        if let Some(f) = self.filter.as_mut() {
            f.predict(dt, p.kalman_b, &shift);
        }
        let ls = if rel.len() > dim {
            least_squares(dim, &rel, &y).ok()
        } else {
            None
        };
        if let Some(ls) = &ls {
            self.noise.observe(ls);
        }
        let sigma_m = p.sigma_m.unwrap_or_else(|| self.noise.sigma());
        if self.filter.is_none() {
            match &ls {
                Some(ls) => self.filter = Some(GradientFilter::new(dim, ls, p.initial_variance)),
                None => estimate_failed = true,
            }
        } else if !fresh.is_empty() {
            let b2 = p.kalman_b * p.kalman_b;
            let var: Vec<f64> = fresh
                .iter()
                .zip(&rel)
                .map(|(q, d)| {
                    let curv = 0.5 * d.dot(&(p.hessian_guess * d)) * p.sigma_h;
                    let age = k.saturating_sub(q.tick) as f64 * dt;
                    sigma_m * sigma_m + curv * curv + b2 * age * (1.0 + d.norm_squared())
                })
                .collect();
            if let Some(f) = self.filter.as_mut() {
                if f.update(&rel, &y, &var).is_err() {
                    estimate_failed = true;
                }
            }
        } else {
            estimate_failed = true;
        }
        let grad_est = self
            .filter
            .as_ref()
            .map(|f| f.grad())
            .unwrap_or_else(Vec3::zeros);

        // Direction of motion (Sec. V): dr/ds = ±∇T_est, saturated to a unit vector above
        // grad_saturation so v0 is a speed in length unit/s.
        let sign = match p.goal {
            Goal::Max => 1.0,
            Goal::Min => -1.0,
        };
        let gnorm = grad_est.norm();
        let dr_ds = if holding || gnorm == 0.0 {
            Vec3::zeros()
        } else {
            grad_est * (sign / gnorm.max(p.grad_saturation))
        };
        // Resolution adaptation dk/ds = -a(k d̄0 - Δd), Δd = k* d̄0 from (V.7) at scale.
        let dk = if p.adapt && !holding {
            let sigma_m = self.sigma_m();
            match optimal_scale(
                &self.design.slots,
                dim,
                &p.hessian_guess,
                p.sigma_h,
                sigma_m,
            ) {
                Ok((k_star, _g)) if k_star.is_finite() => {
                    let d0_bar = self.design.neighbour_spacing();
                    let target = k_star.clamp(p.min_scale, p.max_scale) * d0_bar;
                    dk_ds(self.body.scale, d0_bar, target, p.adapt_gain)
                }
                _ => 0.0,
            }
        } else {
            0.0
        };
        let rates = BodyRates {
            dr_ds,
            omega_ds: Vec3::zeros(),
            dk_ds: dk,
        };

        let positions: Vec<Vec3> = members.iter().map(|q| q.position).collect();
        let velocities: Vec<Vec3> = members.iter().map(|q| q.velocity).collect();
        let mut waiting = 1.0;
        let terms = if rejoining.is_empty() {
            lyapunov_terms(
                &positions,
                &velocities,
                &self.body,
                &rates,
                &self.design,
                p.damping,
            )
        } else {
            // The vehicles rejoining fly the blended law: V, its rates and the power are
            // those of that loop, and the body waits for them.
            let spacing = self.body.scale * self.design.neighbour_spacing();
            let homings: Vec<Option<(Homing, Vec3)>> = members
                .iter()
                .map(|q| {
                    rejoining.iter().find(|(id, _)| *id == q.id).map(|(_, t)| {
                        let h = Homing::towards(
                            &q.position,
                            t,
                            spacing,
                            &self.last_velocity,
                            p.damping,
                            p.v0,
                        );
                        (h, *t)
                    })
                })
                .collect();
            waiting = waiting_factor(&homings);
            blended_lyapunov_terms(
                &positions,
                &velocities,
                &homings,
                &self.body,
                &rates,
                &self.design,
                p.damping,
            )
        };
        let sdot = if holding {
            0.0
        } else {
            waiting * formation_speed(&terms, p.v0, p.v_u, p.delta)
        };

        let command = Command {
            body: self.body,
            sdot,
            velocity: rates.dr_ds * sdot,
            leaders: self.body.leader_positions(&self.design),
            inter: self.body.scaled_inter(&self.design),
            leader: self.body.scaled_leader(&self.design),
            damping: p.damping,
            terms,
            grad_est,
            p_trace: self.filter.as_ref().map_or(0.0, |f| f.covariance().trace()),
            holding,
            estimate_failed,
            reconfigured,
            members: ids,
            rejoining,
        };
        self.last_velocity = command.velocity;
        let mut next = self.body.advance(&rates, sdot * dt);
        next.scale = next.scale.clamp(p.min_scale, p.max_scale);
        if dim == 2 {
            next.r.z = 0.0;
        }
        self.body = next;
        Ok(command)
    }
}
