//! How a vehicle moves when the mission goes beyond the paper's ideal vehicle
//! (`[vehicles] model = "glider"`, a `[current]`, `[land]`): the control u_i of the law
//! acts on what the vehicle knows (its believed position, its velocity through the
//! water), the land term of `vbap_math::vehicle::land` is added, and
//! `vbap_math::vehicle::advance` moves the truth (carried by the current, kept off land)
//! and the belief (dead reckoning). A glider's belief is reset to the truth by a GPS fix
//! ([`Kinematics::fix_at`]). The simulator and the agent process both step through here.

use std::sync::Arc;

use vbap_math::law::{ControlInputs, ControlLaw};
use vbap_math::vehicle::dive::Dive;
use vbap_math::vehicle::land::{repulsion, slide, Avoidance};
use vbap_math::vehicle::{advance, GliderLimits, Motion, VehicleModel};
use vbap_math::Vec3;
use vbap_mission::config::{
    Mission, VehicleModelKind, DEFAULT_DIVE_RATE, DEFAULT_MAX_ACCEL, DEFAULT_MAX_SPEED,
    DEFAULT_MAX_TURN_RATE,
};
use vbap_mission::current::{current_of, CurrentField};
use vbap_mission::land::{avoid_distance, avoid_gain, land_of, LandMask};
use vbap_mission::link::LinkModel;

use crate::Agent;

/// The motion rules of a mission, shared by all its vehicles.
#[derive(Debug)]
pub struct Kinematics {
    /// How u_i moves a vehicle through the water.
    pub model: VehicleModel,
    /// True for a glider: it knows its position only at a fix.
    pub dead_reckoning: bool,
    /// `vehicles.fix_period`, s (None: fixes while at the surface by `surfacing`).
    pub fix_period: Option<f64>,
    /// The link model, for its surfacing schedule.
    pub surfacing: LinkModel,
    /// The current (None: still water).
    pub current: Option<Arc<dyn CurrentField>>,
    /// The land (None: no land).
    pub land: Option<Arc<dyn LandMask>>,
    /// The repulsive term near land.
    pub avoidance: Avoidance,
    /// `vehicles.current_estimate`: a glider estimates the current from the drift found at
    /// each fix and dead-reckons with it.
    pub estimate_current: bool,
    /// Mission dimension.
    pub dim: usize,
    /// `vehicles.dive_depth`: the sawtooth dive z follows (3-D gliders; None: z is the
    /// law's). With it `model` keeps the horizontal speed within √(max² − rate²).
    pub dive: Option<Dive>,
}

impl Kinematics {
    /// The motion rules of `mission`; None for the paper's ideal vehicle in still water
    /// without land, which moves exactly as before (`Agent::step_with`).
    pub fn of(mission: &Mission) -> Option<Arc<Self>> {
        Self::with(mission, current_of(mission), land_of(mission))
    }

    /// [`Kinematics::of`] with the current and the land given (a gridded current or a
    /// land mask read from data).
    pub fn with(
        mission: &Mission,
        current: Option<Arc<dyn CurrentField>>,
        land: Option<Arc<dyn LandMask>>,
    ) -> Option<Arc<Self>> {
        let v = &mission.vehicles;
        let dive = v.dive_depth.map(|depth| Dive {
            depth,
            rate: v.dive_rate.unwrap_or(DEFAULT_DIVE_RATE),
        });
        let max_speed = v.max_speed.unwrap_or(DEFAULT_MAX_SPEED);
        let model = match v.model {
            VehicleModelKind::Ideal => VehicleModel::Ideal,
            VehicleModelKind::Glider => VehicleModel::Glider(GliderLimits {
                // Diving, the speed through the water is the horizontal one and the dive's.
                max_speed: dive.map_or(max_speed, |d| (max_speed.powi(2) - d.rate.powi(2)).sqrt()),
                max_accel: v.max_accel.unwrap_or(DEFAULT_MAX_ACCEL),
                max_turn_rate: v.max_turn_rate.unwrap_or(DEFAULT_MAX_TURN_RATE),
            }),
        };
        if model == VehicleModel::Ideal && current.is_none() && land.is_none() {
            return None;
        }
        Some(Arc::new(Self {
            model,
            dead_reckoning: v.model == VehicleModelKind::Glider,
            fix_period: v.fix_period,
            surfacing: LinkModel::new(mission),
            current,
            land,
            avoidance: Avoidance {
                distance: avoid_distance(mission),
                gain: avoid_gain(mission),
            },
            estimate_current: v.estimates_current(),
            dim: mission.mission.dim,
            dive,
        }))
    }

    /// True when vehicle `id` gets a GPS fix at tick `k` (tick length `dt`, s): with
    /// `fix_period` at the first tick of every period; else while at the surface by the
    /// links' surfacing schedule (always, without one). A vehicle that does not
    /// dead-reckon always knows its position.
    pub fn fix_at(&self, id: u32, k: u64, dt: f64) -> bool {
        if !self.dead_reckoning {
            return true;
        }
        if let Some(d) = &self.dive {
            return d.at_surface(k, dt);
        }
        let t = k as f64 * dt;
        match self.fix_period {
            Some(p) => (t % p) < dt * (1.0 - 1e-9) || k == 0,
            None => self.surfacing.at_surface(id, t),
        }
    }

    /// The current at `p` (length unit) and time `t` (s), zero in still water.
    pub fn current_at(&self, p: &Vec3, t: f64) -> Vec3 {
        let mut c = self
            .current
            .as_ref()
            .map_or_else(Vec3::zeros, |c| c.velocity(p, t));
        if self.dim == 2 {
            c.z = 0.0;
        }
        c
    }
}

/// What a vehicle beyond the ideal one knows and feels, besides its true state.
#[derive(Clone, Debug)]
pub struct Moving {
    /// The mission's motion rules.
    pub kin: Arc<Kinematics>,
    /// Believed position, length unit.
    pub belief: Vec3,
    /// Velocity through the water, length unit/s.
    pub water: Vec3,
    /// The current at the true position and the time of the state, length unit/s.
    pub current: Vec3,
    /// The vehicle's own estimate of the current (`vehicles.current_estimate`; zero
    /// otherwise), length unit/s.
    pub estimate: Vec3,
    /// Time since the last fix, s.
    pub since_fix: f64,
}

impl Moving {
    /// A vehicle of `agent`'s true state at tick `k` (tick length `dt`): it knows where it
    /// is (deployed or restarted with a fix). Deployed (k = 0) it is at rest in the water,
    /// drifting with the current (`agent`'s velocity becomes the current); restarted, its
    /// water velocity is its velocity less the current there.
    ///
    /// With `vehicles.current_estimate` it starts with the current where it is as its
    /// estimate: at the surface its GPS gives its ground velocity, and the difference to
    /// its velocity through the water (zero when just deployed, its own log when restarted)
    /// is the surface drift, as a glider measures it before its first dive. Without it the
    /// first dive is flown blind: the whole formation drifts a dive's current (2.7 spacings
    /// in `dive3d`) from the body before the first fix can say so.
    pub fn start(kin: Arc<Kinematics>, agent: &mut Agent, k: u64, dt: f64) -> Self {
        if let Some(d) = &kin.dive {
            agent.position.z = d.z(k as f64 * dt);
        }
        let current = kin.current_at(&agent.position, k as f64 * dt);
        if k == 0 {
            agent.velocity = current;
        }
        Self {
            belief: agent.position,
            water: agent.velocity - current,
            current,
            estimate: if kin.estimate_current {
                current
            } else {
                Vec3::zeros()
            },
            kin,
            since_fix: 0.0,
        }
    }

    /// One step from tick `k` of `agent` (its true state) under `law` with `inputs`:
    /// u_i from the belief and the water velocity plus the land term at the belief, then
    /// `vbap_math::vehicle::advance`; the belief is reset at a fix of tick k + 1.
    /// Returns u_i.
    pub fn step(
        &mut self,
        agent: &mut Agent,
        law: &dyn ControlLaw,
        inputs: &ControlInputs<'_>,
        k: u64,
        dt: f64,
    ) -> Vec3 {
        let kin = self.kin.clone();
        let land = kin.land.as_deref();
        // The law is given the velocity through the water; what it knows of the current
        // lets a law that damps relative to its slot do so over the ground.
        let inputs = &ControlInputs {
            current: self.estimate,
            ..*inputs
        };
        // A glider steers for where it would stop, so that it brakes in time for its slot
        // (`VehicleModel::braking_point`): relative to its slot over the ground, never
        // past half the distance to its nearest leader or neighbour at equilibrium.
        let reach = 0.5 * inputs.leader.d0.min(inputs.inter.d0);
        let ahead = kin.model.braking_point(
            &self.belief,
            &(self.water - inputs.follow_velocity()),
            reach,
        );
        let mut u = if kin.dive.is_some() {
            // A diving glider flies a horizontal formation (`Mission::formation_dim`): the
            // law sees it in the formation's plane, where the leaders and the neighbours are.
            let flat = |v: &Vec3| Vec3::new(v.x, v.y, 0.0);
            law.control(&flat(&ahead), &flat(&self.water), inputs)
        } else {
            law.control(&ahead, &self.water, inputs)
        };
        if let Some(l) = land {
            u += repulsion(l.clearance(&self.belief), &kin.avoidance);
        }
        if kin.dive.is_some() {
            // z is the dive's: the law steers in the horizontal plane only.
            u.z = 0.0;
            self.water.z = 0.0;
        }
        let before = Motion {
            position: agent.position,
            belief: self.belief,
            water: self.water,
            ground: agent.velocity,
        };
        let mut next = advance(
            &kin.model,
            &before,
            &u,
            &self.current,
            dt,
            kin.dim,
            |from, to| match land {
                Some(l) => slide(from, to, |p| l.is_land(p), l.clearance(from).map(|c| c.1)),
                None => *to,
            },
        );
        if let Some(d) = &kin.dive {
            // The profile sets z (a depth sensor: the belief knows it); a vertical current
            // does not move a diving glider off it.
            let z = d.z((k + 1) as f64 * dt);
            let vz = d.vz(k as f64 * dt);
            next.position.z = z;
            next.belief.z = z;
            next.water.z = vz;
            next.ground.z = vz;
        }
        agent.position = next.position;
        agent.velocity = next.ground;
        self.water = next.water;
        // Dead reckoning with the current as estimated (zero unless estimated).
        let reckoned = next.belief + self.estimate * dt;
        self.since_fix += dt;
        self.belief = if kin.fix_at(agent.id, k + 1, dt) {
            if kin.estimate_current {
                // The drift found at the fix is the current not yet accounted for, averaged
                // over the time since the last fix (as gliders estimate the depth-averaged
                // current from a dive).
                self.estimate += (next.position - reckoned) / self.since_fix;
            }
            self.since_fix = 0.0;
            next.position
        } else {
            reckoned
        };
        self.current = kin.current_at(&agent.position, (k + 1) as f64 * dt);
        u
    }
}
