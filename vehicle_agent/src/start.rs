//! What the mission file says a vehicle starts with and flies: its control law, the
//! initial formation design and its initial state (pure: no IPC).

use std::sync::Arc;

use rand::Rng;
use vbap_math::body::{BodyRates, VirtualBody};
use vbap_math::formation::FormationDesign;
use vbap_math::law::{ControlLaw, PaperLaw, RobustLaw};
use vbap_math::lyapunov::lyapunov_terms;
use vbap_math::rng::{keyed, Stream};
use vbap_math::Vec3;
use vbap_mission::config::{LawKind, Mission};

use crate::Agent;

/// The control law the shipped binaries fly for `mission`: [`RobustLaw`] (with the memory
/// `control.neighbour_memory`) under `control.law = "robust"`, [`PaperLaw`] otherwise.
pub fn mission_law(mission: &Mission) -> Arc<dyn ControlLaw> {
    match mission.control.law {
        LawKind::Paper => Arc::new(PaperLaw),
        LawKind::Robust => Arc::new(
            RobustLaw::new(mission.control.neighbour_memory).following(mission.follows_body()),
        ),
    }
}

/// The initial formation design of a mission (before any loss): regular polygon /
/// Platonic solid of the mission's radius around one central leader.
pub fn initial_design(
    mission: &Mission,
) -> Result<FormationDesign, vbap_math::formation::FormationError> {
    mission.formation_design()
}

/// The initial state of vehicle `id`: its slot of the initial design around
/// `vehicles.start`, displaced by at most `vehicles.start_spread` in a direction and by an
/// amount drawn from the key (seed, InitialPosition, id, 0); at rest.
pub fn initial_agent(mission: &Mission, design: &FormationDesign, id: u32) -> Agent {
    let dim = mission.mission.dim;
    let slot = design
        .slots
        .get(id as usize)
        .copied()
        .unwrap_or_else(Vec3::zeros);
    let mut rng = keyed(
        mission.mission.seed,
        Stream::InitialPosition,
        u64::from(id),
        0,
    );
    // Uniform in the unit disc / ball by rejection (a bounded number of draws in practice).
    let offset = loop {
        let mut o = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if dim == 2 {
            o.z = 0.0;
        }
        if o.norm_squared() <= 1.0 {
            break o;
        }
    };
    let mut position = mission.start_vec() + slot + offset * mission.vehicles.start_spread;
    if dim == 2 {
        position.z = 0.0;
    }
    Agent {
        id,
        dim,
        position,
        velocity: Vec3::zeros(),
    }
}

/// `V(x(t0), s(t0))` of (II.2): the Lyapunov function at the mission's start, every vehicle
/// at its [`initial_agent`] state (at rest), the body at `vehicles.start` at scale 1,
/// energy per unit mass. Theorem 4.1 bounds V by `V_U` only from a start with
/// `V(0) ≤ V_U`; `vbap check` warns when it is above. `None` when the formation cannot be
/// designed, or for a diving mission (its formation is the horizontal one of a 3-D start).
pub fn initial_lyapunov(mission: &Mission) -> Option<f64> {
    if mission.diving() {
        return None;
    }
    let design = initial_design(mission).ok()?;
    let positions: Vec<Vec3> = (0..mission.vehicles.count as u32)
        .map(|id| initial_agent(mission, &design, id).position)
        .collect();
    let velocities = vec![Vec3::zeros(); positions.len()];
    let body = VirtualBody::at(mission.start_vec());
    let terms = lyapunov_terms(
        &positions,
        &velocities,
        &body,
        &BodyRates::zero(),
        &design,
        mission.vehicles.damping,
    );
    Some(terms.v)
}

/// A warning when the mission starts above its bound (`V(0) > body.v_u`,
/// [`initial_lyapunov`]), naming the seed and the keys that change it; `None` otherwise.
pub fn initial_lyapunov_warning(mission: &Mission) -> Option<String> {
    let v0 = initial_lyapunov(mission)?;
    let v_u = mission.body.v_u;
    (v0 > v_u).then(|| {
        format!(
            "{}: the formation starts above its bound: V(0) = {v0:.4} = {:.2} × body.v_u \
             (mission.seed = {}); Theorem 4.1 keeps V ≤ V_U only from a start below it, and \
             V sums a term over every pair of vehicles (N(N−1)/2 = {}): raise body.v_u above \
             {v0:.4}, or lower vehicles.start_spread",
            mission.origin,
            v0 / v_u,
            mission.mission.seed,
            mission.vehicles.count * (mission.vehicles.count - 1) / 2
        )
    })
}
