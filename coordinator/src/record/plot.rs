//! `plot.svg` of a run directory, drawn from the files the recorder wrote.

use std::io;

use vbap_math::Vec3;
use vbap_mission::rundir::RunDir;
use vbap_report::plot::{MissionPlot, Snapshot, Track};

use super::Recorder;

/// Number of formation snapshots drawn on the plot.
const PLOT_SNAPSHOTS: usize = 6;
/// Track points kept per vehicle for the plot (downsampled evenly).
const PLOT_POINTS: usize = 2000;
/// Events closer than 1/`EVENT_SNAPSHOT_GAP` of the mission share one snapshot on the plot.
const EVENT_SNAPSHOT_GAP: u64 = 50;

impl Recorder {
    /// Writes `plot.svg`: tracks on the field's contours, the body path, formation
    /// snapshots (evenly spaced, and at the telling events of `events.jsonl`) and the optimum.
    pub fn write_plot(&self) -> Result<(), vbap_report::plot::PlotError> {
        let m = &self.mission;
        let t = self.stats.last_t;
        let field = &self.field;
        let z = if m.mission.dim == 3 {
            self.stats.last_r.z
        } else {
            0.0
        };
        let sample = move |x: f64, y: f64| field.value(&Vec3::new(x, y, z), t);
        let optimum = field.optimum(t, m.mission.goal).map(|o| (o.x, o.y));
        let io_err = |path: std::path::PathBuf| {
            move |source| vbap_report::plot::PlotError::Io { path, source }
        };
        let events = vbap_report::plot::read_events(&self.dir.events())
            .map_err(io_err(self.dir.events()))?;
        let at_events = vbap_report::plot::event_snapshots(
            &events,
            vbap_report::plot::MAX_EVENT_SNAPSHOTS,
            (m.ticks() / EVENT_SNAPSHOT_GAP).max(1),
        );
        let (tracks, body_path, snapshots) =
            plot_data(&self.dir, m.ticks(), &at_events.into_iter().collect())
                .map_err(io_err(self.dir.vehicles()))?;
        let plot = MissionPlot {
            title: format!("{} (seed {})", m.mission.name, m.mission.seed),
            length_unit: m.mission.length_unit.clone(),
            field: &sample,
            field_label: m.mission.field_label.clone(),
            tracks,
            body_path,
            snapshots,
            optimum,
            events: Vec::new(),
        };
        vbap_report::plot::write_mission_svg(&plot, &self.dir.plot())
    }
}

/// Tracks, body path and formation snapshots read back from `vehicles.csv` and
/// `body.csv` (downsampled), so the plot needs nothing kept in memory.
type PlotData = (Vec<Track>, Vec<(f64, f64)>, Vec<Snapshot>);

/// `at_events`: extra snapshot ticks with their event labels; an evenly spaced snapshot
/// closer than 1/[`EVENT_SNAPSHOT_GAP`] of the mission to one of them is left out (the first
/// and the last are kept).
fn plot_data(
    dir: &RunDir,
    ticks: u64,
    at_events: &std::collections::BTreeMap<u64, String>,
) -> io::Result<PlotData> {
    use std::collections::BTreeMap;
    use std::io::BufRead;
    let ticks = ticks.max(1);
    let stride = (ticks / PLOT_POINTS as u64).max(1);
    let every = (ticks / PLOT_SNAPSHOTS as u64).max(1);
    let gap = (ticks / EVENT_SNAPSHOT_GAP).max(1);
    let snapshot_at = |k: u64| {
        // Evenly spaced, the last one at the end (not also half a step before it).
        let regular = (k.is_multiple_of(every) && k + every / 2 < ticks) || k + 1 == ticks;
        let crowded = at_events
            .range(k.saturating_sub(gap)..=k.saturating_add(gap))
            .next()
            .is_some();
        at_events.contains_key(&k) || (regular && (k == 0 || k + 1 == ticks || !crowded))
    };
    let num = |s: Option<&str>| s.and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::NAN);
    let mut body: BTreeMap<u64, (f64, f64, f64)> = BTreeMap::new();
    let mut path = Vec::new();
    for line in std::io::BufReader::new(std::fs::File::open(dir.body())?)
        .lines()
        .skip(1)
    {
        let line = line?;
        let mut f = line.split(',');
        let t = num(f.next());
        let k = num(f.next()) as u64;
        let (_s, _sd) = (f.next(), f.next());
        let (x, y) = (num(f.next()), num(f.next()));
        if k.is_multiple_of(stride) {
            path.push((x, y));
        }
        if snapshot_at(k) {
            body.insert(k, (t, x, y));
        }
    }
    let mut tracks: BTreeMap<u32, Vec<(f64, f64)>> = BTreeMap::new();
    let mut snaps: BTreeMap<u64, Vec<(f64, f64)>> = BTreeMap::new();
    for line in std::io::BufReader::new(std::fs::File::open(dir.vehicles())?)
        .lines()
        .skip(1)
    {
        let line = line?;
        let mut f = line.split(',');
        let _t = f.next();
        let k = num(f.next()) as u64;
        let id = num(f.next()) as u32;
        let (x, y) = (num(f.next()), num(f.next()));
        if k.is_multiple_of(stride) {
            tracks.entry(id).or_default().push((x, y));
        }
        if body.contains_key(&k) {
            snaps.entry(k).or_default().push((x, y));
        }
    }
    let snapshots = snaps
        .into_iter()
        .filter_map(|(k, positions)| {
            body.get(&k).map(|&(t, x, y)| Snapshot {
                t,
                label: at_events.get(&k).cloned().unwrap_or_default(),
                positions,
                centre: (x, y),
            })
        })
        .collect();
    let tracks = tracks
        .into_iter()
        .map(|(id, points)| Track { id, points })
        .collect();
    Ok((tracks, path, snapshots))
}
