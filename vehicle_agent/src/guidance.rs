//! What the coordinator tells one vehicle for one step ([`Guidance`]): built from a body
//! command's fields (pure: no IPC); `guidance/snapshot.rs` reads the neighbours from the
//! command's payload.

mod snapshot;

pub use snapshot::{Telling, ToldCommand};

use vbap_math::body::VirtualBody;
use vbap_math::formation::FormationDesign;
use vbap_math::potential::PairPotential;
use vbap_math::schedule::{BodyPlan, BodySchedule};
use vbap_math::Vec3;
use vbap_mission::config::Mission;

/// What the coordinator tells a vehicle for one step: the virtual leaders, the
/// neighbours' last known positions and the (scaled) potentials. The content of a body
/// command as one vehicle sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Guidance {
    /// Tick of the command.
    pub tick: u64,
    /// Virtual leader positions b_l(s), length unit.
    pub leaders: Vec<Vec3>,
    /// Positions of the other members (ordered by id).
    pub neighbours: Vec<Vec3>,
    /// Their ids (same order).
    pub neighbour_ids: Vec<u32>,
    /// Scaled inter-vehicle potential.
    pub inter: PairPotential,
    /// Scaled vehicle–leader potential.
    pub leader: PairPotential,
    /// Damping gain of (II.1), 1/s.
    pub damping: f64,
    /// Velocity of the virtual body, length unit/s: while no newer command is visible, the
    /// vehicle dead-reckons the leaders and its neighbours with it.
    pub velocity: Vec3,
    /// Homing weight σ_j of each neighbour (same order as `neighbours`; 0 unless it
    /// rejoins), `vbap_math::rejoin`.
    pub neighbour_sigmas: Vec<f64>,
    /// Slot of each neighbour that rejoins (same order; its own position otherwise).
    pub neighbour_slots: Vec<Vec3>,
    /// The slot this vehicle flies to while it rejoins, length unit (None: not rejoining).
    pub target: Option<Vec3>,
    /// Last known velocity of each neighbour (same order), length unit/s.
    pub neighbour_velocities: Vec<Vec3>,
    /// Age of the coordinator's information on each neighbour at the command's tick (same
    /// order), s; the vehicle adds the command's own age when it steps on an old command.
    pub neighbour_ages: Vec<f64>,
    /// This vehicle's own slot at the command's tick, length unit (None: the coordinator
    /// sent none; under `control.law = "robust"` it sends every member's).
    pub slot: Option<Vec3>,
    /// Approach speed of the homing law relative to the body, length unit/s: the body's
    /// nominal speed `body.v0`, which every vehicle flies anyway.
    pub rejoin_speed: f64,
    /// The body of the command and its committed path (robust law,
    /// `vbap_math::schedule`): out of contact the vehicle predicts the body from it
    /// instead of dead-reckoning at `velocity` (None: the paper's dead reckoning).
    pub plan: Option<BodyPlan>,
    /// Where the hulls of the lost vehicles are, as the coordinator last knew them (length
    /// unit; they do not move with the body): the robust law keeps clear of them
    /// (`vbap_math::hull`). Empty while nobody is lost.
    pub hulls: Vec<Vec3>,
}

impl Guidance {
    /// The guidance of a body command for the step from tick `tick` (its leaders,
    /// potentials, damping and body velocity; neighbours from [`Guidance::with_neighbours`]),
    /// for a vehicle homing at `rejoin_speed` (length unit/s) when it rejoins.
    #[allow(clippy::too_many_arguments)]
    pub fn of_command(
        tick: u64,
        leaders: Vec<Vec3>,
        inter: PairPotential,
        leader: PairPotential,
        damping: f64,
        velocity: Vec3,
        rejoin_speed: f64,
    ) -> Self {
        Self {
            tick,
            leaders,
            neighbours: Vec::new(),
            neighbour_ids: Vec::new(),
            inter,
            leader,
            damping,
            velocity,
            neighbour_sigmas: Vec::new(),
            neighbour_slots: Vec::new(),
            target: None,
            rejoin_speed,
            neighbour_velocities: Vec::new(),
            neighbour_ages: Vec::new(),
            slot: None,
            plan: None,
            hulls: Vec::new(),
        }
    }

    /// This guidance with the committed path `schedule` of its command, whose body is
    /// centred on `r` at scale `scale` (None: no committed path).
    pub fn with_plan(mut self, schedule: Option<BodySchedule>, r: Vec3, scale: f64) -> Self {
        self.plan = schedule.map(|schedule| BodyPlan {
            tick: self.tick,
            r,
            scale,
            schedule,
        });
        self
    }

    /// The guidance of a vehicle admitted back at tick `tick` (a restarted process) before
    /// its first command reaches it: no leaders and no neighbours, so the law's damping
    /// alone brakes it where it is. [`Guidance::initial`] would pull it, at an age of the
    /// whole outage, towards the leaders of the mission's start: seen in random missions
    /// as a kick of 20 spacings per second and V 2.8 V_U on the first tick after a rejoin.
    pub fn restarted(mission: &Mission, design: &FormationDesign, tick: u64) -> Self {
        Self {
            tick,
            leaders: Vec::new(),
            ..Self::initial(mission, design)
        }
    }

    /// The guidance a vehicle starts with before it hears anything: the leaders of the
    /// initial virtual body (the plan it was deployed with), no neighbours.
    pub fn initial(mission: &Mission, design: &FormationDesign) -> Self {
        let body = VirtualBody {
            s: 0.0,
            r: mission.start_vec(),
            rotation: nalgebra::Rotation3::identity(),
            scale: 1.0,
        };
        Self {
            tick: 0,
            leaders: body.leader_positions(design),
            neighbours: Vec::new(),
            neighbour_ids: Vec::new(),
            inter: body.scaled_inter(design),
            leader: body.scaled_leader(design),
            damping: mission.vehicles.damping,
            velocity: Vec3::zeros(),
            neighbour_sigmas: Vec::new(),
            neighbour_slots: Vec::new(),
            target: None,
            rejoin_speed: mission.body.v0,
            neighbour_velocities: Vec::new(),
            neighbour_ages: Vec::new(),
            slot: None,
            plan: None,
            hulls: Vec::new(),
        }
    }
}
