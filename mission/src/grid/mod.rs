//! Gridded fields from files (beyond the paper, whose fields are formulas): a variable of a
//! NetCDF classic / 64-bit offset file or a NumPy `.npy` / `.npz` array on a rectilinear
//! grid, 2-D or 3-D (depth), steady or time-varying, interpolated by a C¹ piecewise
//! bicubic (tricubic in 3-D) Hermite surface with node slopes from local quadratics
//! ([`vbap_math::gridmath`]), linearly in time; its gradient and Hessian are those of the
//! interpolant. Geographic grids (lon/lat in degrees) are projected to local metres about
//! `field.origin` by the equirectangular projection. Missing data and land are
//! [`land`](GridField::is_land): see `land.rs`.
//!
//! The files themselves (NetCDF, NumPy: reading, CF axes and units, writing) are
//! `vbap-formats`'s. Here: [`axis`] (one axis and its interpolation stencil), `build.rs`
//! (from a variable as read to a grid), `values.rs` (the node values), `eval.rs` (value,
//! gradient, Hessian), `land.rs`, `optimum.rs`.

pub mod axis;
mod build;
mod eval;
mod land;
mod optimum;
mod values;

use std::path::PathBuf;

pub use axis::Axis;
pub use vbap_formats::{AxisNames, GridError};

/// The grid a mission loaded (in its `[field]` section; not a key).
pub type GridSlot = crate::loaded::Loaded<std::sync::Arc<GridField>>;

/// The u and v grids of a `current.kind = "grid"` (not keys).
pub type CurrentGridSlot = crate::loaded::Loaded<[std::sync::Arc<GridField>; 2]>;

/// What to read and how (the `[field]` keys of `kind = "grid"`, resolved).
#[derive(Clone, Debug, Default)]
pub struct GridSpec {
    /// The file (`.nc` NetCDF classic or 64-bit offset, `.npy`, `.npz`).
    pub file: PathBuf,
    /// The variable; `None`: the only one of rank ≥ 2.
    pub variable: Option<String>,
    /// Coordinate names given by the mission.
    pub names: AxisNames,
    /// Whether x/y are lon/lat degrees; `None`: from the units (or names in `.npz`).
    pub geographic: Option<bool>,
    /// Projection origin [lon, lat] (degrees); `None`: the grid centre.
    pub origin: Option<[f64; 2]>,
    /// Values above this are land (bathymetry / topography grids).
    pub land_above: Option<f64>,
    /// `.npy` coordinates: [x_first, x_last, y_first, y_last(, z_first, z_last)].
    pub extent: Option<Vec<f64>>,
    /// 2 or 3: the mission's dimension.
    pub dim: usize,
}

/// Where a grid node's value is: `first + j · step` along each axis (x, y, z, time), so that
/// descending axes in the file read as ascending.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub(crate) struct Layout {
    pub first: [isize; 4],
    pub step: [isize; 4],
}

/// A gridded scalar field T(p, t) with its C¹ interpolant (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct GridField {
    /// The file it came from.
    pub file: String,
    /// The variable read.
    pub variable: String,
    /// 2 or 3.
    pub dim: usize,
    /// x nodes (length unit, projected when geographic), ascending.
    pub x: Axis,
    /// y nodes, ascending.
    pub y: Axis,
    /// z nodes (3-D), ascending.
    pub z: Option<Axis>,
    /// Times (s from the first), ascending; one entry for a steady field.
    pub times: Vec<f64>,
    /// [lon, lat] of the projection origin when geographic.
    pub origin: Option<[f64; 2]>,
    /// Values (land and missing filled from the water nearby, see `land.rs`).
    pub(crate) data: values::Values,
    pub(crate) layout: Layout,
    /// Land nodes of the horizontal grid, `[jy * nx + jx]` (ascending indices).
    pub(crate) land: Vec<bool>,
    /// Best water node (x, y, z ascending indices) of each time slice, for Max and Min.
    pub(crate) best: Vec<[[usize; 3]; 2]>,
    /// Number of strict local maxima and minima among the water nodes at t = 0.
    pub(crate) extrema: [usize; 2],
}

impl GridField {
    /// Reads and builds the grid `spec` describes.
    pub fn load(spec: &GridSpec) -> Result<GridField, GridError> {
        build::load(spec)
    }

    /// Whether there is land in the grid.
    pub fn has_land(&self) -> bool {
        self.land.iter().any(|l| *l)
    }

    /// Number of local optima (strict, among water nodes at t = 0) of the goal's kind: more
    /// than one means the formation may end at a local one.
    pub fn local_optima(&self, goal: crate::config::Goal) -> usize {
        match goal {
            crate::config::Goal::Max => self.extrema[0],
            crate::config::Goal::Min => self.extrema[1],
        }
    }

    /// Bytes of node values held (f32 when the file's values are floats, see `values.rs`).
    pub fn value_bytes(&self) -> usize {
        self.data.bytes()
    }

    /// "f32" or "f64": how the node values are held.
    pub fn value_precision(&self) -> &'static str {
        match self.data {
            values::Values::F32(_) => "f32",
            values::Values::F64(_) => "f64",
        }
    }

    /// The same grid with its values held as f64 (what an f32 store widens to): every
    /// reading equal bit for bit; for benches and tests of the store.
    pub fn with_f64_values(&self) -> GridField {
        let mut g = self.clone();
        g.data = values::Values::F64(self.data.iter().collect());
        g
    }

    /// Grid nodes horizontally (nx, ny).
    pub fn size(&self) -> (usize, usize) {
        (self.x.len(), self.y.len())
    }
}

#[cfg(test)]
mod tests;
