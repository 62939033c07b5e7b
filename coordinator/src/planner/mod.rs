//! The coordinator's pure step: the formation's membership and design
//! (`redesign`), the gradient estimate (`estimate`), the body's direction and scale
//! rate (`direction`), the Lyapunov function and the formation speed (`speed`).

use std::collections::BTreeMap;

use vbap_math::adapt::NoiseEstimator;
use vbap_math::body::{BodyRates, VirtualBody};
use vbap_math::curvature::CurvatureEstimator;
use vbap_math::drift::DriftEstimator;
use vbap_math::formation::{design_regular, FormationDesign, FormationError};
use vbap_math::kalman::GradientFilter;
use vbap_math::lyapunov::LyapunovTerms;
use vbap_math::potential::PairPotential;
use vbap_math::schedule::{BodySchedule, Segment};
use vbap_math::speed::formation_speed_informed;
use vbap_math::vehicle::{BodyLimits, GliderLimits};
use vbap_math::{Mat3, Vec3};
use vbap_mission::config::{
    CurvatureSource, Goal, LawKind, Mission, DEFAULT_MAX_ACCEL, DEFAULT_MAX_SPEED,
    DEFAULT_MAX_TURN_RATE,
};

mod commit;
mod direction;
mod drift;
mod estimate;
mod redesign;
mod speed;

use direction::direction;

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

/// What a vehicle says of itself besides its true state (beyond the paper: a glider
/// under water knows its position only by dead reckoning): the planner is given these
/// instead of the truth of the [`Report`]; the run files keep both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Told {
    /// Vehicle id.
    pub id: u32,
    /// Believed position, length unit.
    pub position: Vec3,
    /// Velocity through the water, length unit/s (the velocity it reports).
    pub water: Vec3,
    /// The current at its true position, length unit/s (for the run files only).
    pub current: Vec3,
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
    /// `control.law`: the paper's planner, or the one built for real links.
    pub law: LawKind,
    /// Plan horizon in ticks (robust law; 0: no committed path, the paper's planner),
    /// `Mission::plan_horizon_ticks`.
    #[serde(default)]
    pub plan_ticks: u64,
    /// True when the mission configures `formation.hessian_guess` (the identity stands in
    /// otherwise): only a configured curvature predicts the gradient ahead of the plan.
    #[serde(default)]
    pub hessian_configured: bool,
    /// `control.curvature`: the Hessian of (V.6) under the robust law.
    #[serde(default)]
    pub curvature: CurvatureSource,
    /// `control.curvature_memory`, design spacings of travel.
    #[serde(default = "default_curvature_memory")]
    pub curvature_memory: f64,
    /// `[land]`: the body centre never enters it (beyond the paper; none by default).
    #[serde(default)]
    pub land: Option<vbap_mission::land::AnalyticLand>,
    /// The envelope's bound on the adaptation rate (`vbap_math::envelope`): |dk/dt| ≤
    /// `.0 / k` and ≤ `.1` (None: unbounded; only the robust law over impaired links).
    #[serde(default)]
    pub scale_rate_bound: Option<(f64, f64)>,
    /// The land of a gridded field (loaded with the mission; not in the checkpoint:
    /// [`Planner::attach_land`] gives it back to a restored plan). Wins over `land`.
    #[serde(skip)]
    pub grid_land: vbap_mission::land::LandRef,
    /// `body.track_drift` in force: the robust law on a field that may move
    /// (`Mission::field_may_move`); the drift estimate and its feed-forward ([`drift`]).
    #[serde(default)]
    pub track_drift: bool,
    /// The body's speed budget, length unit/s: v0, and for gliders at most
    /// `Mission::speed_budget` (only the drift's feed-forward is bounded by it).
    #[serde(default)]
    pub speed_budget: f64,
    /// How fast the body may turn and speed up so that gliders follow it
    /// (`vbap_math::vehicle::BodyLimits`): the robust law with the glider model; None
    /// otherwise (the paper's vehicle follows any body).
    #[serde(default)]
    pub body_limits: Option<BodyLimits>,
}

fn default_curvature_memory() -> f64 {
    0.25
}

impl PlannerParams {
    /// The planner's view of a mission (no ground truth in here).
    pub fn from_mission(m: &Mission) -> Self {
        let held = m.held_envelope();
        // Every slot of a regular design is at the formation's radius (scale 1).
        let radius = m.formation.radius;
        Self {
            dim: m.formation_dim(),
            goal: m.mission.goal,
            radius: m.formation.radius,
            alpha: m.formation.alpha,
            damping: m.vehicles.damping,
            adapt: m.formation.adapt,
            adapt_gain: m.formation.adapt_gain,
            min_scale: m.scale_floor(held.as_ref()),
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
            law: m.control.law,
            plan_ticks: m.plan_horizon_ticks(),
            hessian_configured: m.formation.hessian_guess.is_some(),
            curvature: m.control.curvature,
            curvature_memory: m.control.curvature_memory,
            land: vbap_mission::land::analytic_land(&m.land, f64::INFINITY),
            scale_rate_bound: held
                .as_ref()
                .map(|e| (e.scale_rate_times_k, e.slot_speed / radius)),
            grid_land: vbap_mission::loaded::Loaded(m.land()),
            track_drift: m.body.track_drift
                && m.control.law == LawKind::Robust
                && m.field_may_move(),
            speed_budget: m.body.v0.min(m.speed_budget().unwrap_or(f64::INFINITY)),
            body_limits: body_limits(m),
        }
    }
}

/// The limits of the body's motion for the gliders of `m` under the robust law
/// ([`PlannerParams::body_limits`]).
fn body_limits(m: &Mission) -> Option<BodyLimits> {
    let v = &m.vehicles;
    if m.control.law != LawKind::Robust || v.model.is_ideal() {
        return None;
    }
    let gliders = GliderLimits {
        max_speed: m.speed_budget().unwrap_or(DEFAULT_MAX_SPEED),
        max_accel: v.max_accel.unwrap_or(DEFAULT_MAX_ACCEL),
        max_turn_rate: v.max_turn_rate.unwrap_or(DEFAULT_MAX_TURN_RATE),
    };
    BodyLimits::for_gliders(&gliders, m.body.v0)
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
    /// contact dead-reckon the body with it. Under a committed path (robust law), the
    /// velocity of the segment in force, and `sdot` the ṡ of that segment.
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
    /// The committed body path from this tick on (robust law with a plan horizon; None
    /// otherwise), `vbap_math::schedule`: `body` follows it.
    pub schedule: Option<BodySchedule>,
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
    /// Where the vehicles the fleet has lost were last heard of (their hulls, length
    /// unit), told before each step ([`Planner::see_hulls`]): a returning vehicle is not
    /// given a hole with a hull in it. Not in the checkpoint: told again every tick.
    #[serde(skip)]
    hulls: Vec<Vec3>,
    /// Turn of the slots about the body's z axis (rad) that follows the settled members of
    /// a 2-D central design (`vbap_math::rejoin::fit_turn`).
    #[serde(default)]
    turn: f64,
    /// Velocity of the body centre in the last command, length unit/s: the feed-forward
    /// of the rejoining vehicles' homing as the planner models it.
    #[serde(default = "Vec3::zeros")]
    last_velocity: Vec3,
    /// The body velocity dr/ds·ṡ of the last decision (length unit/s), from which
    /// [`PlannerParams::body_limits`] bound the next.
    last_decision: Vec3,
    /// The scale rate dk/dt of the last decision, 1/s (without a committed path).
    #[serde(default)]
    last_scale_rate: f64,
    /// The members' slots (by id, indices into the design) last given to them
    /// (`crate::slots::member_slots`): kept in the checkpoint so that a restarted
    /// coordinator assigns as the one that died would have.
    #[serde(default)]
    held_slots: BTreeMap<u32, usize>,
    /// The committed body path (robust law with a plan horizon; None otherwise).
    #[serde(default)]
    schedule: Option<BodySchedule>,
    /// Under a schedule: the body's scale at each tick a segment came into force, and that
    /// segment, back to the oldest report in use (the past of the committed path).
    #[serde(default)]
    committed: BTreeMap<u64, (f64, Segment)>,
    /// True from a bumpless redesign (law robust) until the coordinator's V is back at or
    /// below V_U: the body holds meanwhile (`redesign`).
    #[serde(default)]
    settling: bool,
    /// The online curvature estimate (law robust, `control.curvature = "estimated"`).
    #[serde(default)]
    curvature: Option<CurvatureEstimator>,
    /// The field's drift estimate (`body.track_drift` in force; None otherwise).
    #[serde(default)]
    drift: Option<DriftEstimator>,
    /// The sum of the jumps of the body centre `r` at bumpless redesigns (length unit):
    /// `r − jumps` moves only with the body's motion ([`Planner::motion_point`]).
    #[serde(default = "Vec3::zeros")]
    jumps: Vec3,
    /// Under law robust, once vehicles were lost: the design the formation had before
    /// (`design` is it with the slots `holes` left empty, `FormationDesign::without_slots`).
    #[serde(default)]
    base: Option<FormationDesign>,
    /// The empty slots of `base` (indices), ascending.
    #[serde(default)]
    holes: Vec<usize>,
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
        let schedule = BodySchedule::at_rest(params.plan_ticks);
        let committed = match schedule {
            Some(_) => BTreeMap::from([(0, (1.0, Segment::REST))]),
            None => BTreeMap::new(),
        };
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
            hulls: Vec::new(),
            turn: 0.0,
            last_velocity: Vec3::zeros(),
            last_decision: Vec3::zeros(),
            last_scale_rate: 0.0,
            held_slots: BTreeMap::new(),
            schedule,
            committed,
            settling: false,
            curvature: None,
            drift: None,
            jumps: Vec3::zeros(),
            base: None,
            holes: Vec::new(),
        })
    }

    /// The current virtual body.
    pub fn body(&self) -> &VirtualBody {
        &self.body
    }
    /// The body centre less its jumps at bumpless redesigns (length unit): it moves with
    /// the body's motion only, as the members do. A member out of contact is dead-reckoned
    /// by its change since the member's report (`Fleet::track_body`); by `r` itself, a
    /// redesign that lays the body 3 L away would move every stale report 3 L, onto other
    /// vehicles (a robust-law vehicle then felt a neighbour 0.5 L away that was 4 L away).
    pub fn motion_point(&self) -> Vec3 {
        self.body.r - self.jumps
    }
    /// The current formation design.
    pub fn design(&self) -> &FormationDesign {
        &self.design
    }
    /// Every member's slot for `command` (`crate::slots::member_slots`), keeping the
    /// assignment of the last call where it still holds.
    pub fn member_slots(&mut self, command: &Command, members: &[Report]) -> Vec<(u32, Vec3)> {
        crate::slots::member_slots(&self.design, &mut self.held_slots, command, members)
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
    /// The law the fleet flies (`control.law`).
    pub fn law(&self) -> LawKind {
        self.params.law
    }

    /// Where the vehicles the fleet has lost were last heard of (`Fleet::hulls`, length
    /// unit), for the next [`Planner::step`]: a hull stays in the water, and a process
    /// restarted there comes back there, so no returning vehicle is given the hole it
    /// sits in.
    pub fn see_hulls(&mut self, hulls: &[Vec3]) {
        self.hulls.clear();
        self.hulls.extend_from_slice(hulls);
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
        let oldest = members.iter().map(|q| q.tick).min().unwrap_or(k);
        let predicted = self.predicted_members(k, members, dt);
        let members = predicted.as_deref().unwrap_or(members);
        let ids: Vec<u32> = members.iter().map(|r| r.id).collect();
        let reconfigured = self.redesign(members, &ids, joined)?;
        self.bring_back_out_of_reach(members);
        let holding = members.len() < self.params.dim + 1;
        let rejoining = Self::update_rejoining(
            &mut self.rejoining,
            &mut self.turn,
            &self.design,
            &self.body,
            members,
            &self.hulls,
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
        let (grad_est, estimate_failed) = self.estimate(k, fresh, dt);
        self.observe_drift(k, dt);
        let p = &self.params;
        let mut dr_ds = direction(
            &self.gradient_ahead(&grad_est, k, dt),
            p.goal,
            p.grad_saturation,
            holding,
        );
        if let Some(limits) = &p.body_limits {
            dr_ds = limits.turn(&self.last_decision, &dr_ds, dt);
        }
        let rates = BodyRates {
            dr_ds,
            omega_ds: Vec3::zeros(),
            dk_ds: self.scale_rate(holding, self.decision_scale(k, dt)),
        };
        let (terms, waiting) = self.lyapunov(members, &rejoining, &rates);
        let confidence = self.confidence(k, oldest, dt);
        let p = &self.params;
        let sdot = if holding {
            0.0
        } else {
            waiting * formation_speed_informed(&terms, p.v0, p.v_u, p.delta, confidence)
        };
        let sdot = self.hold_until_settled(terms.v, sdot);
        let sdot = match &self.params.body_limits {
            Some(limits) if rates.dr_ds.norm() > 0.0 => {
                let most = limits.speed_after(self.last_decision.norm(), dt);
                sdot.min(most / rates.dr_ds.norm())
            }
            _ => sdot,
        };
        let rates = match &self.params.body_limits {
            Some(limits) => BodyRates {
                dk_ds: self.growth_limited(limits, rates.dk_ds, sdot, dt),
                ..rates
            },
            None => rates,
        };
        self.last_decision = rates.dr_ds * sdot;
        self.last_scale_rate = rates.dk_ds * sdot;
        let drift = self.drift_feed_forward(&(rates.dr_ds * sdot), holding);
        let in_force = self.commit(k, &rates, sdot, drift, oldest, dt);
        let (sdot_now, velocity) = match (in_force, drift) {
            (Some(seg), _) => (seg.sdot, seg.velocity),
            (None, None) => (sdot, rates.dr_ds * sdot),
            (None, Some(d)) => (sdot, rates.dr_ds * sdot + d),
        };
        let p = &self.params;

        let command = Command {
            body: self.body,
            sdot: sdot_now,
            velocity,
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
            schedule: self.schedule.clone(),
        };
        self.last_velocity = command.velocity;
        let next = match in_force {
            Some(seg) => self.advanced_committed(&seg, dt),
            None => self.advanced(&rates, sdot * dt, drift.map(|d| d * dt)),
        };
        self.body = self.off_land(next);
        Ok(command)
    }

    /// `next` with its centre kept off `[land]` (beyond the paper): a move of the centre
    /// that would end on land keeps only its part along the coast, or stops
    /// (`vbap_math::vehicle::land::slide`). Under a committed path the vehicles out of
    /// contact still predict the path as committed until the next command reaches them.
    fn off_land(&self, mut next: VirtualBody) -> VirtualBody {
        use vbap_mission::land::LandMask;
        let land: &dyn LandMask = match (&self.params.grid_land.0, &self.params.land) {
            (Some(grid), _) => grid.as_ref(),
            (None, Some(analytic)) => analytic,
            (None, None) => return next,
        };
        let from = self.body.r;
        next.r = vbap_math::vehicle::land::slide(
            &from,
            &next.r,
            |p| land.is_land(p),
            land.clearance(&from).map(|c| c.1),
        );
        next
    }

    /// Gives a plan restored from a checkpoint the land of its mission's gridded field,
    /// which the checkpoint does not keep.
    pub fn attach_land(&mut self, mission: &Mission) {
        self.params.grid_land = vbap_mission::loaded::Loaded(mission.land());
    }

    /// `dk_ds` bounded so that the slots' speed from the body's growth, |dk/dt|·|p̄_i|
    /// ((III.3) differentiated in time), rises no faster than `limits` let the body's
    /// centre speed up: from the last decision's dk/dt by at most `max_accel · Δt / max|p̄_i|`
    /// (Δt: the tick, or under a committed path the segment; speed `sdot`, tick length
    /// `dt` s). Gliders that must turn outwards to follow a
    /// formation that starts to grow at full rate lag it as they lag a body that sets off
    /// at full speed (`vbap_math::vehicle::BodyLimits`); slowing the growth is not limited.
    fn growth_limited(&self, limits: &BodyLimits, dk_ds: f64, sdot: f64, dt: f64) -> f64 {
        let reach = self.design.extent();
        let wanted = dk_ds * sdot;
        if reach <= 0.0 || sdot <= 0.0 {
            return dk_ds;
        }
        // Under a committed path a decision is compared with the last one committed, one
        // segment earlier; else with the last tick's.
        let (last, span) = match &self.schedule {
            Some(s) => (
                s.segments.last().map_or(0.0, |g| g.scale_rate),
                s.seg_ticks as f64 * dt,
            ),
            None => (self.last_scale_rate, dt),
        };
        let most = last.abs() + limits.max_accel * span / reach;
        if wanted.abs() <= most {
            dk_ds
        } else {
            most.copysign(wanted) / sdot
        }
    }

    /// The body of the next tick: moved by `ds` along `rates` ((III.4), (V.7)) and by
    /// `carried` (the drift's feed-forward over the tick, length unit), its scale kept
    /// within [min_scale, max_scale], its centre in the plane z = 0 in 2-D.
    fn advanced(&self, rates: &BodyRates, ds: f64, carried: Option<Vec3>) -> VirtualBody {
        let p = &self.params;
        let mut next = self.body.advance(rates, ds);
        if let Some(c) = carried {
            next.r += c;
        }
        next.scale = next.scale.clamp(p.min_scale, p.max_scale);
        if p.dim == 2 {
            next.r.z = 0.0;
        }
        next
    }
}
