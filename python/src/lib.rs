//! `vbap._native`: the Rust side of the Python package `vbap` (python/vbap/), built by
//! maturin. Each function is the `vbap` command of the same name on the same crates, so
//! it validates, writes and judges exactly as the command line does:
//!
//! - [`check`]: `vbap check` (the summary of a valid mission as JSON);
//! - [`sim`]: `vbap sim` (the run directory and its summary as JSON);
//! - [`batch`]: `vbap batch --in-process` (the batch directory and its exit code);
//! - [`export_netcdf`]: `vbap export --netcdf`.
//!
//! The user's errors (a mission key, a `--set`, a run directory) raise
//! `vbap.InvalidInput` (a `ValueError`) with the message `vbap` prints before its exit
//! code 2; anything else raises `RuntimeError`. A simulation releases the GIL and stops
//! at Ctrl-C after its tick in progress (its files and summary written, verdict
//! "interrupted"), then raises `KeyboardInterrupt`.

use std::path::PathBuf;
use std::sync::atomic::Ordering;

use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use vbap_mission::config::{KeySet, Mission, Overrides};

pyo3::create_exception!(
    _native,
    InvalidInput,
    PyValueError,
    "The user's input is invalid: a mission key, a set, a run directory (vbap's exit code 2)."
);

/// The Python exception of an error: [`InvalidInput`] for what the command line exits 2
/// on, `RuntimeError` (with its causes) otherwise.
fn py_err(e: anyhow::Error) -> PyErr {
    let user = e.is::<vbap_ipc::process::InvalidInput>()
        || e.is::<vbap_report::InvalidRunDir>()
        || e.is::<vbap_sim::RunDirRefused>()
        || e.is::<vbap_mission::config::ConfigError>();
    if user {
        InvalidInput::new_err(e.to_string())
    } else {
        PyRuntimeError::new_err(format!("{e:#}"))
    }
}

/// `KEY=VALUE` texts (as `--set` takes them) parsed as the command line parses them.
fn key_sets(sets: &[String]) -> PyResult<Vec<KeySet>> {
    sets.iter()
        .map(|s| {
            s.parse::<KeySet>()
                .map_err(|e| InvalidInput::new_err(format!("set {s}: {e}")))
        })
        .collect()
}

/// `vbap check PATH --set …`: the mission validated (with its `[batch]` table); returns
/// `{"vehicles", "ticks", "dim", "warnings", "notes"}` as JSON.
#[pyfunction]
#[pyo3(signature = (path, sets = Vec::new()))]
fn check(path: PathBuf, sets: Vec<String>) -> PyResult<String> {
    let sets = key_sets(&sets)?;
    let m = Mission::load_with(&path, &sets).map_err(|e| py_err(e.into()))?;
    vbap_batch::check(&path, &sets, &m).map_err(py_err)?;
    let notes: Vec<String> = m
        .envelope_lines()
        .into_iter()
        .chain(m.trail_line())
        .collect();
    let out = serde_json::json!({
        "mission": m.mission.name,
        "vehicles": m.vehicles.count,
        "ticks": m.ticks(),
        "dim": m.mission.dim,
        "warnings": vbap_sim::mission_warnings(&m),
        "notes": notes,
    });
    Ok(out.to_string())
}

/// `vbap sim PATH --seed --vehicles --duration --set … --out`: runs the mission in this
/// process (without the GIL); returns (the run directory, `summary.json`'s text).
#[pyfunction]
#[pyo3(signature = (path, sets = Vec::new(), seed = None, vehicles = None, duration = None, out = None))]
fn sim(
    py: Python<'_>,
    path: PathBuf,
    sets: Vec<String>,
    seed: Option<u64>,
    vehicles: Option<usize>,
    duration: Option<f64>,
    out: Option<PathBuf>,
) -> PyResult<(String, String)> {
    let sets = key_sets(&sets)?;
    let overrides = Overrides {
        seed,
        vehicles,
        duration,
        pace: None,
    };
    let mission = Mission::load_with(&path, &sets)
        .map_err(anyhow::Error::from)
        .and_then(|m| Ok(m.with_overrides(&overrides)?))
        .map_err(py_err)?;
    let dir = vbap_sim::create_run_dir(out.as_deref(), &mission).map_err(py_err)?;
    vbap_sim::STOP.store(false, Ordering::Relaxed);
    let summary = py.detach(|| {
        // Ctrl-C: Python's signal handler only flags it; look every 2048 ticks.
        let mut progress = |k: u64, _: u64, _: f64, _: Option<f64>| {
            if k.is_multiple_of(2048) && Python::attach(|py| py.check_signals()).is_err() {
                vbap_sim::STOP.store(true, Ordering::Relaxed);
            }
        };
        vbap_sim::simulate(&mission, &dir, &mut progress)
    });
    let summary = summary.map_err(py_err)?;
    let root = dir.root.display().to_string();
    if summary.verdict == "interrupted" {
        return Err(PyKeyboardInterrupt::new_err(format!(
            "interrupted; partial run directory {root}"
        )));
    }
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok((root, json))
}

/// `vbap batch PATH --seeds --set … --sweep … --jobs --out --in-process`: every seed (and
/// sweep point) in this process, `jobs` at a time (without the GIL); returns (the batch
/// directory, the exit code: 0 every criterion met, 1 not).
#[pyfunction]
#[pyo3(signature = (path, seeds, sets = Vec::new(), sweep = Vec::new(), jobs = 1, out = None))]
fn batch(
    py: Python<'_>,
    path: PathBuf,
    seeds: u64,
    sets: Vec<String>,
    sweep: Vec<String>,
    jobs: usize,
    out: Option<PathBuf>,
) -> PyResult<(String, i32)> {
    let sets = key_sets(&sets)?;
    let sweep = sweep
        .iter()
        .map(|s| {
            s.parse::<vbap_batch::SweepArg>()
                .map_err(|e| InvalidInput::new_err(format!("sweep {s}: {e}")))
        })
        .collect::<PyResult<Vec<_>>>()?;
    let out = match out {
        Some(o) => o,
        None => {
            let m = Mission::load_with(&path, &sets).map_err(|e| py_err(e.into()))?;
            vbap_batch::default_batch_dir(&m.mission.name).map_err(py_err)?
        }
    };
    let args = vbap_batch::BatchArgs {
        mission: path,
        seeds,
        jobs,
        in_process: true,
        out: Some(out.clone()),
        quiet: true,
        sets,
        sweep,
        silent: true,
    };
    let code = py.detach(|| vbap_batch::main(&args)).map_err(py_err)?;
    Ok((out.display().to_string(), code))
}

/// `vbap export RUN_DIR --netcdf OUT`: returns (trajectories, ticks, variables).
#[pyfunction]
fn export_netcdf(
    py: Python<'_>,
    run_dir: PathBuf,
    out: PathBuf,
) -> PyResult<(usize, usize, usize)> {
    let done = py
        .detach(|| vbap_report::export::export_netcdf(&run_dir, &out))
        .map_err(py_err)?;
    Ok((done.trajectories, done.ticks, done.variables))
}

/// The module `vbap._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InvalidInput", m.py().get_type::<InvalidInput>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(sim, m)?)?;
    m.add_function(wrap_pyfunction!(batch, m)?)?;
    m.add_function(wrap_pyfunction!(export_netcdf, m)?)?;
    Ok(())
}
