//! One run of the campaign: `vbap run` on the run's mission, the actions on its process
//! set while it runs, then leftovers (reported and cleaned) and the judging of the run.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::ExitStatus;
use std::time::{Duration, Instant, SystemTime};

use anyhow::{Context, Result};
use nix::sys::signal::Signal;
use rand::rngs::StdRng;
use rand::Rng;
use vbap_ipc::topics::Domain;
use vbap_mission::config::{Mission, Pace, RestartPolicy};

use super::args::{policy_name, run_name, run_rng, target_name, Compound};
use super::evaluate::evaluate;
use super::procs::{alive, children, cmdline, epoch_s, is_up, leftover_processes, send, slot_of};
use super::procs::{Seen, Slot, Target};
use super::report::{Action, RunReport};
use super::timing::{COMPOUND_GAP, MIN_STOP, POLL, STOPPED_BEFORE_KILL, UP_TIMEOUT};

/// What a run is: its place in the campaign, its pace, policy, seed and plan.
pub(super) struct RunSpec<'a> {
    pub index: usize,
    pub pace: Pace,
    pub policy: RestartPolicy,
    pub seed: u64,
    pub plan: &'a [(f64, bool, f64)],
    /// The compound faults: (planned wall offset s, case).
    pub compounds: &'a [(f64, Compound)],
    pub calibration: bool,
    pub targets: &'a [Target],
}

/// Starts `vbap run` on the mission variant, acts on its processes, judges the run.
pub(super) fn run_one(exe: &Path, out: &Path, m: Mission, spec: &RunSpec) -> Result<RunReport> {
    let (m, file, run_dir) = write_mission(out, m, spec)?;
    let mut report = RunReport {
        index: spec.index,
        calibration: spec.calibration,
        pace: spec.pace.to_string(),
        policy: policy_name(spec.policy).into(),
        seed: spec.seed,
        mission_name: m.mission.name.clone(),
        run_dir: run_dir.clone(),
        expected_ticks: m.ticks(),
        ..RunReport::default()
    };
    let (mut cmd, _) = vbap_ipc::process::vbap_run(exe, &file, &run_dir)?;
    let wall = Instant::now();
    let mut child = cmd
        .spawn()
        .with_context(|| format!("starting {}", exe.display()))?;
    let sup = child.id();
    let mission_arg = run_dir.join("mission.toml").to_string_lossy().into_owned();

    let mut acting = Acting::new(&m, spec, &run_dir);
    let status = loop {
        let current = acting.observe(sup);
        acting.continue_due(Instant::now());
        match child.try_wait() {
            Ok(Some(st)) => break Ok(st),
            Err(e) => break Err(e),
            Ok(None) => {}
        }
        acting.check_up(&current, wall);
        acting.act_due(&current);
        std::thread::sleep(POLL);
    };
    // The run is over: continue anything still stopped (it may have outlived the run).
    for (pid, _, a) in std::mem::take(&mut acting.stopped) {
        acting.cont(pid, a);
    }
    for a in acting.actions.iter_mut().skip(acting.next) {
        a.outcome = "not sent: the mission was over".into();
    }
    let end_unix = epoch_s(SystemTime::now());
    report.wall_s = wall.elapsed().as_secs_f64();
    record_status(&mut report, status);
    clean_leftovers(&mut report, &m, &mission_arg, &acting.seen)?;
    count_restarts(&mut report, &acting.seen);
    let Acting {
        mut actions, seen, ..
    } = acting;
    evaluate(
        &mut report,
        &mut actions,
        &run_dir,
        &seen,
        end_unix,
        spec.policy,
    );
    report.actions = actions;
    Ok(report)
}

/// The run's mission (name, seed, pace, policy), validated and written to
/// `OUT/missions/NNN.toml`; its run directory `OUT/runs/NNN/` created.
fn write_mission(
    out: &Path,
    mut m: Mission,
    spec: &RunSpec,
) -> Result<(Mission, PathBuf, PathBuf)> {
    let index = spec.index;
    m.mission.name = run_name(&m.mission.name, index);
    m.mission.seed = spec.seed;
    m.mission.pace = spec.pace;
    m.restart.vehicles = spec.policy;
    m.validate().with_context(|| {
        format!(
            "the mission of run {index} ({}, {})",
            spec.pace,
            policy_name(spec.policy)
        )
    })?;
    let file = out.join("missions").join(format!("{index:03}.toml"));
    std::fs::write(&file, m.to_toml_string())
        .with_context(|| format!("writing {}", file.display()))?;
    let run_dir = out.join("runs").join(format!("{index:03}"));
    std::fs::create_dir_all(&run_dir).with_context(|| format!("creating {}", run_dir.display()))?;
    Ok((m, file, run_dir))
}

/// `vbap run`'s exit code, or why there is none.
fn record_status(report: &mut RunReport, status: std::io::Result<ExitStatus>) {
    match status {
        Ok(st) => {
            report.exit_code = st.code();
            if st.code().is_none() {
                report
                    .failures
                    .push(format!("vbap run ended by a signal ({st})"));
            }
        }
        Err(e) => report.failures.push(format!("waiting for vbap run: {e}")),
    }
}

/// Leftovers: files of the run's domain, live processes of the run; then cleans them.
fn clean_leftovers(
    report: &mut RunReport,
    m: &Mission,
    mission_arg: &str,
    seen: &BTreeMap<u32, Seen>,
) -> Result<()> {
    let domain = Domain::new(&m.mission.name)?;
    report.leftover_processes = leftover_processes(mission_arg, seen);
    for entry in &report.leftover_processes {
        if let Some(pid) = entry
            .split_whitespace()
            .next()
            .and_then(|p| p.parse::<u32>().ok())
        {
            send(pid, Signal::SIGCONT);
            send(pid, Signal::SIGKILL);
        }
    }
    report.leftover_files = domain.files();
    for f in &report.leftover_files {
        let _ = std::fs::remove_file(f);
    }
    Ok(())
}

/// Processes started in a slot after its first, per target kind.
fn count_restarts(report: &mut RunReport, seen: &BTreeMap<u32, Seen>) {
    let mut per_slot: BTreeMap<Slot, usize> = BTreeMap::new();
    for p in seen.values() {
        *per_slot.entry(p.slot).or_default() += 1;
    }
    for (slot, n) in per_slot {
        *report
            .restarts_seen
            .entry(target_name(slot.kind()).to_string())
            .or_default() += n - 1;
    }
}

/// The state of a run while it goes: what was seen of its process set, the actions and
/// which of them were sent, the processes stopped.
struct Acting<'a> {
    run_dir: &'a Path,
    targets: &'a [Target],
    seen: BTreeMap<u32, Seen>,
    actions: Vec<Action>,
    rng: StdRng,
    /// Vehicles of the mission.
    n: u32,
    /// Agents are spared at this many alive (dim + 1).
    floor: usize,
    /// When the whole process set was up.
    up: Option<Instant>,
    /// The next action of the plan.
    next: usize,
    /// pid, SIGCONT due, action.
    stopped: Vec<(u32, Instant, usize)>,
    killed_slots: BTreeSet<Slot>,
    stopped_slots: BTreeSet<Slot>,
}

impl<'a> Acting<'a> {
    fn new(m: &Mission, spec: &'a RunSpec, run_dir: &'a Path) -> Self {
        let mut actions: Vec<Action> = spec
            .plan
            .iter()
            .map(|&(at, kill, pause)| Action {
                action: if kill { "kill" } else { "stop" }.into(),
                planned_s: at,
                pause_s: (!kill).then_some(pause),
                ..Action::default()
            })
            .collect();
        for (g, &(at, case)) in spec.compounds.iter().enumerate() {
            actions.extend(compound_actions(g, at, case));
        }
        actions.sort_by(|a, b| a.planned_s.total_cmp(&b.planned_s));
        Acting {
            run_dir,
            targets: spec.targets,
            seen: BTreeMap::new(),
            actions,
            rng: run_rng(spec.seed, spec.index, 1),
            n: m.vehicles.count as u32,
            floor: m.mission.dim + 1,
            up: None,
            next: 0,
            stopped: Vec::new(),
            killed_slots: BTreeSet::new(),
            stopped_slots: BTreeSet::new(),
        }
    }

    /// The process set now: records new children of the supervisor `sup`, returns the
    /// live processes of a slot.
    fn observe(&mut self, sup: u32) -> Vec<(u32, Slot)> {
        let live: Vec<u32> = children(sup);
        for &pid in &live {
            if let std::collections::btree_map::Entry::Vacant(e) = self.seen.entry(pid) {
                if let Some(c) = cmdline(pid) {
                    if let Some(slot) = slot_of(&c) {
                        e.insert(Seen {
                            slot,
                            cmd: c,
                            first_unix_s: epoch_s(SystemTime::now()),
                        });
                    }
                }
            }
        }
        live.iter()
            .filter(|p| alive(**p))
            .filter_map(|p| self.seen.get(p).map(|s| (*p, s.slot)))
            .collect()
    }

    /// Continues the stopped processes that are due (always, even late).
    fn continue_due(&mut self, now: Instant) {
        let (due, waiting): (Vec<_>, Vec<_>) = std::mem::take(&mut self.stopped)
            .into_iter()
            .partition(|&(_, due, _)| now >= due);
        self.stopped = waiting;
        for (pid, _, a) in due {
            self.cont(pid, a);
        }
    }

    /// SIGCONT to stopped process `pid` of action `a` if it is still the process we saw;
    /// records whether it survived and when it was continued.
    fn cont(&mut self, pid: u32, a: usize) {
        let same = self
            .seen
            .get(&pid)
            .is_some_and(|s| cmdline(pid).as_ref() == Some(&s.cmd));
        self.actions[a].survived = Some(same && alive(pid));
        if same {
            send(pid, Signal::SIGCONT);
        }
        self.actions[a].cont_unix_s = Some(epoch_s(SystemTime::now()));
    }

    /// Marks the process set up once every slot has a process and every agent says
    /// `agent up` (or, after `UP_TIMEOUT`, once every slot has a process).
    fn check_up(&mut self, current: &[(u32, Slot)], wall: Instant) {
        if self.up.is_some() {
            return;
        }
        let n = self.n;
        let slots: BTreeSet<Slot> = current.iter().map(|(_, s)| *s).collect();
        let all = slots.contains(&Slot::Coordinator)
            && slots.contains(&Slot::FieldServer)
            && (0..n).all(|i| slots.contains(&Slot::Agent(i)));
        let agents_up = all
            && (0..n).all(|i| {
                std::fs::read_to_string(
                    self.run_dir
                        .join("logs")
                        .join(format!("vehicle_agent_{i}.jsonl")),
                )
                .is_ok_and(|t| t.contains("agent up"))
            });
        if agents_up || (wall.elapsed() > UP_TIMEOUT && all) {
            self.up = Some(Instant::now());
        }
    }

    /// Sends every action whose planned time has come.
    fn act_due(&mut self, current: &[(u32, Slot)]) {
        let Some(t0) = self.up else {
            return;
        };
        while self.next < self.actions.len()
            && t0.elapsed().as_secs_f64() >= self.actions[self.next].planned_s
        {
            let a = self.next;
            self.next += 1;
            if let Err(why) = self.act(a, current, t0) {
                self.actions[a].outcome = why;
            }
        }
    }

    /// Action `a`: picks its target and sends its signal; Err: why it was not sent.
    fn act(&mut self, a: usize, current: &[(u32, Slot)], t0: Instant) -> Result<(), String> {
        let over = std::fs::read_to_string(self.run_dir.join("logs").join("coordinator.jsonl"))
            .is_ok_and(|t| t.contains("coordinator done"));
        if over {
            return Err("not sent: the mission was over".into());
        }
        let kill = self.actions[a].action == "kill";
        let (pid, slot) = match self.stopped_of_group(a, current)? {
            Some(target) => target,
            None => self.pick(kill, current, self.actions[a].forced)?,
        };
        // The pid is still the process we saw (no reuse since).
        if cmdline(pid).as_ref() != self.seen.get(&pid).map(|s| &s.cmd) {
            return Err("not sent: the target ended just before".into());
        }
        let sig = if kill {
            Signal::SIGKILL
        } else {
            Signal::SIGSTOP
        };
        let sent_at = SystemTime::now();
        if !send(pid, sig) {
            return Err("not sent: the target ended just before".into());
        }
        let act = &mut self.actions[a];
        act.sent = true;
        act.target = slot.label();
        act.slot = Some(slot);
        act.vehicle = match slot {
            Slot::Agent(i) => Some(i),
            _ => None,
        };
        act.pid = Some(pid);
        act.at_unix_s = Some(epoch_s(sent_at));
        act.at_s = Some(t0.elapsed().as_secs_f64());
        if kill {
            self.killed_slots.insert(slot);
            // A stopped process killed: never continued.
            self.stopped.retain(|s| s.0 != pid);
        } else {
            self.stopped_slots.insert(slot);
            let pause = Duration::from_secs_f64(act.pause_s.unwrap_or(MIN_STOP));
            self.stopped.push((pid, Instant::now() + pause, a));
        }
        Ok(())
    }

    /// The kill of a compound "kill while stopped" (action `a`): the process its stop
    /// stopped, still stopped (Ok(None): not such a kill; Err: its stop was not sent, the
    /// process is gone, or agents are spared at `floor` alive).
    fn stopped_of_group(
        &self,
        a: usize,
        current: &[(u32, Slot)],
    ) -> Result<Option<(u32, Slot)>, String> {
        let act = &self.actions[a];
        let Some(g) = act.group.filter(|_| act.action == "kill") else {
            return Ok(None);
        };
        let Some(stop) = self
            .actions
            .iter()
            .find(|b| b.group == Some(g) && b.action == "stop")
        else {
            return Ok(None); // a kill during a restart: its target is picked
        };
        let agents_alive = current
            .iter()
            .filter(|(_, s)| matches!(s, Slot::Agent(_)))
            .count();
        if agents_alive <= self.floor {
            return Err(format!(
                "not sent: agents are spared at {} = dim + 1 alive",
                self.floor
            ));
        }
        match (stop.sent, stop.pid, stop.slot) {
            (true, Some(pid), Some(slot)) if self.stopped.iter().any(|s| s.0 == pid) => {
                Ok(Some((pid, slot)))
            }
            (true, ..) => Err("not sent: the stopped process was continued or is gone".into()),
            _ => Err("not sent: its stop was not sent".into()),
        }
    }

    /// The seeded target of a kill (`kill`) or stop: a kind among those with a candidate
    /// (`forced`: that kind, whatever `--targets` says), then a candidate of it. Err: why
    /// there is none.
    fn pick(
        &mut self,
        kill: bool,
        current: &[(u32, Slot)],
        forced: Option<Target>,
    ) -> Result<(u32, Slot), String> {
        let candidates = self.candidates(kill, current, forced);
        let kinds: Vec<Target> = match forced {
            Some(t) => vec![t],
            None => self.targets.to_vec(),
        }
        .into_iter()
        .filter(|t| candidates.iter().any(|(_, s)| s.kind() == *t))
        .collect();
        if kinds.is_empty() {
            return Err(if kill {
                format!(
                    "not sent: no live target (agents are spared at {} = dim + 1 alive)",
                    self.floor
                )
            } else {
                "not sent: no live target".into()
            });
        }
        let kind = kinds[self.rng.random_range(0..kinds.len())];
        let of_kind: Vec<(u32, Slot)> = candidates
            .into_iter()
            .filter(|(_, s)| s.kind() == kind)
            .collect();
        Ok(of_kind[self.rng.random_range(0..of_kind.len())])
    }

    /// Live processes of a target kind, up by their own log and not stopped; an agent
    /// only while more than `floor` are alive for a kill, never one already killed or
    /// stopped for a stop.
    fn candidates(
        &self,
        kill: bool,
        current: &[(u32, Slot)],
        forced: Option<Target>,
    ) -> Vec<(u32, Slot)> {
        let paused: BTreeSet<u32> = self.stopped.iter().map(|s| s.0).collect();
        let agents_alive = current
            .iter()
            .filter(|(_, s)| matches!(s, Slot::Agent(_)))
            .count();
        current
            .iter()
            .copied()
            .filter(|(p, s)| {
                forced.map_or(self.targets.contains(&s.kind()), |t| t == s.kind())
                    && !paused.contains(p)
                    && is_up(self.run_dir, *p, *s)
                    && match (kill, s) {
                        (true, Slot::Agent(_)) => {
                            !self.stopped_slots.contains(s) && agents_alive > self.floor
                        }
                        (false, Slot::Agent(_)) => {
                            !self.killed_slots.contains(s) && !self.stopped_slots.contains(s)
                        }
                        _ => true,
                    }
            })
            .collect()
    }
}

/// The actions of compound fault `g` of case `case` planned at `at` (s after the set was
/// up).
fn compound_actions(g: usize, at: f64, case: Compound) -> Vec<Action> {
    let part = |action: &str, planned_s: f64, forced: Target| Action {
        action: action.into(),
        planned_s,
        compound: Some(case.name().into()),
        group: Some(g),
        forced: Some(forced),
        ..Action::default()
    };
    match case {
        Compound::DuringCoordinatorRestart => vec![
            part("kill", at, Target::Coordinator),
            part("kill", at + COMPOUND_GAP, Target::Agents),
        ],
        Compound::DuringFieldServerRestart => vec![
            part("kill", at, Target::FieldServer),
            part("kill", at + COMPOUND_GAP, Target::Agents),
        ],
        Compound::WhileStopped => {
            let mut stop = part("stop", at, Target::Agents);
            // Continued only if its kill was not sent.
            stop.pause_s = Some(STOPPED_BEFORE_KILL + 2.0);
            vec![stop, part("kill", at + STOPPED_BEFORE_KILL, Target::Agents)]
        }
    }
}
