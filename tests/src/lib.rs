//! Helpers of the end-to-end tests: building and locating the real binaries, temporary
//! run directories, mission files, process guards, waiting on conditions, reading the
//! message records of a run.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

pub use vbap_ipc::msglog::MsgEvent;
use vbap_ipc::msglog::{self, MsgRecord, MSG_SUFFIX};

pub mod columns;
pub mod grid;
pub mod mission;
pub mod netns;
/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

/// Builds the binaries (release, once per test process) and returns their directory.
///
/// It builds every binary of the workspace together with its test targets, so that cargo
/// resolves the features exactly as the README's test command (`deploy/test.sh`: `cargo test --workspace --release`) does:
/// a build of a few packages (`-p …`) unifies them differently and compiles the heavy
/// dependencies (zenoh, iceoryx2) a second time. After that test command's own build,
/// this one finds everything fresh.
pub fn bin_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .current_dir(workspace())
            .args([
                "build",
                "--release",
                "--quiet",
                "--workspace",
                "--bins",
                "--tests",
            ])
            .status()
            .expect("running cargo build");
        assert!(status.success(), "building the binaries failed");
        let target = std::env::var("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|_| workspace().join("target"));
        target.join("release")
    })
}

/// The `vbap` binary.
pub fn vbap() -> Command {
    Command::new(bin_dir().join("vbap"))
}

/// A mission name unique to this test process and call (letters, digits, `_`).
pub fn unique_name(prefix: &str) -> String {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    format!(
        "{prefix}_{}_{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::SeqCst)
    )
}

/// A temporary directory (`tempfile`'s) removed on drop, but kept, with its path printed,
/// when the test thread panics, so the run directories and logs in it can be read.
///
/// Every process of a test mentions its directory (the mission file, `--out`), so on drop
/// each process still running whose command line mentions it is killed (SIGKILL) first: a
/// test that fails half-way, or whose direct child was only a wrapper (`ip netns exec`,
/// `sh -c`), leaves no `vbap run`, agent or bridge behind; then the shared-memory files of
/// its missions are removed (`remove_domains_of`), which killed processes leave.
pub struct TempDir {
    /// The directory.
    pub path: PathBuf,
    dir: Option<tempfile::TempDir>,
}

impl TempDir {
    /// A fresh empty directory under the system temp dir, named `vbap-test-<tag>-<random>`.
    pub fn new(tag: &str) -> Self {
        let dir = tempfile::Builder::new()
            .prefix(&format!("vbap-test-{tag}-"))
            .tempdir()
            .expect("creating a temp dir");
        Self {
            path: dir.path().to_path_buf(),
            dir: Some(dir),
        }
    }
    /// A path inside.
    pub fn join(&self, p: &str) -> PathBuf {
        self.path.join(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        for pid in processes_mentioning(&self.path.to_string_lossy()) {
            let _ = Command::new("kill")
                .args(["-KILL", &pid.to_string()])
                .status();
        }
        remove_domains_of(&self.path);
        // Kept after a failure, or always with `VBAP_TEST_KEEP=1` (to read a passing run).
        if std::thread::panicking() || std::env::var_os("VBAP_TEST_KEEP").is_some() {
            if let Some(dir) = self.dir.take() {
                eprintln!("kept for inspection: {}", dir.keep().display());
            }
        }
    }
}

/// Removes the iceoryx2 files (`vbap_ipc::topics::Domain::remove_files`) of every mission
/// named by a mission file in `dir` or one folder below it (a test's own mission files, and
/// the `mission.toml` of each run directory) with a name of this test process
/// ([`unique_name`]; a shipped mission's name may be another test's running domain): a
/// process killed above, or by the test, leaves its domain's shared memory behind, and a
/// test that fails half-way would leave it in /dev/shm for good (its mission name is
/// unique, so no later run cleans it).
fn remove_domains_of(dir: &Path) {
    let mut files = Vec::new();
    let mut folders = vec![(dir.to_path_buf(), 0)];
    while let Some((folder, depth)) = folders.pop() {
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        for path in entries.flatten().map(|e| e.path()) {
            if path.is_dir() && depth < 1 {
                folders.push((path, depth + 1));
            } else if path.extension().is_some_and(|e| e == "toml") {
                files.push(path);
            }
        }
    }
    let names: std::collections::BTreeSet<String> = files
        .iter()
        .filter_map(|f| std::fs::read_to_string(f).ok())
        .filter_map(|text| text.parse::<toml::Table>().ok())
        .filter_map(|t| t.get("mission")?.get("name")?.as_str().map(str::to_string))
        .filter(|name| name.contains(&format!("_{}_", std::process::id())))
        .collect();
    for name in names {
        if let Ok(domain) = vbap_ipc::topics::Domain::new(&name) {
            domain.remove_files();
        }
    }
}

/// `text` (a mission file) flying `law` (`[control] law`): its own `[control]` section,
/// if any, gives way to one with only that key.
pub fn with_law(text: &str, law: &str) -> String {
    let mut out = String::new();
    let mut in_control = false;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('[') {
            in_control = t.starts_with("[control]");
        }
        if !in_control {
            out.push_str(line);
            out.push('\n');
        }
    }
    out + &format!("\n[control]\nlaw = \"{law}\"\n")
}

/// Writes a mission file `text` into `dir` and returns its path.
pub fn write_mission(dir: &TempDir, file: &str, text: &str) -> PathBuf {
    let path = dir.join(file);
    std::fs::write(&path, text).expect("writing the mission");
    path
}

/// Runs a command to completion, returning its output; prints stderr on failure.
pub fn run_ok(cmd: &mut Command) -> Output {
    let out = cmd.output().expect("spawning");
    if !out.status.success() {
        eprintln!("--- stdout ---\n{}", String::from_utf8_lossy(&out.stdout));
        eprintln!("--- stderr ---\n{}", String::from_utf8_lossy(&out.stderr));
        panic!("command failed: {:?} -> {}", cmd, out.status);
    }
    out
}

/// A child process killed (SIGKILL) and reaped when dropped.
pub struct ChildGuard(pub Option<Child>);

impl ChildGuard {
    /// The child's pid.
    pub fn pid(&self) -> u32 {
        self.0.as_ref().map(|c| c.id()).unwrap_or(0)
    }
    /// Waits for the child, returning its exit status.
    pub fn wait(&mut self) -> std::process::ExitStatus {
        self.0.take().expect("child").wait().expect("waiting")
    }
    /// Sends a signal (panics when it could not be sent: a test must not wait for the
    /// effect of a signal that never left).
    pub fn signal(&self, sig: &str) {
        let status = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(self.pid().to_string())
            .status();
        assert!(
            status.as_ref().is_ok_and(|s| s.success()),
            "sending SIG{sig} to {}: {status:?}",
            self.pid()
        );
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Waits until `cond` holds, checking every 50 ms, panicking with `what` after `timeout`.
pub fn wait_until(cond: impl FnMut() -> bool, timeout: Duration, what: &str) {
    wait_until_or(cond, timeout, || format!("timed out waiting for {what}"));
}

/// [`wait_until`], panicking with `report()` on a timeout (what the test can say of why).
pub fn wait_until_or(
    mut cond: impl FnMut() -> bool,
    timeout: Duration,
    report: impl FnOnce() -> String,
) {
    let start = Instant::now();
    while !cond() {
        if start.elapsed() >= timeout {
            panic!("{}", report());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Shared-memory and iceoryx2 files of mission `name` still present.
pub fn leftover_files(name: &str) -> Vec<PathBuf> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, prefix, out);
            } else if e.file_name().to_string_lossy().starts_with(prefix) {
                out.push(p);
            }
        }
    }
    let prefix = vbap_ipc::topics::domain_prefix(name);
    let mut out = Vec::new();
    walk(Path::new("/dev/shm"), &prefix, &mut out);
    walk(Path::new("/tmp/iceoryx2"), &prefix, &mut out);
    out
}

/// Pids of live processes whose command line mentions `needle`.
pub fn processes_mentioning(needle: &str) -> Vec<u32> {
    let mut pids = Vec::new();
    let me = std::process::id();
    if let Ok(entries) = std::fs::read_dir("/proc") {
        for e in entries.flatten() {
            let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
                continue;
            };
            if pid == me {
                continue;
            }
            if let Ok(cmd) = std::fs::read(e.path().join("cmdline")) {
                let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
                let zombie = std::fs::read_to_string(e.path().join("stat"))
                    .map(|s| s.contains(") Z "))
                    .unwrap_or(false);
                if cmd.contains(needle) && !zombie {
                    pids.push(pid);
                }
            }
        }
    }
    pids
}

/// What each live process whose command line mentions `needle` is doing, one line each:
/// pid, state (`/proc/PID/stat`: R, S, D, T, ...), the kernel function it waits in, the
/// states of its threads and its command line (shortened). For the message of a test
/// that timed out waiting for processes to end.
pub fn process_report(needle: &str) -> String {
    let read = |path: String| std::fs::read_to_string(path).unwrap_or_default();
    let state = |stat: String| {
        stat.rsplit_once(") ")
            .and_then(|(_, rest)| rest.split(' ').next().map(str::to_string))
            .unwrap_or_else(|| "?".into())
    };
    let mut out = String::new();
    for pid in processes_mentioning(needle) {
        let threads: Vec<String> = std::fs::read_dir(format!("/proc/{pid}/task"))
            .map(|d| {
                d.flatten()
                    .map(|t| {
                        let tid = t.file_name().to_string_lossy().to_string();
                        let wchan = read(format!("/proc/{pid}/task/{tid}/wchan"));
                        format!(
                            "{}:{wchan}",
                            state(read(format!("/proc/{pid}/task/{tid}/stat")))
                        )
                    })
                    .collect()
            })
            .unwrap_or_default();
        let cmd = read(format!("/proc/{pid}/cmdline")).replace('\0', " ");
        let cmd: String = cmd.chars().take(160).collect();
        out.push_str(&format!(
            "{pid} {} threads [{}] {cmd}\n",
            state(read(format!("/proc/{pid}/stat"))),
            threads.join(" ")
        ));
    }
    out
}

/// Reads a file to a string (panics naming the file).
pub fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()))
}

/// Asserts two run directories hold byte-identical track files.
pub fn assert_same_tracks(a: &Path, b: &Path) {
    for file in [
        "vehicles.csv",
        "body.csv",
        "events.jsonl",
        "formation.csv",
        "truth.csv",
    ] {
        let (x, y) = (read(&a.join(file)), read(&b.join(file)));
        if x != y {
            let line = x.lines().zip(y.lines()).position(|(p, q)| p != q);
            let at = |text: &str| {
                line.and_then(|l| text.lines().nth(l))
                    .unwrap_or("")
                    .to_string()
            };
            panic!(
                "{file} differs between {} and {} (first differing line {:?}; {} vs {} lines)\n\
                 {}\n{}\n{}",
                a.display(),
                b.display(),
                line.map(|l| l + 1),
                x.lines().count(),
                y.lines().count(),
                at(&x),
                at(&y),
                why_they_differ(a, b)
            );
        }
    }
}

/// What the second run directory `b` noticed and the first `a` did not: the events of `b`
/// absent from `a` (losses, rejoins, faults: why it went another way, and when) and the
/// warnings of `b`'s coordinator, a dozen of each; what a CI log needs to tell a failure.
fn why_they_differ(a: &Path, b: &Path) -> String {
    let text = |p: PathBuf| std::fs::read_to_string(p).unwrap_or_default();
    let (ours, theirs) = (text(a.join("events.jsonl")), text(b.join("events.jsonl")));
    let ours: std::collections::HashSet<&str> = ours.lines().collect();
    let extra: Vec<&str> = theirs
        .lines()
        .filter(|l| !ours.contains(l))
        .take(12)
        .collect();
    let log = text(b.join("logs/coordinator.jsonl"));
    let warnings: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("\"WARN\"") || l.contains("resumed"))
        .take(12)
        .collect();
    format!(
        "events of the second run only:\n{}\nits coordinator's warnings:\n{}",
        extra.join("\n"),
        warnings.join("\n")
    )
}

/// Parses `summary.json` of a run directory.
pub fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&read(&dir.join("summary.json"))).expect("summary.json is JSON")
}

/// Starts `vbap run FILE --out OUT --quiet` in the background (stdout discarded).
pub fn spawn_run(file: &Path, out: &Path) -> ChildGuard {
    ChildGuard(Some(
        run_command(file, out).spawn().expect("spawning vbap run"),
    ))
}

/// [`spawn_run`] with `vbap run`'s own log (info and up) written to `log`, for the message
/// of a test that fails.
pub fn spawn_run_logged(file: &Path, out: &Path, log: &Path) -> ChildGuard {
    let stderr =
        std::fs::File::create(log).unwrap_or_else(|e| panic!("creating {}: {e}", log.display()));
    ChildGuard(Some(
        run_command(file, out)
            .env("RUST_LOG", "info")
            .stderr(stderr)
            .spawn()
            .expect("spawning vbap run"),
    ))
}

/// `vbap run FILE --out OUT --quiet`, its output discarded.
pub fn run_command(file: &Path, out: &Path) -> Command {
    let mut cmd = vbap();
    cmd.arg("run")
        .arg(file)
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .stdout(std::process::Stdio::null());
    cmd
}

/// Lines in a file (0 when it does not exist yet).
pub fn line_count(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .map(|t| t.lines().count())
        .unwrap_or(0)
}

/// Runs `vbap CMD FILE --out OUT --quiet` (CMD: `sim` or `run`) to success; returns its output.
pub fn vbap_quiet(cmd: &str, file: &Path, out: &Path) -> Output {
    run_ok(
        vbap()
            .arg(cmd)
            .arg(file)
            .arg("--out")
            .arg(out)
            .arg("--quiet"),
    )
}

/// A message record of a run, owned; from `logs/<process>.msgs.csv` or, in the JSON logs
/// of earlier versions, `logs/<process>.jsonl`.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedRecord {
    pub event: MsgEvent,
    /// The plain hop (`state`, `body`, …): the JSON `held` records' `<hop>_link` is mapped
    /// back.
    pub hop: String,
    /// Absent from some JSON records.
    pub sender: Option<u32>,
    /// Absent from some JSON records.
    pub receiver: Option<u32>,
    pub tick: Option<u64>,
    pub seq: Option<u64>,
    pub sent_ns: Option<u64>,
    pub recv_ns: Option<u64>,
    /// Held: the delay the link model added, ns of mission time (JSON `injected_ms`
    /// converted, rounded).
    pub injected_ns: Option<u64>,
    pub reason: Option<String>,
    /// The message's size in the compact link encoding, bytes (records that carry it).
    pub bytes: Option<u64>,
}

impl From<MsgRecord<'_>> for OwnedRecord {
    fn from(r: MsgRecord<'_>) -> Self {
        Self {
            event: r.event,
            hop: r.hop.to_string(),
            sender: Some(r.sender),
            receiver: Some(r.receiver),
            tick: Some(r.tick),
            seq: r.seq,
            sent_ns: r.sent_ns,
            recv_ns: r.recv_ns,
            injected_ns: r.injected_ns,
            reason: r.reason.map(str::to_string),
            bytes: r.bytes,
        }
    }
}

impl OwnedRecord {
    /// The injected delay in ms (held records).
    pub fn injected_ms(&self) -> Option<f64> {
        self.injected_ns.map(|ns| ns as f64 / 1e6)
    }

    /// A JSON record of target `vbap::msg` (earlier versions); None for any other line.
    fn from_json(line: &str) -> Option<Self> {
        let v: serde_json::Value = serde_json::from_str(line).ok()?;
        if v["target"].as_str() != Some(vbap_ipc::telemetry::MSG_TARGET) {
            return None;
        }
        let f = &v["fields"];
        let event = match f["message"].as_str()? {
            "recv" => MsgEvent::Recv,
            "held" => MsgEvent::Held,
            "drop" => MsgEvent::Drop,
            _ => return None,
        };
        let hop = f["hop"].as_str()?;
        let u32_of = |k: &str| f[k].as_u64().and_then(|v| u32::try_from(v).ok());
        Some(Self {
            event,
            hop: hop.strip_suffix("_link").unwrap_or(hop).to_string(),
            sender: u32_of("sender"),
            receiver: u32_of("receiver"),
            tick: f["tick"].as_u64(),
            seq: f["seq"].as_u64(),
            sent_ns: f["sent_ns"].as_u64(),
            recv_ns: f["recv_ns"].as_u64(),
            injected_ns: f["injected_ms"]
                .as_f64()
                .map(|ms| (ms * 1e6).round() as u64),
            reason: f["reason"].as_str().map(str::to_string),
            bytes: None,
        })
    }
}

/// The message records of `process` in the run directory `run_dir`: from
/// `logs/<process>.msgs.csv` when it exists, else the JSON records of
/// `logs/<process>.jsonl` (panics when neither can be read).
pub fn msg_records(run_dir: &Path, process: &str) -> Vec<OwnedRecord> {
    let logs = run_dir.join("logs");
    let csv = logs.join(format!("{process}{MSG_SUFFIX}"));
    if csv.exists() {
        read(&csv)
            .lines()
            .filter_map(msglog::parse)
            .map(OwnedRecord::from)
            .collect()
    } else {
        read(&logs.join(format!("{process}.jsonl")))
            .lines()
            .filter_map(OwnedRecord::from_json)
            .collect()
    }
}

/// Asserts that the mission `name` left nothing behind: no file of its iceoryx2 domain and
/// no process whose command line mentions the test's directory `tmp`.
pub fn assert_nothing_left(name: &str, tmp: &TempDir) {
    let files = leftover_files(name);
    assert!(files.is_empty(), "files of {name} left behind: {files:?}");
    let pids = processes_mentioning(&tmp.path.to_string_lossy());
    assert!(pids.is_empty(), "processes left behind: {pids:?}");
}

/// Waits (at most 60 s) until the run writing `out` has recorded more than `rows` ticks in
/// `body.csv`.
pub fn wait_for_ticks(out: &Path, rows: usize) {
    let body = out.join("body.csv");
    wait_until(
        || line_count(&body) > rows,
        Duration::from_secs(60),
        "the run to get going",
    );
}

/// Waits (at most 60 s) until the run writing `out` has recorded `more` ticks in
/// `body.csv` beyond those it has now: the mission goes on.
pub fn wait_for_more_ticks(out: &Path, more: usize) {
    wait_for_ticks(out, line_count(&out.join("body.csv")) + more);
}

/// The rejoin missions of the end-to-end tests: six vehicles on a Gaussian hill 33 units
/// away, dt 0.1 s, agents restarted on failure; `extra` is appended (links, faults).
pub fn rejoin_mission(name: &str, duration: f64, extra: &str) -> String {
    format!(
        r#"
[mission]
name = "{name}"
seed = 11
duration = {duration}
dt = 0.1
goal = "max"
tolerance = 1.0

[field]
kind = "gaussian"
center = [30.0, 15.0]
amplitude = 10.0
width = 12.0
noise_std = 0.1

[vehicles]
count = 6
damping = 5.0

[formation]
alpha = 60.0
radius = 2.0
min_scale = 0.7

[body]
v0 = 0.5
v_u = 10.0
grad_saturation = 0.05

[restart]
vehicles = "on-failure"
{extra}
"#
    )
}

/// Uncomments the trailing example of a mission file: from its first line `# [` on, every
/// line `# x` becomes `x` (`## x` stays a comment).
pub fn uncomment_example(text: &str) -> String {
    let mut on = false;
    let mut out = String::new();
    for line in text.lines() {
        on |= line.starts_with("# [");
        match line.strip_prefix("# ") {
            Some(code) if on => out.push_str(code),
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn a_dropped_directory_kills_the_processes_that_mention_it() {
        let tmp = TempDir::new("dropkill");
        let path = tmp.path.to_string_lossy().to_string();
        // A process that runs until it is killed, its command line naming a file inside.
        let file = tmp.join("followed");
        std::fs::write(&file, "").unwrap();
        let mut tail = Command::new("tail").arg("-f").arg(&file).spawn().unwrap();
        wait_until(
            || !processes_mentioning(&path).is_empty(),
            Duration::from_secs(10),
            "tail to start",
        );
        let report = process_report(&path);
        assert!(report.contains(&format!("{} ", tail.id())), "{report}");
        assert!(report.contains("tail -f"), "{report}");
        drop(tmp);
        let status = tail.wait().unwrap();
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(status.signal(), Some(9), "{status:?}");
        assert!(!Path::new(&path).exists());
    }

    #[test]
    fn records_read_alike_from_csv_and_json() {
        let tmp = TempDir::new("msgrecords");
        let logs = tmp.join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        std::fs::write(
            logs.join("coordinator.jsonl"),
            concat!(
                "{\"fields\":{\"message\":\"started\"},\"target\":\"coordinator\"}\n",
                "{\"fields\":{\"message\":\"recv\",\"hop\":\"state\",\"sender\":2,\"tick\":4,\"seq\":5,\"sent_ns\":10,\"recv_ns\":30},\"target\":\"vbap::msg\"}\n",
                "{\"fields\":{\"message\":\"held\",\"hop\":\"state_link\",\"sender\":2,\"tick\":4,\"injected_ms\":1550.0},\"target\":\"vbap::msg\"}\n",
                "{\"fields\":{\"message\":\"drop\",\"hop\":\"state\",\"sender\":2,\"tick\":5,\"reason\":\"loss\"},\"target\":\"vbap::msg\"}\n",
            ),
        )
        .unwrap();
        let json = msg_records(&tmp.path, "coordinator");
        let mut log = vbap_ipc::msglog::MsgLog::open(&logs.join("coordinator.msgs.csv")).unwrap();
        log.recv("state", 2, u32::MAX - 1, 4, 5, 10, 30);
        log.held("state", 2, u32::MAX - 1, 4, 1.55);
        log.drop("state", 2, u32::MAX - 1, 5, "loss");
        drop(log);
        let csv = msg_records(&tmp.path, "coordinator");
        assert_eq!(json.len(), 3);
        assert_eq!(csv.len(), 3);
        for (j, c) in json.iter().zip(&csv) {
            assert_eq!(j.receiver, None);
            let c = OwnedRecord {
                receiver: None,
                ..c.clone()
            };
            assert_eq!(*j, c);
        }
        assert_eq!(csv[1].injected_ms(), Some(1550.0));
    }
}

#[cfg(test)]
mod harness_tests {
    use super::*;

    /// A test's temp dir removes, when dropped, the shared-memory files of the missions of
    /// this test process named in it, and no other mission's.
    #[test]
    fn a_dropped_temp_dir_removes_its_missions_domain_files() {
        let mine = unique_name("harness");
        let other = format!("harness_{}_other", std::process::id() + 1);
        let leftover = |name: &str| {
            let domain = vbap_ipc::topics::Domain::new(name).expect("a domain");
            let path = Path::new("/dev/shm").join(format!("{}leftover", domain.shm_prefix()));
            std::fs::write(&path, b"x").expect("writing into /dev/shm");
            path
        };
        let (mine_file, other_file) = (leftover(&mine), leftover(&other));
        let dir = TempDir::new("harness");
        write_mission(&dir, "m.toml", &format!("[mission]\nname = \"{mine}\"\n"));
        std::fs::create_dir(dir.join("run")).unwrap();
        write_mission(
            &dir,
            "run/mission.toml",
            &format!("[mission]\nname = \"{other}\"\n"),
        );
        drop(dir);
        assert!(!mine_file.exists(), "{} is left", mine_file.display());
        assert!(
            other_file.exists(),
            "another process's mission is not touched"
        );
        std::fs::remove_file(other_file).unwrap();
    }
}
