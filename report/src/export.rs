//! `vbap export RUN_DIR --netcdf FILE.nc`: a run directory as one CF-1.8 NetCDF file, a
//! discrete sampling geometry of `featureType = "trajectory"` (CF 1.8 §9, appendix H.4.1,
//! the multidimensional array representation): one trajectory per vehicle and one for the
//! virtual body, every trajectory the mission's ticks long.
//!
//! - dimensions `trajectory` (N vehicles, then the body), `obs` (ticks), `name_strlen`;
//! - `trajectory(trajectory, name_strlen)`: `vehicle_<id>` or `body` (`cf_role =
//!   trajectory_id`); `time(trajectory, obs)`: seconds since the mission's start
//!   (`mission.start`, absent: 1970-01-01 stands for it, said in the variable's comment);
//! - positions `x`, `y` (and `z` in 3-D) in the mission's length unit: a vehicle's true
//!   position, the body's centre r; `lon`, `lat` (degrees) for a grid mission on a
//!   longitude/latitude grid (the inverse of the projection the mission used); `depth` (m,
//!   positive down) for diving gliders in metres;
//! - each vehicle's columns of `vehicles.csv` and `formation.csv` (fill on the body),
//!   the body's of `body.csv` and the truth per tick of `truth.csv` (fill on the vehicles);
//! - global attributes: the mission (its name, seed, the resolved `mission.toml`), the
//!   verdict of `summary.json` and the software.
//!
//! Missing values (a vehicle not yet started or killed, an empty CSV field, NaN) are the
//! variable's `_FillValue`. The file is written beside its name and renamed into place, so
//! an error never leaves half a file. Same run directory, same file, byte for byte.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};
use vbap_formats::write::{write_netcdf_with, NcAttr, NcData, NcVar};
use vbap_mission::config::Mission;
use vbap_mission::rundir::RunDir;
use vbap_wire::rundir::CONTACT_STATES;

use crate::InvalidRunDir;

/// The `_FillValue` of double variables (NetCDF's default double fill, `NC_FILL_DOUBLE`).
pub const FILL_F64: f64 = 9.969_209_968_386_869e36;
/// The `_FillValue` of the integer flags (NetCDF's default int fill, `NC_FILL_INT`).
pub const FILL_I32: i32 = -2_147_483_647;

/// What one export wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Exported {
    /// Trajectories: the vehicles, then the body.
    pub trajectories: usize,
    /// Observations per trajectory (ticks).
    pub ticks: usize,
    /// Data variables written (coordinates and names included).
    pub variables: usize,
}

/// One CSV file of the run directory, every field kept as text, by column name.
struct Table {
    header: Vec<String>,
    rows: Vec<csv::StringRecord>,
}

impl Table {
    fn read(path: &Path) -> Result<Table> {
        let mut reader = csv::ReaderBuilder::new()
            .flexible(true)
            .from_path(path)
            .map_err(|e| InvalidRunDir(format!("{}: {e}", path.display())))?;
        let header: Vec<String> = reader.headers()?.iter().map(str::to_string).collect();
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.with_context(|| format!("reading {}", path.display()))?;
            // A partial last line of an interrupted run has fewer fields: skipped.
            if record.len() == header.len() {
                rows.push(record);
            }
        }
        Ok(Table { header, rows })
    }

    fn column(&self, path: &Path, name: &str) -> Result<usize> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| InvalidRunDir(format!("{}: no column {name:?}", path.display())).into())
    }
}

/// A number of a CSV field; empty, `NaN` or unparsable text is missing.
fn number(text: &str) -> Option<f64> {
    text.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// The CF description of one column: long name, units (`None`: none), standard name.
struct Meaning {
    long_name: String,
    units: Option<String>,
    standard_name: Option<&'static str>,
}

/// The mission's length unit as UDUNITS text; `"1"` (dimensionless) for a non-dimensional
/// mission or a unit UDUNITS is not known to read.
fn length_units(unit: &str) -> String {
    match unit.trim() {
        u @ ("m" | "km" | "cm" | "mm" | "nmi") => u.into(),
        _ => "1".into(),
    }
}

/// The field label's unit, `"T (°C)"` → `degree_Celsius`; `None` when it names no unit
/// UDUNITS is known to read.
fn field_units(label: &str) -> Option<String> {
    let inner = label
        .rsplit_once('(')?
        .1
        .trim_end()
        .strip_suffix(')')?
        .trim();
    Some(match inner {
        "°C" | "degC" | "C" | "deg C" => "degree_Celsius".into(),
        "K" => "K".into(),
        "psu" | "PSU" | "g/kg" => "1e-3".into(),
        "m" | "km" | "dbar" | "Pa" | "mg m-3" | "mg/m3" | "µmol/kg" | "umol/kg" => inner
            .replace("µ", "u")
            .replace('/', " ")
            .replace("m3", "m-3"),
        _ => return None,
    })
}

/// What each column means; `length` and `time_unit` as UDUNITS text.
fn meaning(column: &str, mission: &Mission) -> Meaning {
    let length = length_units(&mission.mission.length_unit);
    let speed = if length == "1" {
        "1".to_string()
    } else {
        format!("{length} s-1")
    };
    let m = |long: &str, units: Option<&str>| Meaning {
        long_name: long.into(),
        units: units.map(str::to_string),
        standard_name: None,
    };
    let axis = column.chars().last().unwrap_or('x');
    match column {
        "measurement" => Meaning {
            long_name: format!(
                "{} read by the vehicle's sensor",
                mission.mission.field_label
            ),
            units: field_units(&mission.mission.field_label),
            standard_name: None,
        },
        "vx" | "vy" | "vz" => m(&format!("velocity over the ground, {axis}"), Some(&speed)),
        "bx" | "by" | "bz" => m(
            &format!("believed position (dead reckoning), {axis}"),
            Some(&length),
        ),
        "wx" | "wy" | "wz" => m(&format!("velocity through the water, {axis}"), Some(&speed)),
        "cx" | "cy" | "cz" => m(
            &format!("current at the true position, {axis}"),
            Some(&speed),
        ),
        "info_age_s" => m(
            "age of the coordinator's newest report of the vehicle",
            Some("s"),
        ),
        "slot_error" => m("true distance from its slot / design spacing", Some("1")),
        "nearest_ratio" => m(
            "true distance to the nearest live vehicle / design spacing",
            Some("1"),
        ),
        "s" => m("path parameter s of the virtual body (IV.4)", Some(&length)),
        "sdot" => m("ds/dt of the virtual body (IV.4)", Some(&speed)),
        "scale" => m("formation scale k (expansion factor, V.7)", Some("1")),
        "grad_x" | "grad_y" | "grad_z" => m(
            &format!("estimated gradient of the field, {axis} (Lemma 5.1)"),
            None,
        ),
        "true_grad_x" | "true_grad_y" | "true_grad_z" => {
            m(&format!("true gradient of the field at r, {axis}"), None)
        }
        "V" => m(
            "artificial potential V of the formation (II.2), as the coordinator sees it",
            Some("1"),
        ),
        "n_vehicles" => m(
            "vehicles the coordinator counts in the formation",
            Some("1"),
        ),
        "p_trace" => m("trace of the Kalman covariance P (Sec. V)", None),
        "V_true_over_VU" => m("V (II.2) of the true states / V_U", Some("1")),
        "V_seen_over_VU" => m("V (II.2) the coordinator computed / V_U", Some("1")),
        "min_pair_ratio" => m(
            "least true distance between live vehicles / design spacing",
            Some("1"),
        ),
        "max_slot_error" => m(
            "largest true slot error of a live vehicle / design spacing",
            Some("1"),
        ),
        "n_alive" => m("vehicles alive", Some("1")),
        "n_in_formation" => m("vehicles within the in-formation slot error", Some("1")),
        "sdot_over_v0" => m("ds/dt (IV.4) / v0", Some("1")),
        other => m(other, None),
    }
}

/// The double variables, each `[trajectory * ticks + k]` (NaN: missing), in the order
/// first asked for.
struct Grids {
    cells: usize,
    ticks: usize,
    vars: Vec<(String, Vec<f64>)>,
}

impl Grids {
    fn new(trajectories: usize, ticks: usize) -> Grids {
        Grids {
            cells: trajectories * ticks,
            ticks,
            vars: Vec::new(),
        }
    }

    /// The variable `name`, added (all missing) if new.
    fn index(&mut self, name: &str) -> usize {
        if let Some(i) = self.vars.iter().position(|(n, _)| n == name) {
            return i;
        }
        self.vars
            .push((name.to_string(), vec![f64::NAN; self.cells]));
        self.vars.len() - 1
    }

    fn values(&self, name: &str) -> &[f64] {
        let i = self.vars.iter().position(|(n, _)| n == name);
        i.map_or(&[], |i| &self.vars[i].1)
    }

    /// Every column of `table` but those `skip` names, each into the variable `rename`
    /// names, at the (trajectory, tick) `place` gives each row (None: the row is skipped).
    fn fill(
        &mut self,
        table: &Table,
        skip: impl Fn(&str) -> bool,
        rename: fn(&str) -> &str,
        place: impl Fn(&csv::StringRecord) -> Option<(usize, usize)>,
    ) {
        let columns: Vec<(usize, usize)> = table
            .header
            .iter()
            .enumerate()
            .filter(|(_, c)| !skip(c))
            .map(|(i, c)| (i, self.index(rename(c))))
            .collect();
        for r in &table.rows {
            let Some((traj, k)) = place(r).filter(|&(_, k)| k < self.ticks) else {
                continue;
            };
            for &(i, v) in &columns {
                self.vars[v].1[traj * self.ticks + k] = number(&r[i]).unwrap_or(f64::NAN);
            }
        }
    }
}

/// A column keeps its name.
fn same(column: &str) -> &str {
    column
}

/// The body's centre r is the body trajectory's position.
fn body_column(column: &str) -> &str {
    match column {
        "rx" => "x",
        "ry" => "y",
        "rz" => "z",
        other => other,
    }
}

/// Writes `run_dir` as a CF-1.8 trajectory NetCDF file at `out` (see the module
/// documentation). A run directory that is not one, or lacks a file, is an
/// [`InvalidRunDir`].
pub fn export_netcdf(run_dir: &Path, out: &Path) -> Result<Exported> {
    let dir = RunDir {
        root: run_dir.to_path_buf(),
    };
    for file in [dir.mission(), dir.body(), dir.vehicles()] {
        if !file.is_file() {
            return Err(InvalidRunDir(format!(
                "{}: not a run directory (no {})",
                run_dir.display(),
                file.file_name().map_or("?".into(), |n| n.to_string_lossy())
            ))
            .into());
        }
    }
    let mission = Mission::load(&dir.mission())
        .map_err(|e| InvalidRunDir(format!("{}: {e:#}", dir.mission().display())))?;
    let body = Table::read(&dir.body())?;
    let vehicles = Table::read(&dir.vehicles())?;
    let optional =
        |path: std::path::PathBuf| path.is_file().then(|| Table::read(&path)).transpose();
    let formation = optional(dir.formation())?;
    let truth = optional(dir.truth())?;

    // The ticks: every k of body.csv (one row per tick), their times.
    let (bk, bt) = (
        body.column(&dir.body(), "k")?,
        body.column(&dir.body(), "t")?,
    );
    let mut times: BTreeMap<usize, f64> = BTreeMap::new();
    for r in &body.rows {
        if let (Some(k), Some(t)) = (number(&r[bk]), number(&r[bt])) {
            times.insert(k as usize, t);
        }
    }
    let ticks = times.keys().next_back().map_or(0, |k| k + 1);
    if ticks == 0 {
        return Err(InvalidRunDir(format!("{}: no tick", dir.body().display())).into());
    }
    let (vk, vid) = (
        vehicles.column(&dir.vehicles(), "k")?,
        vehicles.column(&dir.vehicles(), "id")?,
    );
    let max_id = vehicles
        .rows
        .iter()
        .filter_map(|r| number(&r[vid]))
        .fold(0.0, f64::max) as usize;
    let n = mission.vehicles.count.max(max_id + 1);
    let body_row = n;
    let rows = n + 1;
    let cell = |traj: usize, k: usize| traj * ticks + k;
    let dim = mission.mission.dim;
    let axes: &[&str] = if dim == 3 {
        &["x", "y", "z"]
    } else {
        &["x", "y"]
    };
    // (id, k) of a vehicle's row; (the body, k) of a tick's.
    let vehicle_at = |id_col: usize, k_col: usize| {
        move |r: &csv::StringRecord| {
            let (k, id) = (number(&r[k_col])? as usize, number(&r[id_col])? as usize);
            (id < n).then_some((id, k))
        }
    };
    let body_at =
        |k_col: usize| move |r: &csv::StringRecord| Some((body_row, number(&r[k_col])? as usize));

    let mut vars: Vec<NcVar> = Vec::new();
    let mut grids = Grids::new(rows, ticks);
    // Positions first: the vehicles' true x, y (z), the body's r.
    for a in axes {
        grids.index(a);
    }
    let flat = |c: &str| dim == 2 && c.ends_with('z');
    grids.fill(
        &vehicles,
        |c| matches!(c, "t" | "k" | "id") || flat(c),
        same,
        vehicle_at(vid, vk),
    );
    grids.fill(
        &body,
        |c| matches!(c, "t" | "k") || flat(c),
        body_column,
        body_at(bk),
    );
    // The truth per tick, on the body trajectory.
    if let Some(truth) = &truth {
        let tk = truth.column(&dir.truth(), "k")?;
        grids.fill(truth, |c| matches!(c, "t" | "k"), same, body_at(tk));
    }
    // Each vehicle's true formation: numbers, and two integer flags.
    let mut contact = vec![FILL_I32; rows * ticks];
    let mut in_formation = vec![FILL_I32; rows * ticks];
    if let Some(f) = &formation {
        let path = dir.formation();
        let (fk, fid, fc, fin) = (
            f.column(&path, "k")?,
            f.column(&path, "id")?,
            f.column(&path, "contact")?,
            f.column(&path, "in_formation")?,
        );
        let skip = |c: &str| matches!(c, "t" | "k" | "id" | "contact" | "in_formation");
        grids.fill(f, skip, same, vehicle_at(fid, fk));
        let at = vehicle_at(fid, fk);
        for r in &f.rows {
            let Some((id, k)) = at(r).filter(|&(_, k)| k < ticks) else {
                continue;
            };
            if let Some(s) = CONTACT_STATES.iter().position(|s| *s == &r[fc]) {
                contact[cell(id, k)] = s as i32;
            }
            if let Some(v) = number(&r[fin]) {
                in_formation[cell(id, k)] = v as i32;
            }
        }
    }

    // Coordinates.
    let names: Vec<String> = (0..n)
        .map(|i| format!("vehicle_{i}"))
        .chain(["body".to_string()])
        .collect();
    let strlen = names.iter().map(String::len).max().unwrap_or(4);
    let mut chars = vec![0u8; rows * strlen];
    for (i, name) in names.iter().enumerate() {
        chars[i * strlen..i * strlen + name.len()].copy_from_slice(name.as_bytes());
    }
    vars.push(NcVar::new(
        "trajectory",
        &["trajectory", "name_strlen"],
        NcData::Char(chars),
        &[
            ("cf_role", "trajectory_id"),
            (
                "long_name",
                "vehicle_<id>, or body: the virtual body (Sec. IV)",
            ),
        ],
    ));
    let start = mission.mission.start.clone();
    let mut time = vec![FILL_F64; rows * ticks];
    for traj in 0..rows {
        for (k, t) in &times {
            time[cell(traj, *k)] = *t;
        }
    }
    let mut time_var = NcVar::new(
        "time",
        &["trajectory", "obs"],
        NcData::F64(time),
        &[
            ("standard_name", "time"),
            ("long_name", "mission time of the tick"),
            ("axis", "T"),
            ("calendar", "standard"),
        ],
    );
    let units = match &start {
        Some(s) => format!("seconds since {s}"),
        None => {
            time_var.attrs.push((
                "comment".into(),
                NcAttr::Text(
                    "the mission has no start date (mission.start): 1970-01-01 stands for its start"
                        .into(),
                ),
            ));
            "seconds since 1970-01-01T00:00:00Z".into()
        }
    };
    time_var.attrs.push(("units".into(), NcAttr::Text(units)));
    vars.push(time_var);

    let mut coordinates = "time".to_string();
    let length = length_units(&mission.mission.length_unit);
    // Longitude and latitude of a mission on a geographic grid.
    let origin = mission.field.grid.0.as_ref().and_then(|g| g.origin);
    if let Some([lon0, lat0]) = origin {
        let (x, y) = (grids.values("x"), grids.values("y"));
        let mut lon = vec![FILL_F64; rows * ticks];
        let mut lat = vec![FILL_F64; rows * ticks];
        for i in 0..rows * ticks {
            if x[i].is_finite() && y[i].is_finite() {
                (lon[i], lat[i]) =
                    vbap_math::gridmath::equirectangular_inverse(x[i], y[i], lon0, lat0);
            }
        }
        for (name, data, std, units, axis) in [
            ("lon", lon, "longitude", "degrees_east", "X"),
            ("lat", lat, "latitude", "degrees_north", "Y"),
        ] {
            let mut v = NcVar::new(
                name,
                &["trajectory", "obs"],
                NcData::F64(data),
                &[
                    ("standard_name", std),
                    ("units", units),
                    ("axis", axis),
                    ("long_name", "true position (inverse of the mission's equirectangular projection about field.origin)"),
                ],
            );
            v.attrs.push(("_FillValue".into(), NcAttr::F64(FILL_F64)));
            vars.push(v);
        }
        coordinates.push_str(" lat lon");
    }
    // Depth of diving gliders.
    if dim == 3 && mission.vehicles.dive_depth.is_some() && length == "m" {
        let z = grids.values("z");
        let depth: Vec<f64> = z
            .iter()
            .map(|z| if z.is_finite() { -z } else { FILL_F64 })
            .collect();
        let mut v = NcVar::new(
            "depth",
            &["trajectory", "obs"],
            NcData::F64(depth),
            &[
                ("standard_name", "depth"),
                ("units", "m"),
                ("positive", "down"),
                ("axis", "Z"),
                ("long_name", "depth below the surface (−z)"),
            ],
        );
        v.attrs.push(("_FillValue".into(), NcAttr::F64(FILL_F64)));
        vars.push(v);
        coordinates.push_str(" depth");
    }

    // The double variables.
    for (name, values) in grids.vars {
        let data: Vec<f64> = values
            .iter()
            .map(|v| if v.is_finite() { *v } else { FILL_F64 })
            .collect();
        let meaning = if axes.contains(&name.as_str()) {
            Meaning {
                long_name: format!(
                    "true position {name} in the mission frame (vehicles), body centre r (body)"
                ),
                units: Some(length.clone()),
                standard_name: None,
            }
        } else {
            meaning(&name, &mission)
        };
        let mut v = NcVar::new(&name, &["trajectory", "obs"], NcData::F64(data), &[]);
        v.attrs
            .push(("long_name".into(), NcAttr::Text(meaning.long_name)));
        if let Some(s) = meaning.standard_name {
            v.attrs
                .push(("standard_name".into(), NcAttr::Text(s.into())));
        }
        if let Some(u) = meaning.units {
            v.attrs.push(("units".into(), NcAttr::Text(u)));
        }
        v.attrs.push(("_FillValue".into(), NcAttr::F64(FILL_F64)));
        v.attrs
            .push(("coordinates".into(), NcAttr::Text(coordinates.clone())));
        vars.push(v);
    }
    if formation.is_some() {
        let flag = |name: &str, data: Vec<i32>, long: &str, values: Vec<i32>, meanings: &str| {
            let mut v = NcVar::new(name, &["trajectory", "obs"], NcData::I32(data), &[]);
            v.attrs.extend([
                ("long_name".into(), NcAttr::Text(long.into())),
                ("_FillValue".into(), NcAttr::I32(vec![FILL_I32])),
                ("flag_values".into(), NcAttr::I32(values)),
                ("flag_meanings".into(), NcAttr::Text(meanings.into())),
                ("coordinates".into(), NcAttr::Text(coordinates.clone())),
            ]);
            v
        };
        vars.push(flag(
            "contact",
            contact,
            "the vehicle's link to the coordinator",
            (0..CONTACT_STATES.len() as i32).collect(),
            &CONTACT_STATES.join(" "),
        ));
        vars.push(flag(
            "in_formation",
            in_formation,
            "alive and within the in-formation slot error",
            vec![0, 1],
            "out in",
        ));
    }

    let globals = global_attributes(&dir, &mission)?;
    let count = vars.len();
    let partial = out.with_extension("nc.partial");
    write_netcdf_with(
        &partial,
        true,
        &[
            ("trajectory", rows),
            ("obs", ticks),
            ("name_strlen", strlen),
        ],
        &vars,
        &globals,
    )
    .with_context(|| format!("writing {}", partial.display()))?;
    std::fs::rename(&partial, out).with_context(|| format!("renaming to {}", out.display()))?;
    Ok(Exported {
        trajectories: rows,
        ticks,
        variables: count,
    })
}

/// The file's global attributes: CF, the mission, the verdict, the software.
fn global_attributes(dir: &RunDir, mission: &Mission) -> Result<Vec<(String, NcAttr)>> {
    let text = |k: &str, v: String| (k.to_string(), NcAttr::Text(v));
    let mut g = vec![
        text("Conventions", "CF-1.8".into()),
        text("featureType", "trajectory".into()),
        text(
            "title",
            format!("vbap run of mission {}", mission.mission.name),
        ),
        text(
            "source",
            format!(
                "vbap {} (virtual bodies and artificial potentials, Ögren, Fiorelli and Leonard, IEEE TAC 2004)",
                env!("CARGO_PKG_VERSION")
            ),
        ),
        text("history", "vbap export --netcdf of a run directory".into()),
        text("mission_name", mission.mission.name.clone()),
        text("mission_seed", mission.mission.seed.to_string()),
        text("mission_length_unit", mission.mission.length_unit.clone()),
        text("mission_field_label", mission.mission.field_label.clone()),
    ];
    if let Ok(summary) = std::fs::read_to_string(dir.summary()) {
        if let Ok(s) = serde_json::from_str::<serde_json::Value>(&summary) {
            if let Some(v) = s.get("verdict").and_then(|v| v.as_str()) {
                g.push(text("verdict", v.into()));
            }
            if let Some(v) = s.get("converged").and_then(|v| v.as_bool()) {
                g.push(text("converged", v.to_string()));
            }
        }
    }
    let toml = std::fs::read_to_string(dir.mission())
        .with_context(|| format!("reading {}", dir.mission().display()))?;
    g.push(text("mission_toml", toml));
    Ok(g)
}

#[cfg(test)]
#[path = "export/tests.rs"]
mod tests;
