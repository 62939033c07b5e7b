//! `formation.csv` and `truth.csv`, read by column name and summarised for the pictures.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use crate::plot::decimate::Decimator;
use crate::plot::style::{self, CONTACT_STATES};
use anyhow::{bail, Result};

use super::{N_STATES, SILENCE_TICKS};
use crate::rows::{for_each_row, FormationCsv, TruthCsv};

/// One vehicle's lane of the contact timeline and its series.
#[derive(Clone, Debug)]
pub struct Lane {
    /// Time (s) spent in each state of [`CONTACT_STATES`] within each pixel column.
    pub state_time: Vec<[f64; N_STATES]>,
    /// Columns holding at least one delivery.
    pub delivered: Vec<bool>,
    /// Deliveries counted (ticks at which the coordinator's information was renewed).
    pub deliveries: u64,
    /// Deliveries that ended a silence of more than [`SILENCE_TICKS`] ticks.
    pub silences: u64,
    /// Distance from its slot ÷ design spacing over time (s); NaN while dead.
    pub slot_error: Decimator,
    /// Age of the coordinator's newest information over time (s, s); NaN when none.
    pub info_age: Decimator,
    /// Largest information age (s) and when (s).
    pub max_age: Option<(f64, f64)>,
    /// Largest slot error while alive (÷ spacing).
    pub max_slot_error: Option<f64>,
    /// The states met.
    pub seen: [bool; N_STATES],
    /// (t, age) of the previous row with an age.
    prev_age: Option<(f64, f64)>,
}

/// The pixel columns of the timeline: `cols` of `width` s from `t0` to `t1` (s).
#[derive(Clone, Copy)]
struct Columns {
    t0: f64,
    t1: f64,
    width: f64,
    cols: usize,
}

impl Columns {
    /// `cols` columns (at least one) over `t_range` (s).
    fn over(t_range: (f64, f64), cols: usize) -> Self {
        let cols = cols.max(1);
        let (t0, t1) = t_range;
        let width = ((t1 - t0) / cols as f64).max(f64::MIN_POSITIVE);
        Self {
            t0,
            t1,
            width,
            cols,
        }
    }

    /// The column of time `t` (s), if within the columns.
    fn of(&self, t: f64) -> Option<usize> {
        (t >= self.t0 && t < self.t1)
            .then(|| (((t - self.t0) / self.width) as usize).min(self.cols - 1))
    }
}

impl Lane {
    /// The tick at `t` (s) of `dt` s, in state `state`, covers [t, t + dt): spread it over
    /// the columns it touches.
    fn spread(&mut self, columns: &Columns, state: usize, t: f64, dt: f64) {
        let Columns {
            t0,
            t1,
            width,
            cols,
        } = *columns;
        let (a, b) = (t.max(t0), (t + dt).min(t1));
        if b > a {
            let c0 = (((a - t0) / width).floor() as usize).min(cols - 1);
            let c1 = (((b - t0) / width).ceil() as usize).clamp(c0 + 1, cols);
            for c in c0..c1 {
                let lo = t0 + c as f64 * width;
                let overlap = b.min(lo + width) - a.max(lo);
                if overlap > 0.0 {
                    self.state_time[c][state] += overlap;
                }
            }
        }
    }

    /// The coordinator's information on this vehicle is `age` s old at `t` (s; ticks of
    /// `dt` s): a delivery when the age fell below what it would be with no news since the
    /// last tick.
    fn age(&mut self, columns: &Columns, t: f64, age: f64, dt: f64) {
        let renewed = match self.prev_age {
            None => true,
            Some((tp, ap)) => age < ap + (t - tp) - 1e-9 * (1.0 + t.abs()),
        };
        if renewed {
            self.deliveries += 1;
            if self
                .prev_age
                .is_some_and(|(_, ap)| ap > SILENCE_TICKS as f64 * dt)
            {
                self.silences += 1;
            }
            if let Some(c) = columns.of(t) {
                self.delivered[c] = true;
            }
        }
        self.prev_age = Some((t, age));
        if self.max_age.is_none_or(|(m, _)| age > m) {
            self.max_age = Some((age, t));
        }
    }

    fn new(cols: usize, bucket: u64) -> Self {
        Self {
            state_time: vec![[0.0; N_STATES]; cols],
            delivered: vec![false; cols],
            deliveries: 0,
            silences: 0,
            slot_error: Decimator::with_bucket(bucket),
            info_age: Decimator::with_bucket(bucket),
            max_age: None,
            max_slot_error: None,
            seen: [false; N_STATES],
            prev_age: None,
        }
    }
}

/// `formation.csv`, summarised for the pictures.
#[derive(Clone, Debug)]
pub struct Formation {
    /// Per vehicle id.
    pub lanes: BTreeMap<u32, Lane>,
    /// Mission time covered by the pixel columns, s.
    pub t_range: (f64, f64),
    /// Rows read.
    pub rows: u64,
    /// The largest age of the coordinator's information over the vehicles, per tick (s, s).
    pub worst_age: Decimator,
    /// Largest slot error of a vehicle counted in formation (÷ spacing).
    pub in_max: Option<f64>,
    /// Smallest slot error of a live vehicle counted out of formation (÷ spacing).
    pub out_min: Option<f64>,
    /// The in-formation threshold on the slot error (÷ spacing), from `summary.json`.
    pub threshold: Option<f64>,
    /// The near-collision threshold on a pair's distance (÷ spacing), from `summary.json`.
    pub near_collision: Option<f64>,
}

impl Formation {
    /// Reads `formation.csv` from `reader` (`path` names it in errors), with `cols` pixel
    /// columns over `t_range` (s), ticks of `dt` s, and series decimated into buckets of
    /// `bucket` rows per vehicle.
    pub fn read(
        path: &Path,
        reader: impl Read,
        dt: f64,
        t_range: (f64, f64),
        cols: usize,
        bucket: u64,
    ) -> Result<Self> {
        let columns = Columns::over(t_range, cols);
        let cols = columns.cols;
        let mut f = Formation {
            lanes: BTreeMap::new(),
            t_range,
            rows: 0,
            worst_age: Decimator::with_bucket(bucket),
            in_max: None,
            out_min: None,
            threshold: None,
            near_collision: None,
        };
        let mut tick: Option<(u64, f64, f64)> = None; // (k, t, worst age)
        for_each_row(path, reader, |line, r: FormationCsv| {
            let (t, k, id) = (r.t, r.k, r.id);
            let Some(state) = style::contact_index(&r.contact) else {
                bail!(
                    "{} line {line}: column contact: {:?} is none of {}",
                    path.display(),
                    r.contact,
                    CONTACT_STATES.map(|s| s.0).join(", ")
                );
            };
            let (age, slot) = (r.info_age_s, r.slot_error);
            let in_formation = match r.in_formation {
                1 => true,
                0 => false,
                other => bail!(
                    "{} line {line}: column in_formation: {other} is neither 0 nor 1",
                    path.display()
                ),
            };
            f.rows += 1;
            if tick.is_some_and(|(tk, _, _)| tk != k) {
                let (_, tt, worst) = tick.take().unwrap_or_default();
                f.worst_age.push(tt, worst);
            }
            let entry = tick.get_or_insert((k, t, f64::NAN));
            if let Some(a) = age {
                entry.2 = if entry.2.is_nan() { a } else { entry.2.max(a) };
            }
            let lane = f.lanes.entry(id).or_insert_with(|| Lane::new(cols, bucket));
            lane.seen[state] = true;
            lane.spread(&columns, state, t, dt);
            if let Some(age) = age {
                lane.age(&columns, t, age, dt);
            }
            lane.info_age.push(t, age.unwrap_or(f64::NAN));
            lane.slot_error.push(t, slot.unwrap_or(f64::NAN));
            if let Some(e) = slot {
                lane.max_slot_error = Some(lane.max_slot_error.map_or(e, |m| m.max(e)));
                if in_formation {
                    f.in_max = Some(f.in_max.map_or(e, |m| m.max(e)));
                } else if state != style::contact_index("dead").unwrap_or(usize::MAX) {
                    f.out_min = Some(f.out_min.map_or(e, |m| m.min(e)));
                }
            }
            Ok(())
        })?;
        if let Some((_, t, worst)) = tick {
            f.worst_age.push(t, worst);
        }
        Ok(f)
    }
}

/// `truth.csv`, decimated.
#[derive(Clone, Debug, Default)]
pub struct Truth {
    /// V of (II.2) from the true states ÷ V_U over time (s).
    pub v_true: Decimator,
    /// The coordinator's own V ÷ V_U over time (s).
    pub v_seen: Decimator,
    /// Nearest pair of live vehicles ÷ design spacing over time (s).
    pub min_pair: Decimator,
    /// Largest slot error ÷ spacing over time (s).
    pub max_slot: Decimator,
    /// Vehicles alive over time (s).
    pub n_alive: Decimator,
    /// Vehicles in formation over time (s).
    pub n_in_formation: Decimator,
    /// Largest true V ÷ V_U.
    pub max_v_true: f64,
    /// Largest seen V ÷ V_U.
    pub max_v_seen: f64,
    /// Smallest nearest-pair ratio and when (s).
    pub closest: Option<(f64, f64)>,
    /// The near-collision threshold (÷ spacing), from `summary.json`.
    pub near_collision: Option<f64>,
    /// Rows read.
    pub rows: u64,
}

impl Truth {
    /// Reads `truth.csv` from `reader` (`path` names it in errors), decimating in buckets of
    /// `bucket` rows.
    pub fn read(path: &Path, reader: impl Read, bucket: u64) -> Result<Self> {
        let mut tr = Truth::default();
        for d in [
            &mut tr.v_true,
            &mut tr.v_seen,
            &mut tr.min_pair,
            &mut tr.max_slot,
            &mut tr.n_alive,
            &mut tr.n_in_formation,
        ] {
            d.bucket = bucket;
        }
        for_each_row(path, reader, |_, r: TruthCsv| {
            let t = r.t;
            let nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
            let (vt, vs) = (r.V_true_over_VU, r.V_seen_over_VU);
            tr.v_true.push(t, nan(vt));
            tr.v_seen.push(t, nan(vs));
            tr.max_v_true = tr.max_v_true.max(vt.unwrap_or(0.0));
            tr.max_v_seen = tr.max_v_seen.max(vs.unwrap_or(0.0));
            let pair = r.min_pair_ratio;
            tr.min_pair.push(t, nan(pair));
            if let Some(p) = pair {
                if tr.closest.is_none_or(|(c, _)| p < c) {
                    tr.closest = Some((p, t));
                }
            }
            tr.max_slot.push(t, nan(r.max_slot_error));
            tr.n_alive.push(t, nan(r.n_alive));
            tr.n_in_formation.push(t, nan(r.n_in_formation));
            tr.rows += 1;
            Ok(())
        })?;
        Ok(tr)
    }
}
