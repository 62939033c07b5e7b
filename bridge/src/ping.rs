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

/// A host that holds a certificate of the mission but breaks its rules (the access
/// control's test): on host `host`'s session (its certificate), `count` times every 20 ms,
/// puts a state of vehicle `vehicle` on host `victim`'s states key and a body command on
/// the body key of mission `mission`, while subscribed to every host's states. Returns how
/// many states it read (a host may read none but its own).
pub fn forge(
    hosts: &Hosts,
    host: &str,
    mission: &str,
    victim: &str,
    vehicle: u32,
    count: usize,
) -> Result<usize> {
    use vbap_wire::msg::coordinator_to_agent::BodyCommand;
    use vbap_wire::msg::Header;
    // It connects to the shore as `host` does, listening on nothing (the real host's
    // bridge holds its endpoint).
    let mut config = keys::config(hosts, host)?;
    config
        .insert_json5("listen/endpoints", "[]")
        .map_err(|e| anyhow!("zenoh config listen/endpoints: {e}"))?;
    let session = zenoh::open(config)
        .wait()
        .map_err(|e| anyhow!("opening the Zenoh session of host {host}: {e}"))?;
    let k = keys::Keys::new(mission);
    let seen = session
        .declare_subscriber(k.all_states())
        .wait()
        .map_err(|e| anyhow!("subscribing to the states: {e}"))?;
    let states = publisher(&session, k.states(victim), Priority::RealTime)?;
    let body = publisher(&session, k.body(), Priority::RealTime)?;
    let h = std::mem::offset_of!(VehicleState, header);
    for i in 0..count {
        let mut state = vec![0u8; std::mem::size_of::<VehicleState>()];
        let put_at = |b: &mut [u8], at: usize, v: &[u8]| b[at..at + v.len()].copy_from_slice(v);
        put_at(
            &mut state,
            h + std::mem::offset_of!(Header, sender),
            &vehicle.to_ne_bytes(),
        );
        let seq = 1_000_000 + i as u64;
        put_at(
            &mut state,
            h + std::mem::offset_of!(Header, seq),
            &seq.to_ne_bytes(),
        );
        states
            .put(wire::encode(&RawState::from_bytes(&state)))
            .wait()
            .map_err(|e| anyhow!("putting a forged state: {e}"))?;
        let mut command = vec![0u8; std::mem::size_of::<BodyCommand>()];
        let hb = std::mem::offset_of!(BodyCommand, header);
        put_at(
            &mut command,
            hb + std::mem::offset_of!(Header, sender),
            &Header::COORDINATOR.to_ne_bytes(),
        );
        put_at(
            &mut command,
            hb + std::mem::offset_of!(Header, seq),
            &seq.to_ne_bytes(),
        );
        body.put(wire::encode(&crate::wire::RawBody::from_bytes(&command)))
            .wait()
            .map_err(|e| anyhow!("putting a forged command: {e}"))?;
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut read = 0;
    while let Ok(Some(_)) = seen.try_recv() {
        read += 1;
    }
    Ok(read)
}
