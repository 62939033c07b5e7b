//! The `vbap` command line (docs/ARCHITECTURE.md §10). Exit codes: 0 success, 1 runtime failure,
//! 2 invalid input.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use vbap_ipc::process::{EXIT_FAILURE, EXIT_INVALID, EXIT_OK};
use vbap_mission::config::{KeySet, Mission, Overrides, Pace};
use vbap_mission::rundir::{RunDir, Summary};

/// Virtual bodies and artificial potentials: cooperative gradient climbing by a fleet of
/// vehicles, one OS process each, over iceoryx2 shared memory.
#[derive(Parser, Debug)]
#[command(name = "vbap", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Run a mission as a multi-process system (field server, coordinator, N agents).
    Run(RunArgs),
    /// Run a mission in one process (the reference simulator).
    Sim(RunArgs),
    /// Validate a mission file (exit 0 valid, 2 invalid).
    Check {
        /// The mission file.
        mission: PathBuf,
        /// Set a mission key on top of the file, e.g. `--set links.loss=0.2` (repeatable;
        /// validated as if the file said it).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<KeySet>,
    },
    /// Optimal formation (V.7): g, positions, radius, second moments.
    Formation(crate::formation::FormationArgs),
    /// Re-run the planner offline on a run's recorded inputs; check body.csv bit for bit.
    Replay(crate::replay::ReplayArgs),
    /// Run a mission for many seeds; table, aggregate, pass/fail.
    Batch(vbap_batch::BatchArgs),
    /// Seeded random-mission stress campaign over a declared space of missions: pass rates
    /// by law and by dimension, failures shrunk (exit 1 if any mission failed).
    Stress(crate::stress::StressArgs),
    /// Fault campaign: real SIGKILLs and SIGSTOPs at random times; a table of detections,
    /// recoveries and leftovers (exit 1 if any kill went undetected or unrecovered).
    Chaos(vbap_chaos::ChaosArgs),
    /// Benchmarks: IPC hop against its floor, lockstep scaling, real-time capacity.
    Bench(vbap_bench::BenchArgs),
    /// Are two run directories the same run? (files from mission time byte for byte,
    /// summary.json without its wall-clock fields; exit 0 same, 1 different)
    Compare(crate::compare::CompareArgs),
    /// A running mission's iceoryx2 nodes and services, with message rates.
    Services(crate::introspect::ServicesArgs),
    /// One service of a running mission, its messages decoded as JSON lines.
    Echo(crate::introspect::EchoArgs),
    /// Write the synthetic ocean example (CF NetCDF: temperature with a front and eddies,
    /// u/v currents, a coast and an island) for `[field] kind = "grid"` missions.
    Ocean(crate::ocean::OceanArgs),
    /// Serve a browser page that replays a run directory (time slider, map, panels).
    View {
        /// The run directory.
        run_dir: PathBuf,
        /// Address to serve on (loopback by default; another is your explicit choice).
        #[arg(long, default_value = vbap_view::DEFAULT_ADDR)]
        addr: String,
    },
    /// Certificates for mutual TLS between the hosts of a hosts file: a mission CA and one
    /// certificate per host (its endpoint address as subject alternative name); prints
    /// the lines to add to the hosts file.
    Certs(crate::certs::CertsArgs),
    /// A run directory as one CF-1.8 NetCDF file (trajectories of the vehicles and the
    /// virtual body, the readings, the truth per tick) for xarray, Panoply, ERDDAP.
    Export {
        /// The run directory.
        run_dir: PathBuf,
        /// The NetCDF file to write (replaced if it exists).
        #[arg(long, value_name = "FILE.nc")]
        netcdf: PathBuf,
    },
    /// Timing analysis of a run from its tracing logs.
    Analyze {
        /// The run directory.
        run_dir: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Args, Debug)]
struct RunArgs {
    /// The mission file.
    mission: PathBuf,
    /// Run directory (default: runs/<mission>-<UTC timestamp>/).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override mission.seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Override vehicles.count.
    #[arg(long)]
    vehicles: Option<usize>,
    /// Override mission.duration, s.
    #[arg(long)]
    duration: Option<f64>,
    /// Override mission.pace: "lockstep" or a real-time factor (> 0).
    #[arg(long)]
    pace: Option<Pace>,
    /// Set a mission key on top of the file, e.g. `--set control.law=paper` (repeatable;
    /// validated as if the file said it).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<KeySet>,
    /// Do not show the progress bar.
    #[arg(long)]
    quiet: bool,
    /// Print the summary as JSON (as summary.json) instead of the human summary.
    #[arg(long)]
    json: bool,
    /// `vbap run` only: serve the live map of the run in a browser on ADDR (default
    /// loopback, any free port; the URL is printed).
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = vbap_view::DEFAULT_ADDR)]
    view: Option<String>,
    /// Spread over machines: the hosts file (which host runs what; with --host).
    #[arg(long, requires = "host")]
    hosts: Option<PathBuf>,
    /// Spread over machines: this host's name in the hosts file (runs its share only).
    #[arg(long, requires = "hosts")]
    host: Option<String>,
}

use crate::errors::InvalidInput;

/// Runs the command line; returns the exit code.
pub fn main() -> i32 {
    main_with(None)
}

/// Runs the command line of a user's own vbap (`plugins`: its field and law,
/// [`crate::custom`]); `None`: `vbap` itself. Returns the exit code.
pub fn main_with(plugins: Option<&vbap_sim::Plugins>) -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() {
                EXIT_INVALID
            } else {
                EXIT_OK
            };
            let _ = e.print();
            return code;
        }
    };
    let _log = vbap_ipc::telemetry::init_with("vbap", None, "warn");
    match dispatch(cli.command, plugins) {
        Ok(code) => code,
        Err(e) => crate::errors::report(&e),
    }
}

fn dispatch(cmd: Cmd, plugins: Option<&vbap_sim::Plugins>) -> Result<i32> {
    if let (
        Some(_),
        Cmd::Replay(_) | Cmd::Batch(_) | Cmd::Chaos(_) | Cmd::Bench(_) | Cmd::Stress(_),
    ) = (plugins, &cmd)
    {
        return Err(InvalidInput(
            "replay, batch, chaos, bench and stress run the shipped field and control law: use `vbap`"
                .into(),
        )
        .into());
    }
    match cmd {
        Cmd::Check { mission, sets } => check(&mission, &sets),
        Cmd::Sim(args) => sim(&args, plugins),
        Cmd::Run(args) => run(&args, plugins),
        Cmd::Formation(args) => crate::formation::main(&args),
        Cmd::Replay(args) => crate::replay::main(&args),
        Cmd::Batch(args) => vbap_batch::main(&args),
        Cmd::Chaos(args) => vbap_chaos::main(&args),
        Cmd::Stress(args) => crate::stress::main(&args),
        Cmd::Bench(args) => vbap_bench::main(&args),
        Cmd::Compare(args) => crate::compare::main(&args),
        Cmd::Services(args) => crate::introspect::services(&args),
        Cmd::Echo(args) => crate::introspect::echo(&args),
        Cmd::Ocean(args) => crate::ocean::main(&args),
        Cmd::Certs(args) => crate::certs::main(&args),
        Cmd::Export { run_dir, netcdf } => export(&run_dir, &netcdf),
        Cmd::Analyze { run_dir, json } => vbap_report::analyze::main(&run_dir, json),
        Cmd::View { run_dir, addr } => view(&run_dir, &addr),
    }
}

/// `vbap check`: the mission and its `[batch]` criteria, with the stiffness, trail and start
/// warnings.
fn check(mission: &Path, sets: &[KeySet]) -> Result<i32> {
    let m = Mission::load_with(mission, sets)?;
    // The criteria and the sweep of `vbap batch`, checked as it will read them.
    vbap_batch::check(mission, sets, &m)?;
    warn_about(&m);
    for line in m.envelope_lines().into_iter().chain(m.trail_line()) {
        println!("{line}");
    }
    println!(
        "{}: valid ({} vehicles, {} ticks, dim {})",
        mission.display(),
        m.vehicles.count,
        m.ticks(),
        m.mission.dim
    );
    Ok(EXIT_OK)
}

/// `vbap export --netcdf`: the run directory as one CF-1.8 trajectory file.
fn export(run_dir: &Path, netcdf: &Path) -> Result<i32> {
    let done = vbap_report::export::export_netcdf(run_dir, netcdf)?;
    eprintln!(
        "vbap: wrote {} ({} trajectories: the vehicles and the body, {} ticks, {} variables)",
        netcdf.display(),
        done.trajectories,
        done.ticks,
        done.variables
    );
    Ok(EXIT_OK)
}

/// `vbap view`: the replay page of a run directory, until Ctrl-C.
fn view(run_dir: &Path, addr: &str) -> Result<i32> {
    if !run_dir.join("mission.toml").is_file() {
        let e = format!(
            "{}: not a run directory (no mission.toml)",
            run_dir.display()
        );
        return Err(InvalidInput(e).into());
    }
    vbap_view::serve_until_stopped(run_dir, addr).map_err(|e| InvalidInput(format!("{e:#}")))?;
    Ok(EXIT_OK)
}

/// `vbap run --view`: the live page of the run in `dir`, served on its own thread until the
/// returned viewer is dropped.
fn live_view(args: &RunArgs, mission: &Mission, dir: &RunDir) -> Result<Option<vbap_view::Viewer>> {
    let Some(addr) = &args.view else {
        return Ok(None);
    };
    let viewer = vbap_view::spawn(&dir.root, addr, true)
        .map_err(|e| InvalidInput(format!("--view {addr}: {e:#}")))?;
    eprintln!("vbap: live view at {}", viewer.url());
    if mission.restart.coordinator == vbap_mission::config::RestartPolicy::Never {
        eprintln!("vbap: warning: [restart] coordinator = \"never\": the coordinator flushes its files only every 64 KiB, so the live view lags");
    }
    Ok(Some(viewer))
}

/// `vbap sim`: the mission in this process, with a progress bar on a terminal.
fn sim(args: &RunArgs, plugins: Option<&vbap_sim::Plugins>) -> Result<i32> {
    if args.view.is_some() {
        return Err(InvalidInput(
            "--view: only `vbap run` serves a live view (`vbap view DIR` replays a run)".into(),
        )
        .into());
    }
    let (mission, dir) = prepare(args)?;
    let show = !args.quiet && std::io::stderr().is_terminal();
    let bar = indicatif::ProgressBar::new(mission.ticks());
    if !show {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut progress = |k: u64, _n: u64, t: f64, d: Option<f64>| {
        bar.set_position(k);
        bar.set_message(format!(
            "t = {t:.1} s, distance {}",
            d.map_or("n/a".into(), |d| format!("{d:.3}"))
        ));
    };
    // Ctrl-C / SIGTERM stop the simulation after the tick in progress; its files
    // and summary (verdict "interrupted") are still written.
    std::thread::spawn(|| {
        if let Ok(rt) = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
        {
            if let Ok(mut shutdown) = rt.block_on(async { crate::supervise::Shutdown::listen() }) {
                rt.block_on(shutdown.requested());
                vbap_sim::STOP.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        }
    });
    let summary = match plugins {
        Some(p) => vbap_sim::simulate_plugins(&mission, &dir, p, &mut progress)?,
        None => vbap_sim::simulate(&mission, &dir, &mut progress)?,
    };
    bar.finish_and_clear();
    print_summary(&summary, &dir, args.json)?;
    if summary.verdict == "interrupted" {
        eprintln!(
            "vbap: interrupted; partial run directory {}",
            dir.root.display()
        );
        return Ok(130);
    }
    Ok(EXIT_OK)
}

/// `vbap run`: the mission as a process set, under the mission's lock.
fn run(args: &RunArgs, plugins: Option<&vbap_sim::Plugins>) -> Result<i32> {
    vbap_ipc::msglog::parse_records_switch(
        std::env::var(vbap_ipc::msglog::RECORDS_ENV).ok().as_deref(),
    )
    .map_err(InvalidInput)?;
    let mission = prepare_mission(args)?;
    let plan = crate::hosts::plan(args.hosts.as_deref(), args.host.as_deref(), &mission)?;
    if plugins.is_some() && plan.is_some() {
        return Err(InvalidInput("--hosts runs the shipped binaries: use `vbap`".into()).into());
    }
    // One supervisor per mission name, before anything is written: a second start
    // exits 2 at once and leaves --out alone.
    let _lock = crate::lock::MissionLock::acquire(&mission.mission.name).map_err(|e| match e {
        crate::lock::LockError::Busy { .. } => anyhow::Error::new(InvalidInput(e.to_string())),
        other => anyhow::Error::new(other),
    })?;
    // Processes of a supervisor that was killed end on their own (SIGTERM, then
    // their watchdog): wait for them, bounded.
    let domain = vbap_ipc::topics::Domain::new(&mission.mission.name)?;
    vbap_ipc::domain::await_domain_free(
        &domain,
        vbap_ipc::process::ORPHAN_GRACE + std::time::Duration::from_secs(1),
    )
    .map_err(|e| InvalidInput(e.to_string()))?;
    let dir = prepare_dir(args, &mission)?;
    // The mission's iceoryx2 config, for `iox2 ... --config RUN_DIR/iox2.toml`.
    crate::introspect::write_config(&dir, &domain)?;
    let _viewer = live_view(args, &mission, &dir)?;
    if let Some(plan) = &plan {
        crate::hosts::record(plan, &dir)?;
    }
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    let outcome = match (plugins, &plan) {
        (_, Some(plan)) => runtime.block_on(crate::supervise::run_share(
            &mission,
            &dir,
            !args.quiet && plan.shore,
            &crate::supervise::Executables::installed()?,
            None,
            Some(plan),
        ))?,
        (Some(p), None) => runtime.block_on(crate::supervise::run_with(
            &mission,
            &dir,
            !args.quiet,
            &crate::supervise::Executables::this_exe_as_roles()?,
            Some(p.field_of(&mission)),
        ))?,
        (None, None) => runtime.block_on(crate::supervise::run(&mission, &dir, !args.quiet))?,
    };
    if plan.as_ref().is_some_and(|p| !p.shore) {
        // A host without the coordinator: its processes' logs; the run's files are the shore's.
        eprintln!(
            "vbap: this host's share ended; logs in {}/logs",
            dir.root.display()
        );
        return Ok(match (outcome.interrupted, outcome.coordinator_ok) {
            (true, _) => 130,
            (false, true) => EXIT_OK,
            (false, false) => EXIT_FAILURE,
        });
    }
    match (&outcome.summary, outcome.interrupted) {
        (s, true) => {
            if let Some(s) = s {
                print_summary(s, &dir, args.json)?;
            }
            eprintln!(
                "vbap: interrupted; partial run directory {}",
                dir.root.display()
            );
            Ok(130)
        }
        (Some(s), false) if outcome.coordinator_ok => {
            print_summary(s, &dir, args.json)?;
            Ok(EXIT_OK)
        }
        _ => {
            eprintln!("vbap: the run failed; see {}/logs", dir.root.display());
            Ok(EXIT_FAILURE)
        }
    }
}

/// Loads the mission with the command-line overrides, creates the run directory and
/// writes the resolved `mission.toml` into it.
fn prepare(args: &RunArgs) -> Result<(Mission, RunDir)> {
    let mission = prepare_mission(args)?;
    let dir = prepare_dir(args, &mission)?;
    Ok((mission, dir))
}

/// Loads the mission with the command-line overrides (nothing is written).
fn prepare_mission(args: &RunArgs) -> Result<Mission> {
    let overrides = Overrides {
        seed: args.seed,
        vehicles: args.vehicles,
        duration: args.duration,
        pace: args.pace,
    };
    let mission = Mission::load_with(&args.mission, &args.sets)?.with_overrides(&overrides)?;
    warn_about(&mission);
    Ok(mission)
}

/// The warnings of a valid mission that `check`, `run` and `sim` print on stderr
/// ([`vbap_sim::mission_warnings`]).
fn warn_about(mission: &Mission) {
    for w in vbap_sim::mission_warnings(mission) {
        eprintln!("vbap: warning: {w}");
    }
}

/// Creates the run directory of `mission` and writes the resolved `mission.toml` into it
/// ([`vbap_sim::create_run_dir`]).
fn prepare_dir(args: &RunArgs, mission: &Mission) -> Result<RunDir> {
    vbap_sim::create_run_dir(args.out.as_deref(), mission)
}

fn print_summary(summary: &Summary, dir: &RunDir, json: bool) -> Result<()> {
    use std::io::Write;
    let text = if json {
        serde_json::to_string_pretty(summary)?
    } else {
        crate::summary_text::human_summary(summary)
    };
    // A closed pipe (`| head`) is not an error of the run.
    let _ = writeln!(std::io::stdout(), "{text}");
    eprintln!("run directory: {}", dir.root.display());
    Ok(())
}
