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
/// every record of that tick. A `lost` event of tick k is written before the command of
/// tick k is published, so this is the first publication after the verdict (at most one
/// tick period after it in a paced run).
fn command_times(logs: &Path, ticks: &BTreeSet<u64>) -> BTreeMap<u64, f64> {
    use std::io::BufRead as _;
    let mut out: BTreeMap<u64, u64> = BTreeMap::new();
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
                let t = out.entry(tick).or_insert(sent);
                *t = (*t).min(sent);
            }
        }
    }
    out.into_iter()
        .map(|(k, ns)| (k, ns as f64 * 1e-9))
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
    /// Publication time of the command of each tick with a `lost` or `rejoin` event.
    published: BTreeMap<u64, f64>,
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
        let membership_ticks: BTreeSet<u64> = events
            .iter()
            .filter(|e| {
                matches!(
                    e.get("kind").and_then(Value::as_str),
                    Some("lost" | "rejoin")
                )
            })
            .filter_map(|e| e.get("k").and_then(Value::as_u64))
            .collect();
        let published = command_times(&run_dir.join("logs"), &membership_ticks);
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
    /// readmitted (`restarts_vehicles`) or left out of a redesigned formation. An agent
    /// already lost as `stopped` when killed (a lockstep coordinator loses a stopped member)
    /// needs no detection: its kill is judged by the readmission of the new process.
    fn judge_agent_kill(
        &self,
        a: &mut Action,
        k: &AgentKill,
        restarts_vehicles: bool,
        problems: &mut Vec<String>,
    ) {
        let (found, out_already) = self.loss_of_kill(k);
        a.detected = Some(found.is_some() || out_already.is_some());
        a.detected_t = found.and_then(|e| e.get("t")).and_then(Value::as_f64);
        let lost_k = found.and_then(|e| e.get("k")).and_then(Value::as_u64);
        if found.is_some() {
            a.detection_ms = self.detection_ms(lost_k, k);
        } else if out_already.is_none() {
            problems.push("not detected".into());
        }
        let out_k = lost_k.or(out_already);
        if restarts_vehicles {
            let r = self.rejoin_after_kill(k, out_k);
            a.rejoined = Some(r.is_some());
            a.rejoin_t = r.and_then(|e| e.get("t")).and_then(Value::as_f64);
            if r.is_none() {
                problems.push("not readmitted".into());
            }
        } else {
            let re = out_k.is_some_and(|lk| self.reconfigured_without(k.v, lk));
            a.reconfigured = Some(re);
            if !re {
                problems.push("no formation redesigned without it".into());
            }
        }
    }

    /// The command publication time of an event's tick, s since the Unix epoch.
    fn published_at(&self, e: &Value) -> Option<f64> {
        e.get("k")
            .and_then(Value::as_u64)
            .and_then(|k| self.published.get(&k))
            .copied()
    }

    /// The `lost` event that detected kill `k` (a death: any cause but `stopped`), and
    /// else, when the vehicle was already out as `stopped` at the kill, that loss's tick.
    /// With the commands' publication times: the first such loss published at or after
    /// the kill and before the slot's next kill; without them (no message records): the
    /// i-th such loss of the vehicle.
    fn loss_of_kill(&self, k: &AgentKill) -> (Option<&Value>, Option<u64>) {
        let lost = self.of("lost", k.v);
        let cause =
            |e: &Value| e.pointer("/detail/cause").and_then(Value::as_str) == Some("stopped");
        let deaths: Vec<&Value> = lost.iter().copied().filter(|e| !cause(e)).collect();
        if self.published.is_empty() {
            return (deaths.get(k.i).copied(), None);
        }
        let found = deaths.iter().copied().find(|e| {
            self.published_at(e)
                .is_some_and(|t| t >= k.at && t < k.next_kill)
        });
        if found.is_some() {
            return (found, None);
        }
        // Out already: its last loss before the kill was a stop, not followed by a rejoin
        // published before the kill.
        let before = |e: &&Value| self.published_at(e).is_some_and(|t| t < k.at);
        let last_loss = lost.iter().copied().rfind(before);
        let out = last_loss.filter(|e| cause(e)).and_then(|e| {
            let lk = e.get("k").and_then(Value::as_u64)?;
            let rejoined = self
                .of("rejoin", k.v)
                .into_iter()
                .filter(before)
                .any(|r| r.get("k").and_then(Value::as_u64).is_some_and(|rk| rk > lk));
            (!rejoined).then_some(lk)
        });
        (None, out)
    }

    /// The `rejoin` event of the process started after kill `k` (vehicle out from tick
    /// `out_k`): the first rejoin at that tick or later (a process restarted before its
    /// death was decided is lost and admitted at one tick) published after the kill; without
    /// publication times, the i-th rejoin of the vehicle.
    fn rejoin_after_kill(&self, k: &AgentKill, out_k: Option<u64>) -> Option<&Value> {
        let rejoins = self.of("rejoin", k.v);
        if self.published.is_empty() {
            return rejoins.get(k.i).copied();
        }
        rejoins.into_iter().find(|r| {
            let rk = r.get("k").and_then(Value::as_u64);
            rk.zip(out_k).is_some_and(|(rk, lk)| rk >= lk)
                && self.published_at(r).is_some_and(|t| t >= k.at)
        })
    }

    /// Wall time from the kill to the command of the `lost` event's tick `lost_k`, ms;
    /// without message records, to the coordinator's warning about the vehicle.
    fn detection_ms(&self, lost_k: Option<u64>, k: &AgentKill) -> Option<f64> {
        let at = k.at;
        lost_k
            .and_then(|lk| self.published.get(&lk))
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

    fn evidence<'a>(
        events: Vec<Value>,
        published: &[(u64, f64)],
        seen: &'a BTreeMap<u32, Seen>,
    ) -> Evidence<'a> {
        Evidence {
            events,
            log: Vec::new(),
            published: published.iter().copied().collect(),
            mission_end: 1e9,
            seen,
            kill_times: BTreeMap::new(),
        }
    }

    /// Kills are matched to the losses and rejoins published after them, a stop's loss
    /// (lockstep loses a stopped member) never taken for a kill's detection; a kill of an
    /// agent already out as stopped needs no detection and is judged by its rejoin.
    #[test]
    fn a_kill_is_judged_by_the_loss_and_rejoin_published_after_it() {
        let seen = BTreeMap::new();
        let ev = evidence(
            vec![
                event("lost", 2, 100, Some("stopped")),
                event("rejoin", 2, 120, None),
                event("lost", 2, 200, Some("process died")),
                event("rejoin", 2, 230, None),
                event("lost", 2, 300, Some("stopped")),
                event("rejoin", 2, 340, None),
                event("lost", 2, 400, Some("process restarted")),
                event("rejoin", 2, 400, None),
            ],
            &[
                (100, 10.0),
                (120, 11.0),
                (200, 15.1),
                (230, 16.0),
                (300, 20.0),
                (340, 22.0),
                (400, 26.0),
            ],
            &seen,
        );
        // Killed at 15.0 while a member: detected by the loss of tick 200.
        let kill = AgentKill {
            v: 2,
            i: 0,
            at: 15.0,
            next_kill: 20.3,
        };
        let (found, out) = ev.loss_of_kill(&kill);
        assert_eq!(found.and_then(|e| e["k"].as_u64()), Some(200));
        assert_eq!(out, None);
        let rejoin = ev.rejoin_after_kill(&kill, Some(200));
        assert_eq!(rejoin.and_then(|e| e["k"].as_u64()), Some(230));
        // Killed at 20.3 while stopped and already lost (tick 300): out already.
        let kill = AgentKill {
            v: 2,
            i: 1,
            at: 20.3,
            next_kill: 25.0,
        };
        let (found, out) = ev.loss_of_kill(&kill);
        assert!(found.is_none());
        assert_eq!(out, Some(300));
        let rejoin = ev.rejoin_after_kill(&kill, out);
        assert_eq!(rejoin.and_then(|e| e["k"].as_u64()), Some(340));
        // Killed at 12.0, a member again since tick 120, its death never decided: not
        // detected (the stop's loss before it is no detection).
        let kill = AgentKill {
            v: 2,
            i: 0,
            at: 12.0,
            next_kill: 14.0,
        };
        assert_eq!(ev.loss_of_kill(&kill), (None, None));
        // Killed at 25.0 and restarted before its death was decided: lost and readmitted
        // at one tick (400).
        let kill = AgentKill {
            v: 2,
            i: 2,
            at: 25.0,
            next_kill: f64::INFINITY,
        };
        let (found, _) = ev.loss_of_kill(&kill);
        assert_eq!(found.and_then(|e| e["k"].as_u64()), Some(400));
        let rejoin = ev.rejoin_after_kill(&kill, Some(400));
        assert_eq!(rejoin.and_then(|e| e["k"].as_u64()), Some(400));
    }
}
