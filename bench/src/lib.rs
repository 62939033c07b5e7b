//! `vbap bench`: the cost of IPC against its floor, and scaling to 256 vehicles.
//!
//! One run measures, on this machine and in this run, every figure and the baselines it is
//! compared with, then prints ratios (never asserts a time):
//!
//! 1. **Hop latency**: the state → coordinator hop of `vbap run` (one-way, from the message
//!    records of the logs, as `vbap analyze` reports it) against a raw iceoryx2 ping-pong of
//!    the same payload in the same wake-up mode (pub-sub + event, blocking WaitSet on both
//!    sides: the floor) and against the same ping-pong over UDP loopback with a blocking
//!    `recv` (what a user might pick instead). Floors are real two-process measurements: the
//!    peer is this executable in a hidden helper role ([`floors`]); each is taken with idle
//!    CPUs and with the CPUs kept awake by lowest-priority spinners, as a loaded run keeps
//!    them (an idle vCPU of a KVM guest takes ~20 µs longer to wake).
//! 2. **Lockstep scaling**: ticks per second of `vbap run` at N = 4, 16, 64, 256 against the
//!    in-process simulator on the same mission and against the wake-up floor: one blocking
//!    iceoryx2 event round through N + 1 processes per tick, no payload work ([`floors`]).
//! 3. **Real-time capacity**: the largest N that runs at pace 1.0, dt = 0.1 s with no late
//!    tick.
//! 4. **Glider-days per wall minute**: 6 gliders (deploy/missions/glider.toml, dt = 10 s,
//!    surfacing every 2 h for 10 min), `vbap sim` and `vbap run`.
//! 5. **Footprint**: start-up time of the process set and memory (PSS) per vehicle.
//! 6. to 8. (issue 17, [`overhead`]): the lockstep tick against the skeleton floor (our
//!    topology and messages, no math, no files: [`skeleton`]), the N = 4 hop as the median
//!    of 5 interleaved floor/run pairs, the fan-out of one command to 256 processes
//!    through iceoryx2 against UDP unicast ([`fanout`]).
//!
//! How each figure is derived from the runs is in [`system`] and in BENCHMARKS.md.

//! The command's parts: [`args`] (the arguments, the hidden helper roles), [`plan`] (what a
//! run does and aims at), [`report`] (what is recorded), [`measure`] (the measurements in
//! order), [`render`] (the tables), [`floors`] and [`system`] (the floors, the runs),
//! [`missions`] (what the runs fly), [`peer`] (helper processes, private domains),
//! [`roles`] (this executable as a helper), [`stop`] (SIGINT/SIGTERM).

mod args;
mod fanout;
mod floors;
mod hosts;
mod measure;
mod missions;
mod netns;
mod overhead;
mod peer;
mod plan;
mod render;
mod report;
mod roles;
mod skeleton;
mod skeleton_hosts;
mod stop;
mod system;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use vbap_ipc::process::InvalidInput;
use vbap_ipc::topics::Domain;

pub use args::BenchArgs;
use report::Report;
use stop::{Interrupted, StopFlag};

/// Exit code of a bench stopped by SIGINT/SIGTERM.
const EXIT_INTERRUPTED: i32 = 130;

/// Runs the command; returns the exit code.
pub fn main(args: &BenchArgs) -> Result<i32> {
    // iceoryx2's own warnings (no config file: defaults are what the bench wants) would
    // clutter the tables; errors still show.
    iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
    peer::exe()?;
    if let Some(role) = args.role {
        return roles::helper(role, args);
    }
    check_out(args)?;
    let (work, keep) = work_dir(args)?;
    if args.hosts {
        let code = hosts::bench(args, &work)?;
        if !keep {
            let _ = std::fs::remove_dir_all(&work);
        }
        return Ok(code);
    }
    let stop = StopFlag::new(Domain::new(&peer::unique_name("s"))?)?;
    if args.hop {
        let result = overhead::hop_only(args, &work, &stop);
        stop.close();
        if !keep {
            let _ = std::fs::remove_dir_all(&work);
        }
        return result;
    }
    let result = measure::bench(args, &work, &stop);
    stop.close();
    match result {
        Ok(report) => finish(args, report, &work, keep),
        Err(e) if e.downcast_ref::<Interrupted>().is_some() => {
            eprintln!(
                "vbap bench: interrupted; run directories left in {}",
                work.display()
            );
            Ok(EXIT_INTERRUPTED)
        }
        Err(e) => {
            eprintln!(
                "vbap bench: failed; run directories left in {}",
                work.display()
            );
            Err(e)
        }
    }
}

/// `--out`: a file in an existing directory.
fn check_out(args: &BenchArgs) -> Result<()> {
    if let Some(out) = &args.out {
        let parent = out.parent().filter(|p| !p.as_os_str().is_empty());
        if parent.is_some_and(|p| !p.is_dir()) || out.is_dir() {
            return Err(InvalidInput(format!(
                "--out {}: not a file in an existing directory",
                out.display()
            ))
            .into());
        }
    }
    Ok(())
}

/// The directory of the runs, created, and whether to keep it all: `--work-dir` (empty or
/// absent), else a temporary one.
fn work_dir(args: &BenchArgs) -> Result<(PathBuf, bool)> {
    let (work, keep) = match &args.work_dir {
        Some(dir) => {
            let empty = !dir.exists()
                || std::fs::read_dir(dir).is_ok_and(|mut entries| entries.next().is_none());
            if !empty {
                return Err(InvalidInput(format!(
                    "--work-dir {}: must be empty or absent",
                    dir.display()
                ))
                .into());
            }
            (dir.clone(), true)
        }
        None => (
            std::env::temp_dir().join(format!("vbap-bench-{}", std::process::id())),
            false,
        ),
    };
    std::fs::create_dir_all(&work)
        .map_err(|e| InvalidInput(format!("--work-dir {}: {e}", work.display())))?;
    Ok((work, keep))
}

/// A finished bench: prunes the work directory (unless kept), prints the tables, writes
/// `--out`.
fn finish(args: &BenchArgs, mut report: Report, work: &Path, keep: bool) -> Result<i32> {
    if keep {
        report.work_dir = Some(work.to_path_buf());
    } else {
        prune(work, &report.suspect_runs);
        if !report.suspect_runs.is_empty() {
            report.work_dir = Some(work.to_path_buf());
        }
    }
    print!("{}", render::render(&report));
    if let Some(out) = &args.out {
        let text = serde_json::to_string_pretty(&report)? + "\n";
        std::fs::write(out, text).with_context(|| format!("writing {}", out.display()))?;
        eprintln!("vbap bench: results written to {}", out.display());
    }
    Ok(0)
}

/// Removes everything in `work` but the directories in `keep` (and their mission and
/// stderr files); removes `work` itself when nothing is kept.
fn prune(work: &Path, keep: &[PathBuf]) {
    if keep.is_empty() {
        let _ = std::fs::remove_dir_all(work);
        return;
    }
    let names: Vec<String> = keep
        .iter()
        .filter_map(|d| d.file_name().map(|f| f.to_string_lossy().to_string()))
        .collect();
    let Ok(entries) = std::fs::read_dir(work) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let kept = names.iter().any(|n| {
            name == *n || name == format!("{n}.toml") || name == format!("{n}.stderr.log")
        });
        if kept {
            continue;
        }
        let path = entry.path();
        let _ = if path.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
    }
}
