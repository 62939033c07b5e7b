//! NetCDF-4 (HDF5) files, read in pure Rust by `netcdf-reader` (only with the `netcdf4`
//! feature): the same [`RawVar`] as a classic file gives, so everything after the reading
//! (axes, units, projection, land, interpolation) is shared. Variables of the root group.

use std::path::Path;

use netcdf_reader::{NcAttrValue, NcFile, NcType, NcVariable};

use crate::read::{pick, unpack};
use crate::var::{Coord, RawVar};
use crate::GridError;

/// The first number of attribute `name` of `v`, whatever its type.
fn number(v: &NcVariable, name: &str) -> Option<f64> {
    v.attribute(name).and_then(|a| a.value.as_f64())
}

/// The text of attribute `name` of `v` (empty if absent or not text).
fn text(v: &NcVariable, name: &str) -> String {
    v.attribute(name)
        .and_then(|a| match &a.value {
            NcAttrValue::Chars(s) => Some(s.clone()),
            other => other.as_string(),
        })
        .map(|s| s.trim_end_matches('\0').trim().to_string())
        .unwrap_or_default()
}

/// Values of variable `v` as f64, `fill` values as NaN (compared in the file's own type, as
/// for classic files: an f32 fill is compared as f32).
fn values(file: &NcFile, v: &NcVariable, fill: &[f64]) -> Result<Vec<f64>, String> {
    let data = file
        .read_variable_as_f64(&v.name)
        .map_err(|e| format!("cannot read ({e})"))?;
    let as_f32 = v.dtype == NcType::Float;
    let is_fill = |x: f64| {
        if as_f32 {
            fill.iter().any(|f| *f as f32 == x as f32)
        } else {
            fill.contains(&x)
        }
    };
    Ok(data
        .iter()
        .map(|x| if is_fill(*x) { f64::NAN } else { *x })
        .collect())
}

/// Reads `variable` (or, when `None`, the only variable of rank ≥ 2) of a NetCDF-4 file with
/// its coordinate variables; CF packing (`scale_factor`, `add_offset`) is applied.
pub fn netcdf4(path: &Path, variable: Option<&str>) -> Result<RawVar, GridError> {
    let fail = |variable: &str, what: String| GridError::new(path, variable, what);
    let file = NcFile::open(path).map_err(|e| {
        fail(
            variable.unwrap_or("-"),
            format!("not a readable NetCDF-4 file ({e})"),
        )
    })?;
    let vars = file
        .variables()
        .map_err(|e| fail("-", format!("cannot list the variables ({e})")))?;
    let name = match variable {
        Some(v) => v.to_string(),
        None => pick(vars.iter().filter(|v| v.ndim() >= 2).map(|v| v.name()))
            .map_err(|what| fail("-", format!("{what}: name field.variable")))?,
    };
    let var = vars.iter().find(|v| v.name == name).ok_or_else(|| {
        let all: Vec<&str> = vars.iter().map(|v| v.name()).collect();
        fail(
            &name,
            format!("missing variable (the file has {})", all.join(", ")),
        )
    })?;
    let dims: Vec<String> = var.dimensions.iter().map(|d| d.name.clone()).collect();
    let shape: Vec<usize> = var.dimensions.iter().map(|d| d.size as usize).collect();
    let fill: Vec<f64> = ["_FillValue", "missing_value"]
        .iter()
        .filter_map(|a| number(var, a))
        .collect();
    let mut data = values(&file, var, &fill).map_err(|e| fail(&name, e))?;
    unpack(
        &mut data,
        number(var, "scale_factor"),
        number(var, "add_offset"),
    );
    let mut coords = Vec::with_capacity(dims.len());
    for d in &dims {
        let Some(c) = vars.iter().find(|v| &v.name == d && v.ndim() == 1) else {
            coords.push(None);
            continue;
        };
        let values = values(&file, c, &[])
            .map_err(|e| fail(d, format!("cannot read the coordinate variable: {e}")))?;
        coords.push(Some(Coord::of_file(
            d.clone(),
            values,
            text(c, "units"),
            text(c, "standard_name"),
            &text(c, "axis"),
            &text(c, "positive"),
        )));
    }
    Ok(RawVar::of_file(name, dims, shape, data, coords))
}
