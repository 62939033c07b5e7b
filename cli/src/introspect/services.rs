//! `vbap services MISSION`: the mission's nodes and services, with the message rate of every
//! publish-subscribe service over a sampling window.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use iceoryx2::prelude::{ipc, CallbackProgression};
use iceoryx2::service::static_config::messaging_pattern::MessagingPattern;
use iceoryx2::service::Service as _;
use serde::Serialize;
use vbap_mission::config::KeySet;

use super::decode::Kind;
use super::sub::Sub;
use crate::errors::InvalidInput;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct ServicesArgs {
    /// The mission file (its name names the iceoryx2 domain).
    pub mission: PathBuf,
    /// Sampling window for the message rates, s.
    #[arg(long, default_value_t = 1.0)]
    pub sample: f64,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Set a mission key on top of the file (e.g. `--set mission.name=other`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<KeySet>,
}

/// One node of the domain.
#[derive(Debug, Serialize)]
pub struct NodeRow {
    pub name: String,
    pub alive: bool,
}

/// One service of the domain.
#[derive(Debug, Serialize)]
pub struct ServiceRow {
    pub name: String,
    /// "publish_subscribe", "event", "request_response", "blackboard".
    pub pattern: String,
    /// Messages received in the window (publish-subscribe services of vbap only).
    pub messages: Option<usize>,
    /// Messages per second over the window.
    pub rate_hz: Option<f64>,
}

/// What `vbap services --json` prints.
#[derive(Debug, Serialize)]
pub struct Listing {
    pub mission: String,
    pub prefix: String,
    pub sample_s: f64,
    pub nodes: Vec<NodeRow>,
    pub services: Vec<ServiceRow>,
}

/// Runs the command; returns the exit code (1: nothing of the mission is running).
pub fn services(args: &ServicesArgs) -> Result<i32> {
    if !(args.sample.is_finite() && args.sample > 0.0 && args.sample <= 3600.0) {
        return Err(
            InvalidInput(format!("--sample {}: must be in (0, 3600] s", args.sample)).into(),
        );
    }
    let (mission, domain) = super::join::domain_of(&args.mission, &args.sets)?;
    let name = mission.mission.name.clone();
    let mut nodes: Vec<NodeRow> = domain
        .node_states()
        .into_iter()
        .map(|(name, alive)| NodeRow { name, alive })
        .collect();
    let mut found: Vec<(String, String)> = Vec::new();
    ipc::Service::list(domain.config(), |d| {
        let pattern = match d.static_details.messaging_pattern() {
            MessagingPattern::PublishSubscribe(_) => "publish_subscribe",
            MessagingPattern::Event(_) => "event",
            MessagingPattern::RequestResponse(_) => "request_response",
            _ => "blackboard",
        };
        found.push((d.static_details.name().to_string(), pattern.into()));
        CallbackProgression::Continue
    })
    .map_err(|e| anyhow!("listing the services of {name}: {e:?}"))?;
    found.sort();
    if nodes.is_empty() && found.is_empty() {
        eprintln!(
            "vbap: mission {name:?} is not running (no node, no service with prefix {})",
            domain.shm_prefix()
        );
        return Ok(vbap_ipc::process::EXIT_FAILURE);
    }
    let counts = sample_rates(&domain, &name, &found, args.sample)?;
    let services: Vec<ServiceRow> = found
        .into_iter()
        .zip(counts)
        .map(|((name, pattern), n)| ServiceRow {
            name,
            pattern,
            messages: n,
            rate_hz: n.map(|n| n as f64 / args.sample),
        })
        .collect();
    nodes.retain(|n| n.name != super::join::TOOL_NODE);
    let listing = Listing {
        mission: name,
        prefix: domain.shm_prefix(),
        sample_s: args.sample,
        nodes,
        services,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&listing)?);
    } else {
        print!("{}", text(&listing));
    }
    Ok(vbap_ipc::process::EXIT_OK)
}

/// Messages of every publish-subscribe service of vbap in `found` over `window` s (one
/// subscriber each, drained every millisecond; the history sample a new subscriber gets is
/// not counted); `None` for the other services.
fn sample_rates(
    domain: &vbap_ipc::topics::Domain,
    mission: &str,
    found: &[(String, String)],
    window: f64,
) -> Result<Vec<Option<usize>>> {
    let node = domain.node(super::join::TOOL_NODE)?;
    let subs: Vec<Option<Sub>> = found
        .iter()
        .map(|(name, pattern)| {
            let kind = Kind::of(mission, name).filter(|_| pattern == "publish_subscribe")?;
            Sub::open(&node, kind, name).ok()
        })
        .collect();
    let mut ignore = |_| {};
    for s in subs.iter().flatten() {
        s.drain(false, &mut ignore)?;
    }
    let mut counts: Vec<Option<usize>> = subs.iter().map(|s| s.as_ref().map(|_| 0)).collect();
    let end = Instant::now() + Duration::from_secs_f64(window);
    while Instant::now() < end {
        for (s, c) in subs.iter().zip(counts.iter_mut()) {
            if let (Some(s), Some(c)) = (s, c) {
                *c += s.drain(false, &mut ignore)?;
            }
        }
        // Sampling, not synchronisation: the buffers hold far more than a millisecond.
        std::thread::sleep(Duration::from_millis(1));
    }
    Ok(counts)
}

/// The listing for a terminal.
fn text(l: &Listing) -> String {
    let mut out = format!(
        "mission {}: iceoryx2 prefix {} (iox2 ... --config RUN_DIR/iox2.toml)\n\nnodes ({}):\n",
        l.mission,
        l.prefix,
        l.nodes.len()
    );
    for n in &l.nodes {
        out.push_str(&format!(
            "  {:<6} {}\n",
            if n.alive { "alive" } else { "DEAD" },
            n.name
        ));
    }
    out.push_str(&format!(
        "\nservices ({}), rates over {} s:\n  {:<18} {:>10} {:>9}  service\n",
        l.services.len(),
        l.sample_s,
        "pattern",
        "rate/s",
        "messages"
    ));
    for s in &l.services {
        let rate = s.rate_hz.map_or("-".into(), |r| format!("{r:.1}"));
        let n = s.messages.map_or("-".into(), |n| n.to_string());
        out.push_str(&format!(
            "  {:<18} {rate:>10} {n:>9}  {}\n",
            s.pattern, s.name
        ));
    }
    out
}
