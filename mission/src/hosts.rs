//! The hosts file of a mission spread over machines (`vbap run MISSION --hosts FILE --host
//! NAME`): which host runs what, and the Zenoh endpoint each host listens on.
//!
//! ```toml
//! final_wait = 30.0        # optional, s (default 30): see below
//! [tls]                    # mutual TLS between the hosts (`vbap certs` makes the files)
//! ca = "certs/ca.pem"      # the mission's certificate authority
//! [hosts.shore]
//! endpoint = "tls/10.88.0.1:7447"
//! processes = ["coordinator", "field_server"]
//! cert = "certs/shore.pem" # this host's certificate (of `ca`, naming its address) ...
//! key = "certs/shore.key"  # ... and its private key
//! [hosts.glider_a]
//! endpoint = "tls/10.88.0.2:7447"
//! vehicles = [0, 1]
//! cert = "certs/glider_a.pem"
//! key = "certs/glider_a.key"
//! ```
//!
//! Rules (a placement that cannot work is refused, naming the key):
//! - the coordinator and the field server are on one host, the *shore*: the coordinator
//!   asks the field server for every vehicle's reading once per tick (one batch request,
//!   one reply, inside the tick's critical path); the vehicles never ask it themselves, so
//!   nothing of sensing crosses hosts, and the bridge does not forward those services;
//! - every vehicle `0..N` is on exactly one host, and every host runs something;
//! - a host name holds letters, digits and `_`;
//! - endpoints are `tls/<address>:<port>` with a port other than 0, each host its own; the
//!   shore's is one the glider hosts can reach (not the unspecified `0.0.0.0` / `[::]`:
//!   they connect to it);
//! - with `tls/` endpoints, `[tls] ca` and every host's `cert` and `key` are given (paths
//!   relative to the hosts file's folder), and the files exist: a bridge accepts only a
//!   peer whose certificate is of `ca`, and checks that the shore's names its address;
//! - plain `tcp/` endpoints (anyone who reaches a port is in the mission) only with the
//!   explicit top-level `insecure = true`, and then every endpoint is `tcp/` and there is
//!   no `[tls]` (`vbap run` says so on the terminal);
//! - `final_wait` (s, finite, > 0; default [`DEFAULT_FINAL_WAIT`]): how long the shore's
//!   bridge keeps the mission's final command after forwarding it, re-sending it until
//!   every glider host's bridge has acknowledged it (a glider host off the network at that
//!   moment gets it when it returns). When it runs out the shore's run ends anyway and its
//!   bridge's log names the hosts that never acknowledged.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

/// A process a host may run besides vehicle agents.
pub const PROCESSES: [&str; 2] = ["coordinator", "field_server"];

/// One host of the file.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Host {
    /// The Zenoh endpoint this host's bridge listens on, `tls/<address>:<port>` (or
    /// `tcp/` with `insecure = true`).
    pub endpoint: String,
    /// This host's certificate (PEM, of the mission's CA), with `tls/` endpoints.
    #[serde(default)]
    pub cert: Option<PathBuf>,
    /// This host's private key (PEM), with `tls/` endpoints.
    #[serde(default)]
    pub key: Option<PathBuf>,
    /// `coordinator` and/or `field_server` (default: none).
    #[serde(default)]
    pub processes: Vec<String>,
    /// The vehicle ids whose agents run here (default: none).
    #[serde(default)]
    pub vehicles: Vec<u32>,
}

/// Default of the hosts file's `final_wait`, s.
pub const DEFAULT_FINAL_WAIT: f64 = 30.0;

fn default_final_wait() -> f64 {
    DEFAULT_FINAL_WAIT
}

/// The `[tls]` table: the mission's certificate authority.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tls {
    /// The CA certificate (PEM) every host's certificate must be of.
    pub ca: PathBuf,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default = "default_final_wait")]
    final_wait: f64,
    #[serde(default)]
    insecure: bool,
    tls: Option<Tls>,
    hosts: BTreeMap<String, Host>,
}

/// A validated hosts file for a fleet of N vehicles.
#[derive(Clone, Debug, PartialEq)]
pub struct Hosts {
    /// Every host by name.
    pub hosts: BTreeMap<String, Host>,
    /// The host of the coordinator and the field server.
    pub shore: String,
    /// How long the shore keeps the mission's final command for glider hosts that have
    /// not acknowledged it yet, s (`final_wait`, see the module doc).
    pub final_wait: f64,
    /// The mission's CA with `tls/` endpoints (paths resolved); None: plain `tcp/`, which
    /// the file allowed with `insecure = true`.
    pub tls: Option<Tls>,
}

impl Hosts {
    /// Reads and validates the hosts file `path` for a fleet of `vehicles`; the error names
    /// the file and the key.
    pub fn load(path: &Path, vehicles: usize) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let hosts = Self::parse(&text, &path.display().to_string(), vehicles)?;
        hosts.check_files(&path.display().to_string())?;
        Ok(hosts)
    }

    /// The certificate files exist and are readable (a missing one names its key).
    fn check_files(&self, origin: &str) -> Result<(), String> {
        let Some(tls) = &self.tls else {
            return Ok(());
        };
        let readable = |key: String, p: &Path| {
            std::fs::File::open(p)
                .map(|_| ())
                .map_err(|e| format!("{origin}: {key} = {:?}: {e}", p.display().to_string()))
        };
        readable("tls.ca".into(), &tls.ca)?;
        for (name, h) in &self.hosts {
            for (k, p) in [("cert", &h.cert), ("key", &h.key)] {
                if let Some(p) = p {
                    readable(format!("hosts.{name}.{k}"), p)?;
                }
            }
        }
        Ok(())
    }

    /// Every host's endpoint address (`tcp/` or `tls/` alike, IPv6 without brackets) of
    /// hosts file `path`, read without a fleet (`vbap certs`); errors name the key.
    pub fn addresses(path: &Path) -> Result<BTreeMap<String, String>, String> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| format!("{origin}: {e}"))?;
        let file: File = toml::from_str(&text).map_err(|e| format!("{origin}: {e}"))?;
        let mut out = BTreeMap::new();
        for (name, h) in &file.hosts {
            let key = format!("{origin}: hosts.{name}.endpoint = {:?}", h.endpoint);
            check_endpoint(&h.endpoint).map_err(|r| format!("{key}: {r}"))?;
            let (_, address) = split_endpoint(&h.endpoint).ok_or(format!("{key}: no address"))?;
            out.insert(name.clone(), address.to_string());
        }
        if out.is_empty() {
            return Err(format!("{origin}: hosts: no host"));
        }
        Ok(out)
    }

    /// [`Hosts::load`] of the text `text` of file `origin`.
    pub fn parse(text: &str, origin: &str, vehicles: usize) -> Result<Self, String> {
        let file: File = toml::from_str(text).map_err(|e| format!("{origin}: {e}"))?;
        let err = |key: String, reason: String| format!("{origin}: {key}: {reason}");
        if !(file.final_wait.is_finite() && file.final_wait > 0.0) {
            return Err(err(
                format!("final_wait = {}", file.final_wait),
                "must be a finite number of seconds above 0".into(),
            ));
        }
        let mut shore = None;
        let mut field = None;
        let mut owner: Vec<Option<&str>> = vec![None; vehicles];
        for (name, h) in &file.hosts {
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(err(
                    format!("hosts.{name}"),
                    "a host name holds only letters, digits and _".into(),
                ));
            }
            check_endpoint(&h.endpoint)
                .map_err(|r| err(format!("hosts.{name}.endpoint = {:?}", h.endpoint), r))?;
            for p in &h.processes {
                let key = format!("hosts.{name}.processes");
                match p.as_str() {
                    "coordinator" if shore.is_none() => shore = Some(name.clone()),
                    "field_server" if field.is_none() => field = Some(name.clone()),
                    "coordinator" | "field_server" => {
                        return Err(err(key, format!("{p:?} is placed on two hosts")))
                    }
                    _ => {
                        return Err(err(
                            key,
                            format!("unknown process {p:?} (known: {PROCESSES:?})"),
                        ))
                    }
                }
            }
            for &v in &h.vehicles {
                let key = format!("hosts.{name}.vehicles");
                let Some(slot) = owner.get_mut(v as usize) else {
                    return Err(err(
                        key,
                        format!("vehicle {v} is not in the fleet (vehicles.count = {vehicles})"),
                    ));
                };
                if let Some(other) = slot {
                    return Err(err(key, format!("vehicle {v} is also on host {other:?}")));
                }
                *slot = Some(name.as_str());
            }
        }
        let Some(shore) = shore else {
            return Err(err(
                "hosts".into(),
                "no host runs the \"coordinator\"".into(),
            ));
        };
        if field.as_deref() != Some(shore.as_str()) {
            return Err(err(
                "hosts".into(),
                format!("the \"field_server\" must run on the coordinator's host {shore:?} (sensor requests do not cross hosts)"),
            ));
        }
        if let Some(v) = owner.iter().position(Option::is_none) {
            return Err(err("hosts".into(), format!("vehicle {v} is on no host")));
        }
        check_placement(&file.hosts, &shore).map_err(|(key, reason)| err(key, reason))?;
        let base = Path::new(origin).parent().unwrap_or(Path::new(""));
        let (hosts, tls) = check_security(file.hosts, file.tls, file.insecure, base)
            .map_err(|(key, reason)| err(key, reason))?;
        Ok(Self {
            hosts,
            shore,
            final_wait: file.final_wait,
            tls,
        })
    }

    /// Host `name`, or an error naming the hosts there are.
    pub fn host(&self, name: &str) -> Result<&Host, String> {
        self.hosts.get(name).ok_or_else(|| {
            let known: Vec<&str> = self.hosts.keys().map(String::as_str).collect();
            format!("--host {name:?}: no such host in the hosts file (hosts: {known:?})")
        })
    }

    /// The host of vehicle `id`.
    pub fn host_of(&self, id: u32) -> Option<&str> {
        self.hosts
            .iter()
            .find(|(_, h)| h.vehicles.contains(&id))
            .map(|(n, _)| n.as_str())
    }

    /// True when `name` is the shore (the coordinator's host).
    pub fn is_shore(&self, name: &str) -> bool {
        self.shore == name
    }
}

/// What else cannot work: a host that runs nothing, two hosts on one endpoint, a shore
/// endpoint the glider hosts cannot connect to. Errors: (key, reason).
fn check_placement(hosts: &BTreeMap<String, Host>, shore: &str) -> Result<(), (String, String)> {
    let mut seen: BTreeMap<&str, &str> = BTreeMap::new();
    for (name, h) in hosts {
        if h.processes.is_empty() && h.vehicles.is_empty() {
            return Err((
                format!("hosts.{name}"),
                "runs nothing (no processes, no vehicles): the shore would wait for it for ever"
                    .into(),
            ));
        }
        if let Some(other) = seen.insert(h.endpoint.as_str(), name.as_str()) {
            return Err((
                format!("hosts.{name}.endpoint = {:?}", h.endpoint),
                format!("also host {other:?}'s endpoint: each host listens on its own"),
            ));
        }
    }
    let endpoint = &hosts[shore].endpoint;
    let address = split_endpoint(endpoint).map_or("", |(_, a)| a);
    if matches!(address, "0.0.0.0" | "::") {
        return Err((
            format!("hosts.{shore}.endpoint = {endpoint:?}"),
            "the shore's endpoint must be an address the glider hosts can connect to, not the unspecified address".into(),
        ));
    }
    Ok(())
}

/// Mutual TLS or, said explicitly, plain TCP (see the module doc): the hosts with their
/// certificate paths resolved against `base`, and the `[tls]` table. Errors: (key, reason).
#[allow(clippy::type_complexity)]
fn check_security(
    mut hosts: BTreeMap<String, Host>,
    tls: Option<Tls>,
    insecure: bool,
    base: &Path,
) -> Result<(BTreeMap<String, Host>, Option<Tls>), (String, String)> {
    let resolve = |p: &Path| base.join(p);
    let plain: Vec<&String> = hosts
        .iter()
        .filter(|(_, h)| h.endpoint.starts_with("tcp/"))
        .map(|(n, _)| n)
        .collect();
    if insecure {
        if let Some(n) = hosts.keys().find(|n| !plain.contains(n)) {
            return Err((
                format!("hosts.{n}.endpoint = {:?}", hosts[n].endpoint),
                "insecure = true: every endpoint is plain tcp/ (or drop insecure and use tls/ everywhere)".into(),
            ));
        }
        if tls.is_some() {
            return Err((
                "tls".into(),
                "insecure = true and a [tls] table: choose one (drop insecure for mutual TLS)"
                    .into(),
            ));
        }
        for (n, h) in &hosts {
            if h.cert.is_some() || h.key.is_some() {
                return Err((
                    format!("hosts.{n}.cert"),
                    "insecure = true: plain tcp/ takes no certificate".into(),
                ));
            }
        }
        return Ok((hosts, None));
    }
    if let Some(n) = plain.first() {
        return Err((
            format!("hosts.{n}.endpoint = {:?}", hosts[*n].endpoint),
            "plain tcp/ lets anyone who reaches the port into the mission: use tls/ endpoints with [tls] (`vbap certs`), or say insecure = true".into(),
        ));
    }
    let Some(tls) = tls else {
        return Err((
            "tls".into(),
            "tls/ endpoints need [tls] ca = the mission's CA certificate (`vbap certs HOSTS --out DIR` makes it)".into(),
        ));
    };
    for (n, h) in hosts.iter_mut() {
        for (k, p) in [("cert", &mut h.cert), ("key", &mut h.key)] {
            match p {
                Some(path) => *path = resolve(path),
                None => {
                    return Err((
                        format!("hosts.{n}.{k}"),
                        format!("missing: a tls/ host needs its {k} (`vbap certs` makes it)"),
                    ))
                }
            }
        }
    }
    Ok((
        hosts,
        Some(Tls {
            ca: resolve(&tls.ca),
        }),
    ))
}

/// (`tcp` or `tls`, the address without brackets) of endpoint `endpoint`.
fn split_endpoint(endpoint: &str) -> Option<(&str, &str)> {
    let (scheme, rest) = endpoint.split_once('/')?;
    let (address, _) = rest.rsplit_once(':')?;
    let address = address
        .strip_prefix('[')
        .and_then(|a| a.strip_suffix(']'))
        .unwrap_or(address);
    Some((scheme, address))
}

fn check_endpoint(endpoint: &str) -> Result<(), String> {
    let Some(addr) = endpoint
        .strip_prefix("tls/")
        .or_else(|| endpoint.strip_prefix("tcp/"))
    else {
        return Err(
            "must be tls/<address>:<port> (or tcp/ with insecure = true: the bridge speaks TLS or TCP only)"
                .into(),
        );
    };
    match addr.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok_and(|p| p > 0) => {
            Ok(())
        }
        _ => Err("must be tls/<address>:<port>".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
insecure = true
[hosts.shore]
endpoint = "tcp/10.88.0.1:7447"
processes = ["coordinator", "field_server"]
[hosts.glider_a]
endpoint = "tcp/10.88.0.2:7447"
vehicles = [0, 1]
[hosts.glider_b]
endpoint = "tcp/10.88.0.3:7447"
vehicles = [2]
"#;

    #[test]
    fn the_issue_form_places_every_process() {
        let h = Hosts::parse(GOOD, "hosts.toml", 3).unwrap();
        assert_eq!(h.shore, "shore");
        assert_eq!(h.host_of(1), Some("glider_a"));
        assert_eq!(h.host_of(2), Some("glider_b"));
        assert!(h.host("nowhere").unwrap_err().contains("glider_a"));
        assert_eq!(h.final_wait, DEFAULT_FINAL_WAIT);
    }

    #[test]
    fn final_wait_is_read_and_checked() {
        let h = Hosts::parse(&format!("final_wait = 2.5\n{GOOD}"), "hosts.toml", 3).unwrap();
        assert_eq!(h.final_wait, 2.5);
        for bad in ["0.0", "-1.0", "nan", "inf"] {
            let e =
                Hosts::parse(&format!("final_wait = {bad}\n{GOOD}"), "hosts.toml", 3).unwrap_err();
            assert!(e.contains("hosts.toml: final_wait"), "{e}");
        }
    }

    #[test]
    fn bad_placements_name_the_key() {
        let e = Hosts::parse(GOOD, "hosts.toml", 4).unwrap_err();
        assert!(e.contains("vehicle 3 is on no host"), "{e}");
        let e = Hosts::parse(GOOD, "hosts.toml", 2).unwrap_err();
        assert!(
            e.contains("hosts.glider_b.vehicles: vehicle 2 is not in the fleet"),
            "{e}"
        );
        let twice = GOOD.replace("vehicles = [2]", "vehicles = [1, 2]");
        let e = Hosts::parse(&twice, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("vehicle 1 is also on host"), "{e}");
        let udp = GOOD.replace("tcp/10.88.0.3", "udp/10.88.0.3");
        let e = Hosts::parse(&udp, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts.glider_b.endpoint"), "{e}");
        let split = GOOD.replace("\"coordinator\", \"field_server\"", "\"coordinator\"");
        let split = split.replace(
            "vehicles = [2]",
            "vehicles = [2]\nprocesses = [\"field_server\"]",
        );
        let e = Hosts::parse(&split, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("must run on the coordinator's host"), "{e}");
    }

    #[test]
    fn placements_that_cannot_work_name_the_key() {
        let idle = format!("{GOOD}[hosts.spare]\nendpoint = \"tcp/10.88.0.9:7447\"\n");
        let e = Hosts::parse(&idle, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts.toml: hosts.spare: runs nothing"), "{e}");
        let same = GOOD.replace("10.88.0.3", "10.88.0.2");
        let e = Hosts::parse(&same, "hosts.toml", 3).unwrap_err();
        assert!(
            e.contains("hosts.glider_b.endpoint") && e.contains("glider_a"),
            "{e}"
        );
        let any = GOOD.replace("10.88.0.1", "0.0.0.0");
        let e = Hosts::parse(&any, "hosts.toml", 3).unwrap_err();
        assert!(
            e.contains("hosts.shore.endpoint") && e.contains("connect"),
            "{e}"
        );
        let port0 = GOOD.replace("10.88.0.2:7447", "10.88.0.2:0");
        let e = Hosts::parse(&port0, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts.glider_a.endpoint"), "{e}");
        let no_field = GOOD.replace("\"coordinator\", \"field_server\"", "\"coordinator\"");
        let e = Hosts::parse(&no_field, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts: the \"field_server\" must run"), "{e}");
        // Vehicles on the shore work (their states stay in its iceoryx2 domain).
        let mixed = GOOD.replace("\"field_server\"]\n", "\"field_server\"]\nvehicles = [3]\n");
        assert!(Hosts::parse(&mixed, "hosts.toml", 4).is_ok());
    }

    const TLS: &str = r#"
[tls]
ca = "certs/ca.pem"
[hosts.shore]
endpoint = "tls/10.88.0.1:7447"
processes = ["coordinator", "field_server"]
cert = "certs/shore.pem"
key = "certs/shore.key"
[hosts.glider_a]
endpoint = "tls/[fd00::2]:7447"
vehicles = [0, 1, 2]
cert = "/abs/glider_a.pem"
key = "/abs/glider_a.key"
"#;

    #[test]
    fn tls_paths_resolve_against_the_hosts_files_folder() {
        let h = Hosts::parse(TLS, "/missions/hosts.toml", 3).unwrap();
        let tls = h.tls.as_ref().unwrap();
        assert_eq!(tls.ca, PathBuf::from("/missions/certs/ca.pem"));
        assert_eq!(
            h.hosts["shore"].cert.as_deref(),
            Some(Path::new("/missions/certs/shore.pem"))
        );
        assert_eq!(
            h.hosts["glider_a"].key.as_deref(),
            Some(Path::new("/abs/glider_a.key"))
        );
        assert_eq!(
            split_endpoint("tls/[fd00::2]:7447"),
            Some(("tls", "fd00::2"))
        );
    }

    #[test]
    fn plain_tcp_needs_insecure_and_tls_needs_its_files_named() {
        let plain = GOOD.replace("insecure = true\n", "");
        let e = Hosts::parse(&plain, "hosts.toml", 3).unwrap_err();
        assert!(
            e.contains("hosts.toml: hosts.glider_a.endpoint") && e.contains("insecure = true"),
            "{e}"
        );
        let no_ca = TLS.replace("[tls]\nca = \"certs/ca.pem\"\n", "");
        let e = Hosts::parse(&no_ca, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts.toml: tls: "), "{e}");
        let no_key = TLS.replace("key = \"certs/shore.key\"\n", "");
        let e = Hosts::parse(&no_key, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts.shore.key: missing"), "{e}");
        let mixed = TLS.replace("tls/10.88.0.1", "tcp/10.88.0.1");
        let e = Hosts::parse(&mixed, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts.shore.endpoint"), "{e}");
        let both = format!("insecure = true\n{TLS}");
        let e = Hosts::parse(&both, "hosts.toml", 3).unwrap_err();
        assert!(e.contains("hosts.glider_a.endpoint"), "{e}");
        let e = Hosts::load(Path::new("/nonexistent/hosts.toml"), 3).unwrap_err();
        assert!(e.contains("/nonexistent/hosts.toml"), "{e}");
    }

    #[test]
    fn addresses_are_read_without_a_fleet() {
        let dir = std::env::temp_dir().join(format!("vbap-hosts-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("hosts.toml");
        std::fs::write(&file, TLS).unwrap();
        let a = Hosts::addresses(&file).unwrap();
        assert_eq!(a["shore"], "10.88.0.1");
        assert_eq!(a["glider_a"], "fd00::2");
        // The files named do not exist: a run refuses the file, naming the key.
        let e = Hosts::load(&file, 3).unwrap_err();
        assert!(e.contains("tls.ca"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
