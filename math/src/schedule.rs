//! The committed body path of the robust law (beyond the paper).
//!
//! The paper's body moves by (IV.4) on the coordinator's newest view, which a vehicle out
//! of contact cannot know: it dead-reckons the body at the velocity of its last command.
//! Here the body's motion is a schedule of segments (piecewise constant dr/dt and dk/dt
//! over segments of a fixed number of ticks) covering at least the plan horizon H ahead.
//! The planner's decision of a tick (direction, ṡ of (IV.4), dk/ds) only takes effect H
//! later: it is appended at the far end of the schedule, while the body moves by the
//! segment in force. Every command carries the schedule, so every vehicle predicts the
//! body exactly ([`predict_body`]) until its horizon: the plan it last heard stays true.
//!
//! With H = 0 there is no schedule and the paper's planner runs unchanged.

use super::Vec3;

/// Most segments a schedule holds (the payload's fixed capacity).
pub const MAX_PLAN: usize = 16;

/// One segment of the body's motion: constant rates over `BodySchedule::seg_ticks` ticks.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Segment {
    /// Velocity of the body centre dr/dt = dr/ds·ṡ, length unit/s.
    pub velocity: Vec3,
    /// Scale rate dk/dt = dk/ds·ṡ, 1/s.
    pub scale_rate: f64,
    /// Formation speed ṡ (IV.4), 1/s (the body's parameter s; vehicles do not need it).
    pub sdot: f64,
}

impl Segment {
    /// At rest.
    pub const REST: Segment = Segment {
        velocity: Vec3::new(0.0, 0.0, 0.0),
        scale_rate: 0.0,
        sdot: 0.0,
    };

    /// As five numbers (velocity x, y, z, scale rate, ṡ), for a payload.
    pub fn to_array(&self) -> [f64; 5] {
        let v = self.velocity;
        [v.x, v.y, v.z, self.scale_rate, self.sdot]
    }

    /// From the five numbers of [`Segment::to_array`].
    pub fn from_array(a: &[f64; 5]) -> Self {
        Self {
            velocity: Vec3::new(a[0], a[1], a[2]),
            scale_rate: a[3],
            sdot: a[4],
        }
    }
}

/// The committed body path: `segments[i]` is in force over ticks
/// `[start + i·seg_ticks, start + (i + 1)·seg_ticks)`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BodySchedule {
    /// First tick of `segments[0]` (a multiple of `seg_ticks`).
    pub start: u64,
    /// Ticks per segment, ≥ 1.
    pub seg_ticks: u64,
    /// The segments, at most [`MAX_PLAN`].
    pub segments: Vec<Segment>,
}

impl BodySchedule {
    /// The deployment plan for a horizon of `horizon_ticks` ticks: at rest from tick 0 over
    /// n segments of L ticks, L = ⌈H / (MAX_PLAN − 1)⌉ and n = ⌈H / L⌉ + 1 ≤ MAX_PLAN, so
    /// at any tick the schedule reaches at least H + 1 ticks ahead. None for H = 0.
    pub fn at_rest(horizon_ticks: u64) -> Option<Self> {
        if horizon_ticks == 0 {
            return None;
        }
        let seg_ticks = horizon_ticks.div_ceil(MAX_PLAN as u64 - 1).max(1);
        let n = horizon_ticks.div_ceil(seg_ticks) as usize + 1;
        Some(Self {
            start: 0,
            seg_ticks,
            segments: vec![Segment::REST; n],
        })
    }

    /// Ticks from a decision to its effect: (n − 1)·L ≥ H.
    pub fn lead_ticks(&self) -> u64 {
        self.segments.len().saturating_sub(1) as u64 * self.seg_ticks
    }

    /// First tick after the last segment.
    pub fn end_tick(&self) -> u64 {
        self.start + self.segments.len() as u64 * self.seg_ticks
    }

    /// The segment in force at `tick` (the first before the start, the last after the
    /// end; at rest when empty).
    pub fn segment_at(&self, tick: u64) -> Segment {
        let i = (tick.saturating_sub(self.start) / self.seg_ticks.max(1)) as usize;
        self.segments
            .get(i.min(self.segments.len().saturating_sub(1)))
            .copied()
            .unwrap_or(Segment::REST)
    }

    /// At tick `tick`: when the first segment has ended (a segment boundary), drops it and
    /// appends `next` at the far end, in force from [`BodySchedule::end_tick`] on. Returns
    /// true when `next` was appended.
    pub fn roll(&mut self, tick: u64, next: Segment) -> bool {
        if self.segments.is_empty() || tick < self.start + self.seg_ticks {
            return false;
        }
        self.segments.remove(0);
        self.start += self.seg_ticks;
        self.segments.push(next);
        true
    }

    /// The body centre and scale at tick `to` of a body at (`r`, `scale`) at tick `from`
    /// (≤ `to`), tick length `dt` (s): r + Σ dr/dt·Δt, k + Σ dk/dt·Δt over the segments
    /// in force in between. Past the end of the schedule the last velocity goes on and
    /// the scale holds (a vehicle that has not heard for longer than its horizon keeps
    /// its best guess of the motion; the coordinator has decided differently by then).
    pub fn predict(&self, from: u64, to: u64, r: Vec3, scale: f64, dt: f64) -> (Vec3, f64) {
        let (mut r, mut k) = (r, scale);
        let n = self.segments.len() as u64;
        for (i, seg) in self.segments.iter().enumerate() {
            let i = i as u64;
            let a = if i == 0 {
                0
            } else {
                self.start + i * self.seg_ticks
            };
            let b = if i + 1 == n {
                u64::MAX
            } else {
                self.start + (i + 1) * self.seg_ticks
            };
            let lo = a.max(from);
            let hi = b.min(to);
            if hi > lo {
                let span = (hi - lo) as f64 * dt;
                r += seg.velocity * span;
                let planned = hi.min(self.end_tick()).saturating_sub(lo);
                k += seg.scale_rate * (planned as f64 * dt);
            }
        }
        (r, k)
    }
}

/// The body as a vehicle predicts it at some tick from a command of an earlier tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlannedBody {
    /// Centre of the body in the command, length unit.
    pub r_c: Vec3,
    /// Predicted centre, length unit.
    pub r: Vec3,
    /// Predicted scale k.
    pub scale: f64,
    /// k / k_c: how much the formation has grown since the command.
    pub ratio: f64,
    /// Velocity of the centre in force, length unit/s.
    pub velocity: Vec3,
}

impl PlannedBody {
    /// Where a point `p` of the command (a leader, a slot, a neighbour at its place in the
    /// formation) is now: it moves with the body, r + (k / k_c)(p − r_c) (III.3).
    pub fn carry(&self, p: &Vec3) -> Vec3 {
        self.r + (p - self.r_c) * self.ratio
    }
}

/// The body at tick `tick` predicted from a command of tick `tick_c` whose body was
/// centred on `r_c` at scale `k_c` and followed `schedule`; `dt` is the tick length, s.
/// The scaled potentials of (III.3) follow as `potential.scaled(ratio)`.
pub fn predict_body(
    schedule: &BodySchedule,
    tick_c: u64,
    r_c: Vec3,
    k_c: f64,
    tick: u64,
    dt: f64,
) -> PlannedBody {
    let (r, scale) = schedule.predict(tick_c, tick.max(tick_c), r_c, k_c, dt);
    PlannedBody {
        r_c,
        r,
        scale,
        ratio: if k_c > 0.0 { scale / k_c } else { 1.0 },
        velocity: schedule.segment_at(tick).velocity,
    }
}

/// A command's body and the path committed for it: what a vehicle out of contact
/// predicts the body from.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyPlan {
    /// Tick of the command.
    pub tick: u64,
    /// Centre of the body at that tick, length unit.
    pub r: Vec3,
    /// Scale of the body at that tick.
    pub scale: f64,
    /// The committed path from that tick on.
    pub schedule: BodySchedule,
}

impl BodyPlan {
    /// The body at tick `tick` (≥ the command's), tick length `dt` (s): [`predict_body`].
    pub fn at(&self, tick: u64, dt: f64) -> PlannedBody {
        predict_body(&self.schedule, self.tick, self.r, self.scale, tick, dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_deployment_plan_rests_for_the_horizon_in_at_most_max_plan_segments() {
        assert_eq!(BodySchedule::at_rest(0), None);
        for h in [1u64, 6, 14, 15, 16, 100, 724, 7300] {
            let s = BodySchedule::at_rest(h).unwrap();
            assert!(s.segments.len() <= MAX_PLAN, "H = {h}");
            assert!(s.lead_ticks() >= h, "H = {h}: lead {}", s.lead_ticks());
            // Reaches at least H + 1 ticks ahead of every tick of its first segment.
            assert!(s.end_tick() > s.seg_ticks - 1 + h, "H = {h}");
            assert!(s.segments.iter().all(|g| *g == Segment::REST));
        }
        // 7300 ticks: L = ⌈7300 / 15⌉ = 487, n = ⌈7300 / 487⌉ + 1 = 16.
        let s = BodySchedule::at_rest(7300).unwrap();
        assert_eq!((s.seg_ticks, s.segments.len()), (487, 16));
    }

    /// The coordinator's side: every tick a decision, appended at boundaries; the body
    /// moves by the segment in force, one tick at a time (r += v dt, k += dk/dt dt).
    /// Every command's prediction equals that body at every tick within its horizon.
    #[test]
    fn a_vehicle_predicts_the_coordinators_body_until_its_horizon() {
        let dt = 10.0;
        for horizon in [1u64, 7, 45, 730] {
            let mut sched = BodySchedule::at_rest(horizon).unwrap();
            let (mut r, mut k) = (Vec3::new(3.0, -2.0, 0.0), 1.2);
            let mut commands = Vec::new();
            let mut truth = Vec::new();
            let ticks = 4 * horizon + 50;
            for tick in 0..ticks {
                let phase = tick as f64 * 0.013;
                let decision = Segment {
                    velocity: Vec3::new(0.25 * phase.cos(), 0.2 * phase.sin(), 0.0),
                    scale_rate: 1e-5 * (phase * 3.0).sin(),
                    sdot: 0.25,
                };
                sched.roll(tick, decision);
                assert!(sched.end_tick() > tick + horizon, "coverage at {tick}");
                truth.push((r, k));
                commands.push((tick, r, k, sched.clone()));
                let seg = sched.segment_at(tick);
                r += seg.velocity * dt;
                k += seg.scale_rate * dt;
            }
            for (c, r_c, k_c, plan) in commands.iter().step_by(3) {
                let last = (*c + horizon).min(ticks - 1);
                for j in *c..=last {
                    let p = predict_body(plan, *c, *r_c, *k_c, j, dt);
                    let (r_true, k_true) = truth[j as usize];
                    let err = (p.r - r_true).norm();
                    assert!(
                        err <= 1e-9 * (1.0 + r_true.norm()),
                        "H {horizon}, command {c}, tick {j}: {err}"
                    );
                    assert!((p.scale - k_true).abs() <= 1e-12, "scale at {j}");
                    assert!((p.ratio - k_true / k_c).abs() <= 1e-12);
                }
            }
        }
    }

    #[test]
    fn past_the_plan_the_last_velocity_goes_on_and_the_scale_holds() {
        let mut s = BodySchedule::at_rest(3).unwrap();
        let seg = Segment {
            velocity: Vec3::new(1.0, 0.0, 0.0),
            scale_rate: 0.1,
            sdot: 1.0,
        };
        for t in 0..20 {
            s.roll(t, seg);
        }
        let end = s.end_tick();
        let (r, k) = s.predict(end - 1, end + 9, Vec3::zeros(), 1.0, 1.0);
        assert!((r.x - 10.0).abs() < 1e-12);
        assert!((k - 1.1).abs() < 1e-12, "{k}");
        let body = PlannedBody {
            r_c: Vec3::new(1.0, 1.0, 0.0),
            r: Vec3::new(2.0, 1.0, 0.0),
            scale: 2.0,
            ratio: 2.0,
            velocity: Vec3::zeros(),
        };
        assert_eq!(
            body.carry(&Vec3::new(2.0, 1.0, 0.0)),
            Vec3::new(4.0, 1.0, 0.0)
        );
        let a = Segment::from_array(&seg.to_array());
        assert_eq!(a, seg);
    }
}
