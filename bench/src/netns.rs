//! Hosts of `vbap bench --hosts` on one machine: each in its own network namespace, joined
//! only by veth links to a switch namespace's bridge, each share of the mission run with a
//! private /dev/shm and /tmp/iceoryx2 (tmpfs in its own mount namespace). Needs root and
//! iproute2; the namespaces are removed on drop.

use std::path::Path;
use std::process::{Child, Command, Stdio};

use anyhow::{bail, Context, Result};

/// The hosts: the shore, then the glider hosts.
pub const HOSTS: [&str; 3] = ["shore", "glider_a", "glider_b"];

fn ip(args: &[&str]) -> Result<()> {
    let out = Command::new("ip")
        .args(args)
        .output()
        .with_context(|| format!("running `ip {}` (install iproute2)", args.join(" ")))?;
    if !out.status.success() {
        bail!(
            "`ip {}` failed: {} (vbap bench --hosts needs root: network namespaces)",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(())
}

/// The namespaces of [`HOSTS`] and of their switch.
pub struct Net {
    tag: String,
    subnet: u32,
    made: Vec<String>,
}

impl Net {
    /// Makes the namespaces and links (10.88.<s>.<i+1>/24).
    pub fn new() -> Result<Self> {
        let pid = std::process::id();
        let mut net = Self {
            tag: format!("vbb{}", pid % 100_000),
            subnet: 200 + pid % 50,
            made: Vec::new(),
        };
        let sw = net.ns("sw");
        ip(&["netns", "add", &sw])?;
        net.made.push(sw.clone());
        ip(&["-n", &sw, "link", "add", "br0", "type", "bridge"])?;
        ip(&["-n", &sw, "link", "set", "br0", "up"])?;
        for (i, h) in HOSTS.iter().enumerate() {
            let ns = net.ns(h);
            ip(&["netns", "add", &ns])?;
            net.made.push(ns.clone());
            let (inside, outside) = (format!("eth{i}"), format!("p{i}"));
            ip(&[
                "-n", &ns, "link", "add", &inside, "type", "veth", "peer", "name", &outside,
                "netns", &sw,
            ])?;
            ip(&["-n", &sw, "link", "set", &outside, "master", "br0", "up"])?;
            let addr = format!("{}/24", net.addr(i));
            ip(&["-n", &ns, "addr", "add", &addr, "dev", &inside])?;
            ip(&["-n", &ns, "link", "set", &inside, "up"])?;
            ip(&["-n", &ns, "link", "set", "lo", "up"])?;
        }
        Ok(net)
    }

    /// The namespace of host `host`.
    pub fn ns(&self, host: &str) -> String {
        format!("{}{}", self.tag, host.replace("glider_", "g"))
    }

    fn addr(&self, i: usize) -> String {
        format!("10.88.{}.{}", self.subnet, i + 1)
    }

    /// The hosts file placing vehicles `0..n` half on each glider host.
    pub fn hosts_file(&self, n: usize) -> String {
        let list =
            |r: std::ops::Range<usize>| r.map(|v| v.to_string()).collect::<Vec<_>>().join(", ");
        format!(
            "insecure = true\n[hosts.shore]\nendpoint = \"tcp/{}:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\n\
             [hosts.glider_a]\nendpoint = \"tcp/{}:7447\"\nvehicles = [{}]\n\
             [hosts.glider_b]\nendpoint = \"tcp/{}:7447\"\nvehicles = [{}]\n",
            self.addr(0),
            self.addr(1),
            list(0..n / 2),
            self.addr(2),
            list(n / 2..n)
        )
    }

    /// [`Net::hosts_file`] over mutual TLS: `tls/` endpoints, the certificates of
    /// `vbap certs` in folder `certs` (`ca.pem`, `<host>.pem`, `<host>.key`).
    pub fn hosts_file_tls(&self, n: usize, certs: &Path) -> String {
        let plain = self.hosts_file(n);
        let mut text = format!("[tls]\nca = {:?}\n", certs.join("ca.pem"));
        for line in plain.lines().filter(|l| *l != "insecure = true") {
            text.push_str(&line.replace("\"tcp/", "\"tls/"));
            text.push('\n');
            if let Some(h) = line
                .strip_prefix("[hosts.")
                .and_then(|l| l.strip_suffix(']'))
            {
                text.push_str(&format!(
                    "cert = {:?}\nkey = {:?}\n",
                    certs.join(format!("{h}.pem")),
                    certs.join(format!("{h}.key"))
                ));
            }
        }
        text
    }

    /// Starts `program ARGS` in host `host`'s namespace with a private /dev/shm and
    /// /tmp/iceoryx2 and lock directory `locks`; stdout to `stdout`, stderr to file `err`.
    pub fn spawn(
        &self,
        host: &str,
        locks: &Path,
        program: &Path,
        args: &[&std::ffi::OsStr],
        stdout: Stdio,
        err: &Path,
    ) -> Result<Child> {
        let script = "mount -t tmpfs tmpfs /dev/shm && mkdir -p /tmp/iceoryx2 && \
                      mount -t tmpfs tmpfs /tmp/iceoryx2 && exec \"$@\"";
        std::fs::create_dir_all(locks)?;
        Command::new("ip")
            .args(["netns", "exec", &self.ns(host), "unshare", "--mount"])
            .args(["--propagation", "private", "sh", "-c", script, "sh"])
            .arg(program)
            .args(args)
            .env("VBAP_LOCK_DIR", locks)
            .stdout(stdout)
            .stderr(std::fs::File::create(err)?)
            .spawn()
            .with_context(|| format!("starting {} in {}", program.display(), self.ns(host)))
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        for ns in self.made.iter().rev() {
            let _ = Command::new("ip").args(["netns", "del", ns]).status();
        }
    }
}
