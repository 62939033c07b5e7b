//! `vbap echo MISSION SERVICE [--count K]`: one publish-subscribe service's messages,
//! decoded, one JSON object per line.

use std::io::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Result;
use vbap_mission::config::KeySet;

use super::decode::Kind;
use super::sub::Sub;
use crate::errors::InvalidInput;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct EchoArgs {
    /// The mission file (its name names the iceoryx2 domain).
    pub mission: PathBuf,
    /// The service: `vehicle/<id>/state`, `body` or `supervisor/exits` (with or without the
    /// `<mission>/` in front).
    pub service: String,
    /// Messages to print, then exit.
    #[arg(long, default_value_t = 10)]
    pub count: usize,
    /// Give up (exit 1) when fewer messages came within this many seconds.
    #[arg(long, default_value_t = 10.0)]
    pub timeout: f64,
    /// Set a mission key on top of the file (e.g. `--set mission.name=other`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<KeySet>,
}

/// Runs the command; returns the exit code.
pub fn echo(args: &EchoArgs) -> Result<i32> {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        return Err(InvalidInput(format!("--timeout {}: must be > 0 s", args.timeout)).into());
    }
    let (mission, domain) = super::join::domain_of(&args.mission, &args.sets)?;
    let m = &mission.mission.name;
    let name = if args.service.starts_with(&format!("{m}/")) {
        args.service.clone()
    } else {
        format!("{m}/{}", args.service.trim_start_matches('/'))
    };
    let Some(kind) = Kind::of(m, &name) else {
        return Err(InvalidInput(format!(
            "{}: not a service vbap can decode; one of {m}/vehicle/<id>/state, {m}/body, \
             {m}/supervisor/exits (`vbap services` lists them)",
            args.service
        ))
        .into());
    };
    let node = domain.node(super::join::TOOL_NODE)?;
    let sub = Sub::open(&node, kind, &name).map_err(|e| {
        anyhow::Error::new(InvalidInput(format!(
            "{name}: cannot open it; is mission {m:?} running? ({e:#})"
        )))
    })?;
    let end = Instant::now() + Duration::from_secs_f64(args.timeout);
    let mut printed = 0;
    let mut stdout = std::io::stdout().lock();
    let mut failed = None;
    while printed < args.count && Instant::now() < end {
        sub.drain(true, &mut |v| {
            if printed < args.count && failed.is_none() {
                if let Err(e) = writeln!(stdout, "{v}") {
                    failed = Some(e);
                }
                printed += 1;
            }
        })?;
        if failed.is_some() {
            // A closed pipe (`| head`) ends the echo.
            return Ok(vbap_ipc::process::EXIT_OK);
        }
        let _ = stdout.flush();
        // Polling the subscriber's buffer, not synchronisation.
        std::thread::sleep(Duration::from_millis(1));
    }
    if printed < args.count {
        eprintln!(
            "vbap: {printed} of {} messages on {name} within {} s",
            args.count, args.timeout
        );
        return Ok(vbap_ipc::process::EXIT_FAILURE);
    }
    Ok(vbap_ipc::process::EXIT_OK)
}
