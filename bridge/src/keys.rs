//! The Zenoh key expressions of a mission, all under `vbap/<mission>/`, and the session's
//! configuration (explicit endpoints, no multicast scouting, mutual TLS unless the hosts
//! file says `insecure = true`).

use anyhow::{anyhow, Result};
use vbap_mission::hosts::Hosts;

/// Lease of a Zenoh link, ms: a host whose link is silent this long (keep-alives every
/// quarter) is gone; its liveliness token vanishes with it. A closed connection (a killed
/// bridge) is seen at once.
pub const LEASE_MS: u64 = 1000;

/// Batches (of up to 64 KiB) in each priority's transmission queue of a link: Zenoh's
/// maximum (default 2). At the bridge's rates a dead link's queue takes seconds to fill,
/// many leases.
pub const QUEUE_BATCHES: usize = 16;

/// The priorities of a link's transmission queues, as Zenoh's configuration names them.
const QUEUES: [&str; 8] = [
    "control",
    "real_time",
    "interactive_high",
    "interactive_low",
    "data_high",
    "data",
    "data_low",
    "background",
];

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
    /// The liveliness token of host `host`'s bridge process `pid` (up and forwarding): a
    /// restarted bridge's token is another key, so that it is never taken for the old
    /// one's link reopened.
    pub fn host(&self, host: &str, pid: u32) -> String {
        format!("{}/host/{host}/{pid}", self.root)
    }
    /// Every host's liveliness token.
    pub fn hosts(&self) -> String {
        format!("{}/host/*/*", self.root)
    }
    /// The host and bridge pid of a liveliness token's key (None: not a token's key).
    pub fn host_of_token(key: &str) -> Option<(&str, u32)> {
        let mut chunks = key.rsplit('/');
        let pid = chunks.next()?.parse().ok()?;
        let host = chunks.next()?;
        (chunks.next()? == "host").then_some((host, pid))
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
    // A dead link never blocks a healthy one (docs/design/hosts.md, "A dead link"): every
    // priority's queue at Zenoh's most batches, so that a vanished host's link is closed by
    // its lease long before a blocking put to it could find its queue full ...
    for priority in QUEUES {
        set(
            &mut c,
            &format!("transport/link/tx/queue/size/{priority}"),
            QUEUE_BATCHES.to_string(),
        )?;
    }
    // ... and should one ever be full, the put waits at most a lease, not 5 s, before that
    // one link is closed.
    set(
        &mut c,
        "transport/link/tx/queue/congestion_control/block/wait_before_close",
        (LEASE_MS * 1000).to_string(),
    )?;
    match &hosts.tls {
        Some(tls) => {
            // Mutual TLS, nothing else: a peer is accepted only with a certificate of the
            // mission's CA, and the shore's certificate must name the address connected to.
            set(&mut c, "transport/link/protocols", r#"["tls"]"#.into())?;
            let path = |p: &std::path::Path| format!("{:?}", p.display().to_string());
            let (cert, key) = match (&me.cert, &me.key) {
                (Some(c), Some(k)) => (path(c), path(k)),
                _ => return Err(anyhow!("host {host}: tls/ without cert and key")),
            };
            set(
                &mut c,
                "transport/link/tls/root_ca_certificate",
                path(&tls.ca),
            )?;
            set(
                &mut c,
                "transport/link/tls/listen_certificate",
                cert.clone(),
            )?;
            set(&mut c, "transport/link/tls/listen_private_key", key.clone())?;
            set(&mut c, "transport/link/tls/connect_certificate", cert)?;
            set(&mut c, "transport/link/tls/connect_private_key", key)?;
            set(&mut c, "transport/link/tls/enable_mtls", "true".into())?;
            set(
                &mut c,
                "transport/link/tls/verify_name_on_connect",
                "true".into(),
            )?;
        }
        None => set(&mut c, "transport/link/protocols", r#"["tcp"]"#.into())?,
    }
    Ok(c)
}

/// Whether tracing event `event` is Zenoh's TLS listener refusing a handshake (a peer
/// without a certificate of the mission's CA, or not speaking TLS): its message, less
/// Zenoh's hint about open files (a handshake error reaches the same line as an accept
/// error). None for any other event.
pub fn refused_handshake(event: &tracing::Event<'_>) -> Option<String> {
    let meta = event.metadata();
    if !meta.target().starts_with("zenoh_link_tls") || *meta.level() != tracing::Level::WARN {
        return None;
    }
    struct Message(String);
    impl tracing::field::Visit for Message {
        fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
            if field.name() == "message" {
                self.0 = format!("{value:?}");
            }
        }
    }
    let mut m = Message(String::new());
    event.record(&mut m);
    const HINT: &str = ". Hint: increase the system open file limit.";
    if let Some(reason) = m.0.strip_suffix(HINT) {
        return Some(reason.to_string());
    }
    m.0.contains("TLS handshake").then_some(m.0)
}

/// `list` as a JSON array of strings.
fn json_list(list: &[String]) -> String {
    let quoted: Vec<String> = list.iter().map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_key_names_its_host_and_bridge_process() {
        let keys = Keys::new("m1");
        let key = keys.host("glider_a", 4242);
        assert_eq!(Keys::host_of_token(&key), Some(("glider_a", 4242)));
        // Not a token's key: another kind, or no pid.
        assert_eq!(Keys::host_of_token(&keys.exits("glider_a")), None);
        assert_eq!(Keys::host_of_token("vbap/m1/host/glider_a"), None);
        assert_eq!(Keys::host_of_token("vbap/m1/states/glider_a/7"), None);
    }
}
