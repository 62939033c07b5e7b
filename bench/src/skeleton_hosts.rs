//! The skeleton over hosts (`vbap bench --hosts`): the lockstep skeleton of [`skeleton`]
//! spread over the same three hosts as the mission, with a bare relay in place of each
//! host's bridge: the floor of this topology, against which the mission's cross-host hop
//! and tick are measured.
//!
//! Per host, one process in its namespace ([`host`], role `skeleton-host`) starts that
//! host's share as children (so they share its private /dev/shm):
//! - the shore: the skeleton's field server, a relay, and the skeleton's coordinator in
//!   itself (ticks as [`skeleton`]'s: the body fanned out, the N states gathered, one
//!   batched sensor round trip);
//! - each glider host: its vehicles' skeleton agents and a relay.
//!
//! A relay ([`relay`], role `skeleton-relay`) does what the bridge must and nothing else:
//! the same Zenoh session (the hosts file's endpoints, TLS and access control), the same
//! keys, QoS and frames (`vbap_bridge::wire`, the same raw payloads whole), the same
//! iceoryx2 services and wake-ups. A glider host's relay stands for the coordinator: woken
//! by its agents, it puts their states of one pass in one frame; it publishes each body
//! command it gets and wakes its agents. The shore's stands for the remote agents: woken
//! with a body command, it puts it; it publishes each state it gets on its vehicle's
//! service and wakes the coordinator. No checks, no counts, no repeats, no records.
//!
//! The shore's coordinator measures the state hop as the mission's records do (the agent's
//! stamp to the coordinator's clock once it holds the state: hosts share one clock here)
//! and prints one line: ticks per second, the tick's p50 and the hop's p50 and p90.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use vbap_bridge::keys::{self, Keys};
use vbap_bridge::wire::{self, Batch, Headed, RawBody, RawState};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::Header;
use vbap_ipc::ports::{self, Sender};
use vbap_ipc::topics::{Domain, Limits};
use vbap_ipc::wait::{Event, Wake, WakeListener};
use vbap_mission::hosts::Hosts;
use vbap_mission::rundir::Percentiles;
use zenoh::qos::Priority;
use zenoh::Wait;

use super::peer::{say_ready, wait_events, Helper};
use super::skeleton;

/// What the shore's skeleton coordinator measured.
#[derive(Clone, Debug)]
pub struct HostsSkeleton {
    /// Ticks per second over the measured ticks.
    pub ticks_per_s: f64,
    /// The tick (one fan-out, gather and sensor round trip) p50, ms.
    pub tick_ms: f64,
    /// The state hop, agent's stamp to the coordinator holding it, µs.
    pub hop_us: Percentiles,
}

impl HostsSkeleton {
    /// The line the shore's host process prints.
    fn line(&self) -> String {
        format!(
            "skeleton {} {} {} {}",
            self.ticks_per_s, self.tick_ms, self.hop_us.p50, self.hop_us.p90
        )
    }

    /// Parses [`HostsSkeleton::line`].
    pub fn parse(line: &str) -> Result<Self> {
        let v: Vec<f64> = line
            .strip_prefix("skeleton ")
            .ok_or_else(|| anyhow!("not a skeleton line: {line:?}"))?
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .with_context(|| format!("skeleton line {line:?}"))?;
        let [ticks_per_s, tick_ms, p50, p90] = v[..] else {
            bail!("skeleton line {line:?}: 4 numbers expected");
        };
        Ok(Self {
            ticks_per_s,
            tick_ms,
            hop_us: Percentiles {
                p50,
                p90,
                ..Percentiles::default()
            },
        })
    }
}

/// The arguments of a host's share: the iceoryx2 domain (and the keys' mission name), the
/// hosts file, this host, the fleet's size and the measured ticks.
pub struct Share<'a> {
    pub domain: &'a str,
    pub hosts: &'a Path,
    pub host: &'a str,
    pub n: usize,
    pub rounds: usize,
}

impl Share<'_> {
    fn args(&self, role: &str) -> Vec<String> {
        vec![
            "--role".into(),
            role.into(),
            "--domain".into(),
            self.domain.into(),
            "--hosts-file".into(),
            self.hosts.display().to_string(),
            "--host".into(),
            self.host.into(),
            "--agents".into(),
            self.n.to_string(),
        ]
    }
}

/// Helper role `skeleton-host`: this host's share, its children started from here (in
/// this namespace). On the shore, prints the [`HostsSkeleton`] line at the end.
pub fn host(share: &Share<'_>, work: &Path) -> Result<i32> {
    let hosts = Hosts::load(share.hosts, share.n).map_err(|e| anyhow!(e))?;
    std::fs::create_dir_all(work)?;
    let domain = Domain::new(share.domain)?;
    let mut helpers = Vec::new();
    if hosts.is_shore(share.host) {
        let mut field = Helper::spawn(
            work,
            "skeleton-field",
            &[
                "--role".into(),
                "skeleton-field".into(),
                "--domain".into(),
                share.domain.into(),
                "--id".into(),
                "0".into(),
                "--agents".into(),
                share.n.to_string(),
            ],
        )?;
        field.ready()?;
        let mut relay = Helper::spawn(work, "relay", &share.args("skeleton-relay"))?;
        relay.ready()?;
        say_ready("");
        let measured = coordinate(&domain, share.n, share.rounds)?;
        println!("{}", measured.line());
        relay.reap(Duration::from_secs(5));
        field.reap(Duration::from_secs(5));
        return Ok(0);
    }
    let mine = hosts
        .host(share.host)
        .map_err(|e| anyhow!(e))?
        .vehicles
        .clone();
    for &id in &mine {
        let mut agent = Helper::spawn(
            work,
            &format!("agent-{id}"),
            &[
                "--role".into(),
                "skeleton-agent".into(),
                "--domain".into(),
                share.domain.into(),
                "--id".into(),
                id.to_string(),
                "--agents".into(),
                share.n.to_string(),
            ],
        )?;
        agent.ready()?;
        helpers.push(agent);
    }
    let mut relay = Helper::spawn(work, "relay", &share.args("skeleton-relay"))?;
    relay.ready()?;
    say_ready("");
    // The relay ends with the mission's final command, which it hands on to the agents.
    relay.reap(Duration::from_secs(24 * 3600));
    for h in helpers {
        h.reap(Duration::from_secs(5));
    }
    Ok(0)
}

/// The shore's skeleton coordinator: says tick 0 until every remote agent answered (the
/// glider hosts may join late), then warm-up and `rounds` measured ticks.
fn coordinate(domain: &Domain, n: usize, rounds: usize) -> Result<HostsSkeleton> {
    let node = domain.node(vbap_ipc::topics::COORDINATOR_NODE)?;
    let c = skeleton::Coordinator::open(domain, &node, n)?;
    let waiter = c.wake.attach()?;
    let mut body = Box::new(BodyCommand::empty());
    body.n_vehicles = n as u32;
    for (id, e) in body.snapshot.iter_mut().take(n).enumerate() {
        e.id = id as u32;
    }
    let mut batch = Box::new(vbap_ipc::msg::coordinator_to_field::SampleBatch::empty());
    let mut latest = vec![VehicleState::default(); n];
    let mut hops = Vec::with_capacity(rounds * n);
    let hello = Instant::now();
    let mut seq = 0;
    loop {
        seq += 1;
        body.header = Header::new(Header::COORDINATOR, 0, 0.0, seq);
        c.fan_out(&mut body)?;
        if skeleton::gather_within(&c, &waiter, 1, &mut latest, &mut hops, HELLO)? {
            break;
        }
        if hello.elapsed() > Duration::from_secs(60) {
            bail!("skeleton over hosts: the glider hosts never all answered");
        }
    }
    skeleton::sense(&c, &waiter, 1, &latest, &mut batch)?;
    let warmup = (rounds / 5).max(10) as u64;
    let mut ticks = Vec::with_capacity(rounds);
    let mut t0 = Instant::now();
    for k in 1..=(warmup + rounds as u64) {
        if k == warmup + 1 {
            t0 = Instant::now();
            hops.clear();
        }
        let start = Instant::now();
        seq += 1;
        body.header = Header::new(Header::COORDINATOR, k, k as f64 * skeleton::DT, seq);
        c.fan_out(&mut body)?;
        skeleton::gather(&c, &waiter, k + 1, &mut latest, &mut hops)?;
        skeleton::sense(&c, &waiter, k + 1, &latest, &mut batch)?;
        if k > warmup {
            ticks.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    let rate = rounds as f64 / t0.elapsed().as_secs_f64();
    body.header =
        Header::new(Header::COORDINATOR, u64::MAX, 0.0, u64::MAX).with_flags(BodyCommand::FINISHED);
    let _ = c.fan_out(&mut body);
    let _ = c.field.notify();
    let mut hops: Vec<f64> = hops.into_iter().map(|(_, h)| h).collect();
    Ok(HostsSkeleton {
        ticks_per_s: rate,
        tick_ms: Percentiles::of(&mut ticks).p50,
        hop_us: Percentiles::of(&mut hops),
    })
}

/// How long the shore says tick 0 before saying it again while the glider hosts join.
const HELLO: Duration = Duration::from_millis(200);

/// Longest wait of a relay's loops without news (they look at their stop flag then).
const IDLE: Duration = Duration::from_millis(100);

/// Helper role `skeleton-relay`: this host's relay (see the module).
pub fn relay(share: &Share<'_>) -> Result<i32> {
    let hosts = Hosts::load(share.hosts, share.n).map_err(|e| anyhow!(e))?;
    let domain = Domain::new(share.domain)?;
    let limits = Limits::for_fleet(share.n);
    let config = keys::mission_config(&hosts, share.host, share.domain)?;
    let session = zenoh::open(config)
        .wait()
        .map_err(|e| anyhow!("opening the Zenoh session of {}: {e}", share.host))?;
    let keys = Keys::new(share.domain);
    let shore = hosts.is_shore(share.host);
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
        hosts
            .host(share.host)
            .map_err(|e| anyhow!(e))?
            .vehicles
            .clone()
    };
    let outbound = {
        let (session, domain, stop, local) =
            (session.clone(), domain.clone(), stop.clone(), local.clone());
        let key = if shore {
            keys.body()
        } else {
            keys.states(share.host)
        };
        let n = share.n;
        std::thread::spawn(move || -> Result<()> {
            let publisher = vbap_bridge::publisher(&session, key, Priority::RealTime)?;
            if shore {
                bodies_out(&domain, &limits, n, &publisher, &stop)
            } else {
                states_out(&domain, &limits, &local, &publisher, &stop)
            }
        })
    };
    say_ready("");
    let inbound = if shore {
        states_in(&domain, &limits, share.n, &rx, &stop)
    } else {
        bodies_in(&domain, &limits, &local, &rx, &stop)
    };
    stop.store(true, Ordering::Relaxed);
    let out = outbound
        .join()
        .map_err(|_| anyhow!("the relay's outbound thread panicked"))?;
    let _ = session.close().wait();
    inbound?;
    out?;
    Ok(0)
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
        if wait_events(&waiter, IDLE, |_| {})? == Wake::Stop {
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
        if wait_events(&waiter, IDLE, |e| woke.push(e))? == Wake::Stop {
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
