//! Reading one variable and its coordinate variables from a file: NetCDF classic and
//! 64-bit offset (`netcdf3`, pure Rust), NumPy `.npy` and `.npz` (`npyz`). Only the named
//! variable and its 1-D coordinates are read, each in one bulk read.

use std::path::Path;

use netcdf3::{DataSet, DataVector, FileReader};

use crate::cf::AxisNames;
use crate::var::{Coord, RawVar};
use crate::GridError;

/// Unpacks CF packed values in place: `x · scale_factor + add_offset` (absent: 1 and 0).
pub(crate) fn unpack(data: &mut [f64], scale_factor: Option<f64>, add_offset: Option<f64>) {
    let scale = scale_factor.unwrap_or(1.0);
    let offset = add_offset.unwrap_or(0.0);
    if scale != 1.0 || offset != 0.0 {
        data.iter_mut().for_each(|x| *x = *x * scale + offset);
    }
}

/// The first number of an attribute, whatever its type.
fn attr_number(ds: &DataSet, var: &str, attr: &str) -> Option<f64> {
    let a = ds.get_var_attr(var, attr)?;
    a.get_f64()
        .and_then(|v| v.first().copied())
        .or_else(|| a.get_f32().and_then(|v| v.first().map(|x| *x as f64)))
        .or_else(|| a.get_i32().and_then(|v| v.first().map(|x| *x as f64)))
        .or_else(|| a.get_i16().and_then(|v| v.first().map(|x| *x as f64)))
        .or_else(|| a.get_i8().and_then(|v| v.first().map(|x| *x as f64)))
        .or_else(|| a.get_u8().and_then(|v| v.first().map(|x| *x as f64)))
}

fn attr_text(ds: &DataSet, var: &str, attr: &str) -> String {
    ds.get_var_attr_as_string(var, attr)
        .map(|s| s.trim_end_matches('\0').trim().to_string())
        .unwrap_or_default()
}

/// A NetCDF data vector as f64, `fill` values as NaN (compared in the file's own type).
fn to_f64(v: DataVector, fill: &[f64]) -> Vec<f64> {
    fn conv<T: Copy + Into<f64>>(v: &[T], fill: &[f64]) -> Vec<f64> {
        v.iter()
            .map(|x| {
                let x: f64 = (*x).into();
                if fill.contains(&x) {
                    f64::NAN
                } else {
                    x
                }
            })
            .collect()
    }
    match v {
        DataVector::I8(d) => conv(&d, fill),
        DataVector::U8(d) => conv(&d, fill),
        DataVector::I16(d) => conv(&d, fill),
        DataVector::I32(d) => conv(&d, fill),
        DataVector::F32(d) => {
            let fill32: Vec<f32> = fill.iter().map(|f| *f as f32).collect();
            d.iter()
                .map(|x| {
                    if fill32.contains(x) {
                        f64::NAN
                    } else {
                        *x as f64
                    }
                })
                .collect()
        }
        DataVector::F64(d) => conv(&d, fill),
    }
}

/// Reads `variable` (or, when `None`, the only variable of rank ≥ 2) of a NetCDF classic or
/// 64-bit offset file, with its coordinate variables; CF packing (`scale_factor`,
/// `add_offset`) is applied.
pub fn netcdf(path: &Path, variable: Option<&str>) -> Result<RawVar, GridError> {
    let fail = |variable: &str, what: String| GridError::new(path, variable, what);
    let mut reader = FileReader::open(path).map_err(|e| {
        fail(
            variable.unwrap_or("-"),
            format!("not a NetCDF classic or 64-bit offset file ({e})"),
        )
    })?;
    let ds = reader.data_set();
    let name = match variable {
        Some(v) => v.to_string(),
        None => pick(
            ds.get_vars()
                .iter()
                .filter(|v| v.num_dims() >= 2)
                .map(|v| v.name()),
        )
        .map_err(|what| fail("-", format!("{what}: name field.variable")))?,
    };
    let var = ds.get_var(&name).ok_or_else(|| {
        fail(
            &name,
            format!(
                "missing variable (the file has {})",
                ds.get_var_names().join(", ")
            ),
        )
    })?;
    let dims = var.dim_names();
    let shape: Vec<usize> = var.get_dims().iter().map(|d| d.size()).collect();
    let mut fill = Vec::new();
    for a in ["_FillValue", "missing_value"] {
        fill.extend(attr_number(ds, &name, a));
    }
    let scale_factor = attr_number(ds, &name, "scale_factor");
    let add_offset = attr_number(ds, &name, "add_offset");
    let mut coords: Vec<Option<Coord>> = dims
        .iter()
        .map(|d| {
            ds.get_var(d).filter(|c| c.num_dims() == 1).map(|_| {
                Coord::of_file(
                    d.clone(),
                    Vec::new(),
                    attr_text(ds, d, "units"),
                    attr_text(ds, d, "standard_name"),
                    &attr_text(ds, d, "axis"),
                    &attr_text(ds, d, "positive"),
                )
            })
        })
        .collect();
    let raw = reader
        .read_var(&name)
        .map_err(|e| fail(&name, format!("cannot read ({e})")))?;
    let mut data = to_f64(raw, &fill);
    unpack(&mut data, scale_factor, add_offset);
    for c in coords.iter_mut().flatten() {
        let values = reader.read_var(&c.name).map_err(|e| {
            fail(
                &c.name,
                format!("cannot read the coordinate variable ({e})"),
            )
        })?;
        c.values = to_f64(values, &[]);
    }
    Ok(RawVar::of_file(name, dims, shape, data, coords))
}

/// The only name of `names`, or what is wrong.
pub(crate) fn pick<'a>(names: impl Iterator<Item = &'a str>) -> Result<String, String> {
    let all: Vec<&str> = names.collect();
    match all.as_slice() {
        [one] => Ok(one.to_string()),
        [] => Err("no variable of rank 2 or more".into()),
        many => Err(format!("several candidate variables ({})", many.join(", "))),
    }
}

/// One NumPy array as f64 (float or integer dtypes), row-major, with its shape.
fn npy_array<R: std::io::Read>(
    npy: npyz::NpyFile<R>,
    path: &Path,
    name: &str,
) -> Result<(Vec<usize>, Vec<f64>), GridError> {
    let fail = |what: String| GridError::new(path, name, what);
    if npy.order() == npyz::Order::Fortran {
        return Err(fail(
            "Fortran-order array: save it in C order (numpy.ascontiguousarray)".into(),
        ));
    }
    let shape: Vec<usize> = npy.shape().iter().map(|s| *s as usize).collect();
    let dtype = npy.dtype();
    let type_str = match &dtype {
        npyz::DType::Plain(t) => t.to_string(),
        other => return Err(fail(format!("unsupported dtype {}", other.descr()))),
    };
    let bad = |e: std::io::Error| fail(format!("cannot read ({e})"));
    let data: Vec<f64> = match &type_str[1..] {
        "f8" => npy.into_vec::<f64>().map_err(bad)?,
        "f4" => npy
            .into_vec::<f32>()
            .map_err(bad)?
            .into_iter()
            .map(f64::from)
            .collect(),
        "i4" => npy
            .into_vec::<i32>()
            .map_err(bad)?
            .into_iter()
            .map(f64::from)
            .collect(),
        "i8" => npy
            .into_vec::<i64>()
            .map_err(bad)?
            .into_iter()
            .map(|x| x as f64)
            .collect(),
        _ => {
            return Err(fail(format!(
                "unsupported dtype {type_str} (float32/64, int32/64)"
            )))
        }
    };
    Ok((shape, data))
}

/// Reads a `.npy` array: no coordinates (the mission gives `field.extent`).
pub fn npy(path: &Path) -> Result<RawVar, GridError> {
    let file = std::fs::File::open(path)
        .map_err(|e| GridError::new(path, "-", format!("cannot open ({e})")))?;
    let npy = npyz::NpyFile::new(std::io::BufReader::with_capacity(1 << 20, file))
        .map_err(|e| GridError::new(path, "-", format!("not a NumPy .npy file ({e})")))?;
    let (shape, data) = npy_array(npy, path, "-")?;
    Ok(bare(String::from("-"), shape, data))
}

fn bare(name: String, shape: Vec<usize>, data: Vec<f64>) -> RawVar {
    let names = ["time", "z", "y", "x"];
    let dims = names[names.len().saturating_sub(shape.len())..]
        .iter()
        .map(|s| s.to_string())
        .collect();
    RawVar {
        coords: vec![None; shape.len()],
        name,
        dims,
        shape,
        data,
        bare: true,
    }
}

/// Reads `variable` (or the only array of rank ≥ 2) of a `.npz` archive, with its 1-D
/// arrays as coordinate candidates (named by the mission or `x`/`lon`, `y`/`lat`, `z`/`depth`,
/// `time`).
pub fn npz(path: &Path, variable: Option<&str>, names: &AxisNames) -> Result<RawVar, GridError> {
    let fail = |v: &str, what: String| GridError::new(path, v, what);
    let mut zip = npyz::npz::NpzArchive::open(path)
        .map_err(|e| fail("-", format!("not a NumPy .npz archive ({e})")))?;
    let arrays: Vec<String> = zip.array_names().map(str::to_string).collect();
    let read = |zip: &mut npyz::npz::NpzArchive<_>, n: &str| -> Result<_, GridError> {
        let npy = zip
            .by_name(n)
            .map_err(|e| fail(n, format!("cannot read ({e})")))?
            .ok_or_else(|| {
                fail(
                    n,
                    format!("missing variable (the file has {})", arrays.join(", ")),
                )
            })?;
        npy_array(npy, path, n)
    };
    let name = match variable {
        Some(v) => v.to_string(),
        None => {
            let mut ranked = Vec::new();
            for a in &arrays {
                let shape = zip
                    .by_name(a)
                    .ok()
                    .flatten()
                    .map(|f| f.shape().len())
                    .unwrap_or(0);
                if shape >= 2 {
                    ranked.push(a.as_str());
                }
            }
            pick(ranked.into_iter())
                .map_err(|what| fail("-", format!("{what}: name field.variable")))?
        }
    };
    let (shape, data) = read(&mut zip, &name)?;
    let mut var = bare(name, shape, data);
    let dims = var.dims.clone();
    for (k, dim) in dims.iter().enumerate() {
        let candidates = names.candidates(dim);
        if let Some(c) = candidates.iter().find(|c| arrays.iter().any(|a| a == *c)) {
            let (shape, values) = read(&mut zip, c)?;
            if shape.len() != 1 {
                return Err(fail(
                    c,
                    format!("wrong rank: a coordinate must be 1-D, is {}-D", shape.len()),
                ));
            }
            var.coords[k] = Some(Coord {
                name: c.to_string(),
                values,
                ..Coord::default()
            });
        }
    }
    Ok(var)
}
