//! The floors of `vbap bench`, measured between real processes: this executable started
//! again in a hidden helper role (`vbap bench --role ...`) is the peer.
//!
//! - [`iceoryx2_ping_pong`]: the hop's payload ([`VehicleState`]) over iceoryx2 pub-sub with
//!   an event per message and a blocking WaitSet on both sides, the wake-up mode of the
//!   state → coordinator hop of `vbap run` (same service settings as the state service).
//! - [`udp_ping_pong`]: the same payload bytes over UDP on 127.0.0.1, blocking `recv`.
//! - [`wake_floor`]: one blocking iceoryx2 event round through N + 1 processes: the bench
//!   (the "coordinator") notifies N agents, each on its own event service, and waits until
//!   every one has answered on the coordinator's event service. No payload, no work: the
//!   cheapest a lockstep tick through N + 1 processes can be with blocking wake-ups.
//!
//! One-way latencies are measured as `vbap analyze` measures a hop: the sender stamps the
//! wall clock into `header.sent_ns` just before sending, the receiver reads the wall clock
//! once it holds the message. Both directions of each round trip are recorded.

use std::net::UdpSocket;
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use iceoryx2::node::Node;
use iceoryx2::prelude::{ipc, ServiceName};
use iceoryx2::service::port_factory::{event, publish_subscribe};
use serde::Serialize;
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::{wall_ns, Header};
use vbap_ipc::ports::{self, Receiver, Sender};
use vbap_ipc::topics::{Domain, Limits, EVENT_VEHICLE_BASE};
use vbap_ipc::wait::{Event, Wake, WakeListener};
use vbap_mission::rundir::Percentiles;

use super::peer::{in_private_domain, say_ready, wait_events, Helper, PEER_TIMEOUT};
use super::stop::{Interrupted, StopFlag};

/// `header.flags` of the last ping: the peer exits.
const STOP_FLAG: u32 = 1 << 31;
/// Wake-up of a peer: a ping was sent / a round begins (the agents' body event).
const TICK: Event = Event::Body;
/// Wake-up of the wake-up floor's agents: exit.
const QUIT: Event = Event::Exit;
/// Bytes of a [`VehicleState`] on the wire (UDP): the size of the struct itself.
const WIRE: usize = std::mem::size_of::<VehicleState>();
/// Bytes [`encode`] fills (every field of the layout it knows); the rest stays zero.
const ENCODED: usize = 40 + 8 + 6 * 8;
const _: () = assert!(ENCODED <= WIRE);

/// One floor of the hop.
#[derive(Clone, Debug, Default, Serialize)]
pub struct HopFloor {
    /// One-way latency, µs (both directions of every round trip).
    pub one_way_us: Percentiles,
    /// Round trip, µs (monotonic clock).
    pub round_trip_us: Percentiles,
    /// One-way samples.
    pub samples: usize,
}

fn service_name(domain: &Domain, path: &str) -> Result<ServiceName> {
    let full = format!("{}/bench/{path}", domain.mission);
    ServiceName::new(&full).map_err(|e| anyhow!("service name {full:?}: {e:?}"))
}

/// A pub-sub service of [`VehicleState`] with the settings of `<m>/vehicle/<id>/state`
/// (those of the mission's own, for a fleet of none: 8 nodes), at `<m>/bench/<path>`.
fn state_like(
    node: &Node<ipc::Service>,
    domain: &Domain,
    path: &str,
) -> Result<publish_subscribe::PortFactory<ipc::Service, VehicleState, ()>> {
    Ok(domain.state_like_service(node, &format!("bench/{path}"), &Limits::for_fleet(0))?)
}

/// An event service for `notifiers` notifiers and ids up to `id_max`.
fn event_service(
    node: &Node<ipc::Service>,
    domain: &Domain,
    path: &str,
    notifiers: usize,
    id_max: usize,
) -> Result<event::PortFactory<ipc::Service>> {
    let name = service_name(domain, path)?;
    node.service_builder(&name)
        .event()
        .max_listeners(2)
        .max_notifiers(notifiers)
        .max_nodes(notifiers + 4)
        .event_id_max_value(id_max)
        .open_or_create()
        .map_err(|e| anyhow!("opening service {name}: {e:?}"))
}

/// The ping sender (`ping` and its wake `ping_wake`) or the pong sender.
fn sender(node: &Node<ipc::Service>, domain: &Domain, path: &str) -> Result<Sender<VehicleState>> {
    Ok(Sender::new(
        ports::publisher(&state_like(node, domain, path)?)?,
        ports::notifier(
            &event_service(node, domain, &format!("{path}_wake"), 4, 8)?,
            TICK,
        )?,
        TICK,
    ))
}

/// The receiver of `path` (its subscriber and the listener of `<path>_wake`).
fn receiver(
    node: &Node<ipc::Service>,
    domain: &Domain,
    path: &str,
) -> Result<Receiver<VehicleState>> {
    Ok(Receiver::new(
        ports::subscriber(&state_like(node, domain, path)?)?,
        WakeListener::new(&event_service(node, domain, &format!("{path}_wake"), 4, 8)?)?,
    ))
}

/// The ping of round `i`.
fn ping(i: u64, flags: u32) -> VehicleState {
    VehicleState {
        header: Header::new(0, i, i as f64 * 0.05, i + 1).with_flags(flags),
        pid: std::process::id(),
        position: [1.0 + i as f64, 2.0, 0.0],
        velocity: [0.5, -0.25, 0.0],
        ..VehicleState::default()
    }
}

/// The answer to `ping`, received at `recv_ns`: carries the ping's one-way latency (ns)
/// in `position[2]` (a ping's is always 0), and its own send stamp.
fn pong(ping: &VehicleState, recv_ns: u64) -> VehicleState {
    let mut reply = *ping;
    reply.header.sender = 1;
    reply.position[2] = recv_ns.saturating_sub(ping.header.sent_ns) as f64;
    reply.header.sent_ns = wall_ns();
    reply
}

/// Collects the samples of a ping-pong.
#[derive(Default)]
struct Samples {
    one_way_us: Vec<f64>,
    round_trip_us: Vec<f64>,
}

impl Samples {
    fn push(&mut self, reply: &VehicleState, recv_ns: u64, rtt: Duration) {
        self.one_way_us.push(reply.position[2] / 1e3);
        self.one_way_us
            .push(recv_ns.saturating_sub(reply.header.sent_ns) as f64 / 1e3);
        self.round_trip_us.push(rtt.as_secs_f64() * 1e6);
    }

    fn floor(mut self) -> HopFloor {
        HopFloor {
            samples: self.one_way_us.len(),
            one_way_us: Percentiles::of(&mut self.one_way_us),
            round_trip_us: Percentiles::of(&mut self.round_trip_us),
        }
    }
}

/// The raw iceoryx2 floor of the hop: `samples` round trips after `warmup`. `poll`: both
/// sides busy-poll their subscriber instead of sleeping in a WaitSet (no event at all: the
/// payload path alone, each side burning a CPU).
pub fn iceoryx2_ping_pong(
    work: &Path,
    warmup: usize,
    samples: usize,
    poll: bool,
    stop: &StopFlag,
) -> Result<HopFloor> {
    in_private_domain("i", |domain| {
        let node = domain.node("bench_ping")?;
        let pings = sender(&node, domain, "ping")?;
        let pongs = receiver(&node, domain, "pong")?;
        let waiter = pongs.wake().attach()?;
        let role = if poll { "iox-pong-poll" } else { "iox-pong" };
        let mut helper = Helper::spawn(
            work,
            role,
            &[
                "--role".into(),
                role.into(),
                "--domain".into(),
                domain.mission.clone(),
            ],
        )?;
        helper.ready()?;
        let mut out = Samples::default();
        for i in 0..(warmup + samples) as u64 {
            if i % 1000 == 0 {
                stop.check()?;
            }
            let t0 = Instant::now();
            pings.publish(ping(i, 0)).context("sending a ping")?;
            if !poll {
                pings.notify().context("waking the peer")?;
            }
            let (reply, recv_ns) = loop {
                if let Some(sample) = pongs.receive().context("receiving a pong")? {
                    let recv_ns = wall_ns();
                    let reply: VehicleState = *sample;
                    if reply.header.tick == i {
                        break (reply, recv_ns);
                    }
                    continue;
                }
                if poll {
                    anyhow::ensure!(
                        t0.elapsed() < PEER_TIMEOUT,
                        "iceoryx2 ping-pong (polling): no pong within {PEER_TIMEOUT:?}"
                    );
                    continue;
                }
                match wait_events(&waiter, PEER_TIMEOUT, |_| {})? {
                    Wake::Stop => return Err(Interrupted.into()),
                    Wake::Timeout => bail!("iceoryx2 ping-pong: no pong within {PEER_TIMEOUT:?}"),
                    Wake::Events => {}
                }
            };
            let rtt = t0.elapsed();
            if i >= warmup as u64 {
                out.push(&reply, recv_ns, rtt);
            }
        }
        let _ = pings.send(ping(u64::MAX, STOP_FLAG));
        helper.reap(Duration::from_secs(5));
        Ok(out.floor())
    })
}

pub fn iox_pong(domain: &Domain, poll: bool) -> Result<i32> {
    let node = domain.node("bench_pong")?;
    let pings = receiver(&node, domain, "ping")?;
    let pongs = sender(&node, domain, "pong")?;
    let waiter = pings.wake().attach()?;
    say_ready("");
    let mut last = Instant::now();
    loop {
        if !poll && wait_events(&waiter, Duration::from_secs(3600), |_| {})? == Wake::Stop {
            return Ok(0);
        }
        if poll && last.elapsed() > PEER_TIMEOUT {
            bail!("iceoryx2 pong (polling): no ping within {PEER_TIMEOUT:?}");
        }
        while let Some(sample) = pings.receive().context("receiving a ping")? {
            let recv_ns = wall_ns();
            let p: VehicleState = *sample;
            if p.header.flags & STOP_FLAG != 0 {
                return Ok(0);
            }
            pongs.publish(pong(&p, recv_ns)).context("sending a pong")?;
            last = Instant::now();
            if !poll {
                pongs.notify().context("waking the pinger")?;
            }
        }
    }
}

/// Writes the fields of `s` little-endian, in declaration order (no unsafe transmute).
fn encode(s: &VehicleState) -> [u8; WIRE] {
    let h = &s.header;
    let mut out = [0u8; WIRE];
    let fields: [&[u8]; 8] = [
        &h.sender.to_le_bytes(),
        &h.flags.to_le_bytes(),
        &h.tick.to_le_bytes(),
        &h.t.to_le_bytes(),
        &h.seq.to_le_bytes(),
        &h.sent_ns.to_le_bytes(),
        &s.pid.to_le_bytes(),
        &s.incarnation.to_le_bytes(),
    ];
    let mut at = 0;
    for f in fields {
        out[at..at + f.len()].copy_from_slice(f);
        at += f.len();
    }
    for v in s.position.iter().chain(&s.velocity) {
        out[at..at + 8].copy_from_slice(&v.to_le_bytes());
        at += 8;
    }
    out
}

/// The inverse of [`encode`].
fn decode(b: &[u8; WIRE]) -> VehicleState {
    let u32_at = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"));
    let u64_at = |at: usize| u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"));
    let f64_at = |at: usize| f64::from_bits(u64_at(at));
    // Padding bytes are not read back: they carry nothing.
    let mut header =
        Header::new(u32_at(0), u64_at(8), f64_at(16), u64_at(24)).with_flags(u32_at(4));
    header.sent_ns = u64_at(32);
    VehicleState {
        header,
        pid: u32_at(40),
        position: [f64_at(48), f64_at(56), f64_at(64)],
        velocity: [f64_at(72), f64_at(80), f64_at(88)],
        ..VehicleState::default()
    }
}

/// UDP loopback floor of the hop: `samples` round trips after `warmup`. `poll`: both sides
/// busy-poll non-blocking sockets instead of sleeping in `recv`.
pub fn udp_ping_pong(
    work: &Path,
    warmup: usize,
    samples: usize,
    poll: bool,
    stop: &StopFlag,
) -> Result<HopFloor> {
    let role = if poll { "udp-pong-poll" } else { "udp-pong" };
    let mut helper = Helper::spawn(work, role, &["--role".into(), role.into()])?;
    let port: u16 = helper.ready()?.parse().context("the UDP helper's port")?;
    let socket = UdpSocket::bind("127.0.0.1:0").context("binding a UDP socket on 127.0.0.1")?;
    socket
        .connect(("127.0.0.1", port))
        .context("connecting to the UDP helper")?;
    socket.set_read_timeout(Some(PEER_TIMEOUT))?;
    socket.set_nonblocking(poll)?;
    let mut out = Samples::default();
    let mut buf = [0u8; WIRE];
    for i in 0..(warmup + samples) as u64 {
        if i % 1000 == 0 {
            stop.check()?;
        }
        let t0 = Instant::now();
        socket
            .send(&encode(&ping(i, 0)))
            .context("sending a UDP ping")?;
        let (reply, recv_ns) = loop {
            let n = match socket.recv(&mut buf) {
                Ok(n) => n,
                Err(e) if poll && e.kind() == std::io::ErrorKind::WouldBlock => {
                    anyhow::ensure!(
                        t0.elapsed() < PEER_TIMEOUT,
                        "UDP ping-pong (polling): no pong within {PEER_TIMEOUT:?}"
                    );
                    continue;
                }
                Err(e) => {
                    stop.check()?;
                    return Err(anyhow!("UDP ping-pong: no pong: {e}"));
                }
            };
            let recv_ns = wall_ns();
            let reply = decode(&buf);
            if n == WIRE && reply.header.tick == i {
                break (reply, recv_ns);
            }
        };
        let rtt = t0.elapsed();
        if i >= warmup as u64 {
            out.push(&reply, recv_ns, rtt);
        }
    }
    let _ = socket.send(&encode(&ping(u64::MAX, STOP_FLAG)));
    helper.reap(Duration::from_secs(5));
    Ok(out.floor())
}

pub fn udp_pong(poll: bool) -> Result<i32> {
    let socket = UdpSocket::bind("127.0.0.1:0").context("binding a UDP socket on 127.0.0.1")?;
    socket.set_nonblocking(poll)?;
    say_ready(&socket.local_addr()?.port().to_string());
    let mut buf = [0u8; WIRE];
    let mut last = Instant::now();
    loop {
        let (n, from) = match socket.recv_from(&mut buf) {
            Ok(got) => got,
            Err(e) if poll && e.kind() == std::io::ErrorKind::WouldBlock => {
                if last.elapsed() > PEER_TIMEOUT {
                    bail!("UDP pong (polling): no ping within {PEER_TIMEOUT:?}");
                }
                continue;
            }
            Err(e) => return Err(e).context("receiving a UDP ping"),
        };
        last = Instant::now();
        let recv_ns = wall_ns();
        if n != WIRE {
            continue;
        }
        let p = decode(&buf);
        if p.header.flags & STOP_FLAG != 0 {
            return Ok(0);
        }
        socket
            .send_to(&encode(&pong(&p, recv_ns)), from)
            .context("sending a UDP pong")?;
    }
}

/// The coordinator's event service of the wake-up floor (agent `id` notifies with
/// [`Event::Vehicle`]`(id)`, as in a mission).
fn coordinator_wake(
    node: &Node<ipc::Service>,
    domain: &Domain,
    agents: usize,
) -> Result<event::PortFactory<ipc::Service>> {
    event_service(
        node,
        domain,
        "wake/coordinator",
        agents + 2,
        EVENT_VEHICLE_BASE + agents + 2,
    )
}

/// Agent `id`'s event service of the wake-up floor.
fn agent_wake(
    node: &Node<ipc::Service>,
    domain: &Domain,
    id: usize,
) -> Result<event::PortFactory<ipc::Service>> {
    event_service(node, domain, &format!("wake/agent/{id}"), 2, 8)
}

/// The wake-up floor through `agents` + 1 processes: rounds per second over `rounds`
/// rounds (after a fifth as many warm-up rounds).
pub fn wake_floor(work: &Path, agents: usize, rounds: usize, stop: &StopFlag) -> Result<f64> {
    in_private_domain("w", |domain| {
        let node = domain.node("bench_coordinator")?;
        let wake = WakeListener::new(&coordinator_wake(&node, domain, agents)?)?;
        let waiter = wake.attach()?;
        let notifiers = (0..agents)
            .map(|id| Ok(ports::notifier(&agent_wake(&node, domain, id)?, TICK)?))
            .collect::<Result<Vec<_>>>()?;
        let mut helpers = (0..agents)
            .map(|id| {
                Helper::spawn(
                    work,
                    &format!("wake-agent-{id}"),
                    &[
                        "--role".into(),
                        "wake-agent".into(),
                        "--domain".into(),
                        domain.mission.clone(),
                        "--id".into(),
                        id.to_string(),
                        "--agents".into(),
                        agents.to_string(),
                    ],
                )
            })
            .collect::<Result<Vec<_>>>()?;
        for h in helpers.iter_mut() {
            h.ready()?;
            stop.check()?;
        }
        let warmup = (rounds / 5).max(10);
        let mut seen = vec![usize::MAX; agents];
        let mut t0 = Instant::now();
        for round in 0..warmup + rounds {
            if round == warmup {
                t0 = Instant::now();
            }
            for n in &notifiers {
                n.notify().map_err(|e| anyhow!("waking an agent: {e:?}"))?;
            }
            let mut answered = 0;
            while answered < agents {
                let wake_result = wait_events(&waiter, PEER_TIMEOUT, |e| {
                    if let Event::Vehicle(id) = e {
                        let id = id as usize;
                        if id < agents && seen[id] != round {
                            seen[id] = round;
                            answered += 1;
                        }
                    }
                })?;
                match wake_result {
                    Wake::Stop => return Err(Interrupted.into()),
                    Wake::Timeout => bail!(
                        "wake-up floor, N = {agents}: {answered} of {agents} agents answered round {round} within {PEER_TIMEOUT:?}"
                    ),
                    Wake::Events => {}
                }
            }
        }
        let rate = rounds as f64 / t0.elapsed().as_secs_f64();
        for n in &notifiers {
            let _ = n.notify_with_custom_event_id(QUIT.id());
        }
        for h in helpers {
            h.reap(Duration::from_secs(5));
        }
        Ok(rate)
    })
}

pub fn wake_agent(domain: &Domain, id: usize, agents: usize) -> Result<i32> {
    let node = domain.node(&format!("bench_agent_{id}"))?;
    let wake = WakeListener::new(&agent_wake(&node, domain, id)?)?;
    let waiter = wake.attach()?;
    let answer = ports::notifier(
        &coordinator_wake(&node, domain, agents)?,
        Event::Vehicle(id as u32),
    )?;
    say_ready("");
    loop {
        let (mut tick, mut quit) = (false, false);
        let woke = wait_events(&waiter, Duration::from_secs(3600), |e| {
            if e == QUIT {
                quit = true;
            } else {
                tick = true;
            }
        })?;
        if woke == Wake::Stop || quit {
            return Ok(0);
        }
        if tick {
            answer
                .notify()
                .map_err(|e| anyhow!("answering the coordinator: {e:?}"))?;
        }
    }
}

/// Burns CPU until killed (the parent kills it; it dies with the parent).
pub fn spin() -> Result<i32> {
    say_ready("");
    // No `spin_loop` hint: PAUSE in a loop makes a KVM guest's vCPU exit to the host
    // (pause-loop exiting), which is what the spinner must not do.
    let mut x = 0u64;
    loop {
        x = std::hint::black_box(x.wrapping_add(1));
    }
}

/// Keeps every CPU out of idle while alive: one `nice -n 19` spinner per CPU. An idle
/// (halted) vCPU takes ~20 µs longer to wake on a KVM guest; the spinners, at the lowest
/// priority, yield to every real process but keep the CPUs awake, as a loaded `vbap run`
/// does. Dropping it kills and reaps the spinners.
pub struct Warm {
    _spinners: Vec<Helper>,
}

impl Warm {
    /// Starts the spinners; `None` when they cannot be started (no `nice`).
    pub fn start(work: &Path) -> Option<Self> {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let mut spinners = Vec::with_capacity(cpus);
        for i in 0..cpus {
            let mut h = Helper::spawn_with(
                work,
                &format!("spin-{i}"),
                &["--role".into(), "spin".into()],
                true,
            )
            .ok()?;
            h.ready().ok()?;
            spinners.push(h);
        }
        Some(Self {
            _spinners: spinners,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_round_trip() {
        let s = ping(7, 3);
        assert_eq!(decode(&encode(&s)), s);
        let mut odd = s;
        odd.velocity[2] = -0.0;
        odd.position = [f64::MAX, f64::MIN_POSITIVE, 1e-300];
        assert_eq!(encode(&decode(&encode(&odd))), encode(&odd));
    }
}
