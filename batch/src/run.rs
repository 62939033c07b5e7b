//! Running one run of a batch (a grid point and a seed), in this process or as `vbap run`,
//! or skipping it when a resumed batch already has it.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use vbap_mission::config::Mission;
use vbap_mission::rundir::{RunDir, Summary};

use super::row::SeedResult;
use super::sweep::Point;

/// One run: the mission of a grid point with one seed.
pub struct Job<'a> {
    pub point: &'a Point,
    /// The grid point's mission (seed not yet set).
    pub mission: &'a Mission,
    pub seed: u64,
    /// Its run directory.
    pub dir: PathBuf,
}

/// How a run ended.
pub enum Outcome {
    /// Run now.
    Ran(SeedResult),
    /// Complete already (a resumed batch).
    Skipped(SeedResult),
}

/// The run directory of `seed` at `point`: `OUT/seed_<seed>/` without a sweep,
/// `OUT/<point dir>/seed_<seed>/` with one.
pub fn run_dir(out: &Path, point: &Point, seed: u64) -> PathBuf {
    let seed_dir = format!("seed_{seed}");
    match point.dir_name() {
        Some(p) => out.join(p).join(seed_dir),
        None => out.join(seed_dir),
    }
}

/// Runs `job` (or skips it when complete), its row tagged with its grid point.
pub fn run(job: &Job<'_>, in_process: bool, exe: &Path, out: &Path) -> Outcome {
    let tag = |mut r: SeedResult| {
        r.point = job.point.index;
        r.values = job.point.labels();
        r
    };
    if let Some(s) = super::resume::complete(&job.dir) {
        return Outcome::Skipped(tag(SeedResult::from_summary(job.seed, &s, job.dir.clone())));
    }
    let wall = Instant::now();
    let result = (|| -> Result<Summary> {
        // What an interrupted attempt left is not part of this run.
        if job.dir.exists() {
            std::fs::remove_dir_all(&job.dir)
                .with_context(|| format!("clearing {}", job.dir.display()))?;
        }
        if in_process {
            run_in_process(job)
        } else {
            run_process(job, exe, out)
        }
    })();
    Outcome::Ran(tag(match result {
        Ok(s) => SeedResult::from_summary(job.seed, &s, job.dir.clone()),
        Err(e) => {
            let why = format!("{e:#}");
            if job.dir.is_dir() {
                let _ = std::fs::write(job.dir.join(super::resume::FAILED_FILE), &why);
            }
            SeedResult::failed(job.seed, why, wall.elapsed().as_secs_f64(), job.dir.clone())
        }
    }))
}

/// One run with the in-process simulator.
fn run_in_process(job: &Job<'_>) -> Result<Summary> {
    let mut m = job.mission.clone();
    m.mission.seed = job.seed;
    m.validate()?;
    let dir =
        RunDir::create(&job.dir).with_context(|| format!("creating {}", job.dir.display()))?;
    std::fs::write(dir.mission(), m.to_toml_string()).context("writing mission.toml")?;
    vbap_sim::simulate(&m, &dir, &mut |_, _, _, _| {})
}

/// A name for seed `seed` of mission `name`: `<name>_s<seed>`, the name cut to fit.
pub fn seed_name(name: &str, seed: u64) -> String {
    vbap_mission::config::suffixed_name(name, &format!("_s{seed}"))
}

/// One run as a multi-process `vbap run`, its output in `RUN_DIR/vbap.log`. Two runs of one
/// mission name cannot run at once (the name is the IPC domain): the mission is renamed
/// `<name>_s<seed>` (`<name>_p<point>s<seed>` in a sweep) and written to
/// `OUT/missions/`.
fn run_process(job: &Job<'_>, exe: &Path, out: &Path) -> Result<Summary> {
    let name = &job.mission.mission.name;
    let mut m = job.mission.clone();
    m.mission.seed = job.seed;
    let file_name = match job.point.dir_name() {
        None => {
            m.mission.name = seed_name(name, job.seed);
            format!("seed_{}.toml", job.seed)
        }
        Some(p) => {
            let suffix = format!("_p{}s{}", job.point.index, job.seed);
            m.mission.name = vbap_mission::config::suffixed_name(name, &suffix);
            format!("{p}_seed_{}.toml", job.seed)
        }
    };
    m.validate()?;
    let missions = out.join("missions");
    std::fs::create_dir_all(&missions)?;
    let file = missions.join(file_name);
    std::fs::write(&file, m.to_toml_string())
        .with_context(|| format!("writing {}", file.display()))?;
    std::fs::create_dir_all(&job.dir)?;
    let (mut cmd, log_path) = vbap_ipc::process::vbap_run(exe, &file, &job.dir)?;
    let status = cmd
        .status()
        .with_context(|| format!("starting {}", exe.display()))?;
    if !status.success() {
        anyhow::bail!("vbap run exited with {status}; see {}", log_path.display());
    }
    Summary::read(&RunDir {
        root: job.dir.clone(),
    })
    .with_context(|| format!("reading {}/summary.json", job.dir.display()))
}
