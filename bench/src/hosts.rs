//! `vbap bench --hosts` (root: network namespaces): the cost of spreading a mission over
//! hosts against the same topology's skeleton and against raw Zenoh over the same links,
//! measured in one run, printed as ratios.
//!
//! Three hosts (shore, glider_a, glider_b: [`netns`]) on one machine, so one clock:
//! 1. **Floor**: a raw two-process Zenoh ping-pong (`vbap_zenoh_ping`, glider_a → shore →
//!    glider_a) with the bridge's session configuration and QoS and a state frame's size;
//!    round trip p50, one way = half of it.
//! 2. **Hop**: the `state@hosts` hop of a lockstep N = 16 mission over the three hosts (the
//!    vehicles half on each glider host), transport p50 from the shore's message records
//!    merged with the glider hosts' (`vbap analyze`).
//! 3. **Tick**: the coordinator's loop period p50 of that run.
//! 4. **Skeleton over hosts** ([`super::skeleton_hosts`]): the lockstep skeleton (no math, no
//!    files) on the same hosts, with a bare relay in place of each bridge (same session,
//!    keys, QoS, frames and services): its state hop and tick p50. Goals: hop ≤ 1.5 × the
//!    skeleton's, tick ≤ 1.5 × the skeleton's. The first goals (hop against the raw one
//!    way, tick against one host plus a raw round trip) are printed beside them, retired.
//!
//! Both over plain TCP (`insecure = true`) and over mutual TLS (certificates made by
//! `vbap certs`, as a user makes them), side by side: the cost of TLS is printed as the
//! ratios TLS / TCP of the round trip, the hop, the tick and the skeleton's.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};

use anyhow::{anyhow, bail, Context, Result};
use vbap_mission::rundir::{Percentiles, RunDir};
use vbap_report::analyze::analyze;

use super::args::BenchArgs;
use super::netns::{Net, HOSTS};
use super::peer::unique_name;
use super::skeleton_hosts::HostsSkeleton;
use vbap_ipc::process::bin_dir;

const N: usize = 16;

/// Kills and reaps a child left running (an error part-way).
struct Reaped(Child);
impl Drop for Reaped {
    fn drop(&mut self) {
        if self.0.try_wait().ok().flatten().is_none() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

fn mission(name: &str, duration: f64) -> String {
    format!(
        "[mission]\nname = \"{name}\"\nseed = 7\nduration = {duration}\ndt = 0.05\n\
         goal = \"max\"\ndim = 2\ntolerance = 1.0\n\n[field]\nkind = \"gaussian\"\n\
         center = [6.0, 3.0]\namplitude = 10.0\nwidth = 6.0\nnoise_std = 0.1\n\n\
         [vehicles]\ncount = {N}\nstart = [0.0, 0.0]\nstart_spread = 0.6\n"
    )
}

/// What one transport (plain TCP or mutual TLS) costs: the raw round trip, the
/// `state@hosts` hop and the 3-host tick.
struct Leg {
    rtt: Percentiles,
    hop: Percentiles,
    tick3: f64,
    skeleton: HostsSkeleton,
}

/// Measures one transport with the hosts file `hosts_text`, in folder `work`.
fn leg(net: &Net, work: &Path, hosts_text: &str, samples: usize, duration: f64) -> Result<Leg> {
    std::fs::create_dir_all(work)?;
    let hosts = work.join("hosts.toml");
    std::fs::write(&hosts, hosts_text)?;
    let rtt = floor(net, work, &hosts, samples)?;
    let (hop, tick3) = three_hosts(net, work, &hosts, duration)?;
    let skeleton = skeleton_over_hosts(net, work, &hosts, samples)?;
    Ok(Leg {
        rtt,
        hop,
        tick3,
        skeleton,
    })
}

/// The skeleton over the same three hosts ([`super::skeleton_hosts`]) with hosts file `hosts`,
/// `rounds` measured ticks.
fn skeleton_over_hosts(
    net: &Net,
    work: &Path,
    hosts: &Path,
    rounds: usize,
) -> Result<HostsSkeleton> {
    let vbap = bin_dir()?.join("vbap");
    let domain = unique_name("hk");
    let (n, r) = (N.to_string(), rounds.to_string());
    let mut children = Vec::new();
    let mut shore_out = None;
    for h in HOSTS {
        let dir = work.join(format!("skeleton-{h}"));
        std::fs::create_dir_all(&dir)?;
        let args: Vec<&OsStr> = vec![
            "bench".as_ref(),
            "--role".as_ref(),
            "skeleton-host".as_ref(),
            "--domain".as_ref(),
            domain.as_ref(),
            "--hosts-file".as_ref(),
            hosts.as_os_str(),
            "--host".as_ref(),
            h.as_ref(),
            "--agents".as_ref(),
            n.as_ref(),
            "--rounds".as_ref(),
            r.as_ref(),
            "--work-dir".as_ref(),
            dir.as_os_str(),
        ];
        let locks = work.join(format!("skeleton-{h}.locks"));
        let err = work.join(format!("skeleton-{h}.stderr.log"));
        let mut child = Reaped(net.spawn(h, &locks, &vbap, &args, Stdio::piped(), &err)?);
        if h == HOSTS[0] {
            shore_out = child.0.stdout.take();
        }
        children.push((h, child));
    }
    let out = shore_out.ok_or_else(|| anyhow!("no stdout of the shore's skeleton"))?;
    let line = std::io::BufRead::lines(std::io::BufReader::new(out))
        .map_while(Result::ok)
        .find(|l| l.starts_with("skeleton "))
        .ok_or_else(|| {
            anyhow!(
                "the skeleton over hosts ended without its figures: see {}",
                work.display()
            )
        })?;
    // The figures are in. Each glider host ends when its relay hands on the final
    // command; one that has not within 10 s (that command lost with its link: the bare
    // relay puts nothing again) is stopped here, its figures unaffected.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    for (h, child) in &mut children {
        let status = loop {
            if let Some(status) = child.0.try_wait()? {
                break Some(status);
            }
            if std::time::Instant::now() > deadline {
                break None;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        match status {
            Some(status) if !status.success() => bail!(
                "the skeleton's host {h} failed ({status}): see {}",
                work.join(format!("skeleton-{h}.stderr.log")).display()
            ),
            Some(_) => {}
            None => eprintln!("vbap bench: the skeleton's host {h} did not end by itself: stopped"),
        }
    }
    HostsSkeleton::parse(&line)
}

/// The mission's certificates for the TLS leg (`vbap certs`, as a user makes them) and
/// its hosts file.
fn tls_hosts(net: &Net, work: &Path) -> Result<String> {
    let certs = work.join("certs");
    let text = net.hosts_file_tls(N, &certs);
    let file = work.join("hosts_for_certs.toml");
    std::fs::create_dir_all(work)?;
    std::fs::write(&file, &text)?;
    let out = std::process::Command::new(bin_dir()?.join("vbap"))
        .arg("certs")
        .arg(&file)
        .arg("--out")
        .arg(&certs)
        .output()?;
    if !out.status.success() {
        bail!(
            "vbap certs failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(text)
}

/// Runs the bench; prints the table; returns the exit code.
pub fn bench(args: &BenchArgs, work: &Path) -> Result<i32> {
    let net = Net::new()?;
    let samples = if args.quick { 300 } else { 2000 };
    let duration = if args.quick { 10.0 } else { 30.0 };
    let one = one_host(work, duration)?;
    let tcp = leg(
        &net,
        &work.join("tcp"),
        &net.hosts_file(N),
        samples,
        duration,
    )?;
    let tls_text = tls_hosts(&net, &work.join("tls"))?;
    let tls = leg(&net, &work.join("tls"), &tls_text, samples, duration)?;
    drop(net);
    let goal = |r: f64, g: f64| if r <= g { "met" } else { "MISSED" };
    println!("vbap bench --hosts: 3 hosts in network namespaces (veth), N = {N}, lockstep");
    println!("tick, one host        p50 {one:.3} ms");
    for (name, l) in [("plain TCP", &tcp), ("mutual TLS", &tls)] {
        let one_way = l.rtt.p50 / 2.0;
        let hop_ratio = l.hop.p50 / one_way;
        let tick_ratio = l.tick3 * 1e3 / (one * 1e3 + l.rtt.p50);
        let strict = (l.tick3 * 1e3 - l.rtt.p50) / (one * 1e3);
        println!("-- {name}");
        println!(
            "raw Zenoh ping-pong   round trip p50 {:.1} µs (p90 {:.1}), one way {one_way:.1} µs, {samples} samples",
            l.rtt.p50, l.rtt.p90
        );
        println!(
            "state@hosts hop       p50 {:.1} µs (p90 {:.1})",
            l.hop.p50, l.hop.p90
        );
        println!("tick, 3 hosts         p50 {:.3} ms", l.tick3);
        println!(
            "skeleton over hosts   state hop p50 {:.1} µs (p90 {:.1}), tick p50 {:.3} ms, {:.0} ticks/s",
            l.skeleton.hop_us.p50, l.skeleton.hop_us.p90, l.skeleton.tick_ms, l.skeleton.ticks_per_s
        );
        let hop_skeleton = l.hop.p50 / l.skeleton.hop_us.p50;
        let tick_skeleton = l.tick3 / l.skeleton.tick_ms;
        println!(
            "hop / skeleton's hop            = {hop_skeleton:.2}  (goal ≤ 1.5: {})",
            goal(hop_skeleton, 1.5)
        );
        println!(
            "3-host tick / skeleton's tick   = {tick_skeleton:.2}  (goal ≤ 1.5: {})",
            goal(tick_skeleton, 1.5)
        );
        println!(
            "hop / raw one way               = {hop_ratio:.2}  (the first goal, retired: ≤ 1.5: {})",
            goal(hop_ratio, 1.5)
        );
        println!(
            "3-host tick / (1-host tick + raw round trip) = {tick_ratio:.2}  (the first goal, retired: ≤ 2: {})",
            goal(tick_ratio, 2.0)
        );
        println!("(3-host tick − raw round trip) / 1-host tick = {strict:.2}");
    }
    println!(
        "-- the cost of TLS (TLS / TCP, same run): raw round trip {:.2}, state@hosts hop {:.2}, 3-host tick {:.2}; skeleton's hop {:.2}, skeleton's tick {:.2}",
        tls.rtt.p50 / tcp.rtt.p50,
        tls.hop.p50 / tcp.hop.p50,
        tls.tick3 / tcp.tick3,
        tls.skeleton.hop_us.p50 / tcp.skeleton.hop_us.p50,
        tls.skeleton.tick_ms / tcp.skeleton.tick_ms
    );
    Ok(0)
}

/// The raw Zenoh round trip, µs.
fn floor(net: &Net, work: &Path, hosts: &Path, samples: usize) -> Result<Percentiles> {
    let ping = bin_dir()?.join("vbap_zenoh_ping");
    let n = N.to_string();
    let s = samples.to_string();
    let common = |host: &'static str| -> Vec<&OsStr> {
        vec![
            "--hosts".as_ref(),
            hosts.as_os_str(),
            "--host".as_ref(),
            host.as_ref(),
            "--vehicles".as_ref(),
            n.as_ref(),
        ]
    };
    let mut pong_args = common("shore");
    pong_args.push("--pong".as_ref());
    let locks = work.join("locks");
    let pong = Reaped(net.spawn(
        "shore",
        &locks,
        &ping,
        &pong_args,
        Stdio::null(),
        &work.join("pong.err"),
    )?);
    let mut ping_args = common("glider_a");
    ping_args.extend(["--samples".as_ref(), s.as_ref() as &OsStr]);
    let child = net.spawn(
        "glider_a",
        &locks,
        &ping,
        &ping_args,
        Stdio::piped(),
        &work.join("ping.err"),
    )?;
    let out = child.wait_with_output()?;
    if !out.status.success() {
        bail!(
            "the Zenoh ping failed: see {}",
            work.join("ping.err").display()
        );
    }
    let mut pong = pong;
    pong.0.wait()?;
    let mut rtt: Vec<f64> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.trim().parse().ok())
        .collect();
    if rtt.len() != samples {
        bail!("the Zenoh ping printed {} of {samples} samples", rtt.len());
    }
    Ok(Percentiles::of(&mut rtt))
}

/// The coordinator's loop period p50 of run `dir`, ms.
fn tick_ms(dir: &Path) -> Result<f64> {
    let r = analyze(&RunDir {
        root: dir.to_path_buf(),
    })?;
    r.loops
        .get("coordinator")
        .map(|l| l.period_ms.p50)
        .filter(|p| *p > 0.0)
        .ok_or_else(|| anyhow!("{}: no coordinator loop in the records", dir.display()))
}

/// The mission on one host: its tick p50, ms.
fn one_host(work: &Path, duration: f64) -> Result<f64> {
    let file = work.join("one.toml");
    std::fs::write(&file, mission(&unique_name("h1"), duration))?;
    let out = work.join("one");
    let status = std::process::Command::new(bin_dir()?.join("vbap"))
        .arg("run")
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .stdout(Stdio::null())
        .status()?;
    if !status.success() {
        bail!("the one-host run failed: see {}", out.display());
    }
    tick_ms(&out)
}

/// The mission over the three hosts: the `state@hosts` transport, µs, and the tick p50, ms.
fn three_hosts(net: &Net, work: &Path, hosts: &Path, duration: f64) -> Result<(Percentiles, f64)> {
    let file = work.join("three.toml");
    std::fs::write(&file, mission(&unique_name("h3"), duration))?;
    let vbap = bin_dir()?.join("vbap");
    let mut children = Vec::new();
    for h in HOSTS {
        let out: PathBuf = work.join(h);
        let args: Vec<&OsStr> = vec![
            "run".as_ref(),
            file.as_os_str(),
            "--hosts".as_ref(),
            hosts.as_os_str(),
            "--host".as_ref(),
            h.as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
            "--quiet".as_ref(),
        ];
        let locks = work.join(format!("{h}.locks"));
        let err = work.join(format!("{h}.stderr.log"));
        children.push((
            h,
            Reaped(net.spawn(h, &locks, &vbap, &args, Stdio::null(), &err)?),
        ));
    }
    for (h, child) in &mut children {
        let status = child.0.wait()?;
        if !status.success() {
            bail!(
                "host {h} failed ({status}): see {}",
                work.join(format!("{h}.stderr.log")).display()
            );
        }
    }
    let shore = work.join("shore");
    for h in &HOSTS[1..] {
        let to = shore.join("hosts").join(h).join("logs");
        std::fs::create_dir_all(&to)?;
        for e in std::fs::read_dir(work.join(h).join("logs"))?.flatten() {
            std::fs::copy(e.path(), to.join(e.file_name()))
                .with_context(|| format!("merging {}", e.path().display()))?;
        }
    }
    let r = analyze(&RunDir {
        root: shore.clone(),
    })?;
    let hop = r
        .hops
        .get("state@hosts")
        .map(|h| h.transport_us)
        .ok_or_else(|| anyhow!("{}: no state@hosts hop", shore.display()))?;
    Ok((hop, tick_ms(&shore)?))
}
