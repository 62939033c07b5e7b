//! Reader, interpolation, land and error tests of gridded fields.

use std::path::{Path, PathBuf};

use super::*;
use crate::config::Goal;
use crate::land::LandMask;
use vbap_formats::ocean;
use vbap_formats::write::{write_netcdf, NcAttr, NcData, NcVar};
use vbap_math::{Mat3, Vec3};

fn spec(file: &Path, dim: usize) -> GridSpec {
    GridSpec {
        file: file.to_path_buf(),
        dim,
        ..GridSpec::default()
    }
}

/// T = 2 + 0.3 x − 0.2 y + 0.05 x² − 0.02 x y + 0.04 y²: every quadratic is reproduced exactly.
fn poly(x: f64, y: f64) -> f64 {
    2.0 + 0.3 * x - 0.2 * y + 0.05 * x * x - 0.02 * x * y + 0.04 * y * y
}

fn axis_var(name: &str, v: Vec<f64>, units: &str) -> NcVar {
    NcVar::new(name, &[name], NcData::F64(v), &[("units", units)])
}

/// A 2-D NetCDF file of `f` on uneven x (ascending) and descending y nodes.
fn poly_file(dir: &Path, name: &str, offset64: bool, f: fn(f64, f64) -> f64) -> PathBuf {
    let xs = vec![-3.0, -2.0, -0.5, 0.0, 1.5, 2.0, 3.5, 5.0];
    let ys: Vec<f64> = (0..7).map(|j| 4.0 - j as f64 * 1.25).collect();
    let data: Vec<f64> = ys
        .iter()
        .flat_map(|y| xs.iter().map(move |x| f(*x, *y)))
        .collect();
    let path = dir.join(name);
    write_netcdf(
        &path,
        offset64,
        &[("y", ys.len()), ("x", xs.len())],
        &[
            axis_var("x", xs, "m"),
            axis_var("y", ys, "m"),
            NcVar::new("t", &["y", "x"], NcData::F64(data), &[]),
        ],
        "test",
    )
    .unwrap();
    path
}

fn fd_check(g: &GridField, p: &Vec3, t: f64) {
    let h = 1e-5;
    let mut fd_g = Vec3::zeros();
    let mut fd_h = Mat3::zeros();
    for i in 0..g.dim {
        let mut e = Vec3::zeros();
        e[i] = h;
        fd_g[i] = (g.value(&(p + e), t) - g.value(&(p - e), t)) / (2.0 * h);
        let col = (g.gradient(&(p + e), t) - g.gradient(&(p - e), t)) / (2.0 * h);
        for j in 0..g.dim {
            fd_h[(j, i)] = col[j];
        }
    }
    assert!((g.gradient(p, t) - fd_g).norm() < 1e-6, "gradient at {p:?}");
    assert!(
        (g.hessian(p, t) - fd_h).norm() < 1e-5,
        "Hessian at {p:?}: {} vs {fd_h}",
        g.hessian(p, t)
    );
}

#[test]
fn classic_and_64_bit_offset_files_reproduce_a_quadratic_exactly() {
    let dir = tempfile::tempdir().unwrap();
    for (name, offset64) in [("c.nc", false), ("o.nc", true)] {
        let g = GridField::load(&spec(&poly_file(dir.path(), name, offset64, poly), 2)).unwrap();
        assert_eq!(g.variable, "t");
        assert_eq!(g.y.nodes[0], -3.5, "descending y is read ascending");
        for (x, y) in [
            (-3.0, -3.5),
            (0.3, 0.7),
            (4.9, 3.9),
            (1.5, -1.0),
            (-2.7, 2.2),
        ] {
            let p = Vec3::new(x, y, 0.0);
            assert!(
                (g.value(&p, 0.0) - poly(x, y)).abs() < 1e-12,
                "{name} at {p:?}"
            );
            let exact = Vec3::new(0.3 + 0.1 * x - 0.02 * y, -0.2 - 0.02 * x + 0.08 * y, 0.0);
            assert!((g.gradient(&p, 0.0) - exact).norm() < 1e-10);
            let h = g.hessian(&p, 0.0);
            assert!((h[(0, 0)] - 0.1).abs() < 1e-9 && (h[(0, 1)] + 0.02).abs() < 1e-9);
        }
    }
}

#[test]
fn gradient_and_hessian_match_finite_differences_of_the_interpolant() {
    let dir = tempfile::tempdir().unwrap();
    let wavy = |x: f64, y: f64| (0.7 * x).sin() * (0.5 * y).cos() + 0.1 * x * y * y;
    let g = GridField::load(&spec(&poly_file(dir.path(), "w.nc", false, wavy), 2)).unwrap();
    for (x, y) in [(0.3, 0.7), (-1.3, -2.2), (2.7, 1.1), (4.1, -0.4)] {
        fd_check(&g, &Vec3::new(x, y, 0.0), 0.0);
    }
    // Interpolates the nodes.
    assert!((g.value(&Vec3::new(1.5, 1.5, 0.0), 0.0) - wavy(1.5, 1.5)).abs() < 1e-12);
}

/// A .npy file of `data` (f64, C order) with the given shape.
fn write_npy(path: &Path, shape: &[usize], data: &[f64]) {
    let dims: Vec<String> = shape.iter().map(|s| s.to_string()).collect();
    let mut header = format!(
        "{{'descr': '<f8', 'fortran_order': False, 'shape': ({},), }}",
        dims.join(", ")
    );
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend((header.len() as u16).to_le_bytes());
    bytes.extend(header.as_bytes());
    for v in data {
        bytes.extend(v.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn npy_with_extent_and_npz_with_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let (nx, ny) = (9, 6);
    let xs: Vec<f64> = (0..nx).map(|j| -4.0 + j as f64).collect();
    let ys: Vec<f64> = (0..ny).map(|j| 10.0 + 2.0 * j as f64).collect();
    let data: Vec<f64> = ys
        .iter()
        .flat_map(|y| xs.iter().map(move |x| poly(*x, *y)))
        .collect();
    let npy = dir.path().join("a.npy");
    write_npy(&npy, &[ny, nx], &data);
    let mut s = spec(&npy, 2);
    s.extent = Some(vec![-4.0, 4.0, 10.0, 20.0]);
    let g = GridField::load(&s).unwrap();
    let p = Vec3::new(0.4, 13.3, 0.0);
    assert!((g.value(&p, 0.0) - poly(p.x, p.y)).abs() < 1e-10);
    s.extent = None;
    let e = GridField::load(&s).unwrap_err();
    assert!(e.what.contains("field.extent"), "{e}");

    let npz = dir.path().join("b.npz");
    {
        use npyz::WriterBuilder;
        let mut w = npyz::npz::NpzWriter::create(&npz).unwrap();
        let opts = zip::write::FileOptions::default;
        for (name, shape, values) in [
            ("sst", vec![ny as u64, nx as u64], &data),
            ("x", vec![nx as u64], &xs),
            ("y", vec![ny as u64], &ys),
        ] {
            let mut a = w
                .array::<f64>(name, opts())
                .unwrap()
                .default_dtype()
                .shape(&shape)
                .begin_nd()
                .unwrap();
            a.extend(values.iter().copied()).unwrap();
            a.finish().unwrap();
        }
    }
    let g = GridField::load(&spec(&npz, 2)).unwrap();
    assert_eq!(g.variable, "sst");
    assert!((g.value(&p, 0.0) - poly(p.x, p.y)).abs() < 1e-10);
}

/// A geographic file with longitudes as given, T a function of the projected position.
fn geo_file(dir: &Path, name: &str, lons: Vec<f64>, lon0: f64) -> PathBuf {
    let lats: Vec<f64> = (0..8).map(|j| -40.2 + 0.05 * j as f64).collect();
    let lat0 = -40.2 + 0.05 * 3.5;
    let f = |lo: f64, la: f64| {
        let (x, y) = vbap_math::gridmath::equirectangular(lo, la, lon0, lat0);
        poly(x / 1000.0, y / 1000.0)
    };
    let data: Vec<f64> = lats
        .iter()
        .flat_map(|la| lons.iter().map(move |lo| f(*lo, *la)))
        .collect();
    let path = dir.join(name);
    write_netcdf(
        &path,
        false,
        &[("lat", lats.len()), ("lon", lons.len())],
        &[
            axis_var("lon", lons, "degrees_east"),
            axis_var("lat", lats, "degrees_north"),
            NcVar::new("temp", &["lat", "lon"], NcData::F64(data), &[]),
        ],
        "geo",
    )
    .unwrap();
    path
}

#[test]
fn longitudes_0_to_360_and_minus_180_to_180_give_the_same_field() {
    let dir = tempfile::tempdir().unwrap();
    // Across the antimeridian: 179.8 .. 180.2 written both ways.
    let east: Vec<f64> = (0..9).map(|j| 179.8 + 0.05 * j as f64).collect();
    let west: Vec<f64> = east
        .iter()
        .map(|l| if *l > 180.0 { l - 360.0 } else { *l })
        .collect();
    let a = GridField::load(&spec(&geo_file(dir.path(), "e.nc", east, 180.0), 2)).unwrap();
    // −180..180 across the antimeridian: the projection wraps Δlon, so x still ascends.
    let b = GridField::load(&spec(&geo_file(dir.path(), "w.nc", west, 180.0), 2)).unwrap();
    assert_eq!(b.x.nodes.len(), 9);
    for (x, y) in [(0.0, 0.0), (5000.0, -7000.0), (-12000.0, 9000.0)] {
        let p = Vec3::new(x, y, 0.0);
        assert!((a.value(&p, 0.0) - b.value(&p, 0.0)).abs() < 1e-9);
    }
    // The same grid in 0..360 about an origin given as −180: same projected field.
    let mut s = spec(&dir.path().join("e.nc"), 2);
    s.origin = Some([-180.0, -40.2 + 0.05 * 3.5]);
    let c = GridField::load(&s).unwrap();
    assert_eq!(a.origin.unwrap()[1], c.origin.unwrap()[1]);
    assert_eq!(c.origin.unwrap()[0], -180.0);
    for (x, y) in [(0.0, 0.0), (5000.0, -7000.0), (-12000.0, 9000.0)] {
        let p = Vec3::new(x, y, 0.0);
        assert!((a.value(&p, 0.0) - c.value(&p, 0.0)).abs() < 1e-9);
        assert!(
            (a.value(&p, 0.0) - poly(x / 1000.0, y / 1000.0)).abs() < 1e-6,
            "projection is separable: exact"
        );
    }
}

#[test]
fn time_varying_3d_grid_is_tricubic_and_linear_in_time() {
    let dir = tempfile::tempdir().unwrap();
    let xs: Vec<f64> = (0..5).map(|j| j as f64 * 10.0).collect();
    let ys: Vec<f64> = (0..6).map(|j| j as f64 * 8.0).collect();
    let zs = vec![0.0, 5.0, 15.0, 30.0, 50.0];
    let ts = vec![0.0, 1.0, 3.0];
    let f = |x: f64, y: f64, z: f64, t: f64| {
        poly(x / 10.0, y / 10.0) + 0.01 * z * z - 0.02 * x * z + t * (1.0 + 0.1 * x)
    };
    let mut data = Vec::new();
    for t in &ts {
        for z in &zs {
            for y in &ys {
                for x in &xs {
                    data.push(f(*x, *y, *z, *t * 3600.0 / 3600.0));
                }
            }
        }
    }
    let path = dir.path().join("t.nc");
    write_netcdf(
        &path,
        false,
        &[("time", 3), ("depth", 5), ("y", 6), ("x", 5)],
        &[
            NcVar::new(
                "time",
                &["time"],
                NcData::F64(ts),
                &[("units", "hours since 2026-01-01")],
            ),
            NcVar::new(
                "depth",
                &["depth"],
                NcData::F64(zs),
                &[("units", "m"), ("positive", "down")],
            ),
            axis_var("x", xs, "m"),
            axis_var("y", ys, "km"),
            NcVar::new("temp", &["time", "depth", "y", "x"], NcData::F64(data), &[]),
        ],
        "4d",
    )
    .unwrap();
    let g = GridField::load(&spec(&path, 3)).unwrap();
    assert_eq!(g.times, vec![0.0, 3600.0, 10800.0]);
    assert_eq!(g.y.range(), (0.0, 40_000.0), "km become metres");
    // y in km in the file: the field varies slowly along y in metres.
    let truth = |x: f64, y_m: f64, z: f64, t_s: f64| f(x, y_m / 1000.0, z, t_s / 3600.0);
    for (p, t) in [
        (Vec3::new(12.0, 9_000.0, 7.0), 0.0),
        (Vec3::new(33.0, 21_000.0, 41.0), 1800.0),
        (Vec3::new(3.0, 35_500.0, 22.0), 7200.0),
    ] {
        assert!(
            (g.value(&p, t) - truth(p.x, p.y, p.z, t)).abs() < 1e-9,
            "{p:?} {t}"
        );
        fd_check(&g, &p, t);
    }
    let e = GridField::load(&spec(&path, 2)).unwrap_err();
    assert!(e.what.contains("wrong rank"), "{e}");
}

#[test]
fn every_bad_file_names_the_file_the_variable_and_the_fault() {
    let dir = tempfile::tempdir().unwrap();
    let good = poly_file(dir.path(), "g.nc", false, poly);
    let mut s = spec(&good, 2);
    s.variable = Some("salt".into());
    let e = GridField::load(&s).unwrap_err();
    assert!(
        e.to_string().contains("g.nc")
            && e.variable == "salt"
            && e.what.contains("missing variable"),
        "{e}"
    );

    let write = |name: &str, xs: Vec<f64>, xunits: &str, dims: &[&str]| {
        let ys = vec![0.0, 1.0, 2.0, 3.0];
        let path = dir.path().join(name);
        let n = if dims.len() == 1 {
            xs.len()
        } else {
            xs.len() * 4
        };
        write_netcdf(
            &path,
            false,
            &[("y", 4), ("x", xs.len())],
            &[
                axis_var("x", xs, xunits),
                axis_var("y", ys, "m"),
                NcVar::new("t", dims, NcData::F64(vec![1.0; n]), &[]),
            ],
            "bad",
        )
        .unwrap();
        path
    };
    let cases = [
        (
            write("nm.nc", vec![0.0, 2.0, 1.0, 3.0], "m", &["y", "x"]),
            "non-monotone",
        ),
        (
            write("un.nc", vec![0.0, 1.0, 2.0, 3.0], "furlongs", &["y", "x"]),
            "unknown units",
        ),
        (
            write("rk.nc", vec![0.0, 1.0, 2.0, 3.0], "m", &["x"]),
            "wrong rank",
        ),
        (
            write("sh.nc", vec![0.0, 1.0, 2.0], "m", &["y", "x"]),
            "at least 4",
        ),
    ];
    for (path, what) in cases {
        let mut s = spec(&path, 2);
        s.variable = Some("t".into());
        let e = GridField::load(&s).unwrap_err();
        assert!(e.what.contains(what), "{}: {e}", path.display());
        assert!(e
            .file
            .ends_with(path.file_name().unwrap().to_str().unwrap()));
    }
    let e = GridField::load(&spec(&dir.path().join("none.nc"), 2)).unwrap_err();
    assert!(e.what.contains("no such file"), "{e}");
    std::fs::write(dir.path().join("junk.nc"), b"not netcdf").unwrap();
    let e = GridField::load(&spec(&dir.path().join("junk.nc"), 2)).unwrap_err();
    assert!(e.what.contains("not a NetCDF"), "{e}");
}

#[test]
fn the_synthetic_ocean_has_land_an_optimum_and_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.nc");
    let b = dir.path().join("b.nc");
    ocean::write_ocean(&a, 160, 150, 7).unwrap();
    ocean::write_ocean(&b, 160, 150, 7).unwrap();
    assert_eq!(
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        "same seed, same bytes"
    );
    ocean::write_ocean(&b, 160, 150, 8).unwrap();
    assert_ne!(
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        "the seed moves the eddies"
    );
    let mut s = spec(&a, 2);
    s.variable = Some("temperature".into());
    let g = GridField::load(&s).unwrap();
    let o = g.origin.unwrap();
    assert!((o[0] - ocean::CENTRE[0]).abs() < 1e-9 && (o[1] - ocean::CENTRE[1]).abs() < 1e-9);
    assert!(g.has_land());
    assert_eq!(
        g.value_precision(),
        "f32",
        "floats with land filled by floats"
    );
    // The island (centre (0, −9 km), radius 2 km) and the coast to the north.
    assert!(g.is_land(&Vec3::new(0.0, -9000.0, 0.0)));
    assert!(g.is_land(&Vec3::new(0.0, 21000.0, 0.0)));
    assert!(!g.is_land(&Vec3::new(0.0, 0.0, 0.0)));
    assert!(
        g.is_land(&Vec3::new(1e6, 0.0, 0.0)),
        "outside the grid is land"
    );
    let (d, away) = g
        .clearance(&Vec3::new(0.0, -5500.0, 0.0))
        .expect("the island is near");
    assert!((1000.0..2000.0).contains(&d), "{d}");
    assert!(away.y > 0.9, "away from the island is north: {away}");
    assert!(g.clearance(&Vec3::new(-2000.0, 3000.0, 0.0)).is_none());
    // Filled next to land: finite everywhere.
    assert!(g.value(&Vec3::new(0.0, -7000.0, 0.0), 0.0).is_finite());
    let top = g.optimum(0.0, Goal::Max).unwrap();
    assert!(
        (top - Vec3::new(6000.0, 4000.0, 0.0)).norm() < 1500.0,
        "{top}"
    );
    assert!(
        g.gradient(&top, 0.0).norm() < 1e-6,
        "{}",
        g.gradient(&top, 0.0)
    );
    assert!(
        g.local_optima(Goal::Max) >= 2,
        "two warm eddies: {}",
        g.local_optima(Goal::Max)
    );
}

#[test]
fn fill_values_are_land_and_land_above_marks_elevation() {
    let dir = tempfile::tempdir().unwrap();
    let xs: Vec<f64> = (0..6).map(|j| j as f64).collect();
    let ys: Vec<f64> = (0..5).map(|j| j as f64).collect();
    let mut data: Vec<f32> = ys
        .iter()
        .flat_map(|y| xs.iter().map(move |x| (x - y) as f32))
        .collect();
    data[0] = -999.0;
    data[1] = f32::NAN;
    let path = dir.path().join("f.nc");
    let mut var = NcVar::new("h", &["y", "x"], NcData::F32(data), &[]);
    var.attrs.push(("_FillValue".into(), NcAttr::F32(-999.0)));
    write_netcdf(
        &path,
        false,
        &[("y", 5), ("x", 6)],
        &[axis_var("x", xs, "m"), axis_var("y", ys, "m"), var],
        "f",
    )
    .unwrap();
    let g = GridField::load(&spec(&path, 2)).unwrap();
    assert!(g.is_land(&Vec3::new(0.0, 0.0, 0.0)) && g.is_land(&Vec3::new(1.0, 0.0, 0.0)));
    assert!(!g.is_land(&Vec3::new(3.0, 3.0, 0.0)));
    assert!(g.data.iter().all(|v| v.is_finite()));
    let mut s = spec(&path, 2);
    s.land_above = Some(2.5);
    let g = GridField::load(&s).unwrap();
    assert!(g.is_land(&Vec3::new(5.0, 0.0, 0.0)), "x − y = 5 > 2.5");
    assert!(!g.is_land(&Vec3::new(2.0, 1.0, 0.0)));
}

#[test]
fn the_shipped_ocean_file_is_what_the_generator_writes() {
    let shipped = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../deploy/missions/ocean.nc"
    ));
    let dir = tempfile::tempdir().unwrap();
    let made = dir.path().join("ocean.nc");
    let (nx, ny) = ocean::DEFAULT_SIZE;
    ocean::write_ocean(&made, nx, ny, 1).unwrap();
    let want = std::fs::read(shipped).expect("deploy/missions/ocean.nc is shipped");
    assert!(want.len() < 1 << 20, "the shipped file stays small");
    assert!(
        std::fs::read(&made).unwrap() == want,
        "deploy/missions/ocean.nc differs from `vbap ocean --out deploy/missions/ocean.nc --size 160,150 --seed 1`: regenerate it"
    );
}

/// A NetCDF-4 (HDF5) file: read with the `netcdf4` feature, refused naming the file and the
/// feature without it; a damaged one is refused either way, naming the file.
#[test]
fn an_hdf5_file_is_read_with_the_feature_and_refused_without() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.nc");
    std::fs::write(&path, b"\x89HDF\r\n\x1a\nnot really hdf5").unwrap();
    let e = GridField::load(&spec(&path, 2)).unwrap_err();
    assert_eq!(e.file, path.display().to_string());
    if cfg!(feature = "netcdf4") {
        assert!(e.what.contains("not a readable NetCDF-4 file"), "{e}");
    } else {
        assert!(e.what.contains("without the `netcdf4` feature"), "{e}");
    }
}

/// NetCDF-4 files (the `netcdf4` feature) build the same grids as classic ones.
#[cfg(feature = "netcdf4")]
mod netcdf4 {
    use crate::grid::{GridField, GridSpec};
    use vbap_formats::ocean;
    use vbap_formats::write::{write_netcdf, write_netcdf4, NcAttr, NcData, NcVar};

    fn load(path: &Path, variable: &str, dim: usize) -> GridField {
        let spec = GridSpec {
            file: path.to_path_buf(),
            variable: Some(variable.into()),
            dim,
            ..GridSpec::default()
        };
        let mut g = GridField::load(&spec).unwrap();
        g.file = String::new();
        g
    }

    use std::path::Path;

    /// A 3-D, time-varying f32 variable with a fill value and descending depth, written as
    /// NetCDF classic and as NetCDF-4: the same grid.
    #[test]
    fn a_netcdf4_file_reads_equal_to_the_classic_file() {
        let dir = tempfile::tempdir().unwrap();
        let (nx, ny, nz, nt) = (6, 5, 4, 2);
        let mut data: Vec<f32> = (0..nx * ny * nz * nt)
            .map(|i| (i as f32 * 0.37).sin() * 3.0 + 10.0)
            .collect();
        data[3 * nx * ny + 7] = -999.0; // depth 0 (the last level in the file), t = 0
        let axis =
            |n: &str, v: Vec<f64>, u: &str| NcVar::new(n, &[n], NcData::F64(v), &[("units", u)]);
        let mut temp = NcVar::new(
            "temp",
            &["time", "depth", "y", "x"],
            NcData::F32(data),
            &[("units", "degC")],
        );
        temp.attrs.push(("_FillValue".into(), NcAttr::F32(-999.0)));
        let vars = [
            axis("time", vec![0.0, 2.0], "hours since 2026-01-01"),
            axis("depth", vec![60.0, 30.0, 10.0, 0.0], "m"),
            axis("y", (0..ny).map(|j| j as f64 * 1.5).collect(), "km"),
            axis("x", (0..nx).map(|j| j as f64 * 700.0).collect(), "m"),
            temp,
        ];
        let dims = [("time", nt), ("depth", nz), ("y", ny), ("x", nx)];
        let (classic, nc4) = (dir.path().join("c.nc"), dir.path().join("h.nc"));
        write_netcdf(&classic, false, &dims, &vars, "t").unwrap();
        write_netcdf4(&nc4, &dims, &vars, "t").unwrap();
        assert_eq!(&std::fs::read(&nc4).unwrap()[..4], b"\x89HDF");
        let (a, b) = (load(&classic, "temp", 3), load(&nc4, "temp", 3));
        assert!(a.has_land(), "the fill value is land");
        assert_eq!(a, b);
    }

    /// The synthetic ocean (geographic, land) in both formats: the same temperature grid.
    #[test]
    fn the_synthetic_ocean_as_netcdf4_reads_equal_to_the_classic_file() {
        let dir = tempfile::tempdir().unwrap();
        let (classic, nc4) = (dir.path().join("c.nc"), dir.path().join("o.nc"));
        ocean::write_ocean(&classic, 40, 30, 3).unwrap();
        ocean::write_ocean_netcdf4(&nc4, 40, 30, 3).unwrap();
        for v in ["temperature", "u"] {
            assert_eq!(load(&classic, v, 2), load(&nc4, v, 2), "{v}");
        }
    }
}
