//! The hosts file of a mission spread over machines (`vbap run MISSION --hosts FILE --host
//! NAME`): which host runs what, and the Zenoh endpoint each host listens on.
//!
//! ```toml
//! final_wait = 30.0        # optional, s (default 30): see below
//! [hosts.shore]
//! endpoint = "tcp/10.88.0.1:7447"
//! processes = ["coordinator", "field_server"]
//! [hosts.glider_a]
//! endpoint = "tcp/10.88.0.2:7447"
//! vehicles = [0, 1]
//! ```
//!
//! Rules (a placement that cannot work is refused, naming the key):
//! - the coordinator and the field server are on one host, the *shore*: the coordinator
//!   asks the field server for every vehicle's reading once per tick (one batch request,
//!   one reply, inside the tick's critical path); the vehicles never ask it themselves, so
//!   nothing of sensing crosses hosts, and the bridge does not forward those services;
//! - every vehicle `0..N` is on exactly one host, and every host runs something;
//! - a host name holds letters, digits and `_`;
//! - endpoints are `tcp/<address>:<port>` with a port other than 0, each host its own; the
//!   shore's is one the glider hosts can reach (not the unspecified `0.0.0.0` / `[::]`:
//!   they connect to it);
//! - `final_wait` (s, finite, > 0; default [`DEFAULT_FINAL_WAIT`]): how long the shore's
//!   bridge keeps the mission's final command after forwarding it, re-sending it until
//!   every glider host's bridge has acknowledged it (a glider host off the network at that
//!   moment gets it when it returns). When it runs out the shore's run ends anyway and its
//!   bridge's log names the hosts that never acknowledged.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

/// A process a host may run besides vehicle agents.
pub const PROCESSES: [&str; 2] = ["coordinator", "field_server"];

/// One host of the file.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Host {
    /// The Zenoh endpoint this host's bridge listens on, `tcp/<address>:<port>`.
    pub endpoint: String,
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

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default = "default_final_wait")]
    final_wait: f64,
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
}

impl Hosts {
    /// Reads and validates the hosts file `path` for a fleet of `vehicles`; the error names
    /// the file and the key.
    pub fn load(path: &Path, vehicles: usize) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Self::parse(&text, &path.display().to_string(), vehicles)
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
        Ok(Self {
            hosts: file.hosts,
            shore,
            final_wait: file.final_wait,
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
    let address = endpoint
        .strip_prefix("tcp/")
        .and_then(|a| a.rsplit_once(':'))
        .map_or("", |(a, _)| a);
    if matches!(address, "0.0.0.0" | "[::]") {
        return Err((
            format!("hosts.{shore}.endpoint = {endpoint:?}"),
            "the shore's endpoint must be an address the glider hosts can connect to, not the unspecified address".into(),
        ));
    }
    Ok(())
}

fn check_endpoint(endpoint: &str) -> Result<(), String> {
    let Some(addr) = endpoint.strip_prefix("tcp/") else {
        return Err("must be tcp/<address>:<port> (the bridge speaks TCP only)".into());
    };
    match addr.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && port.parse::<u16>().is_ok_and(|p| p > 0) => {
            Ok(())
        }
        _ => Err("must be tcp/<address>:<port>".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
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
}
