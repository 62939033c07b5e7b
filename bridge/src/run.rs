//! The bridge's life: the Zenoh session, the outbound thread (this host's iceoryx2
//! services → Zenoh, [`outbound`]) and the inbound loop (Zenoh → this host's services,
//! [`inbound`]), readiness and the end.
//!
//! Readiness ("hosts start in any order and wait for each other"): a glider host's bridge
//! declares its liveliness token as soon as its ports exist and prints `ready` (its
//! supervisor then starts the agents) once it sees the shore's token. The shore's bridge
//! prints `ready` (its supervisor then starts the field server and the coordinator) once it
//! sees every glider host's token, and declares its own token once the coordinator's body
//! publisher exists: a glider's agents so never speak before the coordinator listens.
//!
//! The end ("the final command reaches a host that was off the network"): the shore's
//! bridge keeps the mission's final command once it has forwarded it and puts it again
//! every [`RESEND`] (and at once when a glider host's token reappears) until every glider
//! host's bridge has acknowledged it on `vbap/<m>/final_ack/<host>`, then ends; a glider
//! host's bridge acknowledges every final command it receives (it publishes only the
//! first to its agents) and ends when the shore's token vanishes after it. Both wait at
//! most the hosts file's `final_wait`; when it runs out on the shore, its bridge's log
//! names the glider hosts that never acknowledged (warning `final command not
//! acknowledged`) and the shore's run ends.

mod inbound;
mod outbound;
pub use outbound::publisher;
mod repeat;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use anyhow::{anyhow, Context, Result};
use tracing::{info, warn};
use vbap_ipc::topics::{Domain, Limits};
use vbap_mission::config::Mission;
use vbap_mission::hosts::Hosts;
use zenoh::sample::SampleKind;
use zenoh::Wait;

use crate::keys::{self, Keys};

/// What the bridge forwarded and refused (logged at the end).
#[derive(Debug, Default)]
pub struct Counts {
    /// Messages sent to Zenoh (a state, a body command, an exit).
    pub out: AtomicU64,
    /// Zenoh puts (frames: a glider host's states of one pass share one).
    pub frames_out: AtomicU64,
    /// Messages received from Zenoh and published here.
    pub inbound: AtomicU64,
    /// Frames refused (another payload type or version, a sender that is not its key's).
    pub refused: AtomicU64,
    /// Frames put again for want of an answer (`repeat`'s doc).
    pub repeated: AtomicU64,
    /// Messages received a second time (a frame put again that had not been lost): dropped.
    pub duplicates: AtomicU64,
}

impl Counts {
    /// Counts a refused frame; logs the first few and then every thousandth.
    pub(crate) fn refuse(&self, key: &str, why: &dyn std::fmt::Display) {
        let n = self.refused.fetch_add(1, Ordering::Relaxed) + 1;
        if n <= 10 || n.is_multiple_of(1000) {
            warn!(key, refused = n, reason = %why, "refused a frame: not propagated");
        }
    }
}

/// Peers refused at the TLS handshake by this host's Zenoh (no certificate of the
/// mission's CA, or not speaking TLS): counted by [`watch_zenoh`] from Zenoh's log.
pub static REFUSED_HANDSHAKES: AtomicU64 = AtomicU64::new(0);

/// Messages of peers (puts, declarations, queries) this host's Zenoh access control
/// denied (`keys::access_control`): counted by [`watch_zenoh`] from Zenoh's log.
pub static DENIED_BY_ACCESS_CONTROL: AtomicU64 = AtomicU64::new(0);

/// The bridge's watcher of Zenoh's log ([`crate::keys::WATCHED_ZENOH_EVENTS`]): counts
/// every TLS handshake Zenoh's listener refused and every message its access control
/// denied, and logs the first ten of each, then every thousandth.
pub fn watch_zenoh(event: &tracing::Event<'_>) {
    let now_and_then = |n: u64| n <= 10 || n.is_multiple_of(1000);
    if let Some(reason) = crate::keys::refused_handshake(event) {
        let n = REFUSED_HANDSHAKES.fetch_add(1, Ordering::Relaxed) + 1;
        if now_and_then(n) {
            warn!(
                refused_handshakes = n,
                reason = %reason,
                "refused a peer at the TLS handshake: no certificate of the mission's CA, or not TLS"
            );
        }
    } else if let Some(what) = crate::keys::denied_by_access_control(event) {
        let n = DENIED_BY_ACCESS_CONTROL.fetch_add(1, Ordering::Relaxed) + 1;
        if now_and_then(n) {
            warn!(
                denied = n,
                what = %what,
                "denied a peer's message by the access control: not propagated"
            );
        }
    }
}

/// A message from Zenoh (the subscribers' callbacks) to the inbound loop.
pub(crate) enum In {
    /// A frame on key `key`; `again`: put again for want of an answer (`repeat`'s doc).
    Frame {
        key: String,
        bytes: Vec<u8>,
        again: bool,
    },
    /// The liveliness token of host `.0`'s bridge process `.1` appeared.
    Up(String, u32),
    /// The liveliness token of host `.0`'s bridge process `.1` vanished (that bridge
    /// ended, or its link's lease ran out, or its link is being reopened).
    Down(String, u32),
    /// The shore's outbound thread forwarded the mission's final command, frame `.0`.
    Final(Vec<u8>),
}

/// Where this bridge is and what it forwards.
pub(crate) struct Place<'a> {
    pub mission: &'a Mission,
    pub hosts: &'a Hosts,
    pub host: &'a str,
    pub domain: Domain,
    pub limits: Limits,
    pub keys: Keys,
}

impl Place<'_> {
    pub fn is_shore(&self) -> bool {
        self.hosts.is_shore(self.host)
    }
    /// The vehicles whose agents run on this host.
    pub fn local_vehicles(&self) -> Vec<u32> {
        self.hosts.hosts[self.host].vehicles.clone()
    }
    /// The vehicles of every other host.
    pub fn remote_vehicles(&self) -> Vec<u32> {
        (0..self.mission.vehicles.count as u32)
            .filter(|v| !self.local_vehicles().contains(v))
            .collect()
    }
    /// The hosts other than the shore.
    pub fn glider_hosts(&self) -> Vec<String> {
        self.hosts
            .hosts
            .keys()
            .filter(|h| !self.hosts.is_shore(h))
            .cloned()
            .collect()
    }
}

/// Set when the bridge is to end (a termination signal; on the shore every glider host's
/// acknowledgement of the mission's final command or `final_wait` run out; on a glider
/// host the shore gone after the final command, or `final_wait` run out).
#[derive(Default)]
pub(crate) struct Stop {
    flag: AtomicBool,
}

impl Stop {
    pub fn set(&self) {
        self.flag.store(true, Ordering::SeqCst);
    }
    pub fn is_set(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
            || iceoryx2_bb_posix::signal::SignalHandler::termination_requested()
    }
}

/// Runs the bridge of host `host` of `mission` placed by `hosts` until a termination
/// signal or the end of the mission's final command's delivery (see [`Stop`]); `ready` is called once this host may start its
/// processes (see the module doc).
pub fn run(
    mission: &Mission,
    hosts: &Hosts,
    host: &str,
    ready: impl FnOnce(),
) -> Result<Arc<Counts>> {
    let place = Place {
        mission,
        hosts,
        host,
        domain: Domain::new(&mission.mission.name)?,
        limits: Limits::for_fleet(mission.vehicles.count),
        keys: Keys::new(&mission.mission.name),
    };
    let config = keys::mission_config(hosts, host, &mission.mission.name)?;
    let session = zenoh::open(config)
        .wait()
        .map_err(|e| anyhow!("opening the Zenoh session of host {host}: {e}"))?;
    info!(
        host,
        shore = place.is_shore(),
        lease_ms = keys::LEASE_MS,
        tls = hosts.tls.is_some(),
        "zenoh session open"
    );
    let counts = Arc::new(Counts::default());
    let stop = Arc::new(Stop::default());
    let peers = Arc::new(repeat::Peers::new(if place.is_shore() {
        place.glider_hosts()
    } else {
        vec![hosts.shore.clone()]
    }));
    let lose = repeat::Lose::from_env()?;
    let (tx, rx) = mpsc::channel::<In>();
    let _subscribers = inbound::subscribe(&session, &place, &tx)?;

    let (up_tx, up_rx) = mpsc::channel::<()>();
    let out = {
        let (session, stop, counts, peers) =
            (session.clone(), stop.clone(), counts.clone(), peers.clone());
        let inbound = tx.clone();
        let (domain, limits, keys) = (place.domain.clone(), place.limits, place.keys.clone());
        let spec = outbound::Spec {
            shore: place.is_shore(),
            host: host.to_string(),
            local: place.local_vehicles(),
            remote: place.remote_vehicles(),
            repeat: repeat::repeat_after(mission),
            lose,
        };
        std::thread::Builder::new()
            .name("outbound".into())
            .spawn(move || {
                outbound::run(
                    &session, &domain, &limits, &keys, &spec, &stop, &counts, &peers, up_tx,
                    inbound,
                )
            })
            .context("starting the outbound thread")?
    };
    // The outbound ports exist (or the thread failed: its error is returned below).
    let _ = up_rx.recv();
    let result = inbound::run(&session, &place, &rx, &stop, &counts, &peers, ready);
    stop.set();
    let out = out
        .join()
        .map_err(|_| anyhow!("the outbound thread panicked"))?;
    let closed = session.close().wait();
    info!(
        out = counts.out.load(Ordering::Relaxed),
        frames_out = counts.frames_out.load(Ordering::Relaxed),
        inbound = counts.inbound.load(Ordering::Relaxed),
        refused = counts.refused.load(Ordering::Relaxed),
        repeated = counts.repeated.load(Ordering::Relaxed),
        duplicates = counts.duplicates.load(Ordering::Relaxed),
        refused_handshakes = REFUSED_HANDSHAKES.load(Ordering::Relaxed),
        denied = DENIED_BY_ACCESS_CONTROL.load(Ordering::Relaxed),
        "bridge done"
    );
    result?;
    out?;
    closed.map_err(|e| anyhow!("closing the Zenoh session: {e}"))?;
    Ok(counts)
}

/// The callback of the liveliness subscriber: host tokens appearing and vanishing.
pub(crate) fn liveliness_event(tx: &mpsc::Sender<In>, sample: &zenoh::sample::Sample) {
    let Some((host, pid)) = Keys::host_of_token(sample.key_expr().as_str()) else {
        return;
    };
    let host = host.to_string();
    let _ = tx.send(match sample.kind() {
        SampleKind::Put => In::Up(host, pid),
        SampleKind::Delete => In::Down(host, pid),
    });
}

/// How often the shore puts the held final command again while a glider host has not
/// acknowledged it.
pub(crate) const RESEND: Duration = Duration::from_millis(250);

/// How long a host's token may be away before the host is gone (its vehicles reported
/// unreachable): Zenoh closes and reopens a link at once now and then (two connections
/// crossing; measured: the token away 4 ms), which must cost no vehicle. A host really
/// gone is still found within its link's lease plus this.
pub(crate) const HOST_GONE_GRACE: Duration = Duration::from_millis(250);

/// How often the inbound loop looks at its stop flag and readiness with nothing received.
pub(crate) const POLL: Duration = Duration::from_millis(50);
