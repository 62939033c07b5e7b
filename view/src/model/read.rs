//! Reading the run directory's files into the [`Model`]: each CSV file by column name,
//! in the order the coordinator flushes them.

use std::path::PathBuf;

use anyhow::Result;
use vbap_math::formation::design_regular;
use vbap_wire::rundir::RunDir;

use super::{contact_code, Body, Event, Model, Tick, Truth, Vehicle};
use crate::tail::{Columns, Polled, Row, Tail};

/// A CSV file followed by column name.
pub(super) struct CsvFile {
    pub(super) tail: Tail,
    pub(super) required: &'static [&'static str],
    pub(super) columns: Option<Columns>,
    /// The last tick a row was read of.
    pub(super) last_k: Option<u64>,
}

impl CsvFile {
    fn new(path: PathBuf, required: &'static [&'static str]) -> Self {
        Self {
            tail: Tail::new(&path),
            required,
            columns: None,
            last_k: None,
        }
    }
}

/// The run directory's files, as read so far.
pub(super) struct Files {
    pub(super) vehicles: CsvFile,
    pub(super) body: CsvFile,
    pub(super) formation: CsvFile,
    pub(super) truth: CsvFile,
    pub(super) events: Tail,
    pub(super) summary: PathBuf,
}

impl Files {
    pub(super) fn new(dir: &RunDir) -> Self {
        Self {
            vehicles: CsvFile::new(dir.vehicles(), &["t", "k", "id", "x", "y"]),
            body: CsvFile::new(dir.body(), &["t", "k", "rx", "ry", "scale", "n_vehicles"]),
            formation: CsvFile::new(
                dir.formation(),
                &["t", "k", "id", "contact", "info_age_s", "slot_error"],
            ),
            truth: CsvFile::new(
                dir.truth(),
                &["t", "k", "V_true_over_VU", "V_seen_over_VU", "sdot_over_v0"],
            ),
            events: Tail::new(&dir.events()),
            summary: dir.summary(),
        }
    }
}

impl Model {
    fn tick_mut(&mut self, k: u64, t: f64) -> &mut Tick {
        let k = k as usize;
        if self.ticks.len() <= k {
            self.ticks.resize_with(k + 1, Tick::default);
        }
        let tick = &mut self.ticks[k];
        tick.t = t;
        tick
    }

    pub(super) fn read_vehicles(&mut self) -> Result<bool> {
        let mut rows = Vec::new();
        let shrunk = read_csv(
            &mut self.files.vehicles,
            |c, r| {
                let id = r.num(c.index("id"))? as u32;
                let at = (id, r.num(c.index("x"))?, r.num(c.index("y"))?);
                Some((r.num(c.index("k"))?, r.num(c.index("t"))?, at))
            },
            &mut rows,
        )?;
        for (k, t, (id, x, y)) in rows {
            let i = id as usize;
            if self.last_pos.len() <= i {
                self.last_pos.resize(i + 1, None);
            }
            self.last_pos[i] = Some((x, y));
            self.tick_mut(k, t).vehicles.push(Vehicle {
                id,
                x,
                y,
                contact: 6,
                age: None,
                slot_error: None,
            });
        }
        Ok(shrunk)
    }

    pub(super) fn read_body(&mut self) -> Result<bool> {
        let mut rows = Vec::new();
        let shrunk = read_csv(
            &mut self.files.body,
            |c, r| {
                let grad = |a: &str| r.num(c.index(a));
                let grad_error = match (
                    grad("grad_x"),
                    grad("grad_y"),
                    grad("true_grad_x"),
                    grad("true_grad_y"),
                ) {
                    (Some(gx), Some(gy), Some(tx), Some(ty)) => {
                        let gz = grad("grad_z").unwrap_or(0.0) - grad("true_grad_z").unwrap_or(0.0);
                        Some(((gx - tx).powi(2) + (gy - ty).powi(2) + gz.powi(2)).sqrt())
                    }
                    _ => None,
                };
                let body = Body {
                    x: r.num(c.index("rx"))?,
                    y: r.num(c.index("ry"))?,
                    scale: r.num(c.index("scale"))?,
                    n_vehicles: r.num(c.index("n_vehicles"))? as usize,
                    grad_error,
                };
                Some((r.num(c.index("k"))?, r.num(c.index("t"))?, body))
            },
            &mut rows,
        )?;
        for (k, t, body) in rows {
            if !self.designs.contains_key(&body.n_vehicles) {
                let m = &self.mission;
                let design = design_regular(
                    body.n_vehicles,
                    m.mission.dim,
                    m.formation.radius,
                    m.formation.alpha,
                    m.formation.alpha,
                )
                .ok();
                self.designs.insert(body.n_vehicles, design);
            }
            self.tick_mut(k, t).body = Some(body);
        }
        Ok(shrunk)
    }

    pub(super) fn read_formation(&mut self) -> Result<bool> {
        let mut rows = Vec::new();
        let shrunk = read_csv(
            &mut self.files.formation,
            |c, r| {
                let row = (
                    r.num(c.index("id"))? as u32,
                    contact_code(r.text(c.index("contact"))?),
                    r.num(c.index("info_age_s")),
                    r.num(c.index("slot_error")),
                );
                Some((r.num(c.index("k"))?, r.num(c.index("t"))?, row))
            },
            &mut rows,
        )?;
        for (k, t, (id, contact, age, slot_error)) in rows {
            let last = self.last_pos.get(id as usize).copied().flatten();
            let tick = self.tick_mut(k, t);
            match tick.vehicles.iter_mut().find(|v| v.id == id) {
                Some(v) => {
                    v.contact = contact;
                    v.age = age;
                    v.slot_error = slot_error;
                }
                // No true state this tick (dead, or a paced state that missed its
                // deadline): where it was last seen.
                None => {
                    if let Some((x, y)) = last {
                        tick.vehicles.push(Vehicle {
                            id,
                            x,
                            y,
                            contact,
                            age,
                            slot_error,
                        });
                        tick.vehicles.sort_by_key(|v| v.id);
                    }
                }
            }
        }
        Ok(shrunk)
    }

    pub(super) fn read_truth(&mut self) -> Result<bool> {
        let mut rows = Vec::new();
        let shrunk = read_csv(
            &mut self.files.truth,
            |c, r| {
                let truth = Truth {
                    v_true: r.num(c.index("V_true_over_VU")),
                    v_seen: r.num(c.index("V_seen_over_VU")),
                    sdot: r.num(c.index("sdot_over_v0")),
                };
                Some((r.num(c.index("k"))?, r.num(c.index("t"))?, truth))
            },
            &mut rows,
        )?;
        for (k, t, truth) in rows {
            self.tick_mut(k, t).truth = Some(truth);
        }
        Ok(shrunk)
    }

    pub(super) fn read_events(&mut self) -> Result<bool> {
        let lines = match self.files.events.poll()? {
            Polled::Shrunk => return Ok(true),
            Polled::Lines(l) => l,
        };
        for line in lines {
            let Ok(e) = serde_json::from_str::<vbap_wire::rundir::Event>(&line) else {
                continue;
            };
            if e.kind == "link_drop" {
                self.link_drops += 1;
                continue;
            }
            let why = ["why", "cause"]
                .iter()
                .find_map(|key| e.detail.get(key).and_then(|v| v.as_str()))
                .map(str::to_owned);
            self.events.push(Event {
                t: e.t,
                k: e.k,
                kind: e.kind,
                vehicle: e.vehicle,
                why,
            });
        }
        Ok(false)
    }
}

/// Reads the new rows of `file` through `parse` (by column name) into `out`, the header
/// first; a row `parse` cannot read (a partial line) is skipped. True when the file shrank.
fn read_csv<T>(
    file: &mut CsvFile,
    parse: impl Fn(&Columns, &Row) -> Option<(f64, f64, T)>,
    out: &mut Vec<(u64, f64, T)>,
) -> Result<bool>
where
    T: Sized,
{
    let lines = match file.tail.poll()? {
        Polled::Shrunk => return Ok(true),
        Polled::Lines(l) => l,
    };
    let mut lines = lines.iter();
    if file.columns.is_none() {
        let Some(header) = lines.next() else {
            return Ok(false);
        };
        file.columns = Some(Columns::parse(file.tail.path(), header, file.required)?);
    }
    let columns = file.columns.as_ref().expect("header read");
    for line in lines {
        let Some(row) = Row::split(line, columns) else {
            continue;
        };
        if let Some((k, t, value)) = parse(columns, &row) {
            file.last_k = Some(k as u64);
            out.push((k as u64, t, value));
        }
    }
    Ok(false)
}
