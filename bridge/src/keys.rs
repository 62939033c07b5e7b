//! The Zenoh key expressions of a mission, all under `vbap/<mission>/`, and the session's
//! configuration (explicit endpoints, no multicast scouting).

use anyhow::{anyhow, Result};
use vbap_mission::hosts::Hosts;

/// Lease of a Zenoh link, ms: a host whose link is silent this long (keep-alives every
/// quarter) is gone; its liveliness token vanishes with it. A closed connection (a killed
/// bridge) is seen at once.
pub const LEASE_MS: u64 = 1000;

/// The key expressions of mission `m`.
#[derive(Clone, Debug)]
pub struct Keys {
    root: String,
}

impl Keys {
    /// The keys of mission `mission`.
    pub fn new(mission: &str) -> Self {
        Self {
            root: format!("vbap/{mission}"),
        }
    }
    /// The states of host `host`'s vehicles, a frame per pass of its bridge (glider host →
    /// shore).
    pub fn states(&self, host: &str) -> String {
        format!("{}/states/{host}", self.root)
    }
    /// Every host's states.
    pub fn all_states(&self) -> String {
        format!("{}/states/*", self.root)
    }
    /// Host `host`'s acknowledgement of the mission's final command (glider host → shore).
    pub fn final_ack(&self, host: &str) -> String {
        format!("{}/final_ack/{host}", self.root)
    }
    /// Every host's acknowledgement of the final command.
    pub fn final_acks(&self) -> String {
        format!("{}/final_ack/*", self.root)
    }
    /// The body commands with their snapshot (shore → every glider host).
    pub fn body(&self) -> String {
        format!("{}/body", self.root)
    }
    /// The process exits host `host`'s supervisor reaped (glider host → shore).
    pub fn exits(&self, host: &str) -> String {
        format!("{}/exits/{host}", self.root)
    }
    /// Every host's process exits.
    pub fn all_exits(&self) -> String {
        format!("{}/exits/*", self.root)
    }
    /// Host `host`'s liveliness token (its bridge is up and forwarding).
    pub fn host(&self, host: &str) -> String {
        format!("{}/host/{host}", self.root)
    }
    /// Every host's liveliness token.
    pub fn hosts(&self) -> String {
        format!("{}/host/*", self.root)
    }
    /// The last chunk of key `key` (a vehicle id, a host name).
    pub fn last(key: &str) -> &str {
        key.rsplit('/').next().unwrap_or(key)
    }
}

/// The Zenoh configuration of host `host`: a peer listening on its own endpoint; a glider
/// host connects to the shore (a star, as the services are), retrying for ever (Zenoh's default period, 1 s doubling to 4 s); multicast
/// and gossip scouting off (only the hosts file's endpoints); link lease [`LEASE_MS`].
pub fn config(hosts: &Hosts, host: &str) -> Result<zenoh::Config> {
    let me = hosts.host(host).map_err(|e| anyhow!(e))?;
    let connect: Vec<String> = if hosts.is_shore(host) {
        Vec::new()
    } else {
        vec![hosts
            .host(&hosts.shore)
            .map_err(|e| anyhow!(e))?
            .endpoint
            .clone()]
    };
    let mut c = zenoh::Config::default();
    let set = |c: &mut zenoh::Config, key: &str, value: String| {
        c.insert_json5(key, &value)
            .map_err(|e| anyhow!("zenoh config {key} = {value}: {e}"))
    };
    set(&mut c, "mode", "\"peer\"".into())?;
    set(
        &mut c,
        "listen/endpoints",
        json_list(std::slice::from_ref(&me.endpoint)),
    )?;
    set(&mut c, "connect/endpoints", json_list(&connect))?;
    set(&mut c, "connect/timeout_ms", "-1".into())?;
    set(&mut c, "connect/exit_on_failure", "false".into())?;
    set(&mut c, "scouting/multicast/enabled", "false".into())?;
    set(&mut c, "scouting/gossip/enabled", "false".into())?;
    set(&mut c, "transport/link/tx/lease", LEASE_MS.to_string())?;
    set(&mut c, "transport/link/tx/keep_alive", "4".into())?;
    Ok(c)
}

/// `list` as a JSON array of strings.
fn json_list(list: &[String]) -> String {
    let quoted: Vec<String> = list.iter().map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}
