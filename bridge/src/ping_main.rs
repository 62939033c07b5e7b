//! `vbap_zenoh_ping --hosts FILE --host NAME --vehicles N (--pong | --samples K)`: the raw Zenoh
//! ping-pong of `vbap bench --hosts` (the floor of a cross-host hop, `vbap_bridge::ping`).
//! The pinging side prints its round-trip times, µs, one a line. With `--forge MISSION`
//! it is instead a host that breaks the mission's rules (the access control's test); with
//! `--relay MISSION` this host's bare relay of the bench's skeleton over hosts
//! (`vbap_bridge::relay`).

use std::path::PathBuf;

use clap::Parser;

/// A raw Zenoh ping-pong between two hosts of a hosts file, with the bridge's settings.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The hosts file.
    #[arg(long)]
    hosts: PathBuf,
    /// This host's name in the hosts file.
    #[arg(long)]
    host: String,
    /// The fleet size the hosts file places.
    #[arg(long)]
    vehicles: usize,
    /// Answer pings (else: send them).
    #[arg(long)]
    pong: bool,
    /// Measured round trips.
    #[arg(long, default_value_t = 1000)]
    samples: usize,
    /// Unmeasured round trips first.
    #[arg(long, default_value_t = 100)]
    warm: usize,
    /// Instead: break the rules of mission MISSION with this host's certificate (the
    /// access control's test, `vbap_bridge::ping::forge`): `--samples` times, a state of
    /// vehicle `--vehicle` on host `--victim`'s key and a body command; prints how many
    /// states it read.
    #[arg(long, requires_all = ["victim", "vehicle"])]
    forge: Option<String>,
    /// The host whose states `--forge` forges.
    #[arg(long)]
    victim: Option<String>,
    /// The vehicle whose state `--forge` forges.
    #[arg(long)]
    vehicle: Option<u32>,
    /// Instead: this host's bare relay for the skeleton of mission (iceoryx2 domain)
    /// MISSION over hosts (`vbap bench --hosts`, `vbap_bridge::relay`); says `ready`, ends
    /// after the mission's final command or with its parent.
    #[arg(long, conflicts_with = "forge")]
    relay: Option<String>,
}

fn main() {
    let args = Args::parse();
    let hosts = vbap_ipc::process::valid_or_exit(
        "vbap_zenoh_ping",
        vbap_mission::hosts::Hosts::load(&args.hosts, args.vehicles)
            .and_then(|h| h.host(&args.host).map(|_| ()).map(|()| h)),
    );
    let result = if let Some(mission) = &args.relay {
        vbap_ipc::process::die_with_parent(None);
        vbap_bridge::relay::relay(&hosts, &args.host, mission, args.vehicles)
    } else if let Some(mission) = &args.forge {
        vbap_bridge::ping::forge(
            &hosts,
            &args.host,
            mission,
            args.victim.as_deref().unwrap_or_default(),
            args.vehicle.unwrap_or_default(),
            args.samples,
        )
        .map(|read| println!("read {read}"))
    } else if args.pong {
        vbap_bridge::ping::pong(&hosts, &args.host)
    } else {
        vbap_bridge::ping::ping(&hosts, &args.host, args.warm, args.samples).map(|rtt| {
            let lines: Vec<String> = rtt.iter().map(|v| format!("{v:.1}")).collect();
            println!("{}", lines.join("\n"));
        })
    };
    if let Err(e) = result {
        eprintln!("vbap_zenoh_ping: {e:#}");
        std::process::exit(1);
    }
}
