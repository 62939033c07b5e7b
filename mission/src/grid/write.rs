//! Writing a NetCDF classic / 64-bit offset file (the example generator and the tests).

use std::path::Path;

use netcdf3::{DataSet, FileWriter, Version};

/// Values of a variable.
#[derive(Clone, Debug)]
pub enum NcData {
    /// 32-bit floats.
    F32(Vec<f32>),
    /// 64-bit floats.
    F64(Vec<f64>),
    /// Bytes (masks).
    I8(Vec<i8>),
}

/// An attribute value.
#[derive(Clone, Debug)]
pub enum NcAttr {
    /// Text.
    Text(String),
    /// A 32-bit float (e.g. `_FillValue` of an f32 variable).
    F32(f32),
    /// A 64-bit float.
    F64(f64),
}

/// A variable to write: name, dimensions (slowest first), values (row-major), attributes.
#[derive(Clone, Debug)]
pub struct NcVar {
    /// Name.
    pub name: String,
    /// Dimension names, slowest first.
    pub dims: Vec<String>,
    /// Values.
    pub data: NcData,
    /// Attributes.
    pub attrs: Vec<(String, NcAttr)>,
}

impl NcVar {
    /// A variable with text attributes `attrs`.
    pub fn new(name: &str, dims: &[&str], data: NcData, attrs: &[(&str, &str)]) -> NcVar {
        NcVar {
            name: name.into(),
            dims: dims.iter().map(|d| d.to_string()).collect(),
            data,
            attrs: attrs
                .iter()
                .map(|(k, v)| (k.to_string(), NcAttr::Text(v.to_string())))
                .collect(),
        }
    }
}

fn invalid(e: impl std::fmt::Debug) -> std::io::Error {
    std::io::Error::other(format!("{e:?}"))
}

/// Writes `vars` over the fixed dimensions `dims` to `path` (replaced if it exists);
/// `offset64` = the 64-bit offset format, otherwise classic.
pub fn write_netcdf(
    path: &Path,
    offset64: bool,
    dims: &[(&str, usize)],
    vars: &[NcVar],
    title: &str,
) -> std::io::Result<()> {
    let mut ds = DataSet::new();
    for (name, n) in dims {
        ds.add_fixed_dim(*name, *n).map_err(invalid)?;
    }
    ds.add_global_attr_string("Conventions", "CF-1.8")
        .map_err(invalid)?;
    ds.add_global_attr_string("title", title).map_err(invalid)?;
    for v in vars {
        let dims: Vec<&str> = v.dims.iter().map(String::as_str).collect();
        match v.data {
            NcData::F32(_) => ds.add_var_f32(&v.name, &dims),
            NcData::F64(_) => ds.add_var_f64(&v.name, &dims),
            NcData::I8(_) => ds.add_var_i8(&v.name, &dims),
        }
        .map_err(invalid)?;
        for (k, a) in &v.attrs {
            match a {
                NcAttr::Text(t) => ds.add_var_attr_string(&v.name, k, t),
                NcAttr::F32(x) => ds.add_var_attr_f32(&v.name, k, vec![*x]),
                NcAttr::F64(x) => ds.add_var_attr_f64(&v.name, k, vec![*x]),
            }
            .map_err(invalid)?;
        }
    }
    let _ = std::fs::remove_file(path);
    let mut w = FileWriter::open(path).map_err(invalid)?;
    let version = if offset64 {
        Version::Offset64Bit
    } else {
        Version::Classic
    };
    w.set_def(&ds, version, 0).map_err(invalid)?;
    for v in vars {
        match &v.data {
            NcData::F32(d) => w.write_var_f32(&v.name, d),
            NcData::F64(d) => w.write_var_f64(&v.name, d),
            NcData::I8(d) => w.write_var_i8(&v.name, d),
        }
        .map_err(invalid)?;
    }
    w.close().map_err(invalid)
}
