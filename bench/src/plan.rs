//! What one bench run does (sample counts, fleet sizes, mission lengths) and what it aims
//! at (a goal and the ratio that checks it). A leaf: it uses no other module of this crate.

use serde::Serialize;

/// Sample counts and mission lengths of one bench run.
#[derive(Clone, Debug, Serialize)]
pub(super) struct Plan {
    /// Round trips of each ping-pong (after the warm-up).
    pub(super) pingpong_samples: usize,
    /// Warm-up round trips, not recorded.
    pub(super) pingpong_warmup: usize,
    /// The lockstep scaling runs.
    pub(super) lockstep: Vec<LockstepPlan>,
    /// N of the real-time sweep (stops at the first N with a late tick).
    pub(super) realtime: Vec<usize>,
    /// Mission time of each real-time run, s.
    pub(super) realtime_duration_s: f64,
    /// N of the footprint runs (start-up, PSS).
    pub(super) footprint: Vec<usize>,
    /// Mission time of each footprint run, s.
    pub(super) footprint_duration_s: f64,
    /// Mission time of the glider runs, s.
    pub(super) glider_duration_s: f64,
}

impl Plan {
    pub(super) fn new(quick: bool) -> Self {
        if quick {
            Self {
                pingpong_samples: 3000,
                pingpong_warmup: 300,
                lockstep: vec![lp(4, 1000, 1000), lp(16, 500, 500), lp(64, 150, 200)],
                realtime: vec![16, 32],
                realtime_duration_s: 3.0,
                footprint: vec![16],
                footprint_duration_s: 4.0,
                glider_duration_s: 21_600.0,
            }
        } else {
            Self {
                pingpong_samples: 20_000,
                pingpong_warmup: 2000,
                lockstep: vec![
                    lp(4, 4000, 5000),
                    lp(16, 2000, 3000),
                    lp(64, 600, 1000),
                    lp(256, 200, 300),
                ],
                realtime: vec![16, 32, 64, 128, 256],
                realtime_duration_s: 10.0,
                footprint: vec![16, 256],
                footprint_duration_s: 8.0,
                glider_duration_s: 129_600.0,
            }
        }
    }
}

/// One N of the lockstep scaling.
#[derive(Clone, Copy, Debug, Serialize)]
pub(super) struct LockstepPlan {
    pub(super) vehicles: usize,
    /// Ticks of `vbap run` and `vbap sim`.
    pub(super) ticks: u64,
    /// Rounds of the wake-up floor.
    pub(super) floor_rounds: usize,
}

const fn lp(vehicles: usize, ticks: u64, floor_rounds: usize) -> LockstepPlan {
    LockstepPlan {
        vehicles,
        ticks,
        floor_rounds,
    }
}

/// Fleet size the `--large` bench adds (issue 17: linear cost and real time at N = 1024).
pub(super) const LARGE_N: usize = 1024;

impl Plan {
    /// `--large`: N = [`LARGE_N`] added to the lockstep scaling (100 ticks), the real-time
    /// sweep and the footprint runs (about 3 more minutes on 2 cores).
    pub(super) fn with_large(mut self) -> Self {
        self.lockstep.push(LockstepPlan {
            vehicles: LARGE_N,
            ticks: 100,
            floor_rounds: 150,
        });
        self.realtime.push(LARGE_N);
        self.footprint.push(LARGE_N);
        self
    }
}

/// A goal of the issue and the ratio that checks it.
#[derive(Clone, Debug, Serialize)]
pub(super) struct Goal {
    pub(super) goal: String,
    pub(super) value: Option<f64>,
    pub(super) target: String,
    pub(super) met: Option<bool>,
}

impl Goal {
    /// Goal `goal`, measured `value`, aimed at `target` (as printed), `met` when known.
    pub(super) fn new(goal: String, value: Option<f64>, target: &str, met: Option<bool>) -> Self {
        Self {
            goal,
            value,
            target: target.into(),
            met,
        }
    }
}
