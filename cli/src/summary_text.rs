//! The terminal summary of `vbap run` and `vbap sim`: the verdict, its reasons and the key
//! figures of summary.json.

use std::fmt::Write;

use vbap_mission::rundir::{FormationSummary, LinkBytes, Summary};

/// A duration for people: seconds, with hours or days beside long ones.
fn duration(s: f64) -> String {
    if s >= 2.0 * 86400.0 {
        format!("{s:.0} s ({:.1} d)", s / 86400.0)
    } else if s >= 2.0 * 3600.0 {
        format!("{s:.0} s ({:.1} h)", s / 3600.0)
    } else {
        format!("{} s", coordinator::truth::fmt(s))
    }
}

/// The terminal summary of `vbap run` / `vbap sim`: verdict, reasons, key figures.
pub fn human_summary(s: &Summary) -> String {
    let mut o = String::new();
    let verdict = if s.verdict.is_empty() {
        if s.converged {
            "converged"
        } else {
            "not converged"
        }
    } else {
        s.verdict.as_str()
    };
    let _ = writeln!(o, "verdict: {verdict}");
    for r in &s.reasons {
        let _ = writeln!(o, "  - {r}");
    }
    let _ = writeln!(
        o,
        "figures ({} mission, seed {}, {}):",
        s.mission, s.seed, s.mode
    );
    row(
        &mut o,
        "mission time",
        format!(
            "{} in {} ticks, wall {} s",
            duration(s.final_time_s),
            s.ticks,
            coordinator::truth::fmt(s.wall_time_s)
        ),
    );
    if let Some(d) = s.final_distance_to_optimum {
        row(
            &mut o,
            "body to optimum",
            format!(
                "{}{}",
                coordinator::truth::fmt(d),
                s.time_to_converge_s
                    .map_or(String::new(), |t| format!(", converged at {}", duration(t)))
            ),
        );
    }
    if let Some(f) = &s.formation {
        formation_rows(&mut o, s, f);
    }
    if let (Some(inside), Some(b)) = (s.in_set_m, s.theorem_5_1_bound) {
        row(
            &mut o,
            "in set M (Thm 5.1)",
            format!(
                "{inside} (|∇T| = {} against the bound {})",
                coordinator::truth::fmt(s.final_grad_norm),
                coordinator::truth::fmt(b)
            ),
        );
    }
    let m = &s.messages;
    row(
        &mut o,
        "messages",
        format!(
            "{} sent, {} delivered, {} dropped by the links{}",
            m.sent,
            m.delivered,
            m.dropped_injected,
            if m.superseded > 0 {
                format!(
                    ", {} replaced at the shore by a newer command",
                    m.superseded
                )
            } else {
                String::new()
            }
        ),
    );
    if let Some(b) = &s.link_bytes {
        row(&mut o, "link bytes", link_bytes(b));
    }
    o.push_str(
        "  (all figures: summary.json; per tick: truth.csv, formation.csv; --json prints the JSON)",
    );
    o
}

/// The `link bytes` row: per vehicle and day, down and up (and Iridium's sessions).
fn link_bytes(b: &LinkBytes) -> String {
    let kb = |x: f64| format!("{:.1} kB", x / 1000.0);
    let mut text = format!(
        "{} per vehicle-day down (commands {} B mean, {} B max), {} up ({} B a report)",
        kb(b.down_b_per_vehicle_day),
        b.command_mean_b.round(),
        b.command_max_b,
        kb(b.up_b_per_vehicle_day),
        b.report_b
    );
    if let Some(i) = &b.iridium {
        let _ = write!(
            text,
            "; Iridium: {} sessions, {} failed, {} commands over the limit ({})",
            i.sessions, i.sessions_failed, i.commands_over_limit, i.oversize
        );
    }
    text
}

/// The rows about the formation (from summary.json `formation`).
fn formation_rows(o: &mut String, s: &Summary, f: &FormationSummary) {
    row(
        o,
        "V / V_U (true)",
        format!(
            "max {}, above 1 in {:.1}% of ticks; the coordinator saw max {}",
            coordinator::truth::fmt(f.max_v_true_over_vu),
            100.0 * f.share_ticks_v_true_above_vu,
            coordinator::truth::fmt(f.max_v_seen_over_vu)
        ),
    );
    if let (Some(t), Some(share)) = (
        f.all_in_contact_t.filter(|t| *t > 0.0),
        f.share_ticks_v_true_above_vu_after_contact,
    ) {
        row(
            o,
            "  after first contact",
            format!(
                "V above 1 in {:.1}% of ticks once every vehicle was heard (t = {})",
                100.0 * share,
                duration(t)
            ),
        );
    }
    if let (Some(r), Some(t), Some([a, b])) = (f.min_pair_ratio, f.min_pair_t, f.min_pair_vehicles)
    {
        row(
            o,
            "closest pair",
            format!(
                "{} spacing (vehicles {a} and {b} at t = {}), {} near-collision ticks",
                coordinator::truth::fmt(r),
                duration(t),
                f.near_collision_ticks
            ),
        );
    }
    if let (Some(e), Some(v), Some(t)) = (f.worst_slot_error, f.worst_slot_vehicle, f.worst_slot_t)
    {
        row(
            o,
            "worst slot error",
            format!(
                "{} spacing (vehicle {v} at t = {})",
                coordinator::truth::fmt(e),
                duration(t)
            ),
        );
    }
    row(
        o,
        "in formation at end",
        format!(
            "{} of {} alive ({} started, {} lost, {} rejoined)",
            f.in_formation_at_end,
            f.alive_at_end,
            s.vehicles_started,
            s.vehicles_lost,
            s.vehicles_rejoined
        ),
    );
    let gaps: Vec<String> = f
        .longest_contact_gap_s
        .iter()
        .enumerate()
        .filter_map(|(i, g)| g.map(|g| format!("{i}: {}", coordinator::truth::fmt(g))))
        .collect();
    if !gaps.is_empty() {
        row(o, "longest silence (s)", gaps.join(", "));
    }
    if f.stalled_s > 0.0 {
        row(
            o,
            "stalled",
            format!(
                "{}{}",
                duration(f.stalled_s),
                if f.stalled_at_end { ", to the end" } else { "" }
            ),
        );
    }
}

/// One `  key                   value` row.
fn row(o: &mut String, k: &str, v: String) {
    let _ = writeln!(o, "  {k:<22}{v}");
}
