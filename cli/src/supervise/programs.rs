//! What the supervisor starts: the program of each role ([`Executables`]), the role command
//! of a user's own executable, and this host's share of a mission spread over machines
//! ([`HostPlan`]). A leaf: it uses no other module of this crate.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result};
use vbap_ipc::process::bin_dir;

/// A program the supervisor starts for a role, with the arguments that come first (the
/// role's own arguments follow: `--mission FILE`, `--id I`, `--rejoin`, `--run-dir DIR`,
/// `--log FILE`, `--parent PID`, as the shipped binaries take them).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Executable {
    /// The program.
    pub program: PathBuf,
    /// Its leading arguments (e.g. the role of a program that plays several).
    pub args: Vec<String>,
}

impl Executable {
    /// `program` with no leading arguments.
    pub fn at(program: impl Into<PathBuf>) -> Self {
        Self {
            program: program.into(),
            args: Vec::new(),
        }
    }
}

/// The programs of a process set: which executable plays each role.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Executables {
    /// The field server.
    pub field_server: Executable,
    /// The coordinator.
    pub coordinator: Executable,
    /// Every vehicle agent.
    pub vehicle_agent: Executable,
}

impl Executables {
    /// The shipped binaries, next to this executable ([`bin_dir`]).
    pub fn installed() -> Result<Self> {
        let bin = bin_dir()?;
        Ok(Self {
            field_server: Executable::at(bin.join("field_server")),
            coordinator: Executable::at(bin.join("coordinator")),
            vehicle_agent: Executable::at(bin.join("vehicle_agent")),
        })
    }

    /// This executable in every role, as `THIS role field-server|coordinator|agent ...`
    /// (what [`crate::custom::main`] answers to).
    pub fn this_exe_as_roles() -> Result<Self> {
        let exe = std::env::current_exe().context("locating this executable")?;
        let role = |name: &str| Executable {
            program: exe.clone(),
            args: vec![ROLE_COMMAND.to_string(), name.to_string()],
        };
        Ok(Self {
            field_server: role("field-server"),
            coordinator: role("coordinator"),
            vehicle_agent: role("agent"),
        })
    }
}

/// The first argument of a user's own executable started in a role by its own supervisor
/// ([`Executables::this_exe_as_roles`], `crate::custom`).
pub const ROLE_COMMAND: &str = "role";

/// This host's share of a mission spread over machines (`vbap run --hosts --host`, see
/// `crate::hosts`): a bridge first, then what the hosts file places here.
#[derive(Clone, Debug)]
pub struct HostPlan {
    /// The bridge program and its arguments after `--mission FILE` (`--hosts F --host N`).
    pub bridge: Executable,
    /// The coordinator and the field server run here (the shore).
    pub shore: bool,
    /// The vehicles whose agents run here.
    pub vehicles: Vec<u32>,
    /// The hosts file (copied into the run directory as `hosts.toml`).
    pub file: PathBuf,
    /// How long the shore's bridge may keep the mission's final command for glider hosts
    /// that have not acknowledged it (the hosts file's `final_wait`): the shore's bridge is
    /// given this long past the grace period (`stop::GRACE`) to end by itself.
    pub final_wait: Duration,
}
