//! The verdict of a run and the reasons given for it, in `summary.json` and the human
//! summary.

use vbap_math::fit::{IN_FORMATION, NEAR_COLLISION};
use vbap_math::Vec3;
use vbap_mission::rundir::FormationSummary;

use super::summary::summary;
use super::{fmt, TruthStats, STALL_FRACTION};

/// The body's part of the outcome, for [`verdict`].
pub struct BodyOutcome {
    /// Ticks recorded and ticks planned.
    pub ticks: u64,
    pub planned: u64,
    /// Final distance of the body from the optimum (none: the field has none), and the
    /// mission's tolerance.
    pub distance: Option<f64>,
    pub tolerance: f64,
    /// Final mission time, s; the length unit's name.
    pub t: f64,
    pub unit: String,
    /// The number of local optima of the goal's kind when the field has several (a gridded
    /// field), else 0.
    pub local_optima: usize,
    /// When the field's optimum moved during the run: how the body followed it.
    pub moving: Option<Tracking>,
    /// The local optimum a noise-free climb from where the body ended reaches, when it is
    /// not the global one (a still field with several: a gaussian sum, a grid).
    pub local_optimum: Option<LocalOptimum>,
}

/// A local optimum of the field other than the global one, near where the body ended
/// (lengths in the length unit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalOptimum {
    /// Where it is.
    pub at: Vec3,
    /// The body centre's final distance from it.
    pub distance: f64,
    /// How near counts as having found it: the tolerance or the formation's radius at its
    /// final scale, whichever is larger (the formation senses the field at its own
    /// resolution: a peak narrower than the formation moves the estimate's zero by up to
    /// about its radius).
    pub reach: f64,
    /// Its distance from the global optimum.
    pub from_global: f64,
}

/// How the body followed a moving optimum (lengths in the length unit, velocities in
/// length unit/s).
#[derive(Clone, Debug, PartialEq)]
pub struct Tracking {
    /// Mission time from which the last quarter of the planned ticks was counted, s.
    pub from_t: f64,
    /// Ticks of the last quarter counted, the mean and the largest distance of the body
    /// centre from the optimum over them (the lag).
    pub ticks: u64,
    pub mean_lag: f64,
    pub max_lag: f64,
    /// The optimum's velocity over the last tick (the truth).
    pub true_drift: Vec3,
    /// The planner's estimate of the drift and whether it was significant (None: the
    /// planner makes none: `body.track_drift = false`, the paper's law, a still kind).
    pub estimated: Option<(Vec3, bool)>,
}

/// The facts a verdict is chosen from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Facts {
    /// Fewer ticks recorded than planned.
    pub interrupted: bool,
    /// The field has an optimum (the body's distance from it is known).
    pub has_optimum: bool,
    /// The body ended within the tolerance of the optimum.
    pub within: bool,
    /// Some live vehicle ended out of formation.
    pub broken: bool,
    /// Two vehicles came closer than [`NEAR_COLLISION`] spacing at some tick.
    pub near_collisions: bool,
    /// The body ended within reach of a local optimum that is not the global one
    /// ([`LocalOptimum`]).
    pub at_local_optimum: bool,
    /// The body was stalled at the end.
    pub stalled: bool,
    /// The body ended farther from the optimum than it started.
    pub diverged: bool,
    /// The field has several local optima of the goal's kind (beyond the paper: a gridded
    /// field), so a stall away from the global one is a stop at a local one.
    pub several_optima: bool,
    /// The optimum moved during the run, and the body was within the tolerance of it at
    /// every tick of the last quarter of the run.
    pub moving: bool,
    pub tracked: bool,
}

/// The verdict and its reasons. In order:
/// - `interrupted`: fewer ticks recorded than planned (Ctrl-C, SIGTERM, a stop);
/// - `tracking` (`, near collisions`, `, formation broken` as below): the optimum moves,
///   and the body centre was within tolerance of it at the end and at every tick of the
///   last quarter of the planned run (ticks k ≥ ¾ of them);
/// - `converged`: body within tolerance of the optimum and every live vehicle in formation;
/// - `converged, near collisions`: the same, but two vehicles came closer than
///   [`NEAR_COLLISION`] spacing at some tick (a collision, at sea): still converged;
/// - `converged, formation broken`: body within tolerance, some live vehicle out of formation;
/// - `converged to a stationary point`: not within tolerance of the global optimum, stalled,
///   on a field with several local optima (a gridded field), or, every live vehicle in
///   formation, within reach of a local optimum other than the global one
///   ([`LocalOptimum`]): the gradient climb ended at a local one, as it may;
/// - `stalled`: not converged and the body stalled at the end (ṡ ≈ 0, see the module docs);
/// - `diverged`: not converged and the body ended farther from the optimum than it started;
/// - `not converged, formation broken` / `not converged`: out of time on the way;
/// - without an optimum (e.g. a front): `formation kept` / `formation broken`.
pub fn verdict(stats: &TruthStats, body: &BodyOutcome) -> (String, Vec<String>) {
    let f = summary(stats);
    let unit = if body.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", body.unit)
    };
    let facts = Facts {
        interrupted: body.ticks < body.planned,
        has_optimum: body.distance.is_some(),
        within: body.distance.is_some_and(|d| d <= body.tolerance),
        broken: !f.out_of_formation_at_end.is_empty(),
        near_collisions: f.near_collision_ticks > 0,
        stalled: stats.stalled,
        diverged: match (body.distance, stats.start_distance) {
            (Some(d), Some(s)) => d > s,
            _ => false,
        },
        several_optima: body.local_optima > 1,
        at_local_optimum: body.local_optimum.is_some_and(|l| l.distance <= l.reach),
        moving: body.moving.is_some(),
        tracked: body
            .moving
            .as_ref()
            .is_some_and(|m| m.ticks > 0 && m.max_lag <= body.tolerance),
    };
    let mut reasons = Vec::new();
    if facts.interrupted {
        reasons.push(format!(
            "the run was stopped at t = {} s, after {} of {} ticks",
            fmt(body.t),
            body.ticks,
            body.planned
        ));
    }
    reasons.push(distance_reason(stats, body, &unit));
    if let Some(m) = &body.moving {
        reasons.push(tracking_reason(m, body.tolerance, &unit));
    }
    reasons.push(formation_reason(stats, &f));
    if facts.several_optima && stats.stalled && !facts.within {
        reasons.push(format!(
            "the field has {} local optima of the goal's kind: the body stopped at a stationary point, not the global one",
            body.local_optima
        ));
    }
    if let Some(l) = body.local_optimum.filter(|_| facts.at_local_optimum) {
        reasons.push(format!(
            "the body ended {}{unit} from a local optimum of the field at ({}, {}, {}), within \
             {}{unit} (the tolerance or the formation's radius), {}{unit} from the global one: \
             the gradient climb found a local optimum, as it may",
            fmt(l.distance),
            fmt(l.at.x),
            fmt(l.at.y),
            fmt(l.at.z),
            fmt(l.reach),
            fmt(l.from_global)
        ));
    }
    reasons.extend(stall_reason(stats, body.t));
    reasons.extend(lyapunov_reason(&f));
    reasons.extend(near_collision_reason(&f));
    (choose(&facts).to_string(), reasons)
}

/// The verdict the `facts` make (the list of [`verdict`], in its order).
pub fn choose(facts: &Facts) -> &'static str {
    let Facts {
        interrupted,
        has_optimum,
        within,
        broken,
        near_collisions,
        stalled,
        diverged,
        several_optima,
        at_local_optimum,
        moving,
        tracked,
    } = *facts;
    if interrupted {
        "interrupted"
    } else if moving && tracked && within && !broken && near_collisions {
        "tracking, near collisions"
    } else if moving && tracked && within && !broken {
        "tracking"
    } else if moving && tracked && within {
        "tracking, formation broken"
    } else if !has_optimum {
        if broken {
            "formation broken"
        } else {
            "formation kept"
        }
    } else if within && !broken && near_collisions {
        "converged, near collisions"
    } else if within && !broken {
        "converged"
    } else if within {
        "converged, formation broken"
    } else if (stalled && several_optima) || (at_local_optimum && !broken) {
        "converged to a stationary point"
    } else if stalled && broken {
        "stalled, formation broken"
    } else if stalled {
        "stalled"
    } else if diverged {
        "diverged"
    } else if broken {
        "not converged, formation broken"
    } else {
        "not converged"
    }
}

/// Where the body ended: its distance from the optimum against the tolerance (and where
/// it started, when outside), in the length unit (`unit`: " name" or empty).
fn distance_reason(stats: &TruthStats, body: &BodyOutcome, unit: &str) -> String {
    match body.distance {
        Some(d) if d <= body.tolerance => format!(
            "the body centre ended {}{unit} from the optimum, within the tolerance {}{unit}",
            fmt(d),
            fmt(body.tolerance)
        ),
        Some(d) => format!(
            "the body centre ended {}{unit} from the optimum, outside the tolerance {}{unit}{}",
            fmt(d),
            fmt(body.tolerance),
            stats.start_distance.map_or(String::new(), |s| format!(
                " (it started {}{unit} away)",
                fmt(s)
            ))
        ),
        None => "the field has no optimum to converge to".into(),
    }
}

/// How the body followed the moving optimum: its lag over the last quarter against the
/// tolerance, and the drift the planner estimated against the optimum's true velocity.
fn tracking_reason(m: &Tracking, tolerance: f64, unit: &str) -> String {
    let v = |x: &Vec3| format!("({}, {}, {})", fmt(x.x), fmt(x.y), fmt(x.z));
    let estimated = match &m.estimated {
        Some((e, true)) => format!("estimated {}", v(e)),
        Some((e, false)) => format!("estimated {} (not significant, not fed forward)", v(e)),
        None => "not estimated (body.track_drift off, or the paper's law)".into(),
    };
    format!(
        "the optimum moves at {}{unit}/s: over the last quarter (from t = {} s) the body \
         centre lagged {}{unit} on average behind it (at most {}{unit}; {} the tolerance \
         {}{unit}); drift {estimated}, true {}{unit}/s",
        fmt(m.true_drift.norm()),
        fmt(m.from_t),
        fmt(m.mean_lag),
        fmt(m.max_lag),
        if m.max_lag <= tolerance {
            "within"
        } else {
            "outside"
        },
        fmt(tolerance),
        v(&m.true_drift)
    )
}

/// Whether every live vehicle ended in formation (within [`IN_FORMATION`] spacing of a
/// slot); if not, the vehicles out, the worst first, at most eight of them named.
fn formation_reason(stats: &TruthStats, f: &FormationSummary) -> String {
    if f.out_of_formation_at_end.is_empty() {
        return format!(
            "all {} live vehicles ended in formation (within {} spacing of a slot)",
            f.alive_at_end, IN_FORMATION
        );
    }
    const LIST: usize = 8;
    let error = |v: u32| stats.vehicles[v as usize].slot_error;
    let mut worst = f.out_of_formation_at_end.clone();
    worst.sort_by(|a, b| {
        let e = |v: &u32| error(*v).unwrap_or(f64::INFINITY);
        e(b).total_cmp(&e(a)).then(a.cmp(b))
    });
    let more = worst.len().saturating_sub(LIST);
    let mut list: Vec<String> = worst
        .iter()
        .take(LIST)
        .map(|&v| match error(v) {
            Some(e) => format!("vehicle {v} ({} spacings from its slot)", fmt(e)),
            None => format!("vehicle {v} (no true state)"),
        })
        .collect();
    if more > 0 {
        list.push(format!("and {more} more"));
    }
    format!(
        "{} of {} live vehicles ended out of formation (more than {} spacing from a slot): {}",
        f.out_of_formation_at_end.len(),
        f.alive_at_end,
        IN_FORMATION,
        list.join(", ")
    )
}

/// The stall at the end (since when, why; `t_end`: the final mission time, s), or the
/// time stalled in all, s, if the body moved again.
fn stall_reason(stats: &TruthStats, t_end: f64) -> Option<String> {
    if stats.stalled {
        Some(format!(
            "the body stalled from t = {} s to the end (ṡ below {} v0; why: {})",
            fmt(stats.slow_since.unwrap_or(t_end)),
            STALL_FRACTION,
            stats.stall_why
        ))
    } else if stats.stalled_s > 0.0 {
        Some(format!(
            "the body stalled for {} s in all, but moved again",
            fmt(stats.stalled_s)
        ))
    } else {
        None
    }
}

/// V of (II.2) from the true states above V_U at some tick: how far, against what the
/// coordinator saw, and for what share of the ticks.
fn lyapunov_reason(f: &FormationSummary) -> Option<String> {
    (f.max_v_true_over_vu > 1.0).then(|| {
        format!(
            "V from the true states reached {} V_U (the coordinator saw at most {} V_U); above V_U for {:.1}% of ticks",
            fmt(f.max_v_true_over_vu),
            fmt(f.max_v_seen_over_vu),
            100.0 * f.share_ticks_v_true_above_vu
        )
    })
}

/// The closest pair, when it came below [`NEAR_COLLISION`] spacing at some tick.
fn near_collision_reason(f: &FormationSummary) -> Option<String> {
    if f.near_collision_ticks == 0 {
        return None;
    }
    let (Some(r), Some(t), Some([a, b])) = (f.min_pair_ratio, f.min_pair_t, f.min_pair_vehicles)
    else {
        return None;
    };
    Some(format!(
        "vehicles {a} and {b} came within {} spacing of each other at t = {} s (near collision: below {}; {} ticks)",
        fmt(r),
        fmt(t),
        NEAR_COLLISION,
        f.near_collision_ticks
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truth::VehicleTruth;

    /// The verdict of `facts` changed by `change`.
    fn choose_after(mut facts: Facts, change: fn(&mut Facts)) -> &'static str {
        change(&mut facts);
        choose(&facts)
    }

    fn converged() -> Facts {
        Facts {
            has_optimum: true,
            within: true,
            ..Facts::default()
        }
    }

    #[test]
    fn each_verdict_from_its_facts() {
        let c = converged();
        assert_eq!(choose(&c), "converged");
        let f = |g| choose_after(c, g);
        assert_eq!(
            f(|x| x.near_collisions = true),
            "converged, near collisions"
        );
        assert_eq!(f(|x| x.broken = true), "converged, formation broken");
        // Near collisions do not hide a broken formation.
        assert_eq!(
            f(|x| {
                x.broken = true;
                x.near_collisions = true
            }),
            "converged, formation broken"
        );
        // Interrupted wins over everything.
        assert_eq!(f(|x| x.interrupted = true), "interrupted");
        assert_eq!(
            f(|x| {
                x.within = false;
                x.stalled = true;
                x.diverged = true
            }),
            "stalled"
        );
        // A stall with survivors out of formation says so.
        assert_eq!(
            f(|x| {
                x.within = false;
                x.stalled = true;
                x.broken = true
            }),
            "stalled, formation broken"
        );
        // A stall on a field with several local optima is a stop at a local one.
        assert_eq!(
            f(|x| {
                x.within = false;
                x.stalled = true;
                x.several_optima = true
            }),
            "converged to a stationary point"
        );
        assert_eq!(
            f(|x| {
                x.within = false;
                x.several_optima = true
            }),
            "not converged"
        );
        assert_eq!(
            f(|x| {
                x.within = false;
                x.diverged = true;
                x.broken = true
            }),
            "diverged"
        );
        assert_eq!(
            f(|x| {
                x.within = false;
                x.broken = true
            }),
            "not converged, formation broken"
        );
        assert_eq!(f(|x| x.within = false), "not converged");
        let none = Facts::default();
        assert_eq!(choose(&none), "formation kept");
        assert_eq!(
            choose(&Facts {
                broken: true,
                ..none
            }),
            "formation broken"
        );
    }

    fn stats(errors: &[Option<f64>]) -> TruthStats {
        TruthStats {
            vehicles: errors
                .iter()
                .map(|&e| VehicleTruth {
                    alive: true,
                    slot_error: e,
                    in_formation: e.is_some_and(|e| e <= IN_FORMATION),
                    ..VehicleTruth::default()
                })
                .collect(),
            start_distance: Some(10.0),
            ..TruthStats::default()
        }
    }

    fn body(distance: Option<f64>, ticks: u64) -> BodyOutcome {
        BodyOutcome {
            ticks,
            planned: 100,
            distance,
            tolerance: 1.0,
            t: 5.0,
            unit: "m".into(),
            local_optima: 0,
            moving: None,
            local_optimum: None,
        }
    }

    /// A body that ended by a local optimum other than the global one, on any field, found
    /// it, stalled or not, when its formation held; farther than the reach, or with the
    /// formation broken, it did not.
    #[test]
    fn a_body_by_a_local_optimum_converged_to_a_stationary_point() {
        let c = converged();
        let f = |g| choose_after(Facts { within: false, ..c }, g);
        assert_eq!(
            f(|x| x.at_local_optimum = true),
            "converged to a stationary point"
        );
        assert_eq!(
            f(|x| {
                x.at_local_optimum = true;
                x.diverged = true
            }),
            "converged to a stationary point"
        );
        assert_eq!(
            f(|x| {
                x.at_local_optimum = true;
                x.broken = true
            }),
            "not converged, formation broken"
        );
        let mut b = body(Some(10.3), 100);
        let local = LocalOptimum {
            at: Vec3::new(-0.5, 0.2, 0.0),
            distance: 0.45,
            reach: 1.2,
            from_global: 10.1,
        };
        b.local_optimum = Some(local);
        let (v, reasons) = verdict(&stats(&[Some(0.0), Some(0.01)]), &b);
        assert_eq!(v, "converged to a stationary point");
        assert!(
            reasons.iter().any(|r| r.contains("found a local optimum")),
            "{reasons:?}"
        );
        b.local_optimum = Some(LocalOptimum {
            distance: 1.3,
            ..local
        });
        let (v, reasons) = verdict(&stats(&[Some(0.0), Some(0.01)]), &b);
        assert_eq!(v, "diverged", "it started 10 away");
        assert!(!reasons.iter().any(|r| r.contains("local optimum")));
    }

    #[test]
    fn a_moving_optimum_tracked_over_the_last_quarter_is_tracking() {
        let c = Facts {
            moving: true,
            tracked: true,
            ..converged()
        };
        assert_eq!(choose(&c), "tracking");
        let f = |g| choose_after(c, g);
        assert_eq!(f(|x| x.near_collisions = true), "tracking, near collisions");
        assert_eq!(f(|x| x.broken = true), "tracking, formation broken");
        // Within at the end but not over the whole last quarter: the rules of a still field.
        assert_eq!(f(|x| x.tracked = false), "converged");
        assert_eq!(
            f(|x| {
                x.tracked = false;
                x.within = false
            }),
            "not converged"
        );
        assert!(crate::truth::is_converged("tracking"));
        let mut b = body(Some(0.5), 100);
        b.moving = Some(Tracking {
            from_t: 3.75,
            ticks: 25,
            mean_lag: 0.25,
            max_lag: 0.5,
            true_drift: Vec3::new(0.3, 0.4, 0.0),
            estimated: Some((Vec3::new(0.29, 0.41, 0.0), true)),
        });
        let (v, reasons) = verdict(&stats(&[Some(0.1)]), &b);
        assert_eq!(v, "tracking");
        assert_eq!(
            reasons[1],
            "the optimum moves at 0.5000 m/s: over the last quarter (from t = 3.750 s) the body \
             centre lagged 0.2500 m on average behind it (at most 0.5000 m; within the tolerance \
             1.000 m); drift estimated (0.2900, 0.4100, 0), true (0.3000, 0.4000, 0) m/s"
        );
    }

    #[test]
    fn the_reasons_of_a_converged_run() {
        let (v, reasons) = verdict(&stats(&[Some(0.1), Some(0.2)]), &body(Some(0.5), 100));
        assert_eq!(v, "converged");
        assert_eq!(
            reasons,
            vec![
                "the body centre ended 0.5000 m from the optimum, within the tolerance 1.000 m",
                "all 2 live vehicles ended in formation (within 0.25 spacing of a slot)",
            ]
        );
    }

    #[test]
    fn the_reasons_of_an_interrupted_diverging_run_name_the_worst_vehicle_first() {
        let (v, reasons) = verdict(
            &stats(&[Some(0.1), Some(3.0), None, Some(0.5)]),
            &body(Some(12.0), 40),
        );
        assert_eq!(v, "interrupted");
        assert_eq!(
            reasons[0],
            "the run was stopped at t = 5.000 s, after 40 of 100 ticks"
        );
        assert_eq!(
            reasons[1],
            "the body centre ended 12.00 m from the optimum, outside the tolerance 1.000 m (it started 10.00 m away)"
        );
        assert_eq!(
            reasons[2],
            "3 of 4 live vehicles ended out of formation (more than 0.25 spacing from a slot): \
             vehicle 2 (no true state), vehicle 1 (3.000 spacings from its slot), \
             vehicle 3 (0.5000 spacings from its slot)"
        );
        let (v, _) = verdict(&stats(&[Some(0.1), Some(3.0)]), &body(Some(12.0), 100));
        assert_eq!(v, "diverged");
    }

    #[test]
    fn at_most_eight_vehicles_are_named() {
        let errors: Vec<Option<f64>> = (0..11).map(|i| Some(1.0 + i as f64)).collect();
        let (_, reasons) = verdict(&stats(&errors), &body(None, 100));
        assert_eq!(reasons[0], "the field has no optimum to converge to");
        assert!(reasons[1].starts_with("11 of 11 live vehicles ended out of formation"));
        assert!(reasons[1].contains("vehicle 10 (11.00 spacings"));
        assert!(!reasons[1].contains("vehicle 2 "));
        assert!(reasons[1].ends_with(", and 3 more"), "{}", reasons[1]);
    }

    #[test]
    fn stall_lyapunov_and_near_collision_reasons() {
        let mut s = stats(&[Some(0.1)]);
        s.stalled = true;
        s.slow_since = Some(2.5);
        s.stall_why = "holding".into();
        s.max_v_true = 2.0;
        s.max_v_seen = 1.5;
        s.ticks = 4;
        s.ticks_v_above = 1;
        s.near_collision_ticks = 2;
        s.min_pair = Some((0.05, 1.25, 0, 1));
        let (v, reasons) = verdict(&s, &body(Some(5.0), 100));
        assert_eq!(v, "stalled");
        assert_eq!(
            &reasons[2..],
            [
                "the body stalled from t = 2.500 s to the end (ṡ below 0.1 v0; why: holding)",
                "V from the true states reached 2.000 V_U (the coordinator saw at most 1.500 V_U); above V_U for 25.0% of ticks",
                "vehicles 0 and 1 came within 0.05000 spacing of each other at t = 1.250 s (near collision: below 0.1; 2 ticks)",
            ]
        );
        s.stalled = false;
        s.stalled_s = 3.0;
        let (_, reasons) = verdict(&s, &body(Some(5.0), 100));
        assert_eq!(
            reasons[2],
            "the body stalled for 3.000 s in all, but moved again"
        );
    }
}
