//! A mission spread over hosts on one machine (tests of `vbap run --hosts --host`,
//! `vbap_bridge`): each host in its own network namespace with a private /dev/shm and
//! /tmp/iceoryx2, joined only by veth links to a switch namespace (10.88.<k>.0/24). Needs
//! root (CI runs as root): when namespaces cannot be made the tests FAIL.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use crate::{bin_dir, processes_mentioning, read, ChildGuard, TempDir};

pub const HOSTS: [&str; 3] = ["shore", "glider_a", "glider_b"];

/// Runs `ip ARGS`, panicking loudly on failure (no namespaces: the test fails).
pub fn ip(args: &[&str]) {
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
pub struct Net {
    tag: String,
    subnet: u32,
}

impl Net {
    /// Makes the namespaces and links (not a `Default`: it changes the machine).
    #[allow(clippy::new_without_default)]
    pub fn new() -> Self {
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
    pub fn ns(&self, host: &str) -> String {
        format!("{}{}", self.tag, host.replace("glider_", "g"))
    }
    pub fn addr(&self, i: usize) -> String {
        format!("10.88.{}.{}", self.subnet % 250, i + 1)
    }
    /// The hosts file: vehicles 0, 1 on glider_a, 2, 3 on glider_b, the coordinator and
    /// the field server on the shore.
    pub fn hosts_file(&self) -> String {
        self.hosts_file_with("")
    }
    /// [`Net::hosts_file`] with the shore's line `shore` added (e.g. `vehicles = [4, 5]`).
    pub fn hosts_file_with(&self, shore: &str) -> String {
        format!(
            "insecure = true\n[hosts.shore]\nendpoint = \"tcp/{}:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n{shore}\n\
             [hosts.glider_a]\nendpoint = \"tcp/{}:7447\"\nvehicles = [0, 1]\n\
             [hosts.glider_b]\nendpoint = \"tcp/{}:7447\"\nvehicles = [2, 3]\n",
            self.addr(0),
            self.addr(1),
            self.addr(2)
        )
    }
    /// The hosts file of mutual TLS: `tls/` endpoints, `[tls] ca` and every host's
    /// certificate and key in folder `certs` (relative to the hosts file: `vbap certs`'s
    /// `--out`, file names `ca.pem`, `<host>.pem`, `<host>.key`).
    pub fn hosts_file_tls(&self, certs: &str) -> String {
        let mut text = format!("[tls]\nca = \"{certs}/ca.pem\"\n");
        for (i, h) in HOSTS.iter().enumerate() {
            let placed = match i {
                0 => "processes = [\"coordinator\", \"field_server\"]",
                1 => "vehicles = [0, 1]",
                _ => "vehicles = [2, 3]",
            };
            text.push_str(&format!(
                "[hosts.{h}]\nendpoint = \"tls/{}:7447\"\n{placed}\ncert = \"{certs}/{h}.pem\"\nkey = \"{certs}/{h}.key\"\n",
                self.addr(i)
            ));
        }
        text
    }
    /// A packet capture of everything between the hosts (`tcpdump` on the switch's bridge,
    /// whole packets, written as they come) into `file`, its messages in `log`; returns
    /// once it listens. Stopped when the guard drops.
    pub fn capture(&self, file: &Path, log: &Path) -> ChildGuard {
        let err = std::fs::File::create(log).expect("the capture's log");
        let guard = ChildGuard(Some(
            Command::new("ip")
                .args(["netns", "exec", &self.ns("sw"), "tcpdump", "-i", "br0"])
                .args(["-n", "-U", "-s", "0", "-w"])
                .arg(file)
                .stdout(Stdio::null())
                .stderr(err)
                .spawn()
                .expect("tcpdump (Debian: tcpdump; deploy/test.sh installs it)"),
        ));
        crate::wait_until(
            || {
                std::fs::read_to_string(log)
                    .unwrap_or_default()
                    .contains("listening on")
            },
            Duration::from_secs(30),
            "tcpdump listening on the switch",
        );
        guard
    }

    /// Runs `program ARGS` in host `host`'s network namespace (stdout and stderr to
    /// `log`); killed when the guard drops.
    pub fn spawn_in(&self, host: &str, program: &Path, args: &[&str], log: &Path) -> ChildGuard {
        let out = std::fs::File::create(log).expect("the log of a process in a namespace");
        ChildGuard(Some(
            Command::new("ip")
                .args(["netns", "exec", &self.ns(host)])
                .arg(program)
                .args(args)
                .stdout(out.try_clone().unwrap())
                .stderr(out)
                .spawn()
                .expect("spawning a process in a namespace"),
        ))
    }
    /// Host `host`'s link (its veth) down or up: the host vanishes from the network, or
    /// returns (its processes live on).
    pub fn link(&self, host: &str, up: bool) {
        let i = HOSTS
            .iter()
            .position(|h| *h == host)
            .expect("a host of HOSTS");
        let state = if up { "up" } else { "down" };
        ip(&[
            "-n",
            &self.ns(host),
            "link",
            "set",
            &format!("eth{i}"),
            state,
        ]);
    }
    /// Every namespace's name.
    pub fn names(&self) -> Vec<String> {
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
pub fn start_host(net: &Net, tmp: &TempDir, file: &Path, hosts: &Path, host: &str) -> ChildGuard {
    start_host_with(net, tmp, file, hosts, host, &[])
}

/// [`start_host`] with environment variables `env` set for the host's `vbap run` (and so
/// for the processes its supervisor starts).
pub fn start_host_with(
    net: &Net,
    tmp: &TempDir,
    file: &Path,
    hosts: &Path,
    host: &str,
    env: &[(&str, &str)],
) -> ChildGuard {
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
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .spawn()
            .expect("spawning vbap run in a namespace"),
    ))
}

/// Whether the bytes of `hay` (a packet capture) hold `needle` anywhere.
pub fn holds(hay: &[u8], needle: &[u8]) -> bool {
    hay.windows(needle.len()).any(|w| w == needle)
}

/// Nothing of the run is left: no process, nothing in any host's /dev/shm or
/// /tmp/iceoryx2 (listed by the host's wrapper as it ended), no namespace, no veth.
pub fn assert_clean(net: Net, tmp: &TempDir) {
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

/// The shared Gaussian-hill test mission ([`crate::mission::GaussianHill`]), `duration` s.
pub fn hosts_mission(name: &str, duration: f64) -> String {
    crate::mission::GaussianHill::new(name)
        .duration(duration)
        .toml()
}

pub fn write(tmp: &TempDir, file: &str, text: &str) -> PathBuf {
    let p = tmp.join(file);
    std::fs::write(&p, text).unwrap();
    p
}

/// `vbap run FILE --hosts HOSTS --host shore --out OUT` on a hosts file it must refuse:
/// asserts exit 2 and that stderr names `want` (the key or the fault), returns stderr.
pub fn refused_hosts_file(file: &Path, hosts: &Path, out: &Path, want: &str) -> String {
    let done = crate::vbap()
        .arg("run")
        .arg(file)
        .arg("--hosts")
        .arg(hosts)
        .arg("--host")
        .arg("shore")
        .arg("--out")
        .arg(out)
        .output()
        .expect("running vbap run --hosts");
    let err = String::from_utf8_lossy(&done.stderr).into_owned();
    assert_eq!(done.status.code(), Some(2), "{err}");
    assert!(err.contains(want), "{want:?} in {err}");
    err
}

/// Waits for each host's `vbap run` (named) and asserts it succeeded, naming the host and
/// its folder under `tmp` when it did not.
pub fn wait_hosts_ok(
    tmp: &TempDir,
    shore: &mut ChildGuard,
    glider_a: &mut ChildGuard,
    glider_b: &mut ChildGuard,
) {
    for (h, child) in HOSTS.into_iter().zip([shore, glider_a, glider_b]) {
        let status = child.wait();
        assert!(
            status.success(),
            "host {h}: {status:?}; see {}",
            tmp.join(h).display()
        );
    }
}
