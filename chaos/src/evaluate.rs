//! Judging a run from its run directory: the summary's figures, the failures of the run,
//! and every action by the rules of the module documentation.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use serde_json::Value;
use vbap_mission::config::RestartPolicy;

use super::procs::{json_lines, message, Seen, Slot};
use super::report::{action_failure, Action, RunReport};
use super::timing::MARGIN;

fn num_list(v: Option<&Value>) -> Vec<f64> {
    v.and_then(Value::as_array)
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default()
}

/// Wall time (s since the Unix epoch) at which the coordinator published the command of
/// each tick of `ticks`, from the agents' message records (`logs/vehicle_agent_*.msgs.csv`,
/// hop `body`: `sent_ns` is the coordinator's clock when it published): the earliest over
/// every record of each publication of that tick, in order (a resumed coordinator
/// publishes again the command its predecessor may have published). A `lost` event of
/// tick k is written before the command of tick k is published, so the first publication
/// after the kill is the first after the verdict (at most one tick period after it in a
/// paced run).
fn command_times(logs: &Path, ticks: &BTreeSet<u64>) -> BTreeMap<u64, Vec<f64>> {
    use std::io::BufRead as _;
    let mut out: BTreeMap<u64, BTreeSet<u64>> = BTreeMap::new();
    if ticks.is_empty() {
        return BTreeMap::new();
    }
    let Ok(entries) = std::fs::read_dir(logs) else {
        return BTreeMap::new();
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !(name.starts_with("vehicle_agent") && name.ends_with(vbap_ipc::msglog::MSG_SUFFIX)) {
            continue;
        }
        let Ok(file) = std::fs::File::open(e.path()) else {
            continue;
        };
        for line in std::io::BufReader::new(file).lines().map_while(Result::ok) {
            let mut f = line.split(',');
            let (Some(_), Some("body"), Some(_), Some(_), Some(tick), Some(_), Some(sent)) = (
                f.next(),
                f.next(),
                f.next(),
                f.next(),
                f.next(),
                f.next(),
                f.next(),
            ) else {
                continue;
            };
            let (Ok(tick), Ok(sent)) = (tick.parse::<u64>(), sent.parse::<u64>()) else {
                continue;
            };
            if ticks.contains(&tick) {
                out.entry(tick).or_default().insert(sent);
            }
        }
    }
    out.into_iter()
        .map(|(k, ns)| (k, ns.into_iter().map(|ns| ns as f64 * 1e-9).collect()))
        .collect()
}

/// Reads the run directory and judges every action of the run.
pub(super) fn evaluate(
    report: &mut RunReport,
    actions: &mut [Action],
    run_dir: &Path,
    seen: &BTreeMap<u32, Seen>,
    end_unix: f64,
    policy: RestartPolicy,
) {
    let summary = read_summary(report, run_dir);
    let completed = summary.is_some() && report.exit_code == Some(0);
    run_failures(report, completed, summary.is_some(), run_dir);
    let went_on = completed && report.ticks == Some(report.expected_ticks);
    let ev = Evidence::read(run_dir, seen, end_unix, actions);
    let restarts_vehicles = policy != RestartPolicy::Never;
    let mut kill_count: BTreeMap<Slot, usize> = BTreeMap::new();
    for a in actions.iter_mut().filter(|a| a.sent) {
        let (Some(slot), Some(at)) = (a.slot, a.at_unix_s) else {
            continue;
        };
        let mut problems: Vec<String> = Vec::new();
        if a.action == "kill" {
            let i = *kill_count.entry(slot).and_modify(|c| *c += 1).or_insert(0);
            let next_kill = ev
                .kill_times
                .get(&slot)
                .and_then(|t| t.get(i + 1))
                .copied()
                .unwrap_or(f64::INFINITY);
            a.restarted_ms = ev
                .restart_of(slot, at)
                .filter(|t| *t < next_kill)
                .map(|t| (t - at) * 1e3);
            match slot {
                Slot::Agent(v) => {
                    let kill = AgentKill {
                        v,
                        i,
                        at,
                        next_kill,
                    };
                    ev.judge_agent_kill(a, &kill, restarts_vehicles, &mut problems);
                    if !completed {
                        problems.push("the run failed".into());
                    }
                }
                Slot::Coordinator | Slot::FieldServer => {
                    a.detected = Some(a.restarted_ms.is_some());
                    a.detection_ms = a.restarted_ms;
                    if a.restarted_ms.is_none() {
                        problems.push("not restarted".into());
                    }
                    if !went_on {
                        problems.push("the mission did not go on to its last tick".into());
                    }
                }
            }
            a.recovered = Some(problems.is_empty());
        } else {
            if a.group.is_none() {
                ev.judge_stop(a, slot, &mut problems);
            } // else: the stop of a stopped-then-killed agent, judged by its kill
            if !completed {
                problems.push("the run failed".into());
            }
        }
        conclude(a, at, problems, ev.mission_end);
        if a.failed() {
            report.failures.push(action_failure(a));
        }
    }
}

/// The summary's figures, verdict and reasons into `report`; the summary, if any.
fn read_summary(report: &mut RunReport, run_dir: &Path) -> Option<Value> {
    let summary: Option<Value> = std::fs::read_to_string(run_dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let Some(s) = &summary else {
        report.verdict = "no summary".into();
        return None;
    };
    let u = |k: &str| s.get(k).and_then(Value::as_u64);
    report.ticks = u("ticks");
    report.late_ticks = u("late_ticks");
    report.vehicles_lost = u("vehicles_lost");
    report.vehicles_rejoined = u("vehicles_rejoined");
    report.reconfigurations = u("reconfigurations");
    report.coordinator_detection_ms = num_list(s.get("detection_latency_ms"));
    report.coordinator_rejoin_ms = num_list(s.get("rejoin_latency_ms"));
    report.verdict = match s.get("verdict") {
        Some(Value::String(v)) => v.clone(),
        Some(other) if !other.is_null() => other.to_string(),
        _ => match s.get("converged").and_then(Value::as_bool) {
            Some(true) => "converged".into(),
            Some(false) => "not converged".into(),
            None => "unknown".into(),
        },
    };
    report.reasons = s
        .get("reasons")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|r| r.as_str().map_or_else(|| r.to_string(), str::to_string))
                .collect()
        })
        .unwrap_or_default();
    summary
}

/// The failures of the run itself: not completed, leftovers.
fn run_failures(report: &mut RunReport, completed: bool, has_summary: bool, run_dir: &Path) {
    if !completed {
        report.failures.push(format!(
            "the run failed (vbap run exit {:?}, summary.json {}); see {}",
            report.exit_code,
            if has_summary { "written" } else { "missing" },
            run_dir.join("vbap.log").display()
        ));
    }
    if !report.leftover_files.is_empty() {
        report.failures.push(format!(
            "{} file(s) of the run's iceoryx2 domain left behind",
            report.leftover_files.len()
        ));
    }
    if !report.leftover_processes.is_empty() {
        report.failures.push(format!(
            "{} process(es) left running",
            report.leftover_processes.len()
        ));
    }
}

/// An event's `kind`.
fn kind(e: &Value) -> Option<&str> {
    e.get("kind").and_then(Value::as_str)
}

/// An event's `vehicle`.
fn vehicle(e: &Value) -> Option<u32> {
    e.get("vehicle")
        .and_then(Value::as_u64)
        .and_then(|v| u32::try_from(v).ok())
}

/// Judged or not, and the outcome, from the problems found and how long the mission went
/// on after the action (`mission_end`, s since the Unix epoch).
fn conclude(a: &mut Action, at: f64, problems: Vec<String>, mission_end: f64) {
    let last = a.cont_unix_s.unwrap_or(at).max(at);
    a.judged = mission_end - last >= MARGIN || problems.is_empty();
    a.outcome = if problems.is_empty() {
        "ok".into()
    } else if a.judged {
        problems.join("; ")
    } else {
        format!(
            "unjudged: the mission ended {:.2} s after ({})",
            mission_end - last,
            problems.join("; ")
        )
    };
}

/// The i-th kill of vehicle `v`, sent at `at` (s since the Unix epoch), the next kill of
/// its slot at `next_kill`.
struct AgentKill {
    v: u32,
    i: usize,
    at: f64,
    next_kill: f64,
}

/// What the run directory and the campaign say about a run.
struct Evidence<'a> {
    events: Vec<Value>,
    /// Coordinator log lines with their time, s since the Unix epoch.
    log: Vec<(f64, Value)>,
    /// Publication time of the command of each tick with a `lost` event.
    published: BTreeMap<u64, Vec<f64>>,
    /// The coordinator's `coordinator done`, else the end of `vbap run`.
    mission_end: f64,
    seen: &'a BTreeMap<u32, Seen>,
    /// Wall times of the sent kills, per slot.
    kill_times: BTreeMap<Slot, Vec<f64>>,
}

impl<'a> Evidence<'a> {
    fn read(
        run_dir: &Path,
        seen: &'a BTreeMap<u32, Seen>,
        end_unix: f64,
        actions: &[Action],
    ) -> Self {
        let events = json_lines(&run_dir.join("events.jsonl"));
        let log: Vec<(f64, Value)> = json_lines(&run_dir.join("logs").join("coordinator.jsonl"))
            .into_iter()
            .filter_map(|l| {
                Some((
                    vbap_report::analyze::parse_utc(l.get("timestamp")?.as_str()?)?,
                    l,
                ))
            })
            .collect();
        let lost_ticks: BTreeSet<u64> = events
            .iter()
            .filter(|e| kind(e) == Some("lost"))
            .filter_map(|e| e.get("k").and_then(Value::as_u64))
            .collect();
        let published = command_times(&run_dir.join("logs"), &lost_ticks);
        let mission_end = log
            .iter()
            .rev()
            .find(|(_, l)| message(l) == Some("coordinator done"))
            .map_or(end_unix, |(t, _)| *t);
        let kill_times = actions
            .iter()
            .filter(|a| a.sent && a.action == "kill")
            .filter_map(|a| Some((a.slot?, a.at_unix_s?)))
            .fold(BTreeMap::new(), |mut acc, (s, t)| {
                acc.entry(s).or_insert_with(Vec::new).push(t);
                acc
            });
        Evidence {
            events,
            log,
            published,
            mission_end,
            seen,
            kill_times,
        }
    }

    /// Events of `kind` about vehicle `v`, scheduled kills left out.
    fn of(&self, kind: &str, v: u32) -> Vec<&Value> {
        self.events
            .iter()
            .filter(|e| e.get("kind").and_then(Value::as_str) == Some(kind))
            .filter(|e| e.get("vehicle").and_then(Value::as_u64) == Some(u64::from(v)))
            .filter(|e| {
                e.pointer("/detail/cause").and_then(Value::as_str) != Some("scheduled kill")
            })
            .collect()
    }

    /// The first process started in `slot` after `after` (s since the Unix epoch).
    fn restart_of(&self, slot: Slot, after: f64) -> Option<f64> {
        self.seen
            .values()
            .filter(|s| s.slot == slot && s.first_unix_s > after)
            .map(|s| s.first_unix_s)
            .fold(None, |a: Option<f64>, t| Some(a.map_or(t, |a| a.min(t))))
    }

    /// A kill of an agent: detected (its `lost` event, the detection latency), then
    /// readmitted (`restarts_vehicles`) or left out of a redesigned formation. The i-th
    /// kill of a vehicle is its i-th death in `events.jsonl`: a `lost` event of any cause
    /// but `stopped` (a lockstep coordinator loses a stopped member: no death), or a `died`
    /// event (the process of a vehicle already lost while stopped died: it needs no
    /// detection, and is judged by its readmission). Its rejoin is the vehicle's first
    /// after that death in the file's order.
    fn judge_agent_kill(
        &self,
        a: &mut Action,
        k: &AgentKill,
        restarts_vehicles: bool,
        problems: &mut Vec<String>,
    ) {
        let deaths = self.deaths_of(k.v);
        let found = deaths.get(k.i).copied();
        a.detected = Some(found.is_some());
        let Some((at, death)) = found else {
            problems.push("not detected".into());
            return;
        };
        let out_already = kind(death) == Some("died");
        let lost_k = death.get("k").and_then(Value::as_u64);
        if !out_already {
            a.detected_t = death.get("t").and_then(Value::as_f64);
            a.detection_ms = self.detection_ms(lost_k, k);
        }
        if restarts_vehicles {
            let r = self.events[at..]
                .iter()
                .find(|e| kind(e) == Some("rejoin") && vehicle(e) == Some(k.v));
            a.rejoined = Some(r.is_some());
            a.rejoin_t = r.and_then(|e| e.get("t")).and_then(Value::as_f64);
            if r.is_none() {
                problems.push("not readmitted".into());
            }
        } else {
            // Out since its loss, or (out already) since the stop's.
            let from = if out_already {
                self.events[..at]
                    .iter()
                    .rev()
                    .find(|e| kind(e) == Some("lost") && vehicle(e) == Some(k.v))
                    .and_then(|e| e.get("k"))
                    .and_then(Value::as_u64)
            } else {
                lost_k
            };
            let re = from.is_some_and(|lk| self.reconfigured_without(k.v, lk));
            a.reconfigured = Some(re);
            if !re {
                problems.push("no formation redesigned without it".into());
            }
        }
    }

    /// The deaths of vehicle `v` in `events.jsonl` with their index in it, in order: its
    /// `lost` events but those of a stop (and of scheduled kills), and its `died` events.
    fn deaths_of(&self, v: u32) -> Vec<(usize, &Value)> {
        self.events
            .iter()
            .enumerate()
            .filter(|(_, e)| vehicle(e) == Some(v))
            .filter(|(_, e)| {
                let cause = e.pointer("/detail/cause").and_then(Value::as_str);
                match kind(e) {
                    Some("lost") => !matches!(cause, Some("stopped" | "scheduled kill")),
                    Some("died") => true,
                    _ => false,
                }
            })
            .collect()
    }

    /// Wall time from the kill to the first publication after it of the command of the
    /// `lost` event's tick `lost_k`, ms;
    /// without message records, to the coordinator's warning about the vehicle.
    fn detection_ms(&self, lost_k: Option<u64>, k: &AgentKill) -> Option<f64> {
        let at = k.at;
        lost_k
            .and_then(|lk| self.published.get(&lk))
            .and_then(|ts| ts.iter().find(|t| **t >= at))
            .map(|t| (t - at) * 1e3)
            .or_else(|| {
                // No message records: the coordinator's warning about the vehicle (its
                // verdict "dead"), if it wrote one.
                self.log
                    .iter()
                    .find(|(t, l)| {
                        *t > at
                            && *t < k.next_kill
                            && l.get("level").and_then(Value::as_str) == Some("WARN")
                            && l.pointer("/fields/vehicle").and_then(Value::as_u64)
                                == Some(u64::from(k.v))
                    })
                    .map(|(t, _)| (t - at) * 1e3)
            })
    }

    /// A `reconfigured` event at or after tick `from` whose formation leaves `v` out.
    fn reconfigured_without(&self, v: u32, from: u64) -> bool {
        self.events
            .iter()
            .filter(|e| e.get("kind").and_then(Value::as_str) == Some("reconfigured"))
            .any(|e| {
                e.get("k")
                    .and_then(Value::as_u64)
                    .is_some_and(|ek| ek >= from)
                    && e.pointer("/detail/vehicles")
                        .and_then(Value::as_array)
                        .is_some_and(|vs| !vs.iter().any(|x| x.as_u64() == Some(u64::from(v))))
            })
    }

    /// A stop: the process survived; a stopped agent declared lost was readmitted.
    fn judge_stop(&self, a: &mut Action, slot: Slot, problems: &mut Vec<String>) {
        if a.survived != Some(true) {
            problems.push("the stopped process did not survive".into());
        }
        if let Slot::Agent(v) = slot {
            let lost = !self.of("lost", v).is_empty();
            a.declared_lost = Some(lost);
            if lost && self.of("rejoin", v).is_empty() {
                problems.push("declared lost and never readmitted".into());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(kind: &str, v: u32, k: u64, cause: Option<&str>) -> Value {
        let mut e = serde_json::json!({ "kind": kind, "vehicle": v, "k": k, "t": k as f64 * 0.05 });
        if let Some(c) = cause {
            e["detail"] = serde_json::json!({ "cause": c });
        }
        e
    }

    fn judge(ev: &Evidence, i: usize, restarts: bool) -> (Action, Vec<String>) {
        let mut a = Action::default();
        let mut problems = Vec::new();
        let kill = AgentKill {
            v: 2,
            i,
            at: 0.0,
            next_kill: f64::INFINITY,
        };
        ev.judge_agent_kill(&mut a, &kill, restarts, &mut problems);
        (a, problems)
    }

    /// The i-th kill is the i-th death: a stop's loss is none, and the death of a process
    /// lost while stopped (`died`) is one that needs no detection; each rejoin follows its
    /// death in the file's order (at the same tick for a process restarted before its
    /// death was decided).
    #[test]
    fn a_kill_is_judged_by_its_death_and_the_rejoin_after_it() {
        let seen = BTreeMap::new();
        let mut events = vec![
            event("lost", 2, 100, Some("stopped")),
            event("rejoin", 2, 120, None),
            event("lost", 2, 200, Some("process died")),
            event("rejoin", 2, 230, None),
            event("lost", 2, 300, Some("stopped")),
            event("reconfigured", 9, 300, None),
            event("died", 2, 310, None),
            event("rejoin", 2, 340, None),
            event("lost", 2, 400, Some("process restarted")),
            event("rejoin", 2, 400, None),
        ];
        events[5]["detail"] = serde_json::json!({ "vehicles": [0, 1, 3] });
        let ev = Evidence {
            events,
            log: Vec::new(),
            published: BTreeMap::new(),
            mission_end: 1e9,
            seen: &seen,
            kill_times: BTreeMap::new(),
        };
        let (a, p) = judge(&ev, 0, true);
        assert!(p.is_empty(), "{p:?}");
        assert_eq!((a.detected_t, a.rejoin_t), (Some(10.0), Some(11.5)));
        let (a, p) = judge(&ev, 1, true);
        assert!(p.is_empty(), "{p:?}");
        assert_eq!(a.detected, Some(true));
        assert_eq!((a.detected_t, a.rejoin_t), (None, Some(17.0)));
        // Never restarted: out since the stop's loss, redesigned without it then.
        let (a, p) = judge(&ev, 1, false);
        assert!(p.is_empty(), "{p:?}");
        assert_eq!(a.reconfigured, Some(true));
        let (a, p) = judge(&ev, 2, true);
        assert!(p.is_empty(), "{p:?}");
        assert_eq!((a.detected_t, a.rejoin_t), (Some(20.0), Some(20.0)));
        let (a, p) = judge(&ev, 3, true);
        assert_eq!(a.detected, Some(false));
        assert_eq!(p, vec!["not detected".to_string()]);
    }
}
