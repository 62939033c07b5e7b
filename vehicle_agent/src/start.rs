//! What the mission file says a vehicle starts with and flies: its control law, the
//! initial formation design and its initial state (pure: no IPC).

use std::sync::Arc;

use rand::Rng;
use vbap_math::formation::FormationDesign;
use vbap_math::law::{ControlLaw, PaperLaw, RobustLaw};
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
    vbap_math::formation::design_regular(
        mission.vehicles.count,
        mission.formation_dim(),
        mission.formation.radius,
        mission.formation.alpha,
        mission.formation.alpha,
    )
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
