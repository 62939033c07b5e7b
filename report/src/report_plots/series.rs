//! The series of `body.csv`, read by column name and decimated while streaming.

use crate::plot::decimate::Decimator;
use anyhow::Result;
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_wire::rundir::RunDir;

use super::MAX_POINTS;
use crate::rows::{for_each_row_of, BodyCsv};

/// The series of a run, decimated, in mission time (s).
#[derive(Default)]
pub(super) struct RunSeries {
    pub v_over_vu: Decimator,
    pub sdot: Decimator,
    pub scale: Decimator,
    pub vehicles: Decimator,
    pub grad_error: Decimator,
    pub grad_true: Decimator,
    pub p_trace: Decimator,
    pub distance: Vec<(f64, f64)>,
    pub rows: u64,
    pub first_t: f64,
    pub last_t: f64,
    pub max_v_over_vu: f64,
    pub has_truth: bool,
}

impl RunSeries {
    /// Reads `body.csv` of `dir` (the distance to the optimum from `mission`'s field).
    pub fn read(dir: &RunDir, mission: &Mission) -> Result<Self> {
        let ticks = mission.ticks().max(1);
        let bucket = ticks.div_ceil((MAX_POINTS / 2) as u64).max(1);
        let mut s = RunSeries::default();
        for d in [
            &mut s.v_over_vu,
            &mut s.sdot,
            &mut s.scale,
            &mut s.vehicles,
            &mut s.grad_error,
            &mut s.grad_true,
            &mut s.p_trace,
        ] {
            d.bucket = bucket;
        }
        let distance_every = ticks.div_ceil(MAX_POINTS as u64).max(1);
        let field = mission.field();
        let goal = mission.mission.goal;
        let v_u = mission.body.v_u;
        let mut i = 0u64;
        for_each_row_of(&dir.body(), |_, b: BodyCsv| {
            let t = b.t;
            s.v_over_vu.push(t, b.v / v_u);
            s.max_v_over_vu = s.max_v_over_vu.max(b.v / v_u);
            s.sdot.push(t, b.sdot);
            s.scale.push(t, b.scale);
            s.vehicles.push(t, b.n_vehicles);
            if let Some(p) = b.p_trace {
                s.p_trace.push(t, p);
            }
            if let (Some(x), Some(y), Some(z)) = (b.true_grad_x, b.true_grad_y, b.true_grad_z) {
                let truth = Vec3::new(x, y, z);
                let grad = Vec3::new(b.grad_x, b.grad_y, b.grad_z);
                s.has_truth = true;
                s.grad_error.push(t, (grad - truth).norm());
                s.grad_true.push(t, truth.norm());
            }
            if i.is_multiple_of(distance_every) {
                if let Some(o) = field.optimum(t, goal) {
                    s.distance
                        .push((t, (Vec3::new(b.rx, b.ry, b.rz) - o).norm()));
                }
            }
            if s.rows == 0 {
                s.first_t = t;
            }
            s.rows += 1;
            s.last_t = t;
            i += 1;
            Ok(())
        })?;
        Ok(s)
    }
}
