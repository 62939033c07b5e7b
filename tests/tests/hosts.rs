//! A mission spread over hosts (`vbap run --hosts --host`, `vbap_bridge`): each host in
//! its own network namespace with a private /dev/shm and /tmp/iceoryx2, joined only by
//! veth links to a switch namespace (10.88.<k>.0/24). Needs root (CI runs as root): when
//! namespaces cannot be made the tests FAIL.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use tests::*;

const HOSTS: [&str; 3] = ["shore", "glider_a", "glider_b"];

/// Runs `ip ARGS`, panicking loudly on failure (no namespaces: the test fails).
fn ip(args: &[&str]) {
    let out = Command::new("ip")
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running `ip {}`: {e} (install iproute2)", args.join(" ")));
    assert!(
        out.status.success(),
        "`ip {}` failed: {} (network namespaces need root and iproute2)",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Three host namespaces and a switch namespace with a bridge; removed on drop.
struct Net {
    tag: String,
    subnet: u32,
}

impl Net {
    fn new() -> Self {
        static K: AtomicU32 = AtomicU32::new(0);
        let k = K.fetch_add(1, Ordering::SeqCst);
        let tag = format!("vb{}x{k}", std::process::id() % 100_000);
        let subnet = 100 + (std::process::id() % 100) + 30 * k;
        let net = Self { tag, subnet };
        let sw = net.ns("sw");
        ip(&["netns", "add", &sw]);
        ip(&["-n", &sw, "link", "add", "br0", "type", "bridge"]);
        ip(&["-n", &sw, "link", "set", "br0", "up"]);
        for (i, h) in HOSTS.iter().enumerate() {
            let ns = net.ns(h);
            ip(&["netns", "add", &ns]);
            let (inside, outside) = (format!("eth{i}"), format!("p{i}"));
            ip(&[
                "-n", &ns, "link", "add", &inside, "type", "veth", "peer", "name", &outside,
                "netns", &sw,
            ]);
            ip(&["-n", &sw, "link", "set", &outside, "master", "br0", "up"]);
            ip(&[
                "-n",
                &ns,
                "addr",
                "add",
                &format!("{}/24", net.addr(i)),
                "dev",
                &inside,
            ]);
            ip(&["-n", &ns, "link", "set", &inside, "up"]);
            ip(&["-n", &ns, "link", "set", "lo", "up"]);
        }
        net
    }
    fn ns(&self, host: &str) -> String {
        format!("{}{}", self.tag, host.replace("glider_", "g"))
    }
    fn addr(&self, i: usize) -> String {
        format!("10.88.{}.{}", self.subnet % 250, i + 1)
    }
    fn hosts_file(&self) -> String {
        format!(
            "[hosts.shore]\nendpoint = \"tcp/{}:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n\
             [hosts.glider_a]\nendpoint = \"tcp/{}:7447\"\nvehicles = [0, 1]\n\
             [hosts.glider_b]\nendpoint = \"tcp/{}:7447\"\nvehicles = [2, 3]\n",
            self.addr(0),
            self.addr(1),
            self.addr(2)
        )
    }
    fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = HOSTS.iter().map(|h| self.ns(h)).collect();
        v.push(self.ns("sw"));
        v
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        for ns in self.names() {
            let _ = Command::new("ip").args(["netns", "del", &ns]).status();
        }
    }
}

/// `vbap run FILE --hosts HOSTS --host HOST --out TMP/HOST --quiet` in host `host`'s
/// namespace, with a private /dev/shm and /tmp/iceoryx2 (tmpfs in its own mount
/// namespace); when it ends, what is left in them is listed in TMP/HOST.left.
fn start_host(net: &Net, tmp: &TempDir, file: &Path, hosts: &Path, host: &str) -> ChildGuard {
    let script = "mount -t tmpfs tmpfs /dev/shm && mkdir -p /tmp/iceoryx2 && \
                  mount -t tmpfs tmpfs /tmp/iceoryx2 && \"$@\"; rc=$?; \
                  find /dev/shm /tmp/iceoryx2 -type f > \"$LEFT\" 2>&1; exit $rc";
    let locks = tmp.join(&format!("{host}.locks"));
    std::fs::create_dir_all(&locks).unwrap();
    ChildGuard(Some(
        Command::new("ip")
            .args([
                "netns",
                "exec",
                &net.ns(host),
                "unshare",
                "--mount",
                "--propagation",
                "private",
            ])
            .args(["sh", "-c", script, "sh"])
            .arg(bin_dir().join("vbap"))
            .arg("run")
            .arg(file)
            .arg("--hosts")
            .arg(hosts)
            .arg("--host")
            .arg(host)
            .arg("--out")
            .arg(tmp.join(host))
            .arg("--quiet")
            .env("VBAP_LOCK_DIR", &locks)
            .env("LEFT", tmp.join(&format!("{host}.left")))
            .stdout(Stdio::null())
            .spawn()
            .expect("spawning vbap run in a namespace"),
    ))
}

/// Nothing of the run is left: no process, nothing in any host's /dev/shm or
/// /tmp/iceoryx2 (listed by the host's wrapper as it ended), no namespace, no veth.
fn assert_clean(net: Net, tmp: &TempDir) {
    for h in HOSTS {
        let left = read(&tmp.join(&format!("{h}.left")));
        let files: Vec<&str> = left.lines().filter(|l| !l.is_empty()).collect();
        assert!(files.is_empty(), "host {h} left files behind: {left}");
    }
    let pids = processes_mentioning(&tmp.path.to_string_lossy());
    assert!(pids.is_empty(), "processes left behind: {pids:?}");
    let names = net.names();
    drop(net);
    let list = Command::new("ip").args(["netns", "list"]).output().unwrap();
    let list = String::from_utf8_lossy(&list.stdout);
    for ns in names {
        assert!(!list.contains(&ns), "namespace {ns} left behind");
    }
}

fn mission(name: &str, duration: f64) -> String {
    format!(
        r#"
[mission]
name = "{name}"
seed = 7
duration = {duration}
dt = 0.05
goal = "max"
dim = 2
tolerance = 1.0

[field]
kind = "gaussian"
center = [6.0, 3.0]
amplitude = 10.0
width = 6.0
noise_std = 0.1

[vehicles]
count = 4
start = [0.0, 0.0]
start_spread = 0.3
"#
    )
}

fn write(tmp: &TempDir, file: &str, text: &str) -> PathBuf {
    let p = tmp.join(file);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn three_hosts_in_lockstep_equal_the_simulator_and_leave_nothing() {
    let tmp = TempDir::new("hosts");
    let net = Net::new();
    let name = unique_name("hosts");
    let file = write(&tmp, "m.toml", &mission(&name, 6.0));
    let hosts = write(&tmp, "hosts.toml", &net.hosts_file());
    vbap_quiet("sim", &file, &tmp.join("sim"));
    // Any order: the glider hosts first, then the shore they wait for.
    let mut a = start_host(&net, &tmp, &file, &hosts, "glider_a");
    let mut b = start_host(&net, &tmp, &file, &hosts, "glider_b");
    let mut shore = start_host(&net, &tmp, &file, &hosts, "shore");
    for (h, child) in [
        ("shore", &mut shore),
        ("glider_a", &mut a),
        ("glider_b", &mut b),
    ] {
        let status = child.wait();
        assert!(
            status.success(),
            "host {h}: {status:?}; see {}",
            tmp.join(h).display()
        );
    }
    let run = tmp.join("shore");
    assert_same_tracks(&tmp.join("sim"), &run);
    let s = summary(&run);
    assert_eq!(s["mode"], "multi-process");
    assert_eq!(s["messages"]["rejected"], 0);
    // The other hosts' message records, merged (copied as hosts/<host>/logs): the hops
    // that crossed hosts apart from the local ones.
    for h in ["glider_a", "glider_b"] {
        assert!(
            tmp.join(h).join("logs/vbap_bridge.jsonl").exists(),
            "{h} has its logs"
        );
        let to = run.join("hosts").join(h).join("logs");
        std::fs::create_dir_all(&to).unwrap();
        for e in std::fs::read_dir(tmp.join(h).join("logs"))
            .unwrap()
            .flatten()
        {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
    let out = run_ok(vbap().arg("analyze").arg(&run).arg("--json"));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).expect("analyze --json");
    for hop in ["state@hosts", "body@hosts", "field_request", "field_reply"] {
        let p50 = r["hops"][hop]["transport_us"]["p50"].as_f64();
        assert!(p50.is_some_and(|v| v > 0.0), "hop {hop} in {}", r["hops"]);
    }
    // Every vehicle is on a glider host: no state stayed on the shore.
    assert!(r["hops"]["state"].is_null(), "{}", r["hops"]);
    assert_clean(net, &tmp);
}

#[test]
fn a_glider_hosts_bridge_killed_loses_its_vehicles_and_restarted_they_rejoin() {
    let tmp = TempDir::new("hostskill");
    let net = Net::new();
    let name = unique_name("hostskill");
    let text = rejoin_mission(&name, 400.0, "").replace("count = 6", "count = 4");
    let file = write(&tmp, "m.toml", &text);
    let hosts = write(&tmp, "hosts.toml", &net.hosts_file());
    let mut shore = start_host(&net, &tmp, &file, &hosts, "shore");
    let mut a = start_host(&net, &tmp, &file, &hosts, "glider_a");
    let mut b = start_host(&net, &tmp, &file, &hosts, "glider_b");
    let out = tmp.join("shore");
    wait_for_ticks(&out, 50);
    // glider_a's bridge, found by its command line (its host name and our temp dir).
    let needle = format!(
        "--host glider_a --mission {}",
        tmp.join("glider_a").display()
    );
    let bridge = processes_mentioning(&needle);
    assert_eq!(bridge.len(), 1, "glider_a's bridge: {bridge:?}");
    let _ = Command::new("kill")
        .args(["-KILL", &bridge[0].to_string()])
        .status();
    let events = || read(&out.join("events.jsonl"));
    let count = |kind: &str| {
        events()
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|e| e["kind"] == kind && e["vehicle"].as_u64().is_some_and(|v| v < 2))
            .count()
    };
    wait_until(
        || count("lost") >= 2,
        Duration::from_secs(60),
        "glider_a's vehicles lost",
    );
    // Its supervisor restarts the bridge (on failure, after the backoff): they rejoin.
    wait_until(
        || count("rejoin") >= 2,
        Duration::from_secs(90),
        "glider_a's vehicles back",
    );
    let ev: Vec<serde_json::Value> = events()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    let lost: Vec<_> = ev.iter().filter(|e| e["kind"] == "lost").collect();
    assert_eq!(
        lost.len(),
        2,
        "only glider_a's two vehicles are lost: {lost:?}"
    );
    for e in &lost {
        assert_eq!(e["detail"]["cause"], "host unreachable", "{e}");
        assert_eq!(e["detail"]["by"], "bridge", "{e}");
    }
    // The mission runs to its end on every host.
    for (h, child) in [
        ("shore", &mut shore),
        ("glider_a", &mut a),
        ("glider_b", &mut b),
    ] {
        let status = child.wait();
        assert!(status.success(), "host {h}: {status:?}");
    }
    assert_eq!(summary(&out)["mode"], "multi-process");
    assert_clean(net, &tmp);
}
