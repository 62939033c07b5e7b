//! `vbap-formats`: the files of gridded fields, apart from what a mission makes of them.
//!
//! - [`read_variable`]: one variable of a file, whatever its format: NetCDF classic and
//!   64-bit offset ([`read`], `netcdf3`), NumPy `.npy` / `.npz` ([`read`], `npyz`),
//!   NetCDF-4 / HDF5 (`nc4.rs`, only with the `netcdf4` feature), as a [`var::RawVar`].
//! - [`cf`]: which dimension is which axis (CF attributes or names given), and the units.
//! - [`write`]: writing NetCDF files (the synthetic ocean, the tests' grids).
//! - [`ocean`]: the synthetic ocean of `vbap ocean`.
//!
//! `vbap-mission` builds its interpolated `GridField` from what [`read_variable`] and [`cf`]
//! tell (`mission/src/grid/`).

pub mod cf;
#[cfg(feature = "netcdf4")]
mod nc4;
pub mod ocean;
pub mod read;
pub mod var;
pub mod write;

use std::path::Path;

pub use cf::AxisNames;
pub use var::{Coord, RawVar};

/// A bad grid file: names the file, the variable and what is wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}: variable {variable:?}: {what}")]
pub struct GridError {
    /// The file.
    pub file: String,
    /// The variable (or `-` when none is concerned).
    pub variable: String,
    /// What is wrong.
    pub what: String,
}

impl GridError {
    /// An error about `variable` of the file at `path`.
    pub fn new(path: &Path, variable: &str, what: impl Into<String>) -> GridError {
        GridError {
            file: path.display().to_string(),
            variable: variable.to_string(),
            what: what.into(),
        }
    }
}

/// Reads `variable` (or, when `None`, the only variable of rank ≥ 2) of the file at `file`,
/// the format told by its extension (`.npy`, `.npz`) or its first bytes (HDF5: NetCDF-4),
/// else NetCDF classic / 64-bit offset. `names`: the coordinate names the mission gives
/// (the coordinate arrays of a `.npz`).
pub fn read_variable(
    file: &Path,
    variable: Option<&str>,
    names: &AxisNames,
) -> Result<RawVar, GridError> {
    let ext = file
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_lowercase();
    if !file.is_file() {
        return Err(GridError::new(file, "-", "no such file"));
    }
    match ext.as_str() {
        "npy" => read::npy(file),
        "npz" => read::npz(file, variable, names),
        _ if is_hdf5(file) => netcdf4(file, variable),
        _ => read::netcdf(file, variable),
    }
}

/// Whether the file starts with the HDF5 signature (a NetCDF-4 file).
fn is_hdf5(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    std::fs::File::open(path).is_ok_and(|mut f| f.read_exact(&mut magic).is_ok())
        && magic == *b"\x89HDF\r\n\x1a\n"
}

#[cfg(feature = "netcdf4")]
fn netcdf4(file: &Path, variable: Option<&str>) -> Result<RawVar, GridError> {
    nc4::netcdf4(file, variable)
}

#[cfg(not(feature = "netcdf4"))]
fn netcdf4(file: &Path, variable: Option<&str>) -> Result<RawVar, GridError> {
    Err(GridError::new(
        file,
        variable.unwrap_or("-"),
        "a NetCDF-4 (HDF5) file, and this vbap was built without the `netcdf4` feature: \
         build with `cargo build --release --workspace --bins --features vbap-mission/netcdf4`, or convert the file with \
         `nccopy -k classic`",
    ))
}

#[cfg(test)]
mod tests;
