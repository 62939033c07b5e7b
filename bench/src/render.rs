//! The human-readable tables of `vbap bench`, a function per section.

use std::fmt::Write as _;

use super::report::{reference_floors, Report};

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("n/a".into(), |v| format!("{v:.prec$}"))
}

/// "   FAILED: why" or "   note: what", or nothing.
fn remark(error: &Option<String>, note: &Option<String>) -> String {
    match (error, note) {
        (Some(e), _) => format!("   FAILED: {e}"),
        (None, Some(n)) => format!("   note: {n}"),
        (None, None) => String::new(),
    }
}

/// The human-readable tables.
pub(super) fn render(r: &Report) -> String {
    let mut s = String::new();
    header(r, &mut s);
    let _ = writeln!(s);
    hops(r, &mut s);
    let _ = writeln!(s);
    lockstep(r, &mut s);
    let _ = writeln!(s);
    realtime(r, &mut s);
    let _ = writeln!(s);
    glider(r, &mut s);
    let _ = writeln!(s);
    footprint(r, &mut s);
    let _ = writeln!(s);
    super::overhead::render(&r.overhead, r.machine.cpus, &mut s);
    let _ = writeln!(s);
    goals(r, &mut s);
    let _ = writeln!(s);
    footer(r, &mut s);
    s
}

/// The title line: the machine, and how busy it was.
fn header(r: &Report, s: &mut String) {
    let m = &r.machine;
    let _ = writeln!(
        s,
        "vbap bench{} — {} CPUs ({}), Linux {}, {}",
        if r.quick { " --quick" } else { "" },
        m.cpus,
        m.cpu_model,
        m.kernel,
        m.date
    );
    if let Some(other) = m.other_load {
        let _ = writeln!(
            s,
            "other processes used {:.0}% of the CPUs during the bench{}",
            other * 100.0,
            if other > 0.05 {
                " — a busy machine: the figures below are low"
            } else {
                ""
            }
        );
    }
}

/// 1. The hop latencies against their floors.
fn hops(r: &Report, s: &mut String) {
    let _ = writeln!(
        s,
        "1. state → coordinator hop, one-way latency (µs; wall clock, sender stamp to receiver read)"
    );
    let _ = writeln!(
        s,
        "   {:<52} {:>8} {:>8} {:>8}",
        "", "p50", "p99", "samples"
    );
    let (floor, udp) = reference_floors(r);
    let which = if r.hop_iceoryx2_warm.is_some() {
        "warm"
    } else {
        "idle"
    };
    let mut floors = vec![
        (
            "raw iceoryx2 ping-pong (pub-sub + event, WaitSet)",
            &r.hop_iceoryx2,
        ),
        ("UDP loopback ping-pong (blocking recv)", &r.hop_udp),
    ];
    if let (Some(i), Some(u)) = (&r.hop_iceoryx2_warm, &r.hop_udp_warm) {
        floors.push(("raw iceoryx2 ping-pong, CPUs kept awake", i));
        floors.push(("UDP loopback ping-pong, CPUs kept awake", u));
    }
    floors.push(("raw iceoryx2 ping-pong, busy polling", &r.hop_iceoryx2_poll));
    floors.push(("UDP loopback ping-pong, busy polling", &r.hop_udp_poll));
    for (name, h) in floors {
        let _ = writeln!(
            s,
            "   {:<52} {:>8.1} {:>8.1} {:>8}",
            name, h.one_way_us.p50, h.one_way_us.p99, h.samples
        );
    }
    for h in &r.hop_system {
        let _ = writeln!(
            s,
            "   {:<52} {:>8.1} {:>8.1} {:>8}   {:.2}× {which} floor, UDP/hop {:.2}×",
            format!("vbap run, lockstep, N = {}", h.vehicles),
            h.transport_us.p50,
            h.transport_us.p99,
            h.samples,
            h.transport_us.p50 / floor,
            udp / h.transport_us.p50
        );
    }
    let _ = writeln!(
        s,
        "   ({which} UDP / raw iceoryx2 p50: {:.2}× — the most any blocking hop can gain on UDP here)",
        udp / floor
    );
    let _ = writeln!(
        s,
        "   (busy polling, UDP / raw iceoryx2 p50: {:.2}× — what the zero-copy path gains when nothing sleeps)",
        r.hop_udp_poll.one_way_us.p50 / r.hop_iceoryx2_poll.one_way_us.p50
    );
}

/// 2. Lockstep ticks per second against the in-process simulator and the wake-up floor.
fn lockstep(r: &Report, s: &mut String) {
    let _ = writeln!(
        s,
        "2. lockstep ticks per second (paper mission, dt = 0.05 s; start-up excluded)"
    );
    let _ = writeln!(
        s,
        "   {:>4} {:>6} {:>10} {:>11} {:>11} {:>10} {:>10}   {:>28}",
        "N",
        "ticks",
        "vbap run",
        "in-process",
        "wake floor",
        "floor/run",
        "inproc/run",
        "µs per tick·vehicle run/inproc/floor"
    );
    for l in &r.lockstep {
        let run = l.run_ticks_per_s;
        let _ = writeln!(
            s,
            "   {:>4} {:>6} {:>10} {:>11.1} {:>11.1} {:>10} {:>10}   {:>10} {:>8.2} {:>8.2}{}",
            l.vehicles,
            l.ticks,
            opt(run, 1),
            l.in_process_ticks_per_s,
            l.wake_floor_ticks_per_s,
            opt(run.map(|v| l.wake_floor_ticks_per_s / v), 2),
            opt(run.map(|v| l.in_process_ticks_per_s / v), 1),
            opt(l.run_us_per_tick_vehicle, 1),
            l.in_process_us_per_tick_vehicle,
            l.floor_us_per_tick_vehicle,
            remark(&l.error, &l.note)
        );
    }
    let _ = writeln!(
        s,
        "   what one vehicle is told per tick, bytes: {:>4} {:>16} {:>12} {:>11}",
        "N", "shared snapshot", "compact mean", "compact max"
    );
    for l in &r.lockstep {
        let _ = writeln!(
            s,
            "   {:>46} {:>16} {:>12} {:>11}",
            l.vehicles,
            l.shared_snapshot_b,
            opt(l.command_mean_b, 0),
            l.command_max_b.map_or("—".to_string(), |b| b.to_string())
        );
    }
}

/// 3. The real-time capacity sweep.
fn realtime(r: &Report, s: &mut String) {
    let rt = &r.realtime;
    let _ = writeln!(
        s,
        "3. real-time capacity (pace 1.0, dt = {} s, {} s of mission per N)",
        rt.dt_s, rt.duration_s
    );
    let _ = writeln!(
        s,
        "   {:>4} {:>6} {:>10} {:>17} {:>5} {:>6} {:>11}",
        "N", "ticks", "late ticks", "rejected (future)", "lost", "holds", "start-up s"
    );
    for row in &rt.rows {
        let _ = writeln!(
            s,
            "   {:>4} {:>6} {:>10} {:>17} {:>5} {:>6} {:>11}{}",
            row.vehicles,
            row.ticks,
            row.late_ticks,
            format!("{} ({})", row.rejected, row.rejected_future),
            row.vehicles_lost,
            if row.holds { "yes" } else { "NO" },
            opt(row.startup_s, 2),
            remark(&row.error, &None)
        );
    }
    let _ = writeln!(
        s,
        "   largest N at real-time pace: {}",
        rt.largest_vehicles
            .map_or("none".into(), |n| format!("{n} (of those tried)"))
    );
}

/// 4. Glider-days per wall minute.
fn glider(r: &Report, s: &mut String) {
    let g = &r.glider;
    let _ = writeln!(
        s,
        "4. simulated glider-days per wall minute ({} gliders, dt = 10 s, {} days, surfacing {} s every {} s)",
        g.vehicles, g.simulated_days, g.surfacing_window_s, g.surfacing_period_s
    );
    let _ = writeln!(
        s,
        "   {:<10} {:>9} {:>16} {:>22}",
        "", "wall s", "days/min (all)", "days/min (mission loop)"
    );
    for (name, rate) in [("vbap sim", &g.sim), ("vbap run", &g.run)] {
        let _ = writeln!(
            s,
            "   {:<10} {:>9.2} {:>16.1} {:>22}{}",
            name,
            rate.wall_s,
            rate.days_per_wall_min,
            opt(rate.mission_days_per_wall_min, 1),
            remark(&rate.error, &None)
        );
    }
    if let Some(note) = &g.note {
        let _ = writeln!(s, "   note: {note}");
    }
}

/// 5. Start-up and memory.
fn footprint(r: &Report, s: &mut String) {
    let _ = writeln!(
        s,
        "5. start-up and memory (pace 1.0; start-up = first process's \"started\" to last \"agent up\")"
    );
    let _ = writeln!(
        s,
        "   {:>4} {:>11} {:>14} {:>12} {:>12} {:>11} {:>11} {:>14}",
        "N",
        "start-up s",
        "incl. launch s",
        "PSS/agent",
        "coordinator",
        "field srv",
        "supervisor",
        "all / vehicle"
    );
    for f in &r.footprint {
        let mib = |v: Option<f64>| opt(v, 2) + " MiB";
        let _ = writeln!(
            s,
            "   {:>4} {:>11} {:>14} {:>12} {:>12} {:>11} {:>11} {:>14}{}",
            f.vehicles,
            opt(f.startup_s, 2),
            opt(f.launch_to_up_s, 2),
            mib(f.pss_agent_mib),
            mib(f.pss_coordinator_mib),
            mib(f.pss_field_server_mib),
            mib(f.pss_supervisor_mib),
            mib(f.pss_total_per_vehicle_mib),
            remark(&f.error, &f.note)
        );
    }
}

/// The goals and their ratios.
fn goals(r: &Report, s: &mut String) {
    let _ = writeln!(s, "Goals (ratios measured in this run, not asserted):");
    for goal in &r.goals {
        let _ = writeln!(
            s,
            "   {:<58} {:>8}  target {:<16} {}",
            goal.goal,
            opt(goal.value, 2),
            goal.target,
            match goal.met {
                Some(true) => "met",
                Some(false) => "MISSED",
                None => "not measured (--quick)",
            }
        );
    }
}

/// Total wall time and where the run directories are.
fn footer(r: &Report, s: &mut String) {
    let _ = writeln!(s, "total wall time: {:.1} s", r.total_wall_s);
    match &r.work_dir {
        Some(dir) if r.suspect_runs.is_empty() => {
            let _ = writeln!(s, "run directories: {}", dir.display());
        }
        Some(dir) => {
            let _ = writeln!(
                s,
                "run directories: {} ({} suspect run{} to look at: late ticks, rejected states, lost vehicles or failures)",
                dir.display(),
                r.suspect_runs.len(),
                if r.suspect_runs.len() == 1 { "" } else { "s" }
            );
        }
        None => {}
    }
}
