//! What `vbap batch` and `vbap chaos` share: a `vbap run` child with its output in the run
//! directory's `vbap.log`, a mission name cut to fit with a suffix, and the closing
//! PASS / FAIL lines with their exit code.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result};
use vbap_ipc::process::{EXIT_FAILURE, EXIT_OK};
use vbap_mission::config::MAX_NAME_LEN;

/// `exe run FILE --out RUN_DIR --quiet`, stdin closed, stdout and stderr into
/// `RUN_DIR/vbap.log` (created here), stopped with its parent. Returns the command and the
/// log's path.
pub fn vbap_run(exe: &Path, file: &Path, run_dir: &Path) -> Result<(Command, PathBuf)> {
    let log_path = run_dir.join("vbap.log");
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("creating {}", log_path.display()))?;
    let mut cmd = Command::new(exe);
    cmd.arg("run")
        .arg(file)
        .arg("--out")
        .arg(run_dir)
        .arg("--quiet")
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log);
    vbap_ipc::process::stop_with_parent(&mut cmd);
    Ok((cmd, log_path))
}

/// `<name><suffix>`, the name cut so that the whole fits in `MAX_NAME_LEN`.
pub fn suffixed_name(name: &str, suffix: &str) -> String {
    let keep = MAX_NAME_LEN.saturating_sub(suffix.len()).min(name.len());
    format!("{}{suffix}", &name[..keep])
}

/// Prints `PASS`, or a `FAIL: …` line per failure, on stderr; returns the exit code.
pub fn pass_or_fail(passed: bool, failures: &[String]) -> i32 {
    if passed {
        eprintln!("PASS");
        EXIT_OK
    } else {
        for f in failures {
            eprintln!("FAIL: {f}");
        }
        EXIT_FAILURE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suffixed_names_fit_and_keep_the_suffix() {
        assert_eq!(suffixed_name("paper", "_s3"), "paper_s3");
        let long = suffixed_name(&"a".repeat(3 * MAX_NAME_LEN), "_c012");
        assert_eq!(long.len(), MAX_NAME_LEN);
        assert!(long.ends_with("_c012"));
    }
}
