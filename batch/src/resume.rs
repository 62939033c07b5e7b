//! Resuming a batch: `OUT/plan.json` records what the batch runs (the resolved mission, the
//! sweep, the seeds, the mode); a batch started again on the same `OUT` with the same plan
//! skips the runs already complete, and refuses a different plan.

use std::path::Path;

use serde::{Deserialize, Serialize};
use vbap_mission::rundir::{RunDir, Summary};

use super::sweep::SweptKey;
use vbap_ipc::process::InvalidInput;

/// The file of the plan in `OUT`.
pub const PLAN_FILE: &str = "plan.json";

/// What a batch runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The mission as resolved (file and `--set`s, before the sweep), as `mission.toml`.
    pub mission: String,
    /// The swept keys and their values.
    pub sweep: Vec<SweptKey>,
    /// The first seed and the number of seeds.
    pub first_seed: u64,
    pub seeds: u64,
    /// "in-process" or "multi-process".
    pub mode: String,
}

impl Plan {
    /// The first field that differs from `other`, in words.
    fn difference(&self, other: &Plan) -> Option<&'static str> {
        if self.mission != other.mission {
            Some("the mission (file or --set)")
        } else if self.sweep != other.sweep {
            Some("the sweep")
        } else if (self.first_seed, self.seeds) != (other.first_seed, other.seeds) {
            Some("the seeds")
        } else if self.mode != other.mode {
            Some("the mode (--in-process)")
        } else {
            None
        }
    }
}

/// Makes `out` ready for `plan`: a new directory gets the plan; one with the same plan is
/// resumed (returns true); one with another plan, or a batch from before plans, is refused.
pub fn prepare(out: &Path, plan: &Plan) -> Result<bool, InvalidInput> {
    let shown = out.display();
    let file = out.join(PLAN_FILE);
    if file.exists() {
        let recorded: Plan = std::fs::read_to_string(&file)
            .map_err(|e| e.to_string())
            .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
            .map_err(|e| InvalidInput(format!("--out {shown}: {PLAN_FILE} unreadable: {e}")))?;
        return match recorded.difference(plan) {
            None => Ok(true),
            Some(what) => Err(InvalidInput(format!(
                "--out {shown}: holds another batch ({what} differs from its {PLAN_FILE}); \
                 resume it with the same mission, sweep, seeds and mode, or choose another \
                 directory"
            ))),
        };
    }
    if out.join("batch.csv").exists() {
        return Err(InvalidInput(format!(
            "--out {shown}: already holds a batch (batch.csv exists); choose an empty directory"
        )));
    }
    std::fs::create_dir_all(out).map_err(|e| InvalidInput(format!("--out {shown}: {e}")))?;
    let text = serde_json::to_string_pretty(plan).expect("a plan is JSON") + "\n";
    let tmp = out.join(".plan.json.tmp");
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, &file))
        .map_err(|e| InvalidInput(format!("--out {shown}: writing {PLAN_FILE}: {e}")))?;
    Ok(false)
}

/// The file a failed run's directory gets (why, in words): a `vbap run` that exited with
/// an error may still have written a summary, and a resumed batch must run it again as the
/// straight batch counted it failed.
pub const FAILED_FILE: &str = "batch.failed";

/// The summary of the run in `dir` if the run is complete: its `summary.json` exists and
/// reads whole, the run was not interrupted and did not fail.
pub fn complete(dir: &Path) -> Option<Summary> {
    if dir.join(FAILED_FILE).exists() {
        return None;
    }
    let s = Summary::read(&RunDir {
        root: dir.to_path_buf(),
    })
    .ok()?;
    (s.verdict != "interrupted").then_some(s)
}
