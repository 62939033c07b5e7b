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

use std::sync::atomic::Ordering;
use std::sync::mpsc;
use std::time::Duration;

use anyhow::{anyhow, Result};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ipc, CallbackProgression, SignalHandlingMode, WaitSetBuilder};
use iceoryx2::waitset::WaitSetRunResult;
use tracing::info;
use vbap_ipc::ports;
use vbap_ipc::topics::{Domain, Limits};
use vbap_wire::msg::coordinator_to_agent::BodyCommand;
use vbap_wire::msg::Header;
use zenoh::qos::{CongestionControl, Priority};
use zenoh::Wait;

use super::{Counts, In, Stop};
use crate::keys::Keys;
use crate::wire::{self, Batch, Raw, RawBody, RawExit, RawState};

/// What the outbound side of a host forwards.
pub(crate) struct Spec {
    pub shore: bool,
    pub host: String,
    pub local: Vec<u32>,
    pub remote: Vec<u32>,
}

/// Longest wait without a wake-up: the subscribers are read then anyway (a wake-up lost
/// to a restart costs at most this).
const IDLE: Duration = Duration::from_millis(100);

/// A Zenoh publisher of our streams: reliable, blocking, express (see the crate doc).
pub(crate) fn publisher(
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

/// Reads every sample of `sub` and puts each in a frame of its own on `publisher`;
/// returns the frame of the mission's final body command when one was read.
fn forward<T: Raw>(
    sub: &Subscriber<ipc::Service, T, ()>,
    publisher: &zenoh::pubsub::Publisher<'static>,
    counts: &Counts,
) -> Result<Option<Vec<u8>>> {
    let mut last = None;
    while let Some(sample) = sub.receive().map_err(|e| anyhow!("receiving: {e:?}"))? {
        let raw: &T = &sample;
        let frame = wire::encode(raw);
        put(publisher, &frame, counts)?;
        counts.out.fetch_add(1, Ordering::Relaxed);
        if T::NAME == RawBody::NAME {
            let h = std::mem::offset_of!(BodyCommand, header);
            let sender = wire::u32_at(raw.bytes(), h + std::mem::offset_of!(Header, sender));
            let flags = wire::u32_at(raw.bytes(), h + std::mem::offset_of!(Header, flags));
            if sender == Header::COORDINATOR && flags & BodyCommand::FINISHED != 0 {
                last = Some(frame);
            }
        }
    }
    Ok(last)
}

/// Reads every sample of every subscriber of `subs` (this host's vehicles' states) into one
/// frame and puts it on `publisher` (nothing when none was read).
fn forward_batch(
    subs: &[Subscriber<ipc::Service, RawState, ()>],
    publisher: &zenoh::pubsub::Publisher<'static>,
    counts: &Counts,
) -> Result<()> {
    let mut batch = Batch::<RawState>::default();
    for sub in subs {
        while let Some(sample) = sub.receive().map_err(|e| anyhow!("receiving: {e:?}"))? {
            batch.push(&sample);
        }
    }
    if !batch.is_empty() {
        put(publisher, batch.frame(), counts)?;
        counts.out.fetch_add(batch.len() as u64, Ordering::Relaxed);
    }
    Ok(())
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
            forward_batch(&states, publisher, counts)?;
        }
        if let Some((sub, publisher)) = &exits {
            forward(sub, publisher, counts)?;
        }
        if let Some((sub, publisher)) = &body {
            if let Some(frame) = forward(sub, publisher, counts)? {
                info!("the mission's final command is forwarded: handed to the inbound loop");
                let _ = inbound.send(In::Final(frame));
                break;
            }
        }
    }
    drop(guards);
    Ok(())
}
