//! The floor of the cross-host bench (`vbap bench --hosts`): a raw two-process Zenoh
//! ping-pong between two hosts of a hosts file, with the bridge's own session
//! configuration ([`keys::config`]) and publisher quality of service (reliable, blocking,
//! express, `Priority::RealTime`), a payload of a state frame's size, and Zenoh's own
//! subscriber queue (no iceoryx2, no bridge): what one hop over the link costs at least.

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Result};
use vbap_mission::hosts::Hosts;
use vbap_wire::msg::agent_to_coordinator::VehicleState;
use zenoh::qos::Priority;
use zenoh::Wait;

use crate::keys;
use crate::run::publisher;
use crate::wire::{self, RawBytes, RawState};

/// The pinging side publishes here.
const PING: &str = "vbap_bench/ping";
/// The answering side publishes here.
const PONG: &str = "vbap_bench/pong";
/// The sequence number that ends the answering side.
const BYE: u64 = u64::MAX;
/// How long the pinging side waits for the first answer before sending again (the peer
/// may not have connected yet), and for the whole warm-up.
const RETRY: Duration = Duration::from_millis(200);
const WARM_UP_FOR: Duration = Duration::from_secs(60);

/// A ping: the size of a state frame, the sequence number in its first 8 bytes.
fn message(seq: u64) -> Vec<u8> {
    let zero = RawState::from_bytes(&[0u8; std::mem::size_of::<VehicleState>()]);
    let mut m = wire::encode(&zero);
    m[..8].copy_from_slice(&seq.to_ne_bytes());
    m
}

fn seq_of(bytes: &[u8]) -> u64 {
    bytes.get(..8).map_or(0, |b| wire::u64_at(b, 0))
}

fn open(hosts: &Hosts, host: &str) -> Result<zenoh::Session> {
    zenoh::open(keys::config(hosts, host)?)
        .wait()
        .map_err(|e| anyhow!("opening the Zenoh session of host {host}: {e}"))
}

/// The answering side on host `host`: sends every ping back until the last.
pub fn pong(hosts: &Hosts, host: &str) -> Result<()> {
    let session = open(hosts, host)?;
    let sub = session
        .declare_subscriber(PING)
        .wait()
        .map_err(|e| anyhow!("subscribing to {PING}: {e}"))?;
    let back = publisher(&session, PONG.to_string(), Priority::RealTime)?;
    loop {
        let sample = sub.recv().map_err(|e| anyhow!("receiving a ping: {e}"))?;
        let bytes = sample.payload().to_bytes();
        back.put(bytes.as_ref())
            .wait()
            .map_err(|e| anyhow!("answering: {e}"))?;
        if seq_of(&bytes) == BYE {
            break;
        }
    }
    drop((sub, back));
    session.close().wait().map_err(|e| anyhow!("closing: {e}"))
}

/// The pinging side on host `host`: `samples` round trips after `warm` unmeasured ones;
/// returns the round-trip times, µs.
pub fn ping(hosts: &Hosts, host: &str, warm: usize, samples: usize) -> Result<Vec<f64>> {
    let session = open(hosts, host)?;
    let sub = session
        .declare_subscriber(PONG)
        .wait()
        .map_err(|e| anyhow!("subscribing to {PONG}: {e}"))?;
    let out = publisher(&session, PING.to_string(), Priority::RealTime)?;
    let put = |seq: u64| {
        out.put(message(seq))
            .wait()
            .map_err(|e| anyhow!("pinging: {e}"))
    };
    // Until the peer answers (it may connect later): ping 0 again and again.
    let started = Instant::now();
    loop {
        put(0)?;
        match sub.recv_timeout(RETRY) {
            Ok(Some(_)) => break,
            Ok(None) if started.elapsed() < WARM_UP_FOR => {}
            Ok(None) => bail!("no answer from the peer in {WARM_UP_FOR:?}"),
            Err(e) => bail!("receiving an answer: {e}"),
        }
    }
    let mut rtt = Vec::with_capacity(samples);
    for seq in 1..=(warm + samples) as u64 {
        let t = Instant::now();
        put(seq)?;
        loop {
            let s = sub
                .recv()
                .map_err(|e| anyhow!("receiving an answer: {e}"))?;
            if seq_of(&s.payload().to_bytes()) == seq {
                break;
            }
        }
        if seq as usize > warm {
            rtt.push(t.elapsed().as_secs_f64() * 1e6);
        }
    }
    put(BYE)?;
    // The answer to BYE: the peer got it (else closing at once could drop it).
    let _ = sub.recv_timeout(Duration::from_secs(5));
    drop((sub, out));
    session
        .close()
        .wait()
        .map_err(|e| anyhow!("closing: {e}"))?;
    Ok(rtt)
}
