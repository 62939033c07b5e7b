//! Helpers of the end-to-end tests: building and locating the real binaries, temporary
//! run directories, mission files, process guards, waiting on conditions.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

/// Builds the four binaries (release, once per test process) and returns their directory.
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
                "-p",
                "deploy",
                "-p",
                "field_server",
                "-p",
                "vehicle_agent",
                "-p",
                "coordinator",
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

/// A temporary directory removed on drop (kept, with its path printed, when the test
/// thread panics, so the logs can be read).
pub struct TempDir {
    pub path: PathBuf,
}

impl TempDir {
    /// A fresh empty directory under the system temp dir.
    pub fn new(tag: &str) -> Self {
        let path = std::env::temp_dir().join(format!("vbap-test-{}", unique_name(tag)));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).expect("creating a temp dir");
        Self { path }
    }
    /// A path inside.
    pub fn join(&self, p: &str) -> PathBuf {
        self.path.join(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("kept for inspection: {}", self.path.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
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
    /// Sends a signal.
    pub fn signal(&self, sig: &str) {
        let _ = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(self.pid().to_string())
            .status();
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
pub fn wait_until(mut cond: impl FnMut() -> bool, timeout: Duration, what: &str) {
    let start = Instant::now();
    while !cond() {
        assert!(start.elapsed() < timeout, "timed out waiting for {what}");
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
    let prefix = format!("vbap_{name}_");
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

/// Reads a file to a string (panics naming the file).
pub fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()))
}

/// Asserts two run directories hold byte-identical track files.
pub fn assert_same_tracks(a: &Path, b: &Path) {
    for file in ["vehicles.csv", "body.csv", "events.jsonl"] {
        let (x, y) = (read(&a.join(file)), read(&b.join(file)));
        if x != y {
            let line = x.lines().zip(y.lines()).position(|(p, q)| p != q);
            panic!(
                "{file} differs between {} and {} (first differing line {:?}; {} vs {} lines)",
                a.display(),
                b.display(),
                line.map(|l| l + 1),
                x.lines().count(),
                y.lines().count()
            );
        }
    }
}

/// Parses `summary.json` of a run directory.
pub fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&read(&dir.join("summary.json"))).expect("summary.json is JSON")
}

/// Starts `vbap run FILE --out OUT --quiet` in the background (stdout discarded).
pub fn spawn_run(file: &Path, out: &Path) -> ChildGuard {
    ChildGuard(Some(
        vbap()
            .arg("run")
            .arg(file)
            .arg("--out")
            .arg(out)
            .arg("--quiet")
            .stdout(std::process::Stdio::null())
            .spawn()
            .expect("spawning vbap run"),
    ))
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
