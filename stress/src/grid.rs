//! The campaign's synthetic gridded field: a small NetCDF classic file written once per
//! campaign with the `vbap-mission` grid writer, for the `field.kind = "grid"` draws.
//!
//! In mission units (L; no `units` on the axes, taken as metres = L): a main Gaussian peak of
//! [`GRID_AMPLITUDE`] F and width [`GRID_WIDTH`] L at (0, 0), a smaller bump beside it (a
//! second local maximum) and a background of 0, over [−[`GRID_HALF`], +[`GRID_HALF`]]² on
//! [`GRID_NODES`]² nodes.

use std::path::Path;

use vbap_formats::write::{write_netcdf, NcData, NcVar};

/// The file name of the grid in the campaign directory.
pub const GRID_FILE: &str = "grid.nc";
/// Half the side of the grid, L.
pub const GRID_HALF: f64 = 45.0;
/// Nodes along each axis.
pub const GRID_NODES: usize = 121;
/// Height of the main peak at (0, 0), F.
pub const GRID_AMPLITUDE: f64 = 10.0;
/// Width (standard deviation) of the main peak, L.
pub const GRID_WIDTH: f64 = 15.0;
/// The smaller bump: centre (L), height (F), width (L).
pub const GRID_BUMP: ([f64; 2], f64, f64) = ([-20.0, 22.0], 3.0, 5.0);

/// The grid's value at (x, y), F.
pub fn grid_value(x: f64, y: f64) -> f64 {
    let g = |c: [f64; 2], a: f64, w: f64| {
        a * (-((x - c[0]).powi(2) + (y - c[1]).powi(2)) / (2.0 * w * w)).exp()
    };
    g([0.0, 0.0], GRID_AMPLITUDE, GRID_WIDTH) + g(GRID_BUMP.0, GRID_BUMP.1, GRID_BUMP.2)
}

/// Writes the grid to `path` (replaced if it exists).
pub fn write_grid(path: &Path) -> std::io::Result<()> {
    let axis: Vec<f64> = (0..GRID_NODES)
        .map(|j| -GRID_HALF + 2.0 * GRID_HALF * j as f64 / (GRID_NODES - 1) as f64)
        .collect();
    let mut values = Vec::with_capacity(GRID_NODES * GRID_NODES);
    for y in &axis {
        for x in &axis {
            values.push(grid_value(*x, *y));
        }
    }
    // The coordinate variables share their dimension's name, as CF expects.
    let vars = vec![
        NcVar::new("x", &["x"], NcData::F64(axis.clone()), &[("axis", "X")]),
        NcVar::new("y", &["y"], NcData::F64(axis), &[("axis", "Y")]),
        NcVar::new(
            "value",
            &["y", "x"],
            NcData::F64(values),
            &[("long_name", "vbap stress synthetic field")],
        ),
    ];
    write_netcdf(
        path,
        false,
        &[("y", GRID_NODES), ("x", GRID_NODES)],
        &vars,
        "vbap stress synthetic grid",
    )
}
