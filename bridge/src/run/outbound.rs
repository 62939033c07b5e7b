//! This host's iceoryx2 services → Zenoh: woken exactly as the absent reader would be.
//!
//! On the shore the bridge stands for the remote agents: it listens on their wake services
//! (`<m>/vehicle/<id>/wake`, notified by the coordinator with every command) and reads the
//! body service. On a glider host it stands for the coordinator: it listens on
//! `<m>/coordinator/wake` (the agents' `Event::Vehicle(id)`, the supervisor's
//! `Event::Exit`) and reads the local vehicles' states and the supervisor's exits.
//!
//! A glider host's states read in one pass (one wake-up: the states of one tick that
//! have arrived) leave in one frame, one put ([`crate::wire::Batch`]). On the shore the
//! mission's final command, once forwarded, is handed to the inbound loop (it keeps it
//! until every glider host has acknowledged it) and this thread ends.
//!
//! What goes unanswered is put again ([`super::repeat`]): a glider host's latest states
//! when no new body command came, the shore's last body command when an up glider host
//! sent nothing new.

use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ipc, CallbackProgression, SignalHandlingMode, WaitSetBuilder};
use iceoryx2::waitset::WaitSetRunResult;
use tracing::{info, warn};
use vbap_ipc::ports;
use vbap_ipc::topics::{Domain, Limits};
use vbap_wire::msg::coordinator_to_agent::BodyCommand;
use vbap_wire::msg::Header;
use zenoh::qos::{CongestionControl, Priority};
use zenoh::Wait;

use super::repeat::{Lose, Peers, AGAIN};
use super::{Counts, In, Stop};
use crate::keys::Keys;
use crate::wire::{self, Batch, Headed, Raw, RawBody, RawExit, RawState};

/// What the outbound side of a host forwards.
pub(crate) struct Spec {
    pub shore: bool,
    pub host: String,
    pub local: Vec<u32>,
    pub remote: Vec<u32>,
    /// Silence after which the last frame is put again.
    pub repeat: Duration,
    /// Frames lost on purpose (tests).
    pub lose: Lose,
}

/// Longest wait without a wake-up: the subscribers are read then anyway (a wake-up lost
/// to a restart costs at most this).
const IDLE: Duration = Duration::from_millis(100);

/// A Zenoh publisher of our streams: reliable, blocking, express (see the crate doc).
pub fn publisher(
    session: &zenoh::Session,
    key: String,
    priority: Priority,
) -> Result<zenoh::pubsub::Publisher<'static>> {
    session
        .declare_publisher(key.clone())
        .congestion_control(CongestionControl::Block)
        .priority(priority)
        .express(true)
        .wait()
        .map_err(|e| anyhow!("declaring the Zenoh publisher {key}: {e}"))
}

/// Puts frame `frame` on `publisher`.
fn put(publisher: &zenoh::pubsub::Publisher<'static>, frame: &[u8], counts: &Counts) -> Result<()> {
    publisher
        .put(frame)
        .wait()
        .map_err(|e| anyhow!("putting on {}: {e}", publisher.key_expr()))?;
    counts.frames_out.fetch_add(1, Ordering::Relaxed);
    Ok(())
}

/// Puts frame `frame` on `publisher` again, marked so (the attachment [`AGAIN`]): the
/// receiver drops it when it already published what it carries.
fn put_again(
    publisher: &zenoh::pubsub::Publisher<'static>,
    frame: &[u8],
    counts: &Counts,
    what: &str,
) -> Result<()> {
    publisher
        .put(frame)
        .attachment(AGAIN)
        .wait()
        .map_err(|e| anyhow!("putting again on {}: {e}", publisher.key_expr()))?;
    counts.frames_out.fetch_add(1, Ordering::Relaxed);
    let n = counts.repeated.fetch_add(1, Ordering::Relaxed) + 1;
    if n <= 10 || n.is_multiple_of(100) {
        info!(
            what,
            repeated = n,
            "no answer: the last frame put again (a link may have closed with it)"
        );
    }
    Ok(())
}

/// Reads every sample of `sub` and puts each in a frame of its own on `publisher`
/// (skipping the put `lose` names); returns the last frame read, if any, and whether it is
/// the mission's final body command.
fn forward<T: Headed>(
    sub: &Subscriber<ipc::Service, T, ()>,
    publisher: &zenoh::pubsub::Publisher<'static>,
    counts: &Counts,
    lose: &mut LoseCount,
) -> Result<Option<(Vec<u8>, bool)>> {
    let mut last = None;
    while let Some(sample) = sub.receive().map_err(|e| anyhow!("receiving: {e:?}"))? {
        let raw: &T = &sample;
        let frame = wire::encode(raw);
        if !lose.skip() {
            put(publisher, &frame, counts)?;
        }
        counts.out.fetch_add(1, Ordering::Relaxed);
        let mut finished = false;
        if T::NAME == RawBody::NAME {
            let h = raw.header();
            finished = h.sender == Header::COORDINATOR && h.flags & BodyCommand::FINISHED != 0;
        }
        last = Some((frame, finished));
    }
    Ok(last)
}

/// Reads every sample of every subscriber of `subs` (this host's vehicles' states) into one
/// frame and puts it on `publisher` (nothing when none was read; no put when `lose` names
/// it); each vehicle's latest state goes into `latest`. Returns how many were read.
fn forward_batch(
    subs: &[Subscriber<ipc::Service, RawState, ()>],
    publisher: &zenoh::pubsub::Publisher<'static>,
    counts: &Counts,
    latest: &mut BTreeMap<u32, RawState>,
    lose: &mut LoseCount,
) -> Result<usize> {
    let mut batch = Batch::<RawState>::default();
    for sub in subs {
        while let Some(sample) = sub.receive().map_err(|e| anyhow!("receiving: {e:?}"))? {
            let raw: &RawState = &sample;
            batch.push(raw);
            latest.insert(raw.header().sender, *raw);
        }
    }
    if !batch.is_empty() {
        if !lose.skip() {
            put(publisher, batch.frame(), counts)?;
        }
        counts.out.fetch_add(batch.len() as u64, Ordering::Relaxed);
    }
    Ok(batch.len())
}

/// Counts the puts of one stream and says which one to skip ([`Lose`]).
struct LoseCount {
    puts: u64,
    skip: Option<u64>,
    stream: &'static str,
}

impl LoseCount {
    fn new(skip: Option<u64>, stream: &'static str) -> Self {
        Self {
            puts: 0,
            skip,
            stream,
        }
    }
    /// One more put of this stream: true when it is the one to lose.
    fn skip(&mut self) -> bool {
        self.puts += 1;
        let lost = self.skip == Some(self.puts);
        if lost {
            warn!(
                stream = self.stream,
                put = self.puts,
                var = Lose::VAR,
                "a frame lost on purpose: not put"
            );
        }
        lost
    }
}

/// The last frame this host put (if any) and the peers' news then: put again once a peer
/// that is up has brought nothing new for [`repeat_after`](super::repeat::repeat_after).
#[derive(Default)]
struct Unanswered {
    /// When the last frame was put (None: nothing put yet).
    since: Option<Instant>,
    /// The peers' news then (its buffer kept from put to put).
    news: Vec<u64>,
}

impl Unanswered {
    /// A frame was just put.
    fn put(&mut self, peers: &Peers) {
        self.since = Some(Instant::now());
        peers.news_into(&mut self.news);
    }
    /// Whether to put the last frame again now (and if so, wait `after` again).
    fn due(&mut self, peers: &Peers, after: Duration) -> bool {
        let Some(since) = self.since else {
            return false;
        };
        if since.elapsed() < after || !peers.one_silent_since(&self.news) {
            return false;
        }
        self.since = Some(Instant::now());
        true
    }
}

/// The outbound thread: opens its ports, says so on `up`, then forwards until `stop` (or,
/// on the shore, until the mission's final command is forwarded: its frame goes to the
/// inbound loop on `inbound`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn run(
    session: &zenoh::Session,
    domain: &Domain,
    limits: &Limits,
    keys: &Keys,
    spec: &Spec,
    stop: &Stop,
    counts: &Counts,
    peers: &Peers,
    up: mpsc::Sender<()>,
    inbound: mpsc::Sender<In>,
) -> Result<()> {
    let node = domain.node("vbap_bridge_out")?;
    let mut listeners: Vec<Listener<ipc::Service>> = Vec::new();
    let mut states = Vec::new();
    let mut states_out = None;
    let mut body = None;
    let mut exits = None;
    if spec.shore {
        for &id in &spec.remote {
            listeners.push(ports::listener(&domain.vehicle_wake(&node, id, limits)?)?);
        }
        body = Some((
            ports::subscriber(&domain.body_service_as::<RawBody>(&node, limits)?)?,
            publisher(session, keys.body(), Priority::RealTime)?,
        ));
    } else {
        listeners.push(ports::listener(&domain.coordinator_wake(&node, limits)?)?);
        for &id in &spec.local {
            let service = domain.state_like_service_as::<RawState>(
                &node,
                &format!("vehicle/{id}/state"),
                limits,
            )?;
            states.push(ports::subscriber(&service)?);
        }
        states_out = Some(publisher(
            session,
            keys.states(&spec.host),
            Priority::RealTime,
        )?);
        exits = Some((
            ports::subscriber(&domain.exits_service_as::<RawExit>(&node, limits)?)?,
            publisher(session, keys.exits(&spec.host), Priority::InteractiveHigh)?,
        ));
    }
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<ipc::Service>()
        .map_err(|e| anyhow!("creating the waitset: {e:?}"))?;
    let mut guards = Vec::new();
    for l in &listeners {
        guards.push(
            waitset
                .attach_notification(l)
                .map_err(|e| anyhow!("attaching a wake listener: {e:?}"))?,
        );
    }
    let _ = up.send(());
    info!(
        shore = spec.shore,
        listeners = listeners.len(),
        "outbound ports up"
    );
    let mut lose_states = LoseCount::new(spec.lose.states, "states");
    let mut lose_body = LoseCount::new(spec.lose.body, "body");
    let mut lose_none = LoseCount::new(None, "exits");
    // A glider host: each local vehicle's latest state; the shore: the last body command.
    let mut latest: BTreeMap<u32, RawState> = BTreeMap::new();
    let mut last_body: Option<Vec<u8>> = None;
    let mut unanswered = Unanswered::default();
    while !stop.is_set() {
        let result = waitset
            .wait_and_process_once_with_timeout(|_| CallbackProgression::Continue, IDLE)
            .map_err(|e| anyhow!("waiting: {e:?}"))?;
        if matches!(result, WaitSetRunResult::TerminationRequest) {
            stop.set();
        }
        for l in &listeners {
            l.try_wait(|_| {})
                .map_err(|e| anyhow!("draining a wake listener: {e:?}"))?;
        }
        if let Some(publisher) = &states_out {
            if forward_batch(&states, publisher, counts, &mut latest, &mut lose_states)? > 0 {
                unanswered.put(peers);
            } else if unanswered.due(peers, spec.repeat) {
                let mut batch = Batch::<RawState>::default();
                latest.values().for_each(|s| batch.push(s));
                put_again(publisher, batch.frame(), counts, "states")?;
            }
        }
        if let Some((sub, publisher)) = &exits {
            forward(sub, publisher, counts, &mut lose_none)?;
        }
        if let Some((sub, publisher)) = &body {
            match forward(sub, publisher, counts, &mut lose_body)? {
                Some((frame, true)) => {
                    info!("the mission's final command is forwarded: handed to the inbound loop");
                    let _ = inbound.send(In::Final(frame));
                    break;
                }
                Some((frame, false)) => {
                    last_body = Some(frame);
                    unanswered.put(peers);
                }
                None => {
                    if let Some(frame) = &last_body {
                        if unanswered.due(peers, spec.repeat) {
                            put_again(publisher, frame, counts, "body")?;
                        }
                    }
                }
            }
        }
    }
    drop(guards);
    Ok(())
}
