//! A synthetic ocean, made by the project itself (`vbap ocean`): a CF NetCDF classic file
//! on a lon/lat grid off an invented coast, with sea temperature (a warm eddy, a weaker
//! warm eddy, a cold eddy and a front), u/v currents (the eddies' rotation and an along-front
//! jet), and land (a coast along the north edge and an island) as `_FillValue` and in a
//! `land_mask` variable. Every number below is in local metres about the grid centre
//! (7.9 °E, 43.9 °N), converted to lon/lat by the inverse equirectangular projection, so a
//! mission using the file can name positions in metres.

use std::path::Path;

use crate::write::{write_netcdf, NcAttr, NcData, NcVar};
use vbap_math::gridmath::equirectangular;

/// Centre of the grid (degrees): the missions' (0, 0).
pub const CENTRE: [f64; 2] = [7.9, 43.9];
/// Extent of the grid (degrees): lon 7.6..8.2, lat 43.7..44.1 (≈ 48 km × 44 km).
pub const LON: [f64; 2] = [7.6, 8.2];
/// See [`LON`].
pub const LAT: [f64; 2] = [43.7, 44.1];
/// `_FillValue` of the variables on land.
pub const FILL: f32 = -999.0;
/// Default grid size (lon × lat nodes).
pub const DEFAULT_SIZE: (usize, usize) = (160, 150);

/// One eddy: centre (m), temperature anomaly (°C), width (m), rotation stream amplitude
/// (m²/s; > 0 clockwise).
struct Eddy {
    c: [f64; 2],
    dt: f64,
    w: f64,
    psi: f64,
}

/// A splitmix64 step: the generator's only randomness (jitter of the eddy centres by `seed`).
fn splitmix(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

fn eddies(seed: u64) -> Vec<Eddy> {
    let mut s = seed;
    let mut j = || (splitmix(&mut s) - 0.5) * 2000.0;
    let speed = |w: f64, u: f64| u * w / (-0.5f64).exp();
    vec![
        Eddy {
            c: [6000.0 + j(), 4000.0 + j()],
            dt: 2.0,
            w: 6000.0,
            psi: speed(6000.0, 0.12),
        },
        Eddy {
            c: [-14000.0 + j(), 8000.0 + j()],
            dt: 0.8,
            w: 3500.0,
            psi: speed(3500.0, 0.08),
        },
        Eddy {
            c: [13000.0 + j(), -12000.0 + j()],
            dt: -1.5,
            w: 5000.0,
            psi: -speed(5000.0, 0.1),
        },
    ]
}

/// The front's position (m north) at easting x.
fn front_y(x: f64) -> f64 {
    12000.0 + 2500.0 * (2.0 * std::f64::consts::PI * x / 20000.0).sin()
}

/// Whether (x, y) (m) is land: north of the coast or on the island.
pub fn is_land(x: f64, y: f64) -> bool {
    let coast = 17500.0 + 2500.0 * (2.0 * std::f64::consts::PI * x / 30000.0).cos();
    let island = ((x - 0.0).powi(2) + (y + 9000.0).powi(2)).sqrt() < 2000.0;
    y > coast || island
}

/// Temperature (°C) and current (u, v; m/s) at (x, y) (m).
pub fn sample(x: f64, y: f64, seed: u64) -> (f64, f64, f64) {
    let mut t = 14.0;
    let (mut u, mut v) = (0.0, 0.0);
    for e in eddies(seed) {
        let (dx, dy) = (x - e.c[0], y - e.c[1]);
        let g = (-(dx * dx + dy * dy) / (2.0 * e.w * e.w)).exp();
        t += e.dt * g;
        // ψ = psi·g, u = ∂ψ/∂y·(−1)… clockwise for psi > 0: u = ψ_y·(−1)·(−1).
        u += e.psi * g * dy / (e.w * e.w);
        v -= e.psi * g * dx / (e.w * e.w);
    }
    let s = (y - front_y(x)) / 3000.0;
    t -= 0.5 * (1.0 + s.tanh());
    u += 0.1 / s.cosh().powi(2);
    (t, u, v)
}

/// The file's variables for an `nx` × `ny` grid (lon × lat) and `seed`.
pub fn variables(nx: usize, ny: usize, seed: u64) -> Vec<NcVar> {
    let axis = |r: [f64; 2], n: usize| -> Vec<f64> {
        (0..n)
            .map(|j| r[0] + (r[1] - r[0]) * j as f64 / (n - 1) as f64)
            .collect()
    };
    let (lon, lat) = (axis(LON, nx), axis(LAT, ny));
    let mut temp = Vec::with_capacity(nx * ny);
    let (mut us, mut vs, mut mask) = (temp.clone(), temp.clone(), Vec::with_capacity(nx * ny));
    for la in &lat {
        for lo in &lon {
            let (x, y) = equirectangular(*lo, *la, CENTRE[0], CENTRE[1]);
            let land = is_land(x, y);
            let (t, u, v) = sample(x, y, seed);
            let f = |q: f64| if land { FILL } else { q as f32 };
            temp.push(f(t));
            us.push(f(u));
            vs.push(f(v));
            mask.push(land as i8);
        }
    }
    let with_fill = |mut v: NcVar| {
        v.attrs.push(("_FillValue".into(), NcAttr::F32(FILL)));
        v
    };
    let dims = ["lat", "lon"];
    vec![
        NcVar::new(
            "lon",
            &["lon"],
            NcData::F64(lon),
            &[
                ("units", "degrees_east"),
                ("standard_name", "longitude"),
                ("axis", "X"),
            ],
        ),
        NcVar::new(
            "lat",
            &["lat"],
            NcData::F64(lat),
            &[
                ("units", "degrees_north"),
                ("standard_name", "latitude"),
                ("axis", "Y"),
            ],
        ),
        with_fill(NcVar::new(
            "temperature",
            &dims,
            NcData::F32(temp),
            &[
                ("units", "degC"),
                ("standard_name", "sea_water_temperature"),
                (
                    "long_name",
                    "synthetic sea temperature: two warm eddies, a cold eddy, a front",
                ),
            ],
        )),
        with_fill(NcVar::new(
            "u",
            &dims,
            NcData::F32(us),
            &[
                ("units", "m s-1"),
                ("standard_name", "eastward_sea_water_velocity"),
            ],
        )),
        with_fill(NcVar::new(
            "v",
            &dims,
            NcData::F32(vs),
            &[
                ("units", "m s-1"),
                ("standard_name", "northward_sea_water_velocity"),
            ],
        )),
        NcVar::new(
            "land_mask",
            &dims,
            NcData::I8(mask),
            &[
                (
                    "long_name",
                    "1 = land (the coast to the north, an island), 0 = sea",
                ),
                ("flag_values", "0 1"),
            ],
        ),
    ]
}

/// Writes the synthetic ocean (NetCDF classic) to `path`.
pub fn write_ocean(path: &Path, nx: usize, ny: usize, seed: u64) -> std::io::Result<()> {
    write_netcdf(
        path,
        false,
        &[("lat", ny), ("lon", nx)],
        &variables(nx, ny, seed),
        &format!("vbap synthetic ocean ({nx} x {ny}, seed {seed})"),
    )
}

/// Writes the synthetic ocean as NetCDF-4 (HDF5) to `path`; an error when built without the
/// `netcdf4` feature ([`NETCDF4`] says which).
pub fn write_ocean_netcdf4(path: &Path, nx: usize, ny: usize, seed: u64) -> std::io::Result<()> {
    #[cfg(feature = "netcdf4")]
    return crate::write::write_netcdf4(
        path,
        &[("lat", ny), ("lon", nx)],
        &variables(nx, ny, seed),
        &format!("vbap synthetic ocean ({nx} x {ny}, seed {seed})"),
    );
    #[cfg(not(feature = "netcdf4"))]
    {
        let _ = (path, nx, ny, seed);
        Err(std::io::Error::other(
            "this vbap was built without the `netcdf4` feature (cargo build --release --workspace --bins --features vbap-mission/netcdf4)",
        ))
    }
}

/// Whether this build reads and writes NetCDF-4 (the `netcdf4` feature of vbap-formats,
/// which vbap-mission's `netcdf4` feature turns on).
pub const NETCDF4: bool = cfg!(feature = "netcdf4");
