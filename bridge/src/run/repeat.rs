//! A frame lost with its link is put again; a frame that comes twice is published once.
//!
//! Zenoh's reliability holds within one link: when a link closes (its lease ran out, a
//! crossing connection replaced it, a put waited too long on a full queue) the frames in
//! its queues are gone, and the session reopens a link without saying which were lost.
//! Lockstep needs every state and every command, so a lost frame would hold the whole
//! mission until the coordinator's silence limit lost the vehicles it was for.
//!
//! The rule, one per direction:
//! - a glider host's bridge that put its vehicles' states and has had no new body command
//!   from the shore for [`repeat_after`] puts the latest state of each of its vehicles
//!   again;
//! - the shore's bridge that put a body command and has had no new state from an up
//!   glider host for [`repeat_after`] puts that command again (on the one body key: every
//!   glider host receives it).
//!
//! A frame put again carries the attachment [`AGAIN`]; a receiving bridge publishes what
//! such a frame carries only when it is not the message it last published for the same
//! sender ([`Identity`]: the header's sequence number and send stamp), so a frame put again
//! is counted and dropped where it was not lost, never seen twice by the coordinator or an
//! agent (they reject replays). A frame put once is published as it always was: a restarted
//! glider host's bridge reads each vehicle's last state again (the service's history) and
//! forwards it, and the shore must publish it (it is the state that brings a vehicle lost
//! with the old bridge back). `repeat_after` is at least
//! [`REPEAT_MIN`] and two ticks of wall time on a paced mission, so a mission that is
//! merely slow puts nothing again.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use anyhow::{anyhow, Result};
use vbap_mission::config::{Mission, Pace};

use crate::wire::WireHeader;

/// The attachment of a frame put again.
pub(crate) const AGAIN: &[u8] = b"again";

/// The least silence after which a frame is put again: half a link lease (a link silent a
/// lease is closed and reopened, and what it held is lost by then).
pub(crate) const REPEAT_MIN: Duration = Duration::from_millis(crate::keys::LEASE_MS / 2);

/// How long a bridge waits for an answer before putting its last frame again: [`REPEAT_MIN`]
/// in lockstep; at least two ticks of wall time (dt / pace) on a paced mission.
pub(crate) fn repeat_after(mission: &Mission) -> Duration {
    match mission.mission.pace {
        Pace::Lockstep => REPEAT_MIN,
        Pace::Factor(f) => REPEAT_MIN.max(Duration::from_secs_f64(2.0 * mission.mission.dt / f)),
    }
}

/// Which message a payload is, for telling a frame put again from a new one: its sender's
/// sequence number and send stamp (ns).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Identity {
    seq: u64,
    sent_ns: u64,
}

impl Identity {
    /// The identity of the payload whose header is `header`.
    pub fn of(header: &WireHeader) -> Self {
        Self {
            seq: header.seq,
            sent_ns: header.sent_ns,
        }
    }
}

/// The hosts this bridge hears from (the glider hosts on the shore, the shore on a glider
/// host): shared by the inbound loop, which counts what is new from each and whether its
/// token is up, and the outbound thread, which puts again what went unanswered.
#[derive(Debug, Default)]
pub(crate) struct Peers {
    hosts: BTreeMap<String, Peer>,
}

#[derive(Debug, Default)]
struct Peer {
    /// Frames from this host that carried something new (published here).
    news: AtomicU64,
    /// Its token is up.
    up: AtomicBool,
}

impl Peers {
    /// The peers named `names`, none up yet.
    pub fn new(names: impl IntoIterator<Item = String>) -> Self {
        Self {
            hosts: names.into_iter().map(|n| (n, Peer::default())).collect(),
        }
    }
    /// A frame from `host` carried something new.
    pub fn heard(&self, host: &str) {
        if let Some(p) = self.hosts.get(host) {
            p.news.fetch_add(1, Ordering::Relaxed);
        }
    }
    /// `host`'s token is up (or gone).
    pub fn set_up(&self, host: &str, up: bool) {
        if let Some(p) = self.hosts.get(host) {
            p.up.store(up, Ordering::Relaxed);
        }
    }
    /// How much news each peer has brought so far (in name order), into `out`.
    pub fn news_into(&self, out: &mut Vec<u64>) {
        out.clear();
        out.extend(self.hosts.values().map(|p| p.news.load(Ordering::Relaxed)));
    }
    /// Whether some up peer has brought nothing new since the counts `before` (from
    /// [`Peers::news_into`]).
    pub fn one_silent_since(&self, before: &[u64]) -> bool {
        self.hosts
            .values()
            .zip(before)
            .any(|(p, &n)| p.up.load(Ordering::Relaxed) && p.news.load(Ordering::Relaxed) == n)
    }
}

/// A frame lost on purpose (`VBAP_BRIDGE_LOSE`, for tests): the bridge skips its
/// `n`-th put (1-based) of state frames or of body commands, as a link that closed with
/// that frame in its queue would. Written `states:N`, `body:N`, or both comma-separated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Lose {
    pub states: Option<u64>,
    pub body: Option<u64>,
}

impl Lose {
    /// The environment variable that names the frames to lose.
    pub const VAR: &'static str = "VBAP_BRIDGE_LOSE";

    /// Reads [`Lose::VAR`] (none when unset).
    pub fn from_env() -> Result<Self> {
        match std::env::var(Self::VAR) {
            Ok(text) => Self::parse(&text),
            Err(_) => Ok(Self::default()),
        }
    }

    /// Parses `states:N,body:M` (either part may be missing).
    pub fn parse(text: &str) -> Result<Self> {
        let mut lose = Self::default();
        for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let bad = || anyhow!("{}: {part:?} is not states:N or body:N (N ≥ 1)", Self::VAR);
            let (stream, n) = part.split_once(':').ok_or_else(bad)?;
            let n: u64 = n.trim().parse().map_err(|_| bad())?;
            if n == 0 {
                return Err(bad());
            }
            match stream.trim() {
                "states" => lose.states = Some(n),
                "body" => lose.body = Some(n),
                _ => return Err(bad()),
            }
        }
        Ok(lose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lose_reads_both_streams_and_refuses_anything_else() {
        assert_eq!(
            Lose::parse("states:5, body:8").unwrap(),
            Lose {
                states: Some(5),
                body: Some(8)
            }
        );
        assert_eq!(Lose::parse("").unwrap(), Lose::default());
        for bad in ["states", "states:0", "exits:3", "body:x"] {
            let e = Lose::parse(bad).unwrap_err().to_string();
            assert!(e.contains(Lose::VAR) && e.contains(bad), "{e}");
        }
    }

    #[test]
    fn a_peer_is_silent_until_it_brings_news_and_only_while_up() {
        let peers = Peers::new(["a".to_string(), "b".to_string()]);
        let mut before = Vec::new();
        peers.news_into(&mut before);
        assert!(!peers.one_silent_since(&before), "no peer up yet");
        peers.set_up("a", true);
        peers.set_up("b", true);
        assert!(peers.one_silent_since(&before));
        peers.heard("a");
        assert!(peers.one_silent_since(&before), "b is still silent");
        peers.heard("b");
        assert!(!peers.one_silent_since(&before));
        let mut now = Vec::new();
        peers.news_into(&mut now);
        peers.set_up("b", false);
        peers.heard("a");
        assert!(!peers.one_silent_since(&now), "b is gone, a spoke");
    }

    #[test]
    fn a_paced_mission_waits_two_ticks_of_wall_time() {
        let mut m = Mission::default();
        m.mission.pace = Pace::Lockstep;
        assert_eq!(repeat_after(&m), REPEAT_MIN);
        m.mission.dt = 10.0;
        m.mission.pace = Pace::Factor(2.0);
        assert_eq!(repeat_after(&m), Duration::from_secs(10));
        m.mission.pace = Pace::Factor(1000.0);
        assert_eq!(repeat_after(&m), REPEAT_MIN);
    }
}
