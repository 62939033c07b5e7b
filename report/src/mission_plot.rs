//! `plot.svg`, the mission plot, from the run directory alone: tracks and formation
//! snapshots read back from `vehicles.csv`, the body path from `body.csv`, the field at the
//! final time from the resolved `mission.toml` (or a user's own [`ScalarField`], which no
//! file describes), snapshots at the telling events of `events.jsonl`. Drawn by
//! [`crate::plot::write_mission_svg`].

use std::collections::BTreeMap;

use crate::plot::{MissionPlot, Snapshot, Track};
use anyhow::{Context, Result};
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::field::ScalarField;
use vbap_wire::rundir::RunDir;

use super::rows::{for_each_row_of, BodyPathCsv, VehicleCsv};

/// Number of formation snapshots drawn on the plot.
const PLOT_SNAPSHOTS: usize = 6;
/// Track points kept per vehicle for the plot (downsampled evenly).
const PLOT_POINTS: usize = 2000;
/// Events closer than 1/`EVENT_SNAPSHOT_GAP` of the mission share one snapshot on the plot.
const EVENT_SNAPSHOT_GAP: u64 = 50;

/// Writes `plot.svg` of `dir`: tracks on the field's contours, the body path, formation
/// snapshots (evenly spaced, and at the telling events of `events.jsonl`) and the optimum.
/// `field`: the field the run sensed when it was not the mission's `[field]` (a user's own,
/// `vbap_cli::custom::Plugins`); None: the mission's.
pub fn write_mission_plot(
    dir: &RunDir,
    mission: &Mission,
    field: Option<&dyn ScalarField>,
) -> Result<()> {
    let m = mission;
    let events = crate::plot::read_events(&dir.events())
        .with_context(|| format!("reading {}", dir.events().display()))?;
    let at_events: BTreeMap<u64, String> = crate::plot::event_snapshots(
        &events,
        crate::plot::MAX_EVENT_SNAPSHOTS,
        (m.ticks() / EVENT_SNAPSHOT_GAP).max(1),
    )
    .into_iter()
    .collect();
    let data = plot_data(dir, m.ticks(), &at_events)?;
    // The field at the final time (the last tick recorded), at the body's depth in 3-D.
    let (t, r) = data.last.unwrap_or((0.0, m.start_vec()));
    let own;
    let field: &dyn ScalarField = match field {
        Some(f) => f,
        None => {
            own = m.field();
            &own
        }
    };
    let z = if m.mission.dim == 3 { r.z } else { 0.0 };
    // Land of a gridded field (and outside its grid) is shaded: no value there.
    let land = m.land();
    let sample = |x: f64, y: f64| {
        let p = Vec3::new(x, y, z);
        if land.as_ref().is_some_and(|l| l.is_land(&p)) {
            f64::NAN
        } else {
            field.value(&p, t)
        }
    };
    let current = vbap_mission::current::current_of(m).map(|c| {
        move |x: f64, y: f64| {
            let v = c.velocity(&Vec3::new(x, y, z), t);
            (v.x, v.y)
        }
    });
    let plot = MissionPlot {
        title: format!("{} (seed {})", m.mission.name, m.mission.seed),
        length_unit: m.mission.length_unit.clone(),
        field: &sample,
        field_label: m.mission.field_label.clone(),
        tracks: data.tracks,
        body_path: data.body_path,
        snapshots: data.snapshots,
        optimum: field.optimum(t, m.mission.goal).map(|o| (o.x, o.y)),
        events: Vec::new(),
        geographic: m.grid().and_then(|g| g.origin),
        current: current
            .as_ref()
            .map(|c| c as &dyn Fn(f64, f64) -> (f64, f64)),
    };
    crate::plot::write_mission_svg(&plot, &dir.plot())
        .with_context(|| format!("drawing {}", dir.plot().display()))
}

/// What the plot shows, read back from the run's CSV files (downsampled).
struct PlotData {
    tracks: Vec<Track>,
    body_path: Vec<(f64, f64)>,
    snapshots: Vec<Snapshot>,
    /// Time (s) and body centre of the last row of `body.csv`.
    last: Option<(f64, Vec3)>,
}

/// `at_events`: extra snapshot ticks with their event labels; an evenly spaced snapshot
/// closer than 1/[`EVENT_SNAPSHOT_GAP`] of the mission to one of them is left out (the first
/// and the last are kept).
fn plot_data(dir: &RunDir, ticks: u64, at_events: &BTreeMap<u64, String>) -> Result<PlotData> {
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
    let mut body: BTreeMap<u64, (f64, f64, f64)> = BTreeMap::new();
    let mut body_path = Vec::new();
    let mut last = None;
    for_each_row_of(&dir.body(), |_, b: BodyPathCsv| {
        if b.k.is_multiple_of(stride) {
            body_path.push((b.rx, b.ry));
        }
        if snapshot_at(b.k) {
            body.insert(b.k, (b.t, b.rx, b.ry));
        }
        last = Some((b.t, Vec3::new(b.rx, b.ry, b.rz)));
        Ok(())
    })?;
    let mut tracks: BTreeMap<u32, Vec<(f64, f64)>> = BTreeMap::new();
    let mut snaps: BTreeMap<u64, Vec<(f64, f64)>> = BTreeMap::new();
    for_each_row_of(&dir.vehicles(), |_, v: VehicleCsv| {
        if v.k.is_multiple_of(stride) {
            tracks.entry(v.id).or_default().push((v.x, v.y));
        }
        if body.contains_key(&v.k) {
            snaps.entry(v.k).or_default().push((v.x, v.y));
        }
        Ok(())
    })?;
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
    Ok(PlotData {
        tracks,
        body_path,
        snapshots,
        last,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plot_data_is_read_back_by_column_name() {
        let root = std::env::temp_dir().join(format!("vbap-mission-plot-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = RunDir::create(&root).unwrap();
        let ticks = 12u64;
        // Columns in another order than the writer's, and one more: read the same.
        let mut body = String::from("k,extra,t,rx,ry,rz\n");
        let mut vehicles = String::from("y,x,id,k\n");
        for k in 0..ticks {
            body.push_str(&format!("{k},x,{},{},{},0.5\n", k as f64 * 0.1, k, 2 * k));
            for id in 0..3 {
                vehicles.push_str(&format!("{},{},{id},{k}\n", id as f64, k as f64 + 0.5));
            }
        }
        std::fs::write(dir.body(), body).unwrap();
        std::fs::write(dir.vehicles(), vehicles).unwrap();
        let at_events = BTreeMap::from([(5, "lost 2".to_string())]);
        let d = plot_data(&dir, ticks, &at_events).unwrap();
        assert_eq!(d.tracks.len(), 3);
        assert_eq!(d.tracks[1].points.len(), ticks as usize);
        assert_eq!(d.tracks[1].points[3], (3.5, 1.0));
        assert_eq!(d.body_path[4], (4.0, 8.0));
        // The first and last tick, and the event's tick with its label.
        let ks: Vec<f64> = d.snapshots.iter().map(|s| s.centre.0).collect();
        assert!(
            ks.contains(&0.0) && ks.contains(&11.0) && ks.contains(&5.0),
            "{ks:?}"
        );
        let at5 = d.snapshots.iter().find(|s| s.centre.0 == 5.0).unwrap();
        assert_eq!(at5.label, "lost 2");
        assert_eq!(at5.positions.len(), 3);
        let (t, r) = d.last.unwrap();
        assert!((t - 1.1).abs() < 1e-12 && r == Vec3::new(11.0, 22.0, 0.5));
        let _ = std::fs::remove_dir_all(&root);
    }

    /// A user's own field: a tilted plane with its optimum at (5, 3), known to no file.
    #[derive(Debug)]
    struct Tilted;

    impl ScalarField for Tilted {
        fn dim(&self) -> usize {
            2
        }
        fn value(&self, p: &Vec3, _t: f64) -> f64 {
            p.x - 2.0 * p.y
        }
        fn gradient(&self, _p: &Vec3, _t: f64) -> Vec3 {
            Vec3::new(1.0, -2.0, 0.0)
        }
        fn hessian(&self, _p: &Vec3, _t: f64) -> vbap_math::Mat3 {
            vbap_math::Mat3::zeros()
        }
        fn optimum(&self, _t: f64, _goal: vbap_mission::config::Goal) -> Option<Vec3> {
            Some(Vec3::new(5.0, 3.0, 0.0))
        }
    }

    #[test]
    fn the_plot_is_drawn_over_the_field_it_is_given() {
        let root = std::env::temp_dir().join(format!("vbap-plot-field-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = RunDir::create(&root).unwrap();
        let paper =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/missions/paper.toml");
        std::fs::copy(&paper, dir.mission()).unwrap();
        let mission = Mission::load(&dir.mission()).unwrap();
        let mut body = String::from("k,t,rx,ry,rz\n");
        let mut vehicles = String::from("k,id,x,y\n");
        for k in 0..20u64 {
            let s = k as f64;
            body.push_str(&format!("{k},{},{},{},0\n", 0.1 * s, s, 0.5 * s));
            for id in 0..3 {
                vehicles.push_str(&format!("{k},{id},{},{}\n", s + f64::from(id), 0.5 * s));
            }
        }
        std::fs::write(dir.body(), body).unwrap();
        std::fs::write(dir.vehicles(), vehicles).unwrap();
        let draw = |field: Option<&dyn ScalarField>| {
            write_mission_plot(&dir, &mission, field).unwrap();
            std::fs::read_to_string(dir.plot()).unwrap()
        };
        let own = draw(None);
        // The mission's field handed over as a user's field: the same bytes.
        assert_eq!(draw(Some(&mission.field())), own);
        // Another field: other contours and the optimum star elsewhere.
        let tilted = draw(Some(&Tilted));
        assert_ne!(tilted, own);
        assert!(tilted.contains("optimum") && own.contains("optimum"));
        let _ = std::fs::remove_dir_all(&root);
    }
}
