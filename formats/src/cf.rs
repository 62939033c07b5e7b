//! Which dimension of a variable is x, y, z or time: named by the mission (`field.x`, ...)
//! or found from the CF attributes `axis`, `standard_name` and `units` of its coordinate
//! variable (or, last, a conventional name); and the units of each axis.

use crate::var::{Coord, RawVar};
use crate::GridError;

/// The role of a dimension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Easting or longitude.
    X,
    /// Northing or latitude.
    Y,
    /// Vertical.
    Z,
    /// Time.
    T,
}

/// The coordinate names a mission gives (`field.x`, `field.y`, `field.z`, `field.time`).
#[derive(Clone, Debug, Default)]
pub struct AxisNames {
    /// `field.x`.
    pub x: Option<String>,
    /// `field.y`.
    pub y: Option<String>,
    /// `field.z`.
    pub z: Option<String>,
    /// `field.time`.
    pub time: Option<String>,
}

impl AxisNames {
    /// Array names that may hold the coordinate of the bare dimension `dim` (`x`, `y`, `z`,
    /// `time`) of a NumPy archive: the mission's name, or the conventional ones.
    pub fn candidates(&self, dim: &str) -> Vec<String> {
        let (given, usual): (&Option<String>, &[&str]) = match dim {
            "x" => (&self.x, &["x", "lon", "longitude"]),
            "y" => (&self.y, &["y", "lat", "latitude"]),
            "z" => (&self.z, &["z", "depth", "lev", "level"]),
            _ => (&self.time, &["time", "t"]),
        };
        match given {
            Some(n) => vec![n.clone()],
            None => usual.iter().map(|s| s.to_string()).collect(),
        }
    }

    fn named(&self, name: &str) -> Option<Role> {
        [
            (&self.x, Role::X),
            (&self.y, Role::Y),
            (&self.z, Role::Z),
            (&self.time, Role::T),
        ]
        .into_iter()
        .find(|(n, _)| n.as_deref() == Some(name))
        .map(|(_, r)| r)
    }
}

/// How a coordinate's values become mission units: metres (or the mission's length unit),
/// degrees (projected later) or seconds from the first time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Units {
    /// Length: multiply by this to get metres (1 for metres or no units).
    Length(f64),
    /// Degrees east (longitude).
    DegreesEast,
    /// Degrees north (latitude).
    DegreesNorth,
    /// Time: multiply by this to get seconds.
    Time(f64),
}

fn time_factor(unit: &str) -> Option<f64> {
    match unit {
        "s" | "sec" | "secs" | "second" | "seconds" => Some(1.0),
        "min" | "mins" | "minute" | "minutes" => Some(60.0),
        "h" | "hr" | "hrs" | "hour" | "hours" => Some(3600.0),
        "d" | "day" | "days" => Some(86400.0),
        _ => None,
    }
}

/// The units of `c` in role `role`, or an error naming them.
pub fn units(c: &Coord, role: Role, path: &std::path::Path) -> Result<Units, GridError> {
    let u = c.units.trim();
    let lower = u.to_lowercase();
    let unknown = || {
        GridError::new(
            path,
            &c.name,
            format!("unknown units {u:?} for the {role:?} axis"),
        )
    };
    if role == Role::T {
        let unit = lower.split(" since ").next().unwrap_or("").trim();
        return match (unit, time_factor(unit)) {
            ("", _) => Ok(Units::Time(1.0)),
            (_, Some(f)) => Ok(Units::Time(f)),
            _ => Err(unknown()),
        };
    }
    let east = [
        "degrees_east",
        "degree_east",
        "degrees_e",
        "degree_e",
        "degreese",
    ];
    let north = [
        "degrees_north",
        "degree_north",
        "degrees_n",
        "degree_n",
        "degreesn",
    ];
    match lower.as_str() {
        l if east.contains(&l) => Ok(Units::DegreesEast),
        l if north.contains(&l) => Ok(Units::DegreesNorth),
        "degrees" | "degree" if role == Role::X => Ok(Units::DegreesEast),
        "degrees" | "degree" if role == Role::Y => Ok(Units::DegreesNorth),
        "" | "m" | "meter" | "meters" | "metre" | "metres" => Ok(Units::Length(1.0)),
        "km" | "kilometer" | "kilometers" | "kilometre" | "kilometres" => Ok(Units::Length(1000.0)),
        _ => Err(unknown()),
    }
}

/// The role of a coordinate from its CF attributes and name, if they tell.
fn role_of(c: &Coord) -> Option<Role> {
    let by_axis = match c.axis.as_str() {
        "X" => Some(Role::X),
        "Y" => Some(Role::Y),
        "Z" => Some(Role::Z),
        "T" => Some(Role::T),
        _ => None,
    };
    let sn = c.standard_name.as_str();
    let by_standard = match sn {
        "longitude" | "grid_longitude" | "projection_x_coordinate" => Some(Role::X),
        "latitude" | "grid_latitude" | "projection_y_coordinate" => Some(Role::Y),
        "depth" | "altitude" | "height" | "air_pressure" => Some(Role::Z),
        "time" => Some(Role::T),
        _ => None,
    };
    let u = c.units.to_lowercase();
    let by_units = if u.contains(" since ") {
        Some(Role::T)
    } else if u.starts_with("degree") && (u.ends_with("east") || u.ends_with("_e")) {
        Some(Role::X)
    } else if u.starts_with("degree") && (u.ends_with("north") || u.ends_with("_n")) {
        Some(Role::Y)
    } else if !c.positive.is_empty() {
        Some(Role::Z)
    } else {
        None
    };
    let n = c.name.to_lowercase();
    let by_name = match n.as_str() {
        "x" | "lon" | "longitude" | "nav_lon" => Some(Role::X),
        "y" | "lat" | "latitude" | "nav_lat" => Some(Role::Y),
        "z" | "depth" | "lev" | "level" | "deptht" => Some(Role::Z),
        "t" | "time" | "time_counter" => Some(Role::T),
        _ => None,
    };
    by_axis.or(by_standard).or(by_units).or(by_name)
}

/// The role of each dimension of `var`, or an error naming the dimension that cannot be told
/// or the role given twice.
pub fn roles(
    var: &RawVar,
    names: &AxisNames,
    dim: usize,
    path: &std::path::Path,
) -> Result<Vec<Role>, GridError> {
    let mut out = Vec::with_capacity(var.dims.len());
    for (k, d) in var.dims.iter().enumerate() {
        let coord = var.coords[k].as_ref();
        let role = if var.bare {
            // NumPy: dimensions by rank; a 3-D array is (z, y, x) in 3-D missions and
            // (time, y, x) in 2-D ones.
            match d.as_str() {
                "x" => Some(Role::X),
                "y" => Some(Role::Y),
                "z" if dim == 2 && var.dims.len() == 3 => Some(Role::T),
                "z" => Some(Role::Z),
                _ => Some(Role::T),
            }
        } else {
            names
                .named(d)
                .or_else(|| coord.and_then(|c| names.named(&c.name)))
                .or_else(|| coord.and_then(role_of))
        };
        let role = role.ok_or_else(|| {
            GridError::new(
                path,
                &var.name,
                format!(
                    "cannot tell which axis dimension {d:?} is (no coordinate variable with \
                     axis, standard_name or units): name it with field.x, field.y, field.z or field.time"
                ),
            )
        })?;
        if out.contains(&role) {
            return Err(GridError::new(
                path,
                &var.name,
                format!("two dimensions are the {role:?} axis (the second is {d:?})"),
            ));
        }
        out.push(role);
    }
    Ok(out)
}
