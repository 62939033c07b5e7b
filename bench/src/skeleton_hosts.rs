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
//! A relay (`vbap_zenoh_ping --relay`, `vbap_bridge::relay`: Zenoh stays out of `vbap`)
//! does what the bridge must and nothing else: the same Zenoh session, keys, QoS, frames,
//! iceoryx2 services and wake-ups, no checks, counts, repeats or records.
//!
//! The shore's coordinator measures the state hop as the mission's records do (the agent's
//! stamp to the coordinator's clock once it holds the state: hosts share one clock here)
//! and prints one line: ticks per second, the tick's p50 and the hop's p50 and p90.

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::Header;
use vbap_ipc::process::bin_dir;
use vbap_ipc::topics::Domain;
use vbap_mission::hosts::Hosts;
use vbap_mission::rundir::Percentiles;

use super::peer::{say_ready, Helper};
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
    /// This host's relay (`vbap_zenoh_ping --relay`), ready.
    fn relay(&self, work: &Path) -> Result<Helper> {
        let args = vec![
            "--relay".into(),
            self.domain.into(),
            "--hosts".into(),
            self.hosts.display().to_string(),
            "--host".into(),
            self.host.into(),
            "--vehicles".into(),
            self.n.to_string(),
        ];
        let ping = bin_dir()?.join("vbap_zenoh_ping");
        let mut relay = Helper::spawn_program(work, "relay", &ping, &args)?;
        relay.ready()?;
        Ok(relay)
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
        let mut field = skeleton::spawn_role(work, share.domain, "skeleton-field", 0, share.n)?;
        field.ready()?;
        let relay = share.relay(work)?;
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
        let mut agent =
            skeleton::spawn_role(work, share.domain, "skeleton-agent", id as usize, share.n)?;
        agent.ready()?;
        helpers.push(agent);
    }
    let relay = share.relay(work)?;
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
    let mut body = skeleton::fleet_body(n);
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
    c.finish(&mut body);
    let mut hops: Vec<f64> = hops.into_iter().map(|(_, h)| h).collect();
    Ok(HostsSkeleton {
        ticks_per_s: rate,
        tick_ms: Percentiles::of(&mut ticks).p50,
        hop_us: Percentiles::of(&mut hops),
    })
}

/// How long the shore says tick 0 before saying it again while the glider hosts join.
const HELLO: Duration = Duration::from_millis(200);
