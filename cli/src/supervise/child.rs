//! One child process: started with its logs, awaited until `ready`, reaped as it ends while
//! its output is read, signalled; a coordinator's handed-over summary.

use std::process::Stdio;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use nix::sys::signal::Signal;
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, ChildStdout, Command};
use tracing::warn;
use vbap_mission::rundir::{RunDir, Summary};

use super::programs::Executable;

/// How long a process may take to print `ready`.
const READY_TIMEOUT: Duration = Duration::from_secs(60);

/// Sends `sig` to a child that has not been reaped yet (its exit not seen, so its pid is
/// still its own); a pid that is no process any more is ignored.
pub fn signal(pid: u32, sig: Signal) {
    if let Ok(pid @ 1..) = i32::try_from(pid) {
        let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), sig);
    }
}

/// Starts `exe` as `name` with `args`, its stderr into `logs/<name>.stderr.log`, its
/// stdout piped.
pub async fn spawn(exe: &Executable, name: &str, args: &[String], dir: &RunDir) -> Result<Child> {
    let stderr = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.root.join("logs").join(format!("{name}.stderr.log")))
        .with_context(|| format!("creating the stderr log of {name}"))?;
    Command::new(&exe.program)
        .args(&exe.args)
        .args(args)
        .arg("--log")
        .arg(dir.log(name))
        .arg("--parent")
        .arg(std::process::id().to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(stderr))
        .kill_on_drop(true)
        .spawn()
        .with_context(|| format!("starting {}", exe.program.display()))
}

/// A child's standard output, read line by line.
pub type StdoutLines = tokio::io::Lines<BufReader<tokio::process::ChildStdout>>;

/// Waits until the process whose output is `stdout` prints `ready`; returns the rest of its
/// output.
pub async fn await_ready(name: &str, stdout: Option<ChildStdout>) -> Result<StdoutLines> {
    let mut lines = BufReader::new(stdout.context("child stdout")?).lines();
    let line = tokio::time::timeout(READY_TIMEOUT, lines.next_line())
        .await
        .with_context(|| format!("{name} did not get ready within {READY_TIMEOUT:?}"))?
        .with_context(|| format!("reading {name}'s stdout"))?;
    match line.as_deref() {
        Some("ready") => Ok(lines),
        other => bail!("{name} exited before it was ready ({other:?}); see its logs"),
    }
}

/// Waits for `child` to end while `output` (the reading of its output) runs; returns its
/// exit status. The child is reaped as it ends, not after its output: a death is never
/// behind a read of a pipe whose write end another process may keep open. What it wrote
/// before it ended is in the pipe, and is read for at most `drain` after.
pub async fn reap_while_reading(
    child: &mut Child,
    output: impl std::future::Future<Output = ()>,
    drain: Duration,
) -> std::io::Result<std::process::ExitStatus> {
    tokio::pin!(output);
    tokio::select! {
        status = child.wait() => {
            let _ = tokio::time::timeout(drain, &mut output).await;
            status
        }
        () = &mut output => child.wait().await,
    }
}

/// The summary a coordinator hands over on its output (`coordinator::handover`), read
/// until the output ends (the coordinator exits).
pub async fn read_handover(mut lines: StdoutLines) -> Option<Summary> {
    let mut summary = None;
    while let Ok(Some(line)) = lines.next_line().await {
        match coordinator::handover::parse_summary_line(&line) {
            Some(Ok(s)) => summary = Some(s),
            Some(Err(e)) => warn!(error = %e, "the coordinator's summary does not parse"),
            None => {}
        }
    }
    summary
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn a_process_is_reaped_as_it_ends_though_another_keeps_its_output_open() {
        // The shell prints its background sleep's pid and exits 3; the sleep keeps the
        // write end of the shell's stdout open for a minute.
        let mut child = Command::new("sh")
            .args(["-c", "sleep 60 & echo $!; exit 3"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("spawning sh");
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let mut printed = Vec::new();
        let output = async {
            while let Ok(Some(line)) = lines.next_line().await {
                printed.push(line);
            }
        };
        let status = tokio::time::timeout(
            Duration::from_secs(30),
            reap_while_reading(&mut child, output, Duration::from_millis(200)),
        )
        .await;
        let holder: Option<i32> = printed.first().and_then(|l| l.trim().parse().ok());
        if let Some(pid) = holder {
            signal(pid as u32, Signal::SIGKILL);
        }
        let status = status
            .expect("the exit waited for the output's end (a minute away)")
            .expect("waiting for sh");
        assert_eq!(status.code(), Some(3));
        // What it wrote before it ended was read.
        assert!(holder.is_some(), "{printed:?}");
    }
}
