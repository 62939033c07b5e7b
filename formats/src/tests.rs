//! The readers against the writer: what a file says arrives in the [`RawVar`], and
//! [`cf`] tells the axes and units from it.

use super::cf::{self, Role, Units};
use super::write::{write_netcdf, NcAttr, NcData, NcVar};
use super::*;

/// A (time, y, x) variable with a fill value, packing and CF coordinates.
fn packed_file(dir: &Path) -> std::path::PathBuf {
    let axis =
        |n: &str, v: Vec<f64>, attrs: &[(&str, &str)]| NcVar::new(n, &[n], NcData::F64(v), attrs);
    let mut sst = NcVar::new(
        "sst",
        &["time", "lat", "lon"],
        NcData::F32(vec![
            1.0, 2.0, -999.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0,
        ]),
        &[("units", "degC")],
    );
    sst.attrs.push(("_FillValue".into(), NcAttr::F32(-999.0)));
    sst.attrs.push(("scale_factor".into(), NcAttr::F64(0.5)));
    sst.attrs.push(("add_offset".into(), NcAttr::F64(10.0)));
    let vars = [
        axis(
            "time",
            vec![0.0, 6.0],
            &[("units", "hours since 2026-01-01")],
        ),
        axis("lat", vec![44.0, 43.9], &[("units", "degrees_north")]),
        axis("lon", vec![7.6, 7.7, 7.8], &[("axis", "x")]),
        sst,
    ];
    let path = dir.join("sst.nc");
    write_netcdf(
        &path,
        false,
        &[("time", 2), ("lat", 2), ("lon", 3)],
        &vars,
        "t",
    )
    .unwrap();
    path
}

#[test]
fn a_netcdf_variable_arrives_unpacked_with_its_fill_as_nan_and_its_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let path = packed_file(dir.path());
    let var = read_variable(&path, None, &AxisNames::default()).unwrap();
    assert_eq!((var.name.as_str(), var.bare), ("sst", false));
    assert_eq!(var.dims, ["time", "lat", "lon"]);
    assert_eq!(var.shape, [2, 2, 3]);
    assert_eq!(var.data[0], 1.0 * 0.5 + 10.0);
    assert!(var.data[2].is_nan(), "the fill value is NaN");
    assert_eq!(var.data[11], 12.0 * 0.5 + 10.0);
    let lon = var.coords[2].as_ref().unwrap();
    assert_eq!(
        (lon.axis.as_str(), lon.values.len()),
        ("X", 3),
        "axis upper-cased"
    );
    let roles = cf::roles(&var, &AxisNames::default(), 2, &path).unwrap();
    assert_eq!(roles, [Role::T, Role::Y, Role::X]);
    let time = var.coords[0].as_ref().unwrap();
    assert_eq!(
        cf::units(time, Role::T, &path).unwrap(),
        Units::Time(3600.0)
    );
    let lat = var.coords[1].as_ref().unwrap();
    assert_eq!(cf::units(lat, Role::Y, &path).unwrap(), Units::DegreesNorth);
}

#[test]
fn a_missing_file_or_variable_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let none = read_variable(&dir.path().join("none.nc"), None, &AxisNames::default());
    assert_eq!(none.unwrap_err().what, "no such file");
    let path = packed_file(dir.path());
    let err = read_variable(&path, Some("temp"), &AxisNames::default()).unwrap_err();
    assert_eq!(err.variable, "temp");
    assert!(
        err.what.starts_with("missing variable (the file has "),
        "{err}"
    );
    // A name given by the mission wins over the attributes.
    let var = read_variable(&path, Some("sst"), &AxisNames::default()).unwrap();
    let names = AxisNames {
        z: Some("time".into()),
        ..AxisNames::default()
    };
    assert_eq!(
        cf::roles(&var, &names, 3, &path).unwrap(),
        [Role::Z, Role::Y, Role::X]
    );
}
