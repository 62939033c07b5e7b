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

/// The access control of host `host` of mission `mission` over mutual TLS, as Zenoh's
/// `access_control` configuration (JSON): every peer is known by the common name of its
/// certificate (its host name, `vbap certs`), and everything not allowed here is denied.
/// The shore takes from glider host `h` only puts of `states/h`, `exits/h` and
/// `final_ack/h`, `h`'s own liveliness token, and subscriptions to the body commands and
/// the hosts' tokens; it sends `h` only body commands, tokens and its own subscriptions. A
/// glider host takes from the shore only body commands, tokens and subscriptions, and sends
/// it only its own states, exits, acknowledgements, token and subscriptions. So a glider
/// host can neither publish another host's states nor a command, nor read another host's
/// states (what Zenoh cannot say, a state whose vehicle is not its key's host's, the
/// shore's bridge refuses itself).
pub fn access_control(hosts: &Hosts, host: &str, mission: &str) -> String {
    let k = Keys::new(mission);
    let all = format!("{}/**", k.root);
    let tokens = format!("{}/host/**", k.root);
    // A rule allowing `messages` on `keys` in direction `flow`: its id and its JSON.
    let rule = |id: &str, flow: &str, messages: &[&str], keys: &[String]| {
        let json = format!(
            r#"{{"id":{id:?},"flows":[{flow:?}],"messages":{},"key_exprs":{},"permission":"allow"}}"#,
            json_list(&messages.iter().map(|m| m.to_string()).collect::<Vec<_>>()),
            json_list(keys)
        );
        (id.to_string(), json)
    };
    let mut rules = Vec::new();
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    let peers: Vec<String> = if hosts.is_shore(host) {
        hosts
            .hosts
            .keys()
            .filter(|h| !hosts.is_shore(h))
            .cloned()
            .collect()
    } else {
        vec![hosts.shore.clone()]
    };
    for peer in &peers {
        // What a glider host `g` sends the shore (and the shore takes from it).
        let from_glider = |g: &str, flow: &str| {
            [
                rule(
                    &format!("{g}_{flow}_puts"),
                    flow,
                    &["put"],
                    &[k.states(g), k.exits(g), k.final_ack(g)],
                ),
                rule(
                    &format!("{g}_{flow}_token"),
                    flow,
                    &["liveliness_token"],
                    &[format!("{}/host/{g}/*", k.root)],
                ),
                rule(
                    &format!("{g}_{flow}_subscriptions"),
                    flow,
                    &["declare_subscriber"],
                    &[k.body()],
                ),
                rule(
                    &format!("{g}_{flow}_token_subscriptions"),
                    flow,
                    &["declare_liveliness_subscriber", "liveliness_query"],
                    std::slice::from_ref(&tokens),
                ),
            ]
        };
        // What the shore sends a glider host (and the glider host takes from it).
        let from_shore = |flow: &str, tag: &str| {
            [
                rule(&format!("{tag}_{flow}_body"), flow, &["put"], &[k.body()]),
                rule(
                    &format!("{tag}_{flow}_tokens"),
                    flow,
                    &["liveliness_token"],
                    std::slice::from_ref(&tokens),
                ),
                rule(
                    &format!("{tag}_{flow}_subscriptions"),
                    flow,
                    &[
                        "declare_subscriber",
                        "declare_liveliness_subscriber",
                        "liveliness_query",
                    ],
                    std::slice::from_ref(&all),
                ),
            ]
        };
        let these: Vec<(String, String)> = if hosts.is_shore(host) {
            from_glider(peer, "ingress")
                .into_iter()
                .chain(from_shore("egress", peer))
                .collect()
        } else {
            from_glider(host, "egress")
                .into_iter()
                .chain(from_shore("ingress", peer))
                .collect()
        };
        let ids: Vec<String> = these.iter().map(|(id, _)| id.clone()).collect();
        rules.extend(these.into_iter().map(|(_, json)| json));
        subjects.push(format!(
            r#"{{"id":{:?},"cert_common_names":[{peer:?}]}}"#,
            format!("host_{peer}")
        ));
        policies.push(format!(
            r#"{{"id":{:?},"rules":{},"subjects":[{:?}]}}"#,
            format!("policy_{peer}"),
            json_list(&ids),
            format!("host_{peer}")
        ));
    }
    format!(
        r#"{{"enabled":true,"default_permission":"deny","rules":[{}],"subjects":[{}],"policies":[{}]}}"#,
        rules.join(","),
        subjects.join(","),
        policies.join(",")
    )
}

/// [`config`] for the bridge of mission `mission`: over mutual TLS with its
/// [`access_control`].
pub fn mission_config(hosts: &Hosts, host: &str, mission: &str) -> Result<zenoh::Config> {
    let mut c = config(hosts, host)?;
    if hosts.tls.is_some() {
        let acl = access_control(hosts, host, mission);
        c.insert_json5("access_control", &acl)
            .map_err(|e| anyhow!("zenoh config access_control = {acl}: {e}"))?;
    }
    Ok(c)
}

/// The Zenoh log events the bridge watches (an `EnvFilter` directive): the TLS
/// listener's warnings ([`refused_handshake`]) and the access control's decisions, which
/// Zenoh logs only at `trace` ([`denied_by_access_control`]). The log file keeps its own
/// filter: none of these reach it unless `RUST_LOG` asks.
pub const WATCHED_ZENOH_EVENTS: &str =
    "zenoh_link_tls=warn,zenoh::net::routing::interceptor::access_control=trace";

/// The `message` field of tracing event `event`, formatted.
fn message_of(event: &tracing::Event<'_>) -> String {
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
    m.0
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
    let m = message_of(event);
    const HINT: &str = ". Hint: increase the system open file limit.";
    if let Some(reason) = m.strip_suffix(HINT) {
        return Some(reason.to_string());
    }
    m.contains("TLS handshake").then_some(m)
}

/// How many permissions Zenoh 1.10's access control decides, one after the other on the
/// same thread, when it caches them for a key expression (its `Cache`: query, reply, put,
/// delete, the three declarations, the liveliness query and subscriber).
const ACL_CACHED_DECISIONS: u32 = 9;

thread_local! {
    /// Decisions of a key expression's permission cache still to come on this thread (not
    /// messages: [`denied_by_access_control`] does not count them).
    static ACL_CACHING: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Whether tracing event `event` is this host's Zenoh access control denying a peer's
/// message (a put, a declaration, a query against [`access_control`]'s rules): Zenoh's
/// message ("`zid` on `subject` is unauthorized to `action` on `key`"). None for any
/// other event: the decisions that allow, and the decisions Zenoh makes ahead for every
/// kind of message when it caches a key expression's permissions (logged alike, but no
/// message was denied). One event per denied message as long as each peer matches one
/// subject, as [`access_control`]'s do (its certificate's common name).
pub fn denied_by_access_control(event: &tracing::Event<'_>) -> Option<String> {
    let meta = event.metadata();
    if !meta.target().ends_with("access_control") || *meta.level() != tracing::Level::TRACE {
        return None;
    }
    let m = message_of(event);
    if m.contains("caching permissions for") {
        ACL_CACHING.set(ACL_CACHED_DECISIONS);
        return None;
    }
    let denied = m.contains(" is unauthorized to ");
    if !m.starts_with("Using cached result")
        && (denied || m.contains(" is authorized to "))
        && ACL_CACHING.get() > 0
    {
        ACL_CACHING.set(ACL_CACHING.get() - 1);
        return None;
    }
    denied.then_some(m)
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
    fn the_access_control_lets_each_glider_host_put_only_its_own_keys_and_zenoh_takes_it() {
        let text = "[tls]\nca = \"/c/ca.pem\"\n\
            [hosts.shore]\nendpoint = \"tls/10.0.0.1:7447\"\nprocesses = [\"coordinator\", \"field_server\"]\ncert = \"/c/shore.pem\"\nkey = \"/c/shore.key\"\n\
            [hosts.glider_a]\nendpoint = \"tls/10.0.0.2:7447\"\nvehicles = [0, 1]\ncert = \"/c/glider_a.pem\"\nkey = \"/c/glider_a.key\"\n\
            [hosts.glider_b]\nendpoint = \"tls/10.0.0.3:7447\"\nvehicles = [2, 3]\ncert = \"/c/glider_b.pem\"\nkey = \"/c/glider_b.key\"\n";
        let hosts = Hosts::parse(text, "test", 4).unwrap();
        let shore = access_control(&hosts, "shore", "m1");
        // The shore takes puts of glider_a's own keys from glider_a's certificate only.
        assert!(shore.contains(
            r#"{"id":"glider_a_ingress_puts","flows":["ingress"],"messages":["put"],"key_exprs":["vbap/m1/states/glider_a","vbap/m1/exits/glider_a","vbap/m1/final_ack/glider_a"],"permission":"allow"}"#
        ), "{shore}");
        assert!(shore.contains(r#""cert_common_names":["glider_b"]"#));
        assert!(shore.contains(r#""default_permission":"deny""#));
        // A glider host takes puts of the body commands only, from the shore.
        let a = access_control(&hosts, "glider_a", "m1");
        assert!(a.contains(r#""cert_common_names":["shore"]"#), "{a}");
        assert!(!a.contains("glider_b"), "{a}");
        // Zenoh reads every host's rules (a typo would fail the session at start).
        for h in ["shore", "glider_a", "glider_b"] {
            mission_config(&hosts, h, "m1").unwrap();
        }
    }

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
