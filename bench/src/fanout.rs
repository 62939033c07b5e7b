//! The fan-out of one command to N agents: our zero-copy path against UDP unicast.
//!
//! The command carries the swarm snapshot: a [`BodyCommand`] of N vehicles is written
//! entries-in-use only ([`command_bytes`]: ~40 KB at N = 256). One fan-out sends it to N receiver processes (`vbap bench --role fanout-iox` /
//! `fanout-udp`, one process each) and each receiver reads what an agent needs of it: the
//! header and its own snapshot entry.
//!
//! - *iceoryx2 (our path)*: the coordinator copies the command once into shared memory
//!   (`vbap_ipc::prefix::publish` on the body service, as `coordinator::run` publishes it:
//!   the entries in use only) and notifies each
//!   agent on its own wake service; every agent reads the one copy in place. Ports through
//!   the system's own builders (`Domain::body_service`, `vehicle_wake`, `body_receiver`).
//! - *UDP unicast*: the same number of bytes sent to each receiver's socket on 127.0.0.1
//!   (N `send_to` of the whole command, N kernel copies into the receivers' buffers),
//!   blocking `recv`.
//!
//! Fan-outs are paced (one every `interval`, like ticks at a fixed pace) so that one never
//! overlaps the next; the pace is a rate, not a synchronisation: every receiver reports
//! which rounds it got. CPU per fan-out = the sender's thread CPU time over its sends plus
//! every receiver's process CPU time over the measured rounds (`CLOCK_*_CPUTIME_ID`, user +
//! system), divided by the rounds. Latency to the last agent = per round, the largest
//! (receiver's wall clock once it holds the command − sender's stamp just before sending).

use std::net::UdpSocket;
use std::path::Path;
use std::time::Duration;

use anyhow::{anyhow, Context, Result};
use nix::time::{clock_gettime, ClockId};
use serde::Serialize;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::{wall_ns, Header, MAX_NEAR_ENTRIES, MAX_VEHICLES};
use vbap_ipc::ports;
use vbap_ipc::topics::{Domain, Limits};
use vbap_ipc::wait::{Event, Wake};
use vbap_mission::rundir::Percentiles;

use super::peer::{in_private_domain, say_ready, wait_events, Helper};
use super::stop::StopFlag;

/// Bytes of a command of `n` vehicles as the coordinator writes it (the snapshot's entries
/// and the list starts in use, no neighbour list entries: the fan-out's command has empty
/// lists; the leaders and the path whole), and as UDP sends it.
pub fn command_bytes(n: usize) -> usize {
    let unused = MAX_VEHICLES - n.min(MAX_VEHICLES);
    std::mem::size_of::<BodyCommand>()
        - unused * std::mem::size_of::<vbap_ipc::msg::coordinator_to_agent::SnapshotEntry>()
        - unused * std::mem::size_of::<u32>()
        - MAX_NEAR_ENTRIES * std::mem::size_of::<u16>()
}
/// Flag of the last message: the receiver reports and exits.
const STOP: u32 = 1 << 31;

/// One transport's fan-out figures.
#[derive(Clone, Debug, Serialize)]
pub struct FanoutSide {
    /// CPU time per fan-out, µs: sender + every receiver.
    pub cpu_us: f64,
    /// Of which the sender's, µs.
    pub sender_cpu_us: f64,
    /// Of the sender's, the write of the command (iceoryx2: the copy into shared memory;
    /// UDP: all N sends), µs; the rest wakes the receivers.
    pub write_cpu_us: f64,
    /// One receiver's CPU time per fan-out, µs (mean over receivers).
    pub receiver_cpu_us: f64,
    /// Latency to the last receiver of a fan-out, µs (one sample per fan-out).
    pub last_us: Percentiles,
    /// Fan-outs measured.
    pub rounds: usize,
    /// Deliveries that never arrived (receiver × round).
    pub missed: usize,
}

/// The fan-out comparison.
#[derive(Clone, Debug, Serialize)]
pub struct Fanout {
    pub receivers: usize,
    pub bytes: usize,
    /// Time between two fan-outs, ms.
    pub interval_ms: f64,
    pub iceoryx2: FanoutSide,
    pub udp: FanoutSide,
    /// Why loopback multicast is not measured.
    pub multicast: String,
}

fn cpu_ns(clock: ClockId) -> u64 {
    clock_gettime(clock).map_or(0, |t| {
        t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64
    })
}

/// What a receiver measured: its CPU time over the measured rounds and each round's
/// latency (ns; `None`: never arrived).
struct Tally {
    warmup: u64,
    cpu0: u64,
    cpu1: u64,
    latency_ns: Vec<Option<u64>>,
}

impl Tally {
    fn new(warmup: u64, rounds: usize) -> Self {
        Self {
            warmup,
            cpu0: cpu_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID),
            cpu1: 0,
            latency_ns: vec![None; rounds],
        }
    }

    /// Round `round` (sent at `sent_ns`) handled now.
    fn handled(&mut self, round: u64, sent_ns: u64, recv_ns: u64) {
        let now = cpu_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID);
        if round < self.warmup {
            self.cpu0 = now;
        } else if let Some(slot) = self.latency_ns.get_mut((round - self.warmup) as usize) {
            *slot = Some(recv_ns.saturating_sub(sent_ns));
            self.cpu1 = now;
        }
    }

    /// `done <cpu ns> <latency ns or -> ...` on stdout.
    fn report(&self) {
        let mut line = format!("done {}", self.cpu1.saturating_sub(self.cpu0));
        for l in &self.latency_ns {
            match l {
                Some(ns) => line += &format!(" {ns}"),
                None => line += " -",
            }
        }
        println!("{line}");
    }
}

/// Runs both fan-outs to `n` receivers.
pub fn fanout(
    work: &Path,
    n: usize,
    warmup: usize,
    rounds: usize,
    interval: Duration,
    stop: &StopFlag,
) -> Result<Fanout> {
    let iceoryx2 = iox_fanout(work, n, warmup, rounds, interval, stop)?;
    stop.check()?;
    let udp = udp_fanout(work, n, warmup, rounds, interval, stop)?;
    Ok(Fanout {
        receivers: n,
        bytes: command_bytes(n),
        interval_ms: interval.as_secs_f64() * 1e3,
        iceoryx2,
        udp,
        multicast: "not measured: lo has no MULTICAST flag on this machine, and N receivers \
                    sharing a port need SO_REUSEADDR, which std's sockets do not set"
            .into(),
    })
}

/// Reads every receiver's report and sums up one side.
fn collect(
    helpers: Vec<Helper>,
    (sender_cpu_ns, write_ns): (u64, u64),
    rounds: usize,
) -> Result<FanoutSide> {
    let receivers = helpers.len().max(1);
    let mut last = vec![0u64; rounds];
    let mut missed = 0;
    let mut cpu = sender_cpu_ns;
    for mut h in helpers {
        let line = h.line()?;
        let mut words = line.split_whitespace();
        anyhow::ensure!(
            words.next() == Some("done"),
            "a fan-out receiver did not report (see helpers.stderr.log)"
        );
        cpu += words
            .next()
            .and_then(|w| w.parse::<u64>().ok())
            .context("a receiver's CPU time")?;
        for (r, w) in words.enumerate().take(rounds) {
            match w.parse::<u64>() {
                Ok(ns) => last[r] = last[r].max(ns),
                Err(_) => missed += 1,
            }
        }
        h.reap(Duration::from_secs(5));
    }
    let mut last_us: Vec<f64> = last.iter().map(|&ns| ns as f64 / 1e3).collect();
    Ok(FanoutSide {
        cpu_us: cpu as f64 / 1e3 / rounds as f64,
        sender_cpu_us: sender_cpu_ns as f64 / 1e3 / rounds as f64,
        write_cpu_us: write_ns as f64 / 1e3 / rounds as f64,
        receiver_cpu_us: (cpu - sender_cpu_ns) as f64 / 1e3 / rounds as f64 / receivers as f64,
        last_us: Percentiles::of(&mut last_us),
        rounds,
        missed,
    })
}

fn receiver_args(
    role: &str,
    domain: &str,
    id: usize,
    n: usize,
    warmup: usize,
    rounds: usize,
) -> Vec<String> {
    [
        "--role",
        role,
        "--domain",
        domain,
        "--id",
        &id.to_string(),
        "--agents",
        &n.to_string(),
        "--warmup",
        &warmup.to_string(),
        "--rounds",
        &rounds.to_string(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

fn iox_fanout(
    work: &Path,
    n: usize,
    warmup: usize,
    rounds: usize,
    interval: Duration,
    stop: &StopFlag,
) -> Result<FanoutSide> {
    in_private_domain("f", |domain| {
        let limits = Limits::for_fleet(n);
        let node = domain.node("bench_fanout")?;
        let body = ports::publisher(&domain.body_service(&node, &limits)?)?;
        let agents = (0..n as u32)
            .map(|id| {
                Ok(ports::notifier(
                    &domain.vehicle_wake(&node, id, &limits)?,
                    Event::Body,
                )?)
            })
            .collect::<Result<Vec<_>>>()?;
        let mut helpers = Vec::with_capacity(n);
        for id in 0..n {
            let args = receiver_args("fanout-iox", &domain.mission, id, n, warmup, rounds);
            helpers.push(Helper::spawn(work, &format!("fanout-iox-{id}"), &args)?);
        }
        for h in helpers.iter_mut() {
            h.ready()?;
            stop.check()?;
        }
        let mut command = Box::new(BodyCommand::empty());
        command.n_vehicles = n as u32;
        let (mut sender_ns, mut write_ns) = (0, 0);
        for r in 0..(warmup + rounds) as u64 {
            stop.check()?;
            let c0 = cpu_ns(ClockId::CLOCK_THREAD_CPUTIME_ID);
            command.header = Header::new(Header::COORDINATOR, r, 0.0, r + 1);
            command.header.sent_ns = wall_ns();
            vbap_ipc::prefix::publish(&body, &*command)
                .map_err(|e| anyhow!("publishing the command: {e:?}"))?;
            let c1 = cpu_ns(ClockId::CLOCK_THREAD_CPUTIME_ID);
            for a in &agents {
                a.notify().map_err(|e| anyhow!("waking an agent: {e:?}"))?;
            }
            if r >= warmup as u64 {
                sender_ns += cpu_ns(ClockId::CLOCK_THREAD_CPUTIME_ID).saturating_sub(c0);
                write_ns += c1.saturating_sub(c0);
            }
            std::thread::sleep(interval); // the pace of the fan-outs (see the module doc)
        }
        command.header = Header::new(Header::COORDINATOR, u64::MAX, 0.0, u64::MAX).with_flags(STOP);
        vbap_ipc::prefix::publish(&body, &*command)
            .map_err(|e| anyhow!("publishing the last command: {e:?}"))?;
        for a in &agents {
            let _ = a.notify();
        }
        collect(helpers, (sender_ns, write_ns), rounds)
    })
}

/// Helper role: one receiver of the iceoryx2 fan-out (agent `id` of `n`).
pub fn iox_receiver(
    domain: &Domain,
    id: usize,
    n: usize,
    warmup: u64,
    rounds: usize,
) -> Result<i32> {
    let limits = Limits::for_fleet(n);
    let node = domain.agent_node(&format!("bench_fanout_{id}"))?;
    let body = domain.body_receiver(&node, id as u32, &limits)?;
    let waiter = body.wake().attach()?;
    let mut tally = Tally::new(warmup, rounds);
    say_ready("");
    loop {
        if wait_events(&waiter, Duration::from_secs(3600), |_| {})? == Wake::Stop {
            return Ok(0);
        }
        while let Some(command) = body.receive()? {
            let recv_ns = wall_ns();
            let h = command.header;
            if h.flags & STOP != 0 {
                tally.report();
                return Ok(0);
            }
            // What an agent reads of it, in place: the header and its own entry.
            std::hint::black_box(command.snapshot[id.min(command.snapshot.len() - 1)]);
            tally.handled(h.tick, h.sent_ns, recv_ns);
        }
    }
}

/// The UDP payload: the command's size, the round, the send stamp and the flags first.
fn datagram(buf: &mut [u8], round: u64, flags: u32) {
    buf[0..8].copy_from_slice(&round.to_le_bytes());
    buf[16..20].copy_from_slice(&flags.to_le_bytes());
    buf[8..16].copy_from_slice(&wall_ns().to_le_bytes());
}

fn udp_fanout(
    work: &Path,
    n: usize,
    warmup: usize,
    rounds: usize,
    interval: Duration,
    stop: &StopFlag,
) -> Result<FanoutSide> {
    let mut helpers = Vec::with_capacity(n);
    for id in 0..n {
        let args = receiver_args("fanout-udp", "-", id, n, warmup, rounds);
        helpers.push(Helper::spawn(work, &format!("fanout-udp-{id}"), &args)?);
    }
    let mut to = Vec::with_capacity(n);
    for h in helpers.iter_mut() {
        let port: u16 = h.ready()?.parse().context("a UDP receiver's port")?;
        to.push(std::net::SocketAddr::from(([127, 0, 0, 1], port)));
        stop.check()?;
    }
    let socket = UdpSocket::bind("127.0.0.1:0").context("binding a UDP socket on 127.0.0.1")?;
    let mut buf = vec![0u8; command_bytes(n)];
    let mut sender_ns = 0;
    for r in 0..(warmup + rounds) as u64 {
        stop.check()?;
        let c0 = cpu_ns(ClockId::CLOCK_THREAD_CPUTIME_ID);
        datagram(&mut buf, r, 0);
        for addr in &to {
            socket
                .send_to(&buf, addr)
                .context("sending a UDP command")?;
        }
        if r >= warmup as u64 {
            sender_ns += cpu_ns(ClockId::CLOCK_THREAD_CPUTIME_ID).saturating_sub(c0);
        }
        std::thread::sleep(interval); // the pace of the fan-outs (see the module doc)
    }
    datagram(&mut buf, u64::MAX, STOP);
    for addr in &to {
        let _ = socket.send_to(&buf, addr);
    }
    collect(helpers, (sender_ns, sender_ns), rounds)
}

/// Helper role: one receiver of the UDP fan-out (of `n` receivers).
pub fn udp_receiver(id: usize, n: usize, warmup: u64, rounds: usize) -> Result<i32> {
    let bytes = command_bytes(n);
    let socket = UdpSocket::bind("127.0.0.1:0").context("binding a UDP socket on 127.0.0.1")?;
    let mut tally = Tally::new(warmup, rounds);
    say_ready(&socket.local_addr()?.port().to_string());
    let mut buf = vec![0u8; bytes];
    // Where this receiver's own snapshot entry would be: read it, as the agent does.
    let entry = (std::mem::offset_of!(BodyCommand, snapshot)
        + id * std::mem::size_of::<vbap_ipc::msg::coordinator_to_agent::SnapshotEntry>())
    .min(bytes - 8);
    loop {
        let got = socket.recv(&mut buf).context("receiving a UDP command")?;
        let recv_ns = wall_ns();
        if got != bytes {
            continue;
        }
        let u64_at = |at: usize| u64::from_le_bytes(buf[at..at + 8].try_into().expect("8 bytes"));
        let flags = u32::from_le_bytes(buf[16..20].try_into().expect("4 bytes"));
        if flags & STOP != 0 {
            tally.report();
            return Ok(0);
        }
        std::hint::black_box(u64_at(entry));
        tally.handled(u64_at(0), u64_at(8), recv_ns);
    }
}
