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
    /// Bytes (masks, flags).
    I8(Vec<i8>),
    /// 32-bit integers.
    I32(Vec<i32>),
    /// Characters (`NC_CHAR`: names, padded with NUL to the last dimension).
    Char(Vec<u8>),
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
    /// 32-bit integers (`flag_values` and `_FillValue` of an `I32` variable). Byte
    /// attributes are not offered: `netcdf3` 0.6 pads them with 0x81, not the zeros the
    /// format requires, and then refuses its own file.
    I32(Vec<i32>),
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
    let globals = [
        ("Conventions".to_string(), NcAttr::Text("CF-1.8".into())),
        ("title".to_string(), NcAttr::Text(title.into())),
    ];
    write_netcdf_with(path, offset64, dims, vars, &globals)
}

/// [`write_netcdf`] with the global attributes `globals` (in this order; `Conventions`
/// and `title` are not added).
pub fn write_netcdf_with(
    path: &Path,
    offset64: bool,
    dims: &[(&str, usize)],
    vars: &[NcVar],
    globals: &[(String, NcAttr)],
) -> std::io::Result<()> {
    let mut ds = DataSet::new();
    for (name, n) in dims {
        ds.add_fixed_dim(*name, *n).map_err(invalid)?;
    }
    for (k, a) in globals {
        match a {
            NcAttr::Text(t) => ds.add_global_attr_string(k, t),
            NcAttr::F32(x) => ds.add_global_attr_f32(k, vec![*x]),
            NcAttr::F64(x) => ds.add_global_attr_f64(k, vec![*x]),
            NcAttr::I32(x) => ds.add_global_attr_i32(k, x.clone()),
        }
        .map_err(invalid)?;
    }
    for v in vars {
        let dims: Vec<&str> = v.dims.iter().map(String::as_str).collect();
        match v.data {
            NcData::F32(_) => ds.add_var_f32(&v.name, &dims),
            NcData::F64(_) => ds.add_var_f64(&v.name, &dims),
            NcData::I8(_) => ds.add_var_i8(&v.name, &dims),
            NcData::I32(_) => ds.add_var_i32(&v.name, &dims),
            NcData::Char(_) => ds.add_var_u8(&v.name, &dims),
        }
        .map_err(invalid)?;
        for (k, a) in &v.attrs {
            match a {
                NcAttr::Text(t) => ds.add_var_attr_string(&v.name, k, t),
                NcAttr::F32(x) => ds.add_var_attr_f32(&v.name, k, vec![*x]),
                NcAttr::F64(x) => ds.add_var_attr_f64(&v.name, k, vec![*x]),
                NcAttr::I32(x) => ds.add_var_attr_i32(&v.name, k, x.clone()),
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
            NcData::I32(d) => w.write_var_i32(&v.name, d),
            NcData::Char(d) => w.write_var_u8(&v.name, d),
        }
        .map_err(invalid)?;
    }
    w.close().map_err(invalid)
}

/// Writes the same file as [`write_netcdf`] in the NetCDF-4 (HDF5) format, through the pure
/// Rust `netcdf-writer` (only with the `netcdf4` feature). A `_FillValue` is the variable's
/// fill value (NetCDF-4 keeps it as a dataset property as well as an attribute).
#[cfg(feature = "netcdf4")]
pub fn write_netcdf4(
    path: &Path,
    dims: &[(&str, usize)],
    vars: &[NcVar],
    title: &str,
) -> std::io::Result<()> {
    use netcdf_writer::{NcAttrValue, NcFileBuilder, NcWriteFormat, NcWriteOptions};
    let mut b = NcFileBuilder::new();
    let mut ids = std::collections::HashMap::new();
    for (name, n) in dims {
        ids.insert(*name, b.add_dimension(*name, *n as u64).map_err(invalid)?);
    }
    for (k, t) in [("Conventions", "CF-1.8"), ("title", title)] {
        b.add_attribute(k, NcAttrValue::Chars(t.into()))
            .map_err(invalid)?;
    }
    for v in vars {
        let d: Vec<_> = v.dims.iter().map(|n| ids[n.as_str()]).collect();
        let id = match &v.data {
            NcData::F32(_) => b.add_variable::<f32>(&v.name, &d),
            NcData::F64(_) => b.add_variable::<f64>(&v.name, &d),
            NcData::I8(_) => b.add_variable::<i8>(&v.name, &d),
            NcData::I32(_) => b.add_variable::<i32>(&v.name, &d),
            NcData::Char(_) => b.add_variable::<u8>(&v.name, &d),
        }
        .map_err(invalid)?;
        for (k, a) in &v.attrs {
            match (k.as_str(), a) {
                ("_FillValue", NcAttr::F32(x)) => b.set_variable_fill_value(id, *x),
                ("_FillValue", NcAttr::F64(x)) => b.set_variable_fill_value(id, *x),
                (_, NcAttr::Text(t)) => {
                    b.add_variable_attribute(id, k, NcAttrValue::Chars(t.clone()))
                }
                (_, NcAttr::F32(x)) => {
                    b.add_variable_attribute(id, k, NcAttrValue::Floats(vec![*x]))
                }
                (_, NcAttr::F64(x)) => {
                    b.add_variable_attribute(id, k, NcAttrValue::Doubles(vec![*x]))
                }
                (_, NcAttr::I32(x)) => {
                    b.add_variable_attribute(id, k, NcAttrValue::Ints(x.clone()))
                }
            }
            .map_err(invalid)?;
        }
        match &v.data {
            NcData::F32(x) => b.write_variable(id, x),
            NcData::F64(x) => b.write_variable(id, x),
            NcData::I8(x) => b.write_variable(id, x),
            NcData::I32(x) => b.write_variable(id, x),
            NcData::Char(x) => b.write_variable(id, x),
        }
        .map_err(invalid)?;
    }
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    let options = NcWriteOptions {
        format: NcWriteFormat::Nc4,
    };
    b.write(file, options).map_err(invalid)?;
    Ok(())
}
