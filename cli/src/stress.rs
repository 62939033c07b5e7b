//! `vbap stress`: a seeded random-mission stress campaign (docs/STRESS.md), thin: the
//! arguments, then `vbap_stress::run` with the in-process simulator as the flyer.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};
use vbap_ipc::process::{EXIT_FAILURE, EXIT_OK};
use vbap_mission::config::{KeySet, Mission};
use vbap_mission::rundir::{RunDir, Summary};
use vbap_stress::{BadInput, Config, Space};

use crate::errors::InvalidInput;

/// Which control laws a campaign flies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LawChoice {
    /// `control.law = "robust"` (the default law).
    Robust,
    /// `control.law = "paper"`.
    Paper,
    /// Every mission under both laws (paired).
    Both,
}

/// Arguments of `vbap stress`.
#[derive(Args, Debug)]
pub struct StressArgs {
    /// Missions to sample (indices 0..MISSIONS).
    #[arg(long, default_value_t = 100)]
    pub missions: u64,
    /// The campaign seed: mission i is a pure function of (seed, i).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The campaign directory (results, table, failures); started again, it resumes.
    #[arg(long, required_unless_present = "space")]
    pub out: Option<PathBuf>,
    /// Worker threads (default: the CPUs available).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// The control law(s) every mission flies.
    #[arg(long, value_enum, default_value_t = LawChoice::Robust)]
    pub law: LawChoice,
    /// Bound on the true V/V_U after first contact (V ≤ bound · V_U passes).
    #[arg(long, default_value_t = 2.0)]
    pub v_bound: f64,
    /// Shrink every failure to a simpler mission that fails the same criterion.
    #[arg(long)]
    pub shrink: bool,
    /// Print the declared space and exit.
    #[arg(long)]
    pub space: bool,
    /// Set a mission key on every sampled mission, e.g. `--set links.downlink=false`
    /// (repeatable; validated as if the mission said it).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<KeySet>,
    /// Do not print a line per flight.
    #[arg(long)]
    pub quiet: bool,
    /// Fly only these mission indices (comma-separated or repeated, each below MISSIONS),
    /// e.g. to fly a failure of a large campaign again: `--missions 1000 --only 779`.
    #[arg(long, value_delimiter = ',', value_name = "I")]
    pub only: Vec<u64>,
}

/// The flyer: `vbap sim` without its progress bar.
fn fly(mission: &Mission, dir: &RunDir) -> Result<Summary> {
    vbap_sim::simulate(mission, dir, &mut |_, _, _, _| {})
}

/// Runs `vbap stress`: exit 0 when every flight passed, 1 when any failed, 2 on bad input.
pub fn main(args: &StressArgs) -> Result<i32> {
    let space = Space::default();
    if args.space {
        print!("{space}");
        return Ok(EXIT_OK);
    }
    let Some(out) = args.out.clone() else {
        return Err(InvalidInput("--out DIR is required".into()).into());
    };
    if args.missions == 0 {
        return Err(InvalidInput("--missions 0: must be at least 1".into()).into());
    }
    if args.jobs == Some(0) {
        return Err(InvalidInput("--jobs 0: must be at least 1".into()).into());
    }
    if !(args.v_bound > 0.0 && args.v_bound.is_finite()) {
        return Err(
            InvalidInput(format!("--v-bound {}: must be a number > 0", args.v_bound)).into(),
        );
    }
    let laws = match args.law {
        LawChoice::Robust => vec!["robust".to_string()],
        LawChoice::Paper => vec!["paper".to_string()],
        LawChoice::Both => vec!["robust".to_string(), "paper".to_string()],
    };
    let jobs = args.jobs.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    let config = Config {
        missions: args.missions,
        seed: args.seed,
        out,
        jobs,
        laws,
        v_bound: args.v_bound,
        shrink: args.shrink,
        sets: args.sets.clone(),
        space,
        verbose: !args.quiet,
        only: {
            let mut only = args.only.clone();
            only.sort_unstable();
            only.dedup();
            only
        },
    };
    let outcome = vbap_stress::run(&config, &fly).map_err(|e| match e.downcast::<BadInput>() {
        Ok(bad) => anyhow::Error::new(InvalidInput(bad.0)),
        Err(e) => e,
    })?;
    print!("{}", outcome.table.text());
    eprintln!(
        "vbap: stress table in {}/stress.md and stress.json ({} flights flown now, {} resumed)",
        config.out.display(),
        outcome.flown,
        outcome.results.len().saturating_sub(outcome.flown)
    );
    Ok(if outcome.all_passed() {
        EXIT_OK
    } else {
        EXIT_FAILURE
    })
}
