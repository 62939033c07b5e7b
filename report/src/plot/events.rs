//! The events of `events.jsonl` as the mission plot takes its snapshots at them.

use super::*;

/// Most formation snapshots `plot.svg` draws at events (besides the evenly spaced ones).
pub const MAX_EVENT_SNAPSHOTS: usize = 6;

/// The events of `events.jsonl` at `path`, in file order (no file: none; lines that are not
/// an event, such as a partial last line of an interrupted run, are skipped).
pub fn read_events(path: &Path) -> std::io::Result<Vec<Event>> {
    use std::io::BufRead;
    let file = match std::fs::File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let mut out = Vec::new();
    for line in std::io::BufReader::new(file).lines() {
        if let Ok(e) = serde_json::from_str::<Event>(&line?) {
            out.push(e);
        }
    }
    Ok(out)
}

/// The ticks at which the mission plot draws a formation snapshot for an event, each with its
/// label, in tick order: events of the kinds of [`style::SNAPSHOT_EVENTS`] (a vehicle lost,
/// the formation broken, a stall, a near collision, a rejoin, a redesign). Events less than
/// `min_gap` ticks after the first of a group share its snapshot ("lost 2, redesign"). Of
/// more than `max` groups, the first group of each kind is kept first (in the order of
/// [`style::SNAPSHOT_EVENTS`]), then the others by that order and time.
pub fn event_snapshots(events: &[Event], max: usize, min_gap: u64) -> Vec<(u64, String)> {
    let priority = |kind: &str| style::SNAPSHOT_EVENTS.iter().position(|k| *k == kind);
    let mut wanted: Vec<(u64, usize, String)> = events
        .iter()
        .filter_map(|e| priority(&e.kind).map(|p| (e.k, p, style::event_label(e))))
        .collect();
    wanted.sort_by_key(|w| w.0);
    // Groups: (first tick, best priority, kinds seen, labels).
    let mut groups: Vec<(u64, usize, Vec<usize>, Vec<String>)> = Vec::new();
    for (k, p, label) in wanted {
        match groups.last_mut() {
            Some(g) if k < g.0 + min_gap.max(1) => {
                g.1 = g.1.min(p);
                g.2.push(p);
                if !g.3.contains(&label) {
                    g.3.push(label);
                }
            }
            _ => groups.push((k, p, vec![p], vec![label])),
        }
    }
    let mut chosen: Vec<usize> = Vec::new();
    if groups.len() <= max {
        chosen = (0..groups.len()).collect();
    } else {
        for p in 0..style::SNAPSHOT_EVENTS.len() {
            if chosen.len() >= max {
                break;
            }
            if let Some(i) = groups.iter().position(|g| g.2.contains(&p)) {
                if !chosen.contains(&i) {
                    chosen.push(i);
                }
            }
        }
        let mut rest: Vec<usize> = (0..groups.len()).filter(|i| !chosen.contains(i)).collect();
        rest.sort_by_key(|&i| (groups[i].1, groups[i].0));
        chosen.extend(rest.into_iter().take(max.saturating_sub(chosen.len())));
        chosen.sort_unstable();
    }
    chosen
        .into_iter()
        .map(|i| {
            let labels = &groups[i].3;
            let mut label = labels.join(", ");
            if label.chars().count() > 48 {
                label = label.chars().take(47).collect::<String>() + "…";
            }
            (groups[i].0, label)
        })
        .collect()
}
