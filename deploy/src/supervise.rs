//! `vbap run`: start the process set, supervise it, collect the run directory.
//!
//! Order of start: field server, coordinator, then the N agents, each awaited until it
//! prints `ready` (its ports exist). Children ask the kernel to die with the supervisor
//! (PR_SET_PDEATHSIG). SIGINT/SIGTERM to the supervisor: SIGTERM to every child, a grace
//! period, SIGKILL for stragglers, then the mission's iceoryx2 resources are cleaned.

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use shared::config::Mission;
use shared::rundir::{RunDir, Summary};
use shared::topics::Domain;
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, Command};
use tracing::{info, warn};

use crate::analyze;
use crate::progress::ProgressView;

/// Grace period between SIGTERM and SIGKILL.
const GRACE: Duration = Duration::from_secs(5);
/// How long a process may take to print `ready`.
const READY_TIMEOUT: Duration = Duration::from_secs(60);

/// One supervised child.
struct Proc {
    name: String,
    child: Child,
}

/// The directory of the vbap binaries (the one holding this executable).
pub fn bin_dir() -> Result<PathBuf> {
    let exe = std::env::current_exe().context("locating the vbap executable")?;
    Ok(exe
        .parent()
        .context("vbap executable has no parent directory")?
        .to_path_buf())
}

/// Sends `sig` to a child that has not been reaped yet.
#[allow(unsafe_code)]
fn signal(child: &Child, sig: i32) {
    if let Some(pid) = child.id() {
        // SAFETY: kill(2) takes a pid and a signal number; the child is not reaped yet
        // (`id()` is Some), so the pid still names our child.
        unsafe {
            libc::kill(pid as libc::pid_t, sig);
        }
    }
}

/// Removes the stale iceoryx2 resources of `domain`: dead nodes, then any file of the
/// domain's prefix left in /dev/shm and under iceoryx2's root folder. Refuses when a live
/// process of the same mission exists.
pub fn clean_domain(domain: &Domain) -> Result<usize> {
    let alive = domain.alive_node_names();
    if !alive.is_empty() {
        bail!(
            "mission {:?} is already running on this host (live processes: {}); choose another mission.name",
            domain.mission,
            alive.join(", ")
        );
    }
    let dead = domain.cleanup_dead_nodes();
    let prefix = domain.shm_prefix();
    let mut removed = 0;
    for root in [Path::new("/dev/shm"), Path::new("/tmp/iceoryx2")] {
        removed += remove_prefixed(root, &prefix);
    }
    Ok(dead + removed)
}

fn remove_prefixed(dir: &Path, prefix: &str) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().to_string();
        if path.is_dir() {
            removed += remove_prefixed(&path, prefix);
        } else if name.starts_with(prefix) && std::fs::remove_file(&path).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Files of the domain still present (for checks and tests).
pub fn leftover_files(domain: &Domain) -> Vec<PathBuf> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, prefix, out);
            } else if entry.file_name().to_string_lossy().starts_with(prefix) {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    for root in [Path::new("/dev/shm"), Path::new("/tmp/iceoryx2")] {
        walk(root, &domain.shm_prefix(), &mut out);
    }
    out
}

async fn spawn(bin: &Path, name: &str, args: &[String], dir: &RunDir) -> Result<Proc> {
    let stderr = std::fs::File::create(dir.root.join("logs").join(format!("{name}.stderr.log")))
        .with_context(|| format!("creating the stderr log of {name}"))?;
    let child = Command::new(bin)
        .args(args)
        .arg("--log")
        .arg(dir.log(name))
        .arg("--parent")
        .arg(std::process::id().to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(stderr))
        .kill_on_drop(true)
        .spawn()
        .with_context(|| format!("starting {}", bin.display()))?;
    Ok(Proc {
        name: name.to_string(),
        child,
    })
}

async fn await_ready(proc: &mut Proc) -> Result<()> {
    let stdout = proc.child.stdout.take().context("child stdout")?;
    let mut lines = BufReader::new(stdout).lines();
    let line = tokio::time::timeout(READY_TIMEOUT, lines.next_line())
        .await
        .with_context(|| format!("{} did not get ready within {READY_TIMEOUT:?}", proc.name))?
        .with_context(|| format!("reading {}'s stdout", proc.name))?;
    match line.as_deref() {
        Some("ready") => Ok(()),
        other => bail!(
            "{} exited before it was ready ({other:?}); see its logs",
            proc.name
        ),
    }
}

/// How a supervised run ended.
#[derive(Debug)]
pub struct RunOutcome {
    /// The summary, when the coordinator wrote one.
    pub summary: Option<Summary>,
    /// True when a signal stopped the run.
    pub interrupted: bool,
    /// True when the coordinator exited with success.
    pub coordinator_ok: bool,
    /// Wall time from first spawn to every process ready, s.
    pub startup_s: f64,
}

/// Runs `mission` as a process set writing `dir`.
pub async fn run(mission: &Mission, dir: &RunDir, show_progress: bool) -> Result<RunOutcome> {
    let wall = Instant::now();
    let bin = bin_dir()?;
    let domain = Domain::new(&mission.mission.name)?;
    let cleaned = clean_domain(&domain)?;
    if cleaned > 0 {
        info!(
            cleaned,
            "removed stale resources of an earlier run of this mission"
        );
    }
    let mission_file = dir.mission().to_string_lossy().to_string();
    let mut procs: Vec<Proc> = Vec::new();
    let interrupted = Arc::new(AtomicBool::new(false));

    let start = async {
        let mut fs = spawn(
            &bin.join("field_server"),
            "field_server",
            &["--mission".into(), mission_file.clone()],
            dir,
        )
        .await?;
        await_ready(&mut fs).await?;
        procs.push(fs);
        let mut co = spawn(
            &bin.join("coordinator"),
            "coordinator",
            &[
                "--mission".into(),
                mission_file.clone(),
                "--run-dir".into(),
                dir.root.to_string_lossy().to_string(),
            ],
            dir,
        )
        .await?;
        await_ready(&mut co).await?;
        procs.push(co);
        let mut agents = Vec::new();
        for id in 0..mission.vehicles.count {
            let name = format!("vehicle_agent_{id}");
            agents.push(
                spawn(
                    &bin.join("vehicle_agent"),
                    &name,
                    &[
                        "--mission".into(),
                        mission_file.clone(),
                        "--id".into(),
                        id.to_string(),
                    ],
                    dir,
                )
                .await?,
            );
        }
        for a in agents.iter_mut() {
            await_ready(a).await?;
        }
        procs.extend(agents);
        anyhow::Ok(())
    };
    let started = tokio::select! {
        r = start => r,
        _ = shutdown_signal() => { interrupted.store(true, Ordering::SeqCst); Ok(()) }
    };
    let startup_s = wall.elapsed().as_secs_f64();
    if let Err(e) = started {
        stop_all(&mut procs).await;
        let _ = clean_domain(&domain);
        return Err(e);
    }
    info!(startup_s, processes = procs.len(), "process set up");

    let mut view = ProgressView::start(
        mission,
        show_progress && !interrupted.load(Ordering::SeqCst),
    );
    let coordinator_ok = if interrupted.load(Ordering::SeqCst) {
        false
    } else {
        let coord_idx = procs
            .iter()
            .position(|p| p.name == "coordinator")
            .expect("coordinator started");
        let status = tokio::select! {
            s = procs[coord_idx].child.wait() => Some(s),
            _ = shutdown_signal() => None,
        };
        match status {
            Some(Ok(s)) => {
                if !s.success() {
                    warn!(status = %s, "coordinator failed");
                }
                s.success()
            }
            Some(Err(e)) => {
                warn!(error = %e, "waiting for the coordinator");
                false
            }
            None => {
                interrupted.store(true, Ordering::SeqCst);
                false
            }
        }
    };
    view.finish();
    // Finished (or stopped): the others end on FINISHED; stragglers get SIGTERM, SIGKILL.
    if interrupted.load(Ordering::SeqCst) {
        stop_all(&mut procs).await;
    } else {
        let deadline = Instant::now() + GRACE;
        for p in procs.iter_mut() {
            let left = deadline.saturating_duration_since(Instant::now());
            if tokio::time::timeout(left, p.child.wait()).await.is_err() {
                warn!(process = %p.name, "still running after the mission: terminating");
            }
        }
        stop_all(&mut procs).await;
    }
    let _ = clean_domain(&domain);

    let mut summary = Summary::read(dir).ok();
    if let Some(s) = summary.as_mut() {
        s.wall_time_s = wall.elapsed().as_secs_f64();
        if let Ok(report) = analyze::analyze(dir) {
            s.latency_us = report.latency_summary();
        }
        s.write(dir).context("writing summary.json")?;
        if let Err(e) = crate::report_plots::write_run_plots(dir) {
            warn!(error = %e, "time-series plots failed");
        }
    }
    Ok(RunOutcome {
        summary,
        interrupted: interrupted.load(Ordering::SeqCst),
        coordinator_ok,
        startup_s,
    })
}

/// SIGTERM to every live child, a grace period, then SIGKILL; reaps all.
async fn stop_all(procs: &mut [Proc]) {
    for p in procs.iter() {
        signal(&p.child, libc::SIGTERM);
    }
    let deadline = Instant::now() + GRACE;
    for p in procs.iter_mut() {
        let left = deadline.saturating_duration_since(Instant::now());
        if tokio::time::timeout(left, p.child.wait()).await.is_err() {
            warn!(process = %p.name, "did not stop within the grace period: SIGKILL");
            let _ = p.child.kill().await;
        }
    }
}

/// Resolves on SIGINT or SIGTERM.
pub async fn shutdown_signal() {
    use tokio::signal::unix::{signal, SignalKind};
    let mut term = signal(SignalKind::terminate()).expect("installing the SIGTERM handler");
    let mut int = signal(SignalKind::interrupt()).expect("installing the SIGINT handler");
    tokio::select! {
        _ = term.recv() => {},
        _ = int.recv() => {},
    }
}
