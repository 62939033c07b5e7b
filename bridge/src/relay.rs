//! A bare relay in place of a host's bridge, for the skeleton over hosts of `vbap bench
//! --hosts` (`vbap_zenoh_ping --relay`): what the bridge must do and nothing else. The same
//! Zenoh session (the hosts file's endpoints, TLS and access control), keys, QoS and frames
//! ([`crate::wire`], the payloads' bytes in use), the same iceoryx2 services and wake-ups.
//! A glider host's relay stands for the coordinator: woken by its agents, it puts their
//! states of one pass in one frame; it publishes each body command it gets and wakes its
//! agents. The shore's stands for the remote agents: woken with a body command, it puts
//! it; it publishes each state it gets on its vehicle's service and wakes the coordinator.
//! No checks, no counts, no repeats, no records.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use anyhow::{anyhow, Context, Result};
use vbap_ipc::ports::{self, Sender};
use vbap_ipc::topics::{Domain, Limits};
use vbap_ipc::wait::{Event, Wake, WakeListener};
use vbap_mission::hosts::Hosts;
use vbap_wire::msg::coordinator_to_agent::BodyCommand;
use zenoh::qos::Priority;
use zenoh::Wait;

use crate::keys::{self, Keys};
use crate::wire::{self, Batch, Headed, RawBody, RawState};

/// Longest wait of a relay's loops without news (they look at their stop flag then).
const IDLE: Duration = Duration::from_millis(100);

/// This host's relay for the skeleton of mission (iceoryx2 domain and keys) `mission` of
/// `n` vehicles (see the module). Prints `ready` once its ports and session are up;
/// returns after the mission's final command.
pub fn relay(hosts: &Hosts, host: &str, mission: &str, n: usize) -> Result<()> {
    let domain = Domain::new(mission)?;
    let limits = Limits::for_fleet(n);
    let config = keys::mission_config(hosts, host, mission)?;
    let session = zenoh::open(config)
        .wait()
        .map_err(|e| anyhow!("opening the Zenoh session of {host}: {e}"))?;
    let keys = Keys::new(mission);
    let shore = hosts.is_shore(host);
    let (tx, rx) = mpsc::channel::<Vec<u8>>();
    let _sub = session
        .declare_subscriber(if shore {
            keys.all_states()
        } else {
            keys.body()
        })
        .callback(move |s| {
            let _ = tx.send(s.payload().to_bytes().into_owned());
        })
        .wait()
        .map_err(|e| anyhow!("subscribing: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    let local: Vec<u32> = if shore {
        Vec::new()
    } else {
        hosts.host(host).map_err(|e| anyhow!(e))?.vehicles.clone()
    };
    let outbound = {
        let (session, domain, stop, local) =
            (session.clone(), domain.clone(), stop.clone(), local.clone());
        let key = if shore {
            keys.body()
        } else {
            keys.states(host)
        };
        std::thread::spawn(move || -> Result<()> {
            let publisher = crate::publisher(&session, key, Priority::RealTime)?;
            if shore {
                bodies_out(&domain, &limits, n, &publisher, &stop)
            } else {
                states_out(&domain, &limits, &local, &publisher, &stop)
            }
        })
    };
    println!("ready");
    let inbound = if shore {
        states_in(&domain, &limits, n, &rx, &stop)
    } else {
        bodies_in(&domain, &limits, &local, &rx, &stop)
    };
    stop.store(true, Ordering::Relaxed);
    let out = outbound
        .join()
        .map_err(|_| anyhow!("the relay's outbound thread panicked"))?;
    let _ = session.close().wait();
    inbound?;
    out
}

/// Shore, outbound: woken as remote vehicle 0 is, puts every body command; ends after the
/// final one.
fn bodies_out(
    domain: &Domain,
    limits: &Limits,
    n: usize,
    publisher: &zenoh::pubsub::Publisher<'static>,
    stop: &AtomicBool,
) -> Result<()> {
    anyhow::ensure!(n > 0, "no vehicle");
    let node = domain.node("relay_out")?;
    let body = ports::subscriber(&domain.body_service_as::<RawBody>(&node, limits)?)?;
    let wake = WakeListener::new(&domain.vehicle_wake(&node, 0, limits)?)?;
    let waiter = wake.attach()?;
    while !stop.load(Ordering::Relaxed) {
        if waiter.wait(IDLE, |_| {})? == Wake::Stop {
            return Ok(());
        }
        while let Some(sample) = body.receive().context("receiving a body command")? {
            publisher
                .put(wire::encode(&*sample))
                .wait()
                .map_err(|e| anyhow!("putting a body command: {e}"))?;
            if Headed::header(&*sample).flags & BodyCommand::FINISHED != 0 {
                return Ok(());
            }
        }
    }
    Ok(())
}

/// Glider host, outbound: woken by its agents, puts their states of one pass in one frame.
fn states_out(
    domain: &Domain,
    limits: &Limits,
    local: &[u32],
    publisher: &zenoh::pubsub::Publisher<'static>,
    stop: &AtomicBool,
) -> Result<()> {
    let node = domain.node("relay_out")?;
    let mut states = std::collections::BTreeMap::new();
    for &id in local {
        let service = domain.state_like_service_as::<RawState>(
            &node,
            &format!("vehicle/{id}/state"),
            limits,
        )?;
        states.insert(id, ports::subscriber(&service)?);
    }
    let wake = WakeListener::new(&domain.coordinator_wake(&node, limits)?)?;
    let waiter = wake.attach()?;
    let mut woke = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        woke.clear();
        if waiter.wait(IDLE, |e| woke.push(e))? == Wake::Stop {
            return Ok(());
        }
        let mut batch = Batch::<RawState>::default();
        for e in &woke {
            let Event::Vehicle(id) = *e else { continue };
            let Some(sub) = states.get(&id) else { continue };
            while let Some(s) = sub.receive().context("receiving a state")? {
                batch.push(&s);
            }
        }
        if !batch.is_empty() {
            publisher
                .put(batch.frame().to_vec())
                .wait()
                .map_err(|e| anyhow!("putting states: {e}"))?;
        }
    }
    Ok(())
}

/// Shore, inbound: each state received is published on its vehicle's service, waking the
/// coordinator.
fn states_in(
    domain: &Domain,
    limits: &Limits,
    n: usize,
    rx: &mpsc::Receiver<Vec<u8>>,
    stop: &AtomicBool,
) -> Result<()> {
    let node = domain.node("relay_in")?;
    let mut senders: Vec<Sender<RawState>> = Vec::with_capacity(n);
    for id in 0..n as u32 {
        let service = domain.state_like_service_as::<RawState>(
            &node,
            &format!("vehicle/{id}/state"),
            limits,
        )?;
        senders.push(Sender::new(
            ports::publisher(&service)?,
            ports::notifier(&domain.coordinator_wake(&node, limits)?, Event::Data)?,
            Event::Vehicle(id),
        ));
    }
    while !stop.load(Ordering::Relaxed) {
        let Ok(frame) = rx.recv_timeout(IDLE) else {
            continue;
        };
        for state in wire::decode_all::<RawState>(&frame)?.into_iter().flatten() {
            let id = state.header().sender as usize;
            if let Some(s) = senders.get(id) {
                s.send(state)?;
            }
        }
    }
    Ok(())
}

/// Glider host, inbound: each body command received is published and wakes the host's
/// agents; ends after the final one.
fn bodies_in(
    domain: &Domain,
    limits: &Limits,
    local: &[u32],
    rx: &mpsc::Receiver<Vec<u8>>,
    stop: &AtomicBool,
) -> Result<()> {
    let node = domain.node("relay_in")?;
    let body = ports::publisher(&domain.body_service_as::<RawBody>(&node, limits)?)?;
    let mut wakes = Vec::with_capacity(local.len());
    for &id in local {
        wakes.push(ports::notifier(
            &domain.vehicle_wake(&node, id, limits)?,
            Event::Body,
        )?);
    }
    while !stop.load(Ordering::Relaxed) {
        let Ok(frame) = rx.recv_timeout(IDLE) else {
            continue;
        };
        let command = wire::decode::<RawBody>(&frame)?;
        body.send_copy(command)
            .map_err(|e| anyhow!("publishing a body command: {e:?}"))?;
        for w in &wakes {
            w.notify().map_err(|e| anyhow!("waking an agent: {e:?}"))?;
        }
        if command.header().flags & BodyCommand::FINISHED != 0 {
            return Ok(());
        }
    }
    Ok(())
}
