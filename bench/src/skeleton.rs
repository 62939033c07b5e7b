//! The skeleton floor of `vbap bench`: the system's own topology and message pattern with
//! no math and no files.
//!
//! The bench plays the coordinator; N helper processes (`vbap bench --role skeleton-agent`)
//! play the agents and one (`--role skeleton-field`) the field server. Every port is opened
//! through the same service builders of `vbap_ipc::topics` the system uses
//! (`Domain::state_sender`, `body_receiver`, `body_service`, `sample_service`,
//! `vehicle_wake`, `coordinator_wake`, `field_wake`), so the skeleton follows any change of
//! the system's topology or service settings. One tick:
//!
//! 1. the coordinator publishes a [`BodyCommand`] (the real type, written once into shared
//!    memory entries-in-use only, `vbap_ipc::prefix`, as `coordinator::run` does) and wakes
//!    every agent on its own wake service;
//! 2. each agent reads the command in place (its header and its own snapshot entry) and
//!    publishes a [`VehicleState`] of the next tick, waking the coordinator with its
//!    vehicle event;
//! 3. once the N states are in, the coordinator sends one [`SampleBatch`] of N reads to the
//!    field server (request-response, wake on the field's service) and waits for the
//!    [`ReadingBatch`] (the field server wakes it with the sample event; it also drains the
//!    body subscriber it holds, as the real one does).
//!
//! The coordinator waits as the real one does: it polls for up to
//! [`vbap_ipc::wait::COORDINATOR_SPIN`] before it sleeps.
//!
//! Nothing is computed (readings are zeros), nothing is written to a file: the cheapest a
//! lockstep tick of this design can be.

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use iceoryx2::prelude::ipc;
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::coordinator_to_field::{SampleBatch, SensorRead};
use vbap_ipc::msg::field_to_coordinator::{Reading, ReadingBatch};
use vbap_ipc::msg::{wall_ns, Header};
use vbap_ipc::ports;
use vbap_ipc::topics::{self, Domain, Limits};
use vbap_ipc::wait::{Event, Wake, WakeListener, COORDINATOR_SPIN};
use vbap_mission::rundir::Percentiles;

use super::peer::{
    in_private_domain, say_ready, wait_events, wait_events_spinning, Helper, PEER_TIMEOUT,
};
use super::stop::{Interrupted, StopFlag};

/// Time step written into the headers (s); nothing depends on it.
pub(crate) const DT: f64 = 0.05;

/// The coordinator's side of the skeleton: its ports.
pub(crate) struct Coordinator {
    states: Vec<iceoryx2::port::subscriber::Subscriber<ipc::Service, VehicleState, ()>>,
    agents: Vec<iceoryx2::port::notifier::Notifier<ipc::Service>>,
    body: iceoryx2::port::publisher::Publisher<ipc::Service, BodyCommand, ()>,
    client: iceoryx2::port::client::Client<ipc::Service, SampleBatch, (), ReadingBatch, ()>,
    pub(crate) field: iceoryx2::port::notifier::Notifier<ipc::Service>,
    pub(crate) wake: WakeListener,
}

impl Coordinator {
    pub(crate) fn open(
        domain: &Domain,
        node: &iceoryx2::node::Node<ipc::Service>,
        n: usize,
    ) -> Result<Self> {
        let limits = Limits::for_fleet(n);
        let mut states = Vec::with_capacity(n);
        let mut agents = Vec::with_capacity(n);
        for id in 0..n as u32 {
            states.push(ports::subscriber(
                &domain.state_service(node, id, &limits)?,
            )?);
            agents.push(ports::notifier(
                &domain.vehicle_wake(node, id, &limits)?,
                Event::Body,
            )?);
        }
        Ok(Self {
            states,
            agents,
            body: ports::publisher(&domain.body_service(node, &limits)?)?,
            client: domain
                .sample_service(node, &limits)?
                .client_builder()
                .create()
                .map_err(|e| anyhow!("creating the sensor-read client: {e:?}"))?,
            field: ports::notifier(&domain.field_wake(node, &limits)?, Event::Data)?,
            wake: WakeListener::new(&domain.coordinator_wake(node, &limits)?)?,
        })
    }

    /// Says the mission's final command (the agents and the field server end), ignoring
    /// peers already gone.
    pub(crate) fn finish(&self, body: &mut BodyCommand) {
        body.header = Header::new(Header::COORDINATOR, u64::MAX, 0.0, u64::MAX)
            .with_flags(BodyCommand::FINISHED);
        let _ = self.fan_out(body);
        let _ = self.field.notify();
    }

    /// Publishes `body` (one copy into shared memory) and wakes every agent.
    pub(crate) fn fan_out(&self, body: &mut BodyCommand) -> Result<()> {
        body.header.sent_ns = wall_ns();
        vbap_ipc::prefix::publish(&self.body, &*body)
            .map_err(|e| anyhow!("publishing the body: {e:?}"))?;
        for a in &self.agents {
            a.notify().map_err(|e| anyhow!("waking an agent: {e:?}"))?;
        }
        Ok(())
    }
}

/// Helper `role` (`skeleton-agent`, `skeleton-field`) number `id` of a fleet of `n` in
/// domain `mission`, started from folder `work`.
pub(crate) fn spawn_role(
    work: &std::path::Path,
    mission: &str,
    role: &str,
    id: usize,
    n: usize,
) -> Result<Helper> {
    Helper::spawn(
        work,
        &format!("{role}-{id}"),
        &[
            "--role".into(),
            role.into(),
            "--domain".into(),
            mission.into(),
            "--id".into(),
            id.to_string(),
            "--agents".into(),
            n.to_string(),
        ],
    )
}

/// The skeleton's body command for a fleet of `n`: every vehicle's snapshot entry named.
pub(crate) fn fleet_body(n: usize) -> Box<BodyCommand> {
    let mut body = Box::new(BodyCommand::empty());
    body.n_vehicles = n as u32;
    for (id, e) in body.snapshot.iter_mut().take(n).enumerate() {
        e.id = id as u32;
    }
    body
}

/// Ticks per second of the skeleton through `n` agents, over `rounds` ticks after a fifth
/// as many warm-up ticks.
pub fn skeleton_floor(
    work: &std::path::Path,
    n: usize,
    rounds: usize,
    stop: &StopFlag,
) -> Result<f64> {
    Ok(skeleton_run(work, n, rounds, stop)?.ticks_per_s)
}

/// What a skeleton run measured.
#[derive(Clone, Debug)]
pub struct SkeletonFloor {
    /// Ticks per second.
    pub ticks_per_s: f64,
    /// The state hop, one-way (agent's stamp just before sending to the coordinator's
    /// wall clock once it holds the state, as `vbap analyze` measures the system's), µs.
    pub hop_us: Percentiles,
    /// The state hop p50 by arrival order within a tick (the first state of a tick to
    /// reach the coordinator, the second, …), µs.
    pub hop_by_rank_us: Vec<f64>,
}

/// [`skeleton_floor`], with the state hop of the measured ticks.
pub fn skeleton_run(
    work: &std::path::Path,
    n: usize,
    rounds: usize,
    stop: &StopFlag,
) -> Result<SkeletonFloor> {
    in_private_domain("k", |domain| {
        let node = domain.node(topics::COORDINATOR_NODE)?;
        let c = Coordinator::open(domain, &node, n)?;
        let waiter = c.wake.attach()?;
        let helper = |role: &str, id: usize| spawn_role(work, &domain.mission, role, id, n);
        let mut helpers = vec![helper("skeleton-field", 0)?];
        for id in 0..n {
            helpers.push(helper("skeleton-agent", id)?);
        }
        for h in helpers.iter_mut() {
            h.ready()?;
            stop.check()?;
        }
        let mut body = fleet_body(n);
        let mut batch = Box::new(SampleBatch::empty());
        let mut latest = vec![VehicleState::default(); n];
        let warmup = (rounds / 5).max(10);
        let mut hops = Vec::with_capacity(rounds * n);
        let mut t0 = Instant::now();
        for k in 0..(warmup + rounds) as u64 {
            if k == warmup as u64 {
                t0 = Instant::now();
                hops.clear();
            }
            body.header = Header::new(Header::COORDINATOR, k, k as f64 * DT, k + 1);
            c.fan_out(&mut body)?;
            gather(&c, &waiter, k + 1, &mut latest, &mut hops)?;
            sense(&c, &waiter, k + 1, &latest, &mut batch)?;
        }
        let rate = rounds as f64 / t0.elapsed().as_secs_f64();
        c.finish(&mut body);
        for h in helpers {
            h.reap(Duration::from_secs(5));
        }
        let mut by_rank = vec![Vec::with_capacity(rounds); n];
        for &(rank, hop) in &hops {
            by_rank[rank.min(n - 1)].push(hop);
        }
        let mut hops: Vec<f64> = hops.into_iter().map(|(_, h)| h).collect();
        Ok(SkeletonFloor {
            ticks_per_s: rate,
            hop_us: Percentiles::of(&mut hops),
            hop_by_rank_us: by_rank.iter_mut().map(|v| Percentiles::of(v).p50).collect(),
        })
    })
}

/// Waits until every agent's state of tick `tick` is in (draining only the subscribers
/// whose vehicles woke the coordinator, as the coordinator does); the one-way latency of
/// each state goes to `hops` (µs), after the number of the tick's states in before it.
pub(crate) fn gather(
    c: &Coordinator,
    waiter: &vbap_ipc::wait::Waiter<'_>,
    tick: u64,
    latest: &mut [VehicleState],
    hops: &mut Vec<(usize, f64)>,
) -> Result<()> {
    if gather_within(c, waiter, tick, latest, hops, PEER_TIMEOUT)? {
        return Ok(());
    }
    let n = latest.len();
    let have = latest.iter().filter(|s| s.header.tick == tick).count();
    bail!("skeleton, N = {n}: {have} of {n} states of tick {tick}")
}

/// [`gather`] for at most `timeout` without news: false when it ran out.
pub(crate) fn gather_within(
    c: &Coordinator,
    waiter: &vbap_ipc::wait::Waiter<'_>,
    tick: u64,
    latest: &mut [VehicleState],
    hops: &mut Vec<(usize, f64)>,
    timeout: Duration,
) -> Result<bool> {
    let n = latest.len();
    let mut have = latest.iter().filter(|s| s.header.tick == tick).count();
    let mut woke = Vec::new();
    while have < n {
        woke.clear();
        match wait_events_spinning(waiter, timeout, COORDINATOR_SPIN, |e| woke.push(e))? {
            Wake::Stop => return Err(Interrupted.into()),
            Wake::Timeout => return Ok(false),
            Wake::Events => {}
        }
        for e in &woke {
            let Event::Vehicle(id) = *e else { continue };
            let Some(sub) = c.states.get(id as usize) else {
                continue;
            };
            while let Some(s) = sub.receive().context("receiving a state")? {
                hops.push((
                    have,
                    wall_ns().saturating_sub(s.header.sent_ns) as f64 / 1e3,
                ));
                let slot = &mut latest[id as usize];
                if s.header.tick == tick && slot.header.tick != tick {
                    have += 1;
                }
                *slot = *s;
            }
        }
    }
    Ok(true)
}

/// One batched sensor round trip for the states of tick `tick`.
pub(crate) fn sense(
    c: &Coordinator,
    waiter: &vbap_ipc::wait::Waiter<'_>,
    tick: u64,
    latest: &[VehicleState],
    batch: &mut SampleBatch,
) -> Result<()> {
    for (read, s) in batch.reads.iter_mut().zip(latest) {
        *read = SensorRead {
            vehicle: s.header.sender,
            _pad: 0,
            tick: s.header.tick,
            t: s.header.t,
            position: s.position,
        };
    }
    batch.n = latest.len() as u32;
    batch.header = Header::new(Header::COORDINATOR, tick, tick as f64 * DT, tick);
    let pending = vbap_ipc::prefix::request(&c.client, &*batch)
        .map_err(|e| anyhow!("sending the sensor reads: {e:?}"))?;
    c.field
        .notify()
        .map_err(|e| anyhow!("waking the field server: {e:?}"))?;
    loop {
        if let Some(reply) = pending
            .receive()
            .map_err(|e| anyhow!("receiving readings: {e:?}"))?
        {
            anyhow::ensure!(
                reply.request_seq == tick && reply.readings().len() == latest.len(),
                "skeleton: readings out of turn"
            );
            return Ok(());
        }
        match wait_events_spinning(waiter, PEER_TIMEOUT, COORDINATOR_SPIN, |_| {})? {
            Wake::Stop => return Err(Interrupted.into()),
            Wake::Timeout => bail!("skeleton: no readings for tick {tick}"),
            Wake::Events => {}
        }
    }
}

/// Helper role: agent `id` of a fleet of `n`.
pub fn agent(domain: &Domain, id: usize, n: usize) -> Result<i32> {
    let limits = Limits::for_fleet(n);
    let node = domain.agent_node(&topics::agent_node_name(id as u32))?;
    let state = domain.state_sender(&node, id as u32, &limits)?;
    let body = domain.body_receiver(&node, id as u32, &limits)?;
    let waiter = body.wake().attach()?;
    say_ready("");
    let mut seq = 0;
    loop {
        if wait_events(&waiter, Duration::from_secs(3600), |_| {})? == Wake::Stop {
            return Ok(0);
        }
        while let Some(command) = body.receive()? {
            let h = command.header;
            if h.flags & BodyCommand::FINISHED != 0 {
                return Ok(0);
            }
            // Read in place: the header and this vehicle's snapshot entry.
            let mine = command.snapshot[id.min(command.snapshot.len() - 1)];
            seq += 1;
            state.send(VehicleState {
                header: Header::new(id as u32, h.tick + 1, h.t + DT, seq),
                pid: std::process::id(),
                position: mine.position,
                velocity: mine.velocity,
                ..VehicleState::default()
            })?;
        }
    }
}

/// Helper role: the field server of a fleet of `n` (answers with zeros).
pub fn field(domain: &Domain, n: usize) -> Result<i32> {
    let limits = Limits::for_fleet(n);
    let node = domain.node(topics::FIELD_SERVER_NODE)?;
    let server = domain
        .sample_service(&node, &limits)?
        .server_builder()
        .create()
        .map_err(|e| anyhow!("creating the sample server: {e:?}"))?;
    let wake = WakeListener::new(&domain.field_wake(&node, &limits)?)?;
    let coordinator = ports::notifier(&domain.coordinator_wake(&node, &limits)?, Event::Sample)?;
    let body = ports::subscriber(&domain.body_service(&node, &limits)?)?;
    let waiter = wake.attach()?;
    let mut reply = Box::new(ReadingBatch::empty());
    say_ready("");
    loop {
        if wait_events(&waiter, Duration::from_secs(3600), |_| {})? == Wake::Stop {
            return Ok(0);
        }
        while let Some(request) = server
            .receive()
            .map_err(|e| anyhow!("receiving a request: {e:?}"))?
        {
            reply.n = 0;
            for read in request.reads() {
                reply.readings[reply.n as usize] = Reading {
                    vehicle: read.vehicle,
                    rejected: 0,
                    tick: read.tick,
                    value: 0.0,
                };
                reply.n += 1;
            }
            reply.header = Header::new(Header::FIELD_SERVER, request.header.tick, 0.0, 0);
            reply.request_seq = request.header.seq;
            let _ = vbap_ipc::prefix::respond(&request, &*reply);
            let _ = coordinator.notify();
        }
        while let Some(b) = body
            .receive()
            .map_err(|e| anyhow!("receiving the body: {e:?}"))?
        {
            if b.header.flags & BodyCommand::FINISHED != 0 {
                return Ok(0);
            }
        }
    }
}
