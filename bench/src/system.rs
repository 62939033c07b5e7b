//! The system figures of `vbap bench`: the real `vbap run` (a child process running the
//! whole process set) and the in-process simulator, on generated missions.
//!
//! What is read from a run, and how:
//! - **ticks per second** of the mission loop, start-up and shut-down excluded: from the
//!   coordinator's message records (`logs/coordinator.msgs.csv`, `recv` of hop `state`;
//!   the JSON records of `logs/coordinator.jsonl` in runs of earlier versions). Tick k is
//!   complete when the last state of tick k has arrived, at T_k = max `recv_ns` over the
//!   states of tick k; rate = (K − k₀) / (T_K − T_k₀) with k₀ a tenth of the way in (the
//!   first ticks warm caches and page in shared memory) and K the last tick. Without
//!   message records (`VBAP_MSG_RECORDS=off`): ticks / (last `agent up` →
//!   `coordinator done`).
//! - **hop latency**: `vbap analyze`'s transport percentiles of the `state` hop
//!   ([`vbap_report::analyze::analyze`]).
//! - **start-up**: from the first `started` line of any process log (the field server's,
//!   spawned first) to the last `agent up` line (an agent's ports exist), log timestamps.
//!   "Incl. launch" also counts the `vbap run` process itself: from its spawn by the bench
//!   (wall clock) to the same last `agent up`.
//! - **late ticks**: `summary.json`.
//! - **PSS**: `/proc/<pid>/smaps_rollup` of every process whose command line names the run
//!   directory, sampled once the mission ticks (the coordinator's CSV files have begun to
//!   reach the disk, so every agent has reported tick 0), then every second while it runs;
//!   the sample with every agent present, latest, is kept.
//! - **in-process rate**: `vbap sim`'s progress callback (about 200 calls per mission)
//!   timestamps ticks; the same tenth-of-the-way-in window as above.

use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use serde::Serialize;
use vbap_ipc::msg::wall_ns;
use vbap_ipc::msglog::{self, MsgEvent};
use vbap_ipc::topics::Domain;
use vbap_mission::config::Mission;
use vbap_mission::rundir::{RunDir, Summary};

use super::stop::StopFlag;
use vbap_ipc::domain::clean_domain;
use vbap_report::analyze::{analyze, HopReport};

/// The longest a single `vbap run` of the bench may take.
const RUN_DEADLINE: Duration = Duration::from_secs(900);

/// `vbap sim` on a mission.
pub struct SimResult {
    /// Ticks per second of the mission loop.
    pub tick_rate: f64,
    /// Wall time of the whole simulation (set-up, loop, files, plots), s.
    pub wall_s: f64,
    /// The loop's time by the process that does each part in `vbap run`.
    pub parts: vbap_sim::TickParts,
    /// What the vehicles' own links carried (`summary.json`), as `vbap run` in lockstep.
    pub link_bytes: Option<vbap_mission::rundir::LinkBytes>,
}

/// Runs `mission` in process (the reference simulator) in `work/<name>-sim`.
pub fn simulate(mission: &Mission, work: &Path) -> Result<SimResult> {
    let dir = RunDir::create(&work.join(format!("{}-sim", mission.mission.name)))
        .context("creating the simulator's run directory")?;
    std::fs::write(dir.mission(), mission.to_toml_string()).context("writing mission.toml")?;
    let mut marks: Vec<(u64, Instant)> = Vec::new();
    let started = Instant::now();
    let (_, parts) = vbap_sim::simulate_timed(
        mission,
        &dir,
        &mut |k: u64, _: u64, _: f64, _: Option<f64>| marks.push((k, Instant::now())),
    )?;
    let wall_s = started.elapsed().as_secs_f64();
    let ticks = mission.ticks();
    let from = marks
        .iter()
        .find(|(k, _)| *k >= (ticks / 10).max(1))
        .copied();
    let tick_rate = match (from, marks.last().copied()) {
        (Some((k0, t0)), Some((k1, t1))) if k1 > k0 => {
            (k1 - k0) as f64 / t1.duration_since(t0).as_secs_f64()
        }
        _ => ticks as f64 / wall_s,
    };
    let link_bytes = Summary::read(&dir).ok().and_then(|s| s.link_bytes);
    Ok(SimResult {
        tick_rate,
        wall_s,
        parts,
        link_bytes,
    })
}

/// PSS of the processes of one run, kB.
#[derive(Clone, Debug, Default)]
pub struct PssSample {
    agents: Vec<u64>,
    coordinator: Option<u64>,
    field_server: Option<u64>,
    supervisor: Option<u64>,
}

/// Start-up and memory of a process set.
#[derive(Clone, Debug, Serialize)]
pub struct Footprint {
    pub vehicles: usize,
    /// First `started` to last `agent up`, s.
    pub startup_s: Option<f64>,
    /// Spawn of `vbap run` to last `agent up`, s.
    pub launch_to_up_s: Option<f64>,
    /// Mean PSS of an agent process, MiB.
    pub pss_agent_mib: Option<f64>,
    pub pss_coordinator_mib: Option<f64>,
    pub pss_field_server_mib: Option<f64>,
    /// PSS of `vbap run` (the supervisor), MiB.
    pub pss_supervisor_mib: Option<f64>,
    /// PSS of every process of the set, divided by N, MiB.
    pub pss_total_per_vehicle_mib: Option<f64>,
    pub error: Option<String>,
    pub note: Option<String>,
}

/// What one `vbap run` gave.
#[derive(Clone, Debug)]
pub struct SystemRun {
    /// The run directory.
    pub dir: PathBuf,
    /// Why the run failed (and where its files are), if it did: no figures.
    pub error: Option<String>,
    /// Something that makes the figures suspect (rejected messages, lost vehicles).
    pub note: Option<String>,
    /// Messages the coordinator rejected, vehicles it lost.
    pub rejected: u64,
    pub vehicles_lost: usize,
    /// Spawn to exit of `vbap run`, s.
    pub wall_s: f64,
    /// Ticks run and late ticks (`summary.json`).
    pub ticks: u64,
    pub late_ticks: u64,
    /// Ticks per second of the mission loop, from the coordinator's message records.
    pub tick_rate: Option<f64>,
    /// First `started` to last `agent up`, s.
    pub startup_s: Option<f64>,
    /// Spawn of `vbap run` to last `agent up`, s.
    pub launch_to_up_s: Option<f64>,
    /// The state → coordinator hop.
    pub state_hop: Option<HopReport>,
    /// Memory, when sampled.
    pub pss: Option<PssSample>,
    /// States rejected as from the future (an agent stepped without the coordinator).
    pub future_states: u64,
}

impl SystemRun {
    fn failed(dir: &Path, error: String, wall_s: f64) -> Self {
        Self {
            dir: dir.to_path_buf(),
            error: Some(error),
            note: None,
            rejected: 0,
            vehicles_lost: 0,
            wall_s,
            ticks: 0,
            late_ticks: 0,
            tick_rate: None,
            startup_s: None,
            launch_to_up_s: None,
            state_hop: None,
            pss: None,
            future_states: 0,
        }
    }

    /// True when the run's files are worth keeping: it failed, lost vehicles, rejected
    /// states or ran late.
    pub fn suspect(&self) -> bool {
        self.error.is_some() || self.note.is_some() || self.late_ticks > 0
    }

    /// The start-up and memory figures of this run of `n` vehicles.
    pub fn footprint(&self, n: usize) -> Footprint {
        let mib = |kb: u64| kb as f64 / 1024.0;
        let pss = self.pss.as_ref().filter(|p| p.agents.len() == n);
        Footprint {
            vehicles: n,
            startup_s: self.startup_s,
            launch_to_up_s: self.launch_to_up_s,
            pss_agent_mib: pss.map(|p| mib(p.agents.iter().sum::<u64>()) / n as f64),
            pss_coordinator_mib: pss.and_then(|p| p.coordinator.map(mib)),
            pss_field_server_mib: pss.and_then(|p| p.field_server.map(mib)),
            pss_supervisor_mib: pss.and_then(|p| p.supervisor.map(mib)),
            pss_total_per_vehicle_mib: pss.map(|p| {
                let all = p.agents.iter().sum::<u64>()
                    + p.coordinator.unwrap_or(0)
                    + p.field_server.unwrap_or(0)
                    + p.supervisor.unwrap_or(0);
                mib(all) / n as f64
            }),
            error: self.error.clone().or_else(|| {
                pss.is_none()
                    .then(|| "no PSS sample with every agent running".to_string())
            }),
            note: self.note.clone(),
        }
    }
}

/// A running `vbap run`: on drop (an error or an interrupt of the bench), SIGTERM, a grace
/// period, SIGKILL, then the mission's iceoryx2 files are removed.
struct RunGuard {
    child: Option<Child>,
    domain: Domain,
}

impl Drop for RunGuard {
    fn drop(&mut self) {
        let Some(mut child) = self.child.take() else {
            return;
        };
        if let Ok(None) = child.try_wait() {
            let _ = Command::new("kill")
                .arg("-TERM")
                .arg(child.id().to_string())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status();
            let deadline = Instant::now() + Duration::from_secs(10);
            while Instant::now() < deadline && matches!(child.try_wait(), Ok(None)) {
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = child.kill();
        }
        let _ = child.wait();
        // Children of a killed supervisor die with it (PR_SET_PDEATHSIG); their nodes are
        // then dead and clean_domain removes them.
        let deadline = Instant::now() + Duration::from_secs(5);
        while clean_domain(&self.domain).is_err() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Runs `mission` with `vbap run` in `work/<name>`; samples PSS when `sample_pss`.
/// A failed run is a [`SystemRun`] with `error` set; an interrupt is an error.
pub fn run(mission: &Mission, work: &Path, stop: &StopFlag, sample_pss: bool) -> Result<SystemRun> {
    let name = &mission.mission.name;
    let n = mission.vehicles.count;
    let file = work.join(format!("{name}.toml"));
    let dir = work.join(name);
    let stderr_path = work.join(format!("{name}.stderr.log"));
    std::fs::write(&file, mission.to_toml_string())
        .with_context(|| format!("writing {}", file.display()))?;
    let stderr = std::fs::File::create(&stderr_path)
        .with_context(|| format!("creating {}", stderr_path.display()))?;
    let exe = super::peer::exe()?;
    let launch_ns = wall_ns();
    let started = Instant::now();
    let child = Command::new(exe)
        .arg("run")
        .arg(&file)
        .arg("--out")
        .arg(&dir)
        .arg("--quiet")
        .env_remove("RUST_LOG")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(stderr))
        .spawn()
        .context("starting vbap run")?;
    let mut guard = RunGuard {
        child: Some(child),
        domain: Domain::new(name)?,
    };
    let dir_text = dir.to_string_lossy().to_string();
    let mut pss: Option<PssSample> = None;
    let mut last_sample: Option<Instant> = None;
    let status = loop {
        let child = guard.child.as_mut().expect("held until the end");
        if let Some(status) = child.try_wait().context("waiting for vbap run")? {
            break status;
        }
        stop.check()?;
        if started.elapsed() > RUN_DEADLINE {
            return Ok(SystemRun::failed(
                &dir,
                format!(
                    "vbap run took longer than {RUN_DEADLINE:?}; see {}",
                    dir.display()
                ),
                started.elapsed().as_secs_f64(),
            ));
        }
        if sample_pss
            && last_sample.is_none_or(|t| t.elapsed() >= Duration::from_secs(1))
            && ticking(&dir)
        {
            last_sample = Some(Instant::now());
            let sample = sample_pss_of(&dir_text);
            if sample.agents.len() == n && sample.coordinator.is_some() {
                pss = Some(sample);
            }
        }
        std::thread::sleep(Duration::from_millis(if sample_pss { 50 } else { 20 }));
    };
    let wall_s = started.elapsed().as_secs_f64();
    guard.child = None;
    let domain = guard.domain.clone();
    drop(guard);
    if !domain.files().is_empty() {
        let _ = clean_domain(&domain);
    }
    if !status.success() {
        let tail = std::fs::read_to_string(&stderr_path)
            .map(|t| t.lines().last().unwrap_or("").to_string())
            .unwrap_or_default();
        return Ok(SystemRun::failed(
            &dir,
            format!("vbap run: {status} ({tail}); see {}", dir.display()),
            wall_s,
        ));
    }
    finished(&dir, wall_s, launch_ns, n, pss)
}

/// The measurements of a `vbap run` that ended well in `dir` (after `wall_s` s, launched
/// at `launch_ns` of the wall clock, `n` vehicles, `pss` the last memory sample): its
/// summary, message records and start-up marks.
fn finished(
    dir: &Path,
    wall_s: f64,
    launch_ns: u64,
    n: usize,
    pss: Option<PssSample>,
) -> Result<SystemRun> {
    let run_dir = RunDir {
        root: dir.to_path_buf(),
    };
    let summary = Summary::read(&run_dir)
        .with_context(|| format!("reading {}", run_dir.summary().display()))?;
    let report = analyze(&run_dir)?;
    let marks = Marks::read(&run_dir);
    let note = (summary.messages.rejected > 0 || summary.vehicles_lost > 0).then(|| {
        format!(
            "{} states rejected, {} vehicles lost; see {}",
            summary.messages.rejected,
            summary.vehicles_lost,
            dir.display()
        )
    });
    Ok(SystemRun {
        dir: dir.to_path_buf(),
        error: None,
        note,
        rejected: summary.messages.rejected,
        vehicles_lost: summary.vehicles_lost,
        wall_s,
        ticks: summary.ticks,
        late_ticks: summary.late_ticks,
        tick_rate: tick_rate(&run_dir).or_else(|| marks.tick_rate(summary.ticks, n)),
        startup_s: marks.startup_s(n),
        launch_to_up_s: marks
            .last_agent_up
            .filter(|_| marks.agents_up >= n)
            .map(|up| up - launch_ns as f64 / 1e9),
        future_states: marks.future_states,
        state_hop: report.hops.get("state").cloned(),
        pss,
    })
}

/// True once the coordinator's CSV files have begun to reach the disk (their 64 KiB
/// buffers filled at least once): the mission is past tick 0, every agent is up.
fn ticking(dir: &Path) -> bool {
    ["vehicles.csv", "planner_inputs.csv", "body.csv"]
        .iter()
        .any(|f| std::fs::metadata(dir.join(f)).is_ok_and(|m| m.len() > 0))
}

/// PSS (kB) of every process whose command line mentions `dir`.
fn sample_pss_of(dir: &str) -> PssSample {
    let mut out = PssSample::default();
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return out;
    };
    for entry in entries.flatten() {
        let pid = entry.file_name();
        let Some(pid) = pid
            .to_str()
            .filter(|p| p.bytes().all(|b| b.is_ascii_digit()))
        else {
            continue;
        };
        let Ok(cmdline) = std::fs::read(format!("/proc/{pid}/cmdline")) else {
            continue;
        };
        let args: Vec<String> = cmdline
            .split(|b| *b == 0)
            .map(|a| String::from_utf8_lossy(a).to_string())
            .collect();
        if !args.iter().any(|a| a.contains(dir)) {
            continue;
        }
        let Some(pss) = std::fs::read_to_string(format!("/proc/{pid}/smaps_rollup"))
            .ok()
            .and_then(|t| {
                t.lines()
                    .find_map(|l| l.strip_prefix("Pss:"))
                    .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            })
        else {
            continue;
        };
        let exe = Path::new(&args[0])
            .file_name()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default();
        match exe.as_str() {
            "vehicle_agent" => out.agents.push(pss),
            "coordinator" => out.coordinator = Some(pss),
            "field_server" => out.field_server = Some(pss),
            "vbap" => out.supervisor = Some(pss),
            _ => {}
        }
    }
    out
}

/// Ticks per second of the mission loop, from the coordinator's `state` message records
/// (see the module documentation).
fn tick_rate(dir: &RunDir) -> Option<f64> {
    let complete = state_arrivals_csv(dir)
        .filter(|c| !c.is_empty())
        .or_else(|| state_arrivals_json(dir))?;
    let ticks: Vec<(u64, u64)> = complete.into_iter().collect();
    if ticks.len() < 3 {
        return None;
    }
    let (k0, t0) = ticks[(ticks.len() / 10).max(1)];
    let (k1, t1) = *ticks.last()?;
    (k1 > k0 && t1 > t0).then(|| (k1 - k0) as f64 / ((t1 - t0) as f64 / 1e9))
}

/// Tick → the latest `recv_ns` of its states at the coordinator, from
/// `logs/coordinator.msgs.csv` (None without the file).
fn state_arrivals_csv(dir: &RunDir) -> Option<BTreeMap<u64, u64>> {
    let file = std::fs::File::open(dir.msg_log("coordinator")).ok()?;
    let mut complete: BTreeMap<u64, u64> = BTreeMap::new();
    for line in std::io::BufReader::new(file).lines() {
        let Ok(line) = line else { continue };
        let Some(r) = msglog::parse(&line) else {
            continue;
        };
        if let (MsgEvent::Recv, "state", Some(recv)) = (r.event, r.hop, r.recv_ns) {
            let t = complete.entry(r.tick).or_insert(recv);
            *t = (*t).max(recv);
        }
    }
    Some(complete)
}

/// The same from the JSON message records of `logs/coordinator.jsonl` (runs of earlier
/// versions).
fn state_arrivals_json(dir: &RunDir) -> Option<BTreeMap<u64, u64>> {
    let file = std::fs::File::open(dir.log("coordinator")).ok()?;
    let mut complete: BTreeMap<u64, u64> = BTreeMap::new();
    for line in std::io::BufReader::new(file).lines() {
        let Ok(line) = line else { continue };
        if !line.contains("\"hop\":\"state\"") {
            continue;
        }
        let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) else {
            continue;
        };
        let f = &v["fields"];
        if let (Some(tick), Some(recv)) = (f["tick"].as_u64(), f["recv_ns"].as_u64()) {
            let t = complete.entry(tick).or_insert(recv);
            *t = (*t).max(recv);
        }
    }
    Some(complete)
}

/// Lifecycle marks of a run, from the `info`/`warn` lines of every process log.
#[derive(Clone, Copy, Debug, Default)]
struct Marks {
    /// Earliest `started` line, s since the epoch.
    first_started: Option<f64>,
    /// Latest `agent up` line, s since the epoch, and how many agents logged one.
    last_agent_up: Option<f64>,
    agents_up: usize,
    /// The coordinator's `coordinator done` line, s since the epoch.
    coordinator_done: Option<f64>,
    /// States the coordinator rejected as from the future (an agent stepped on its own).
    future_states: u64,
}

impl Marks {
    fn read(dir: &RunDir) -> Self {
        let mut m = Marks::default();
        let Ok(entries) = std::fs::read_dir(dir.root.join("logs")) else {
            return m;
        };
        for entry in entries.flatten() {
            let path: PathBuf = entry.path();
            if path.extension().is_none_or(|e| e != "jsonl") {
                continue;
            }
            let Ok(file) = std::fs::File::open(&path) else {
                continue;
            };
            for line in std::io::BufReader::new(file).lines() {
                let Ok(line) = line else { continue };
                if line.contains(MSG_TARGET_FIELD) {
                    continue; // a message record: the bulk of every log
                }
                let kind = if line.contains("\"message\":\"started\"") {
                    0
                } else if line.contains("\"message\":\"agent up\"") {
                    1
                } else if line.contains("\"message\":\"coordinator done\"") {
                    2
                } else if line.contains("\"message\":\"rejected a state\"")
                    && line.contains("\"future\":true")
                {
                    m.future_states += 1;
                    continue;
                } else {
                    continue;
                };
                let Some(t) = serde_json::from_str::<serde_json::Value>(&line)
                    .ok()
                    .and_then(|v| {
                        v["timestamp"]
                            .as_str()
                            .and_then(vbap_report::analyze::parse_utc)
                    })
                else {
                    continue;
                };
                match kind {
                    0 => m.first_started = Some(m.first_started.map_or(t, |f| f.min(t))),
                    1 => {
                        m.agents_up += 1;
                        m.last_agent_up = Some(m.last_agent_up.map_or(t, |f| f.max(t)));
                    }
                    _ => m.coordinator_done = Some(t),
                }
            }
        }
        m
    }

    /// First `started` → last `agent up`, s, when all `n` agents logged `agent up`.
    fn startup_s(&self, n: usize) -> Option<f64> {
        match (self.first_started, self.last_agent_up) {
            (Some(a), Some(b)) if self.agents_up >= n => Some(b - a),
            _ => None,
        }
    }

    /// Ticks per second from the last `agent up` to `coordinator done`: the fallback when
    /// the message records are off (it includes tick 0's wait for the last agent's first
    /// report and the final flush, so it reads a little low on short runs).
    fn tick_rate(&self, ticks: u64, n: usize) -> Option<f64> {
        match (self.last_agent_up, self.coordinator_done) {
            (Some(up), Some(done)) if self.agents_up >= n && done > up && ticks > 0 => {
                Some(ticks as f64 / (done - up))
            }
            _ => None,
        }
    }
}

/// The `target` of message records as it appears in a JSON log line.
const MSG_TARGET_FIELD: &str = "\"target\":\"vbap::msg\"";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_rate_from_either_format() {
        let root = std::env::temp_dir().join(format!("vbap-bench-rate-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = RunDir::create(&root).unwrap();
        let t0: u64 = 1_795_437_897_283_832_923;
        // JSON records only (runs of earlier versions): 20 ticks, 10 ms apart.
        let mut json = String::from("{\"fields\":{\"message\":\"started\"}}\n");
        for k in 0..20u64 {
            for v in 0..2u64 {
                json.push_str(&format!(
                    "{{\"fields\":{{\"message\":\"recv\",\"hop\":\"state\",\"sender\":{v},\"tick\":{k},\"seq\":{k},\"sent_ns\":{t0},\"recv_ns\":{}}},\"target\":\"vbap::msg\"}}\n",
                    t0 + k * 10_000_000 + v
                ));
            }
        }
        std::fs::write(dir.log("coordinator"), json).unwrap();
        let rate = tick_rate(&dir).unwrap();
        assert!((rate - 100.0).abs() < 1e-3, "{rate}");
        // The CSV records come first: 20 ticks, 5 ms apart.
        let mut log = msglog::MsgLog::open(&dir.msg_log("coordinator")).unwrap();
        for k in 0..20u64 {
            for v in 0..2u32 {
                let recv = t0 + k * 5_000_000 + u64::from(v);
                log.recv("state", v, u32::MAX - 1, k, k, t0, recv);
                log.drop("state", v, u32::MAX - 1, k, "loss");
            }
            log.recv("body", u32::MAX - 1, 0, k, k, t0, t0 + 10_000_000_000);
        }
        drop(log);
        let rate = tick_rate(&dir).unwrap();
        assert!((rate - 200.0).abs() < 1e-3, "{rate}");
        let _ = std::fs::remove_dir_all(&root);
    }
}
