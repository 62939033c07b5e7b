//! The missions the bench flies: the paper's at any N and the glider mission, from the
//! shipped mission files (embedded), each with a fresh name.

use anyhow::Result;
use vbap_mission::config::{Mission, Pace};

use super::peer::unique_name;

/// The paper's mission (deploy/missions/paper.toml), with N vehicles on a polygon whose
/// edge is that of the paper's optimal square (radius 1.229 for N = 4), so neighbours
/// keep the paper's spacing at every N.
pub fn paper_mission(n: usize, duration: f64, dt: f64, pace: Pace) -> Result<Mission> {
    const PAPER: &str = include_str!("../../deploy/missions/paper.toml");
    let mut m = Mission::from_toml_str(PAPER, "deploy/missions/paper.toml (embedded)")?;
    let edge = 2.0 * m.formation.radius * (std::f64::consts::PI / 4.0).sin();
    m.mission.name = unique_name("p");
    m.vehicles.count = n;
    m.formation.radius = edge / (2.0 * (std::f64::consts::PI / n as f64).sin());
    m.mission.duration = duration;
    m.mission.dt = dt;
    m.mission.pace = pace;
    m.validate()?;
    Ok(m)
}

/// The glider mission (deploy/missions/glider.toml), `n` gliders, lockstep, surfacing.
pub fn glider_mission(n: usize, duration: f64, period: f64, window: f64) -> Result<Mission> {
    const GLIDER: &str = include_str!("../../deploy/missions/glider.toml");
    let mut m = Mission::from_toml_str(GLIDER, "deploy/missions/glider.toml (embedded)")?;
    m.mission.name = unique_name("g");
    m.vehicles.count = n;
    m.mission.duration = duration;
    m.mission.pace = Pace::Lockstep;
    m.links.surfacing_period = period;
    m.links.surfacing_window = window;
    m.validate()?;
    Ok(m)
}
