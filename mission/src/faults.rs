//! Scheduled faults of a mission (`[[faults]]`, docs/ARCHITECTURE.md §8), as ticks and pure functions.
//!
//! `kill` at time t means: the vehicle is gone from tick ⌈t/dt⌉ on (its last report is
//! the one of the tick before); with `until`, it is admitted back at tick ⌈until/dt⌉ at
//! its last known state. `link_down` lives in the link model ([`crate::link`]). Sensor
//! faults change what the vehicle's sensor reports, not the field.

use crate::config::{FaultKind, Mission};

/// The first tick at or after mission time `t`.
pub fn tick_at(t: f64, dt: f64) -> u64 {
    (t / dt - 1e-9).ceil().max(0.0) as u64
}

/// A scheduled kill.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kill {
    /// The vehicle.
    pub vehicle: u32,
    /// First tick without it.
    pub tick: u64,
    /// Tick it is admitted back, if it is restarted.
    pub restart: Option<u64>,
}

/// A sensor fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorFault {
    /// The vehicle.
    pub vehicle: u32,
    /// Active from this mission time (s)...
    pub from: f64,
    /// ...until this one (s, exclusive).
    pub until: f64,
    /// What the sensor does.
    pub kind: SensorFaultKind,
}

/// What a faulty sensor does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SensorFaultKind {
    /// Reads this value, or its last good reading when `None`.
    Stuck(Option<f64>),
    /// Reads T + bias.
    Bias(f64),
}

/// Memory of a sensor (for "stuck at the last reading").
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorState {
    /// Last reading taken while no fault was active.
    pub last_good: Option<f64>,
}

/// Every scheduled fault of a mission, in ticks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaultPlan {
    /// Kills, in file order.
    pub kills: Vec<Kill>,
    /// Sensor faults, in file order.
    pub sensors: Vec<SensorFault>,
}

impl FaultPlan {
    /// The plan of `mission`.
    pub fn new(mission: &Mission) -> Self {
        let dt = mission.mission.dt;
        let mut plan = Self::default();
        for f in &mission.faults {
            match f.kind {
                FaultKind::Kill => plan.kills.push(Kill {
                    vehicle: f.vehicle,
                    tick: tick_at(f.at, dt),
                    restart: f.until.map(|u| tick_at(u, dt)),
                }),
                FaultKind::SensorStuck | FaultKind::SensorBias => plan.sensors.push(SensorFault {
                    vehicle: f.vehicle,
                    from: f.at,
                    until: f.until.unwrap_or(f64::INFINITY),
                    kind: if f.kind == FaultKind::SensorStuck {
                        SensorFaultKind::Stuck(f.value)
                    } else {
                        SensorFaultKind::Bias(f.value.unwrap_or(0.0))
                    },
                }),
                FaultKind::LinkDown => {}
            }
        }
        plan
    }

    /// Vehicles killed at tick `k`.
    pub fn kills_at(&self, k: u64) -> impl Iterator<Item = u32> + '_ {
        self.kills
            .iter()
            .filter(move |x| x.tick == k)
            .map(|x| x.vehicle)
    }

    /// Vehicles admitted back at tick `k`.
    pub fn restarts_at(&self, k: u64) -> impl Iterator<Item = u32> + '_ {
        self.kills
            .iter()
            .filter(move |x| x.restart == Some(k))
            .map(|x| x.vehicle)
    }

    /// True when vehicle `v` has a scheduled restart after tick `k`.
    pub fn restart_pending(&self, v: u32, k: u64) -> bool {
        self.kills
            .iter()
            .any(|x| x.vehicle == v && x.restart.is_some_and(|r| r > k))
    }

    /// What vehicle `v`'s sensor reports at mission time `t` when the field reads `raw`.
    pub fn sensor(&self, v: u32, t: f64, raw: f64, state: &mut SensorState) -> f64 {
        let active = self
            .sensors
            .iter()
            .find(|f| f.vehicle == v && t >= f.from && t < f.until);
        match active {
            None => {
                state.last_good = Some(raw);
                raw
            }
            Some(f) => match f.kind {
                SensorFaultKind::Stuck(Some(value)) => value,
                SensorFaultKind::Stuck(None) => state.last_good.unwrap_or(raw),
                SensorFaultKind::Bias(b) => raw + b,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plan_in_ticks_and_sensor_faults() {
        let text = r#"
[mission]
name = "t"
dt = 0.5
duration = 100.0
[field]
center = [20.0, 10.0]
amplitude = 10.0
width = 15.0
[formation]
min_scale = 1.0
[restart]
vehicles = "on-failure"
[[faults]]
kind = "kill"
vehicle = 1
at = 10.2
until = 20.0
[[faults]]
kind = "sensor_stuck"
vehicle = 2
at = 5.0
until = 6.0
[[faults]]
kind = "sensor_bias"
vehicle = 3
at = 1.0
value = 0.5
"#;
        let plan = FaultPlan::new(&Mission::from_toml_str(text, "<test>").unwrap());
        assert_eq!(
            plan.kills,
            vec![Kill {
                vehicle: 1,
                tick: 21,
                restart: Some(40)
            }]
        );
        assert_eq!(plan.kills_at(21).collect::<Vec<_>>(), vec![1]);
        assert_eq!(plan.restarts_at(40).collect::<Vec<_>>(), vec![1]);
        assert!(plan.restart_pending(1, 30) && !plan.restart_pending(1, 40));
        let mut s = SensorState::default();
        assert_eq!(plan.sensor(2, 4.5, 7.0, &mut s), 7.0);
        assert_eq!(
            plan.sensor(2, 5.0, 8.0, &mut s),
            7.0,
            "stuck at the last good reading"
        );
        assert_eq!(plan.sensor(2, 6.0, 9.0, &mut s), 9.0);
        assert_eq!(plan.sensor(3, 2.0, 1.0, &mut SensorState::default()), 1.5);
        assert_eq!(tick_at(10.0, 0.5), 20);
    }
}
