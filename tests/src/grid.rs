//! Gridded copies of analytic fields, for the tests of `[field] kind = "grid"`.

use std::path::Path;

use vbap_formats::write::{write_netcdf, NcData, NcVar};

/// The Gaussian of the multiprocess tests' 2-D mission (centre (6, 3), amplitude 10, width 6).
pub fn gaussian(x: f64, y: f64) -> f64 {
    10.0 * (-((x - 6.0).powi(2) + (y - 3.0).powi(2)) / (2.0 * 36.0)).exp()
}

/// Writes [`gaussian`] sampled every `step` length units over x in [−10, 22], y in [−12, 18]
/// as the variable `t` of a NetCDF classic file (coordinates `x`, `y` in metres).
pub fn write_gaussian_grid(path: &Path, step: f64) {
    let axis = |a: f64, b: f64| -> Vec<f64> {
        let n = ((b - a) / step).round() as usize + 1;
        (0..n).map(|j| a + j as f64 * step).collect()
    };
    let (xs, ys) = (axis(-10.0, 22.0), axis(-12.0, 18.0));
    let data: Vec<f64> = ys
        .iter()
        .flat_map(|y| xs.iter().map(move |x| gaussian(*x, *y)))
        .collect();
    let (nx, ny) = (xs.len(), ys.len());
    write_netcdf(
        path,
        false,
        &[("y", ny), ("x", nx)],
        &[
            NcVar::new("x", &["x"], NcData::F64(xs), &[("units", "m")]),
            NcVar::new("y", &["y"], NcData::F64(ys), &[("units", "m")]),
            NcVar::new("t", &["y", "x"], NcData::F64(data), &[]),
        ],
        "sampled Gaussian",
    )
    .expect("the grid file is written");
}
