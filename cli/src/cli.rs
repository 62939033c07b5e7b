//! The `vbap` command line (docs/ARCHITECTURE.md §9). Exit codes: 0 success, 1 runtime failure,
//! 2 invalid input.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use vbap_ipc::process::{EXIT_FAILURE, EXIT_INVALID, EXIT_OK};
use vbap_math::Mat3;
use vbap_mission::config::{Mission, Overrides, Pace};
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
    },
    /// Optimal formation (V.7): g, positions, radius, second moments.
    Formation(FormationArgs),
    /// Re-run the planner offline on a run's recorded inputs; check body.csv bit for bit.
    Replay(crate::replay::ReplayArgs),
    /// Run a mission for many seeds; table, aggregate, pass/fail.
    Batch(crate::batch::BatchArgs),
    /// Fault campaign: real SIGKILLs and SIGSTOPs at random times; a table of detections,
    /// recoveries and leftovers (exit 1 if any kill went undetected or unrecovered).
    Chaos(crate::chaos::ChaosArgs),
    /// Benchmarks: IPC hop against its floor, lockstep scaling, real-time capacity.
    Bench(crate::bench::BenchArgs),
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
    pace: Option<String>,
    /// Do not show the progress bar.
    #[arg(long)]
    quiet: bool,
    /// Print the summary as JSON (as summary.json) instead of the human summary.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct FormationArgs {
    /// Number of vehicles.
    #[arg(long)]
    n: usize,
    /// Dimension, 2 or 3.
    #[arg(long, default_value_t = 2)]
    dim: usize,
    /// σ_M, the sensor noise standard deviation.
    #[arg(long, default_value_t = 1.0)]
    sigma_m: f64,
    /// σ_H, the standard deviation of the Hessian factor.
    #[arg(long, default_value_t = 1.0)]
    sigma_h: f64,
    /// The Hessian guess H: h11,h12,h21,h22 (2-D) or 9 numbers row by row (3-D). Default I.
    #[arg(long, allow_hyphen_values = true)]
    hessian: Option<String>,
    /// Seed of the multi-start search.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// An error that is the user's input (exit 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InvalidInput(pub String);

/// Runs the command line; returns the exit code.
pub fn main() -> i32 {
    main_with(None)
}

/// Runs the command line of a user's own vbap (`plugins`: its field and law,
/// [`crate::custom`]); `None`: `vbap` itself. Returns the exit code.
pub fn main_with(plugins: Option<&crate::custom::Plugins>) -> i32 {
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
        Err(e) => {
            if let Some(inv) = e.downcast_ref::<InvalidInput>() {
                eprintln!("vbap: {inv}");
                EXIT_INVALID
            } else if let Some(inv) = e.downcast_ref::<vbap_report::InvalidRunDir>() {
                eprintln!("vbap: {inv}");
                EXIT_INVALID
            } else if let Some(cfg) = e.downcast_ref::<vbap_mission::config::ConfigError>() {
                eprintln!("vbap: {cfg}");
                EXIT_INVALID
            } else {
                eprintln!("vbap: {e:#}");
                EXIT_FAILURE
            }
        }
    }
}

fn dispatch(cmd: Cmd, plugins: Option<&crate::custom::Plugins>) -> Result<i32> {
    if let (Some(_), Cmd::Replay(_) | Cmd::Batch(_) | Cmd::Chaos(_) | Cmd::Bench(_)) =
        (plugins, &cmd)
    {
        return Err(InvalidInput(
            "replay, batch, chaos and bench run the shipped field and control law: use `vbap`"
                .into(),
        )
        .into());
    }
    match cmd {
        Cmd::Check { mission } => {
            let m = Mission::load(&mission)?;
            if m.batch.is_some() {
                // The criteria of `vbap batch`, checked as it will read them.
                let text = vbap_mission::config::read_mission_file(&mission)?;
                crate::batch::split_batch_table(&text, &mission.display().to_string())?;
            }
            if let Some(w) = m.stiffness_warning() {
                eprintln!("vbap: warning: {w}");
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
        Cmd::Sim(args) => {
            let (mission, dir) = prepare(&args)?;
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
                    rt.block_on(crate::supervise::shutdown_signal());
                    crate::sim::STOP.store(true, std::sync::atomic::Ordering::Relaxed);
                }
            });
            let summary = match plugins {
                Some(p) => crate::sim::simulate_plugins(&mission, &dir, p, &mut progress)?,
                None => crate::sim::simulate(&mission, &dir, &mut progress)?,
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
        Cmd::Run(args) => {
            vbap_ipc::msglog::parse_records_switch(
                std::env::var(vbap_ipc::msglog::RECORDS_ENV).ok().as_deref(),
            )
            .map_err(InvalidInput)?;
            let mission = prepare_mission(&args)?;
            // One supervisor per mission name, before anything is written: a second start
            // exits 2 at once and leaves --out alone.
            let _lock =
                crate::lock::MissionLock::acquire(&mission.mission.name).map_err(|e| match e {
                    crate::lock::LockError::Busy { .. } => {
                        anyhow::Error::new(InvalidInput(e.to_string()))
                    }
                    other => anyhow::Error::new(other),
                })?;
            // Processes of a supervisor that was killed end on their own (SIGTERM, then
            // their watchdog): wait for them, bounded.
            let domain = vbap_ipc::topics::Domain::new(&mission.mission.name)?;
            crate::supervise::await_domain_free(
                &domain,
                vbap_ipc::process::ORPHAN_GRACE + std::time::Duration::from_secs(1),
            )
            .map_err(|e| InvalidInput(e.to_string()))?;
            let dir = prepare_dir(&args, &mission)?;
            let runtime = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()?;
            let outcome = match plugins {
                Some(p) => runtime.block_on(crate::supervise::run_with(
                    &mission,
                    &dir,
                    !args.quiet,
                    &crate::supervise::Executables::this_exe_as_roles()?,
                    Some(p.field_of(&mission)),
                ))?,
                None => runtime.block_on(crate::supervise::run(&mission, &dir, !args.quiet))?,
            };
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
        Cmd::Formation(args) => formation(&args),
        Cmd::Replay(args) => crate::replay::main(&args),
        Cmd::Batch(args) => crate::batch::main(&args),
        Cmd::Chaos(args) => crate::chaos::main(&args),
        Cmd::Bench(args) => crate::bench::main(&args),
        Cmd::Analyze { run_dir, json } => vbap_report::analyze::main(&run_dir, json),
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
    let pace = match args.pace.as_deref() {
        None => None,
        Some("lockstep") => Some(Pace::Lockstep),
        Some(p) => match p.parse::<f64>() {
            Ok(f) if f.is_finite() && f > 0.0 => Some(Pace::Factor(f)),
            _ => {
                return Err(InvalidInput(format!(
                    "--pace {p}: must be \"lockstep\" or a number > 0"
                ))
                .into())
            }
        },
    };
    let overrides = Overrides {
        seed: args.seed,
        vehicles: args.vehicles,
        duration: args.duration,
        pace,
    };
    let mission = Mission::load(&args.mission)?.with_overrides(&overrides)?;
    if let Some(w) = mission.stiffness_warning() {
        eprintln!("vbap: warning: {w}");
    }
    Ok(mission)
}

/// Creates the run directory of `mission` and writes the resolved `mission.toml` into it.
fn prepare_dir(args: &RunArgs, mission: &Mission) -> Result<RunDir> {
    let root = match &args.out {
        Some(p) => p.clone(),
        None => default_run_dir(&mission.mission.name)?,
    };
    let dir = RunDir::create(&root)
        .map_err(|e| InvalidInput(format!("--out {}: {e}", root.display())))?;
    for existing in [dir.vehicles(), dir.body(), dir.summary()] {
        if existing.exists() {
            return Err(InvalidInput(format!(
                "--out {}: already holds a run ({} exists); choose an empty directory",
                root.display(),
                existing.display()
            ))
            .into());
        }
    }
    std::fs::write(dir.mission(), mission.to_toml_string()).context("writing mission.toml")?;
    Ok(dir)
}

/// `runs/<label>-<UTC timestamp>`: the default place of a run (label: the mission name) or
/// a batch (`<name>-batch`).
pub(crate) fn default_run_dir(label: &str) -> Result<PathBuf> {
    let now = time::OffsetDateTime::now_utc();
    let stamp = now
        .format(&time::format_description::parse_borrowed::<2>(
            "[year][month][day]T[hour][minute][second]Z",
        )?)
        .context("formatting the timestamp")?;
    Ok(Path::new("runs").join(format!("{label}-{stamp}")))
}

fn print_summary(summary: &Summary, dir: &RunDir, json: bool) -> Result<()> {
    use std::io::Write;
    let text = if json {
        serde_json::to_string_pretty(summary)?
    } else {
        human_summary(summary)
    };
    // A closed pipe (`| head`) is not an error of the run.
    let _ = writeln!(std::io::stdout(), "{text}");
    eprintln!("run directory: {}", dir.root.display());
    Ok(())
}

/// A duration for people: seconds, with hours or days beside long ones.
fn duration(s: f64) -> String {
    if s >= 2.0 * 86400.0 {
        format!("{s:.0} s ({:.1} d)", s / 86400.0)
    } else if s >= 2.0 * 3600.0 {
        format!("{s:.0} s ({:.1} h)", s / 3600.0)
    } else {
        format!("{} s", coordinator::truth::fmt(s))
    }
}

/// The terminal summary of `vbap run` / `vbap sim`: verdict, reasons, key figures.
pub fn human_summary(s: &Summary) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    let verdict = if s.verdict.is_empty() {
        if s.converged {
            "converged"
        } else {
            "not converged"
        }
    } else {
        s.verdict.as_str()
    };
    let _ = writeln!(o, "verdict: {verdict}");
    for r in &s.reasons {
        let _ = writeln!(o, "  - {r}");
    }
    let _ = writeln!(
        o,
        "figures ({} mission, seed {}, {}):",
        s.mission, s.seed, s.mode
    );
    let row = |o: &mut String, k: &str, v: String| {
        let _ = writeln!(o, "  {k:<22}{v}");
    };
    row(
        &mut o,
        "mission time",
        format!(
            "{} in {} ticks, wall {} s",
            duration(s.final_time_s),
            s.ticks,
            coordinator::truth::fmt(s.wall_time_s)
        ),
    );
    if let Some(d) = s.final_distance_to_optimum {
        row(
            &mut o,
            "body to optimum",
            format!(
                "{}{}",
                coordinator::truth::fmt(d),
                s.time_to_converge_s
                    .map_or(String::new(), |t| format!(", converged at {}", duration(t)))
            ),
        );
    }
    if let Some(f) = &s.formation {
        row(
            &mut o,
            "V / V_U (true)",
            format!(
                "max {}, above 1 in {:.1}% of ticks; the coordinator saw max {}",
                coordinator::truth::fmt(f.max_v_true_over_vu),
                100.0 * f.share_ticks_v_true_above_vu,
                coordinator::truth::fmt(f.max_v_seen_over_vu)
            ),
        );
        if let (Some(r), Some(t), Some([a, b])) =
            (f.min_pair_ratio, f.min_pair_t, f.min_pair_vehicles)
        {
            row(
                &mut o,
                "closest pair",
                format!(
                    "{} spacing (vehicles {a} and {b} at t = {}), {} near-collision ticks",
                    coordinator::truth::fmt(r),
                    duration(t),
                    f.near_collision_ticks
                ),
            );
        }
        if let (Some(e), Some(v), Some(t)) =
            (f.worst_slot_error, f.worst_slot_vehicle, f.worst_slot_t)
        {
            row(
                &mut o,
                "worst slot error",
                format!(
                    "{} spacing (vehicle {v} at t = {})",
                    coordinator::truth::fmt(e),
                    duration(t)
                ),
            );
        }
        row(
            &mut o,
            "in formation at end",
            format!(
                "{} of {} alive ({} started, {} lost, {} rejoined)",
                f.in_formation_at_end,
                f.alive_at_end,
                s.vehicles_started,
                s.vehicles_lost,
                s.vehicles_rejoined
            ),
        );
        let gaps: Vec<String> = f
            .longest_contact_gap_s
            .iter()
            .enumerate()
            .filter_map(|(i, g)| g.map(|g| format!("{i}: {}", coordinator::truth::fmt(g))))
            .collect();
        if !gaps.is_empty() {
            row(&mut o, "longest silence (s)", gaps.join(", "));
        }
        if f.stalled_s > 0.0 {
            row(
                &mut o,
                "stalled",
                format!(
                    "{}{}",
                    duration(f.stalled_s),
                    if f.stalled_at_end { ", to the end" } else { "" }
                ),
            );
        }
    }
    if let (Some(inside), Some(b)) = (s.in_set_m, s.theorem_5_1_bound) {
        row(
            &mut o,
            "in set M (Thm 5.1)",
            format!(
                "{inside} (|∇T| = {} against the bound {})",
                coordinator::truth::fmt(s.final_grad_norm),
                coordinator::truth::fmt(b)
            ),
        );
    }
    let m = &s.messages;
    row(
        &mut o,
        "messages",
        format!(
            "{} sent, {} delivered, {} dropped by the links",
            m.sent, m.delivered, m.dropped_injected
        ),
    );
    o.push_str(
        "  (all figures: summary.json; per tick: truth.csv, formation.csv; --json prints the JSON)",
    );
    o
}

fn parse_hessian(text: &str, dim: usize) -> Result<Mat3> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| InvalidInput(format!("--hessian {text}: {e}")))?;
    if values.len() != dim * dim || values.iter().any(|v| !v.is_finite()) {
        return Err(InvalidInput(format!(
            "--hessian {text}: needs {} finite numbers for dim {dim}",
            dim * dim
        ))
        .into());
    }
    let mut h = Mat3::zeros();
    for i in 0..dim {
        for j in 0..dim {
            h[(i, j)] = values[i * dim + j];
        }
    }
    Ok(h)
}

fn formation(args: &FormationArgs) -> Result<i32> {
    if args.dim != 2 && args.dim != 3 {
        return Err(InvalidInput(format!("--dim {}: must be 2 or 3", args.dim)).into());
    }
    if args.n < args.dim + 1 || args.n > vbap_ipc::msg::MAX_VEHICLES {
        return Err(InvalidInput(format!(
            "--n {}: must be between dim + 1 = {} and {}",
            args.n,
            args.dim + 1,
            vbap_ipc::msg::MAX_VEHICLES
        ))
        .into());
    }
    for (name, v) in [("--sigma-m", args.sigma_m), ("--sigma-h", args.sigma_h)] {
        if !v.is_finite() || v < 0.0 {
            return Err(InvalidInput(format!("{name} {v}: must be finite and >= 0")).into());
        }
    }
    let h = match &args.hessian {
        Some(text) => parse_hessian(text, args.dim)?,
        None => {
            let mut h = Mat3::zeros();
            for i in 0..args.dim {
                h[(i, i)] = 1.0;
            }
            h
        }
    };
    let f = vbap_math::optimal::optimal_formation(
        args.n,
        args.dim,
        &h,
        args.sigma_h,
        args.sigma_m,
        args.seed,
    )
    .map_err(|e| InvalidInput(format!("optimal formation: {e}")))?;
    let d = args.dim;
    let positions: Vec<Vec<f64>> = f
        .positions
        .iter()
        .map(|p| p.iter().take(d).copied().collect())
        .collect();
    let moments: Vec<Vec<f64>> = (0..d)
        .map(|i| (0..d).map(|j| f.second_moments[(i, j)]).collect())
        .collect();
    if args.json {
        let out = serde_json::json!({ "g": f.g, "radius": f.radius, "positions": positions, "second_moments": moments });
        println!("{}", serde_json::to_string(&out)?);
    } else {
        println!(
            "N = {}, dim = {}, sigma_M = {}, sigma_H = {}",
            args.n, d, args.sigma_m, args.sigma_h
        );
        println!("g = {:.6}", f.g);
        println!("radius = {:.6}", f.radius);
        for (i, p) in positions.iter().enumerate() {
            println!(
                "p{i} = {:?}",
                p.iter()
                    .map(|v| (v * 1e6).round() / 1e6)
                    .collect::<Vec<_>>()
            );
        }
        println!("second moments = {moments:?}");
    }
    Ok(EXIT_OK)
}
