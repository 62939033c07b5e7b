use super::*;
use netcdf3::FileReader;

fn sim(mission: &str, sets: &[&str], dir: &Path) {
    let sets: Vec<vbap_mission::config::KeySet> = sets.iter().map(|s| s.parse().unwrap()).collect();
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../deploy/missions")
        .join(mission);
    let mission = Mission::load_with(&path, &sets).unwrap();
    let run = RunDir::create(dir).unwrap();
    std::fs::write(run.mission(), mission.to_toml_string()).unwrap();
    vbap_wire_free_sim(&mission, &run);
}

/// A run directory written by hand, the way the recorder writes it, so that this crate
/// needs no simulator: two vehicles, three ticks, the second vehicle missing at tick 2.
fn vbap_wire_free_sim(_m: &Mission, run: &RunDir) {
    std::fs::write(
        run.body(),
        "t,k,s,sdot,rx,ry,rz,scale,grad_x,grad_y,grad_z,V,n_vehicles,p_trace,true_grad_x,true_grad_y,true_grad_z\n\
         0,0,0,0,0,0,0,1,0,0,0,0,2,0,1,2,0\n\
         10,1,1,0.1,1,2,0,1,0.5,0.25,0,3,2,0.5,1,2,0\n\
         20,2,2,0.1,2,4,0,1,0.5,0.25,0,3,2,0.5,1,2,0\n",
    )
    .unwrap();
    std::fs::write(
        run.vehicles(),
        "t,k,id,x,y,z,vx,vy,vz,measurement\n\
         0,0,0,10,20,0,0,0,0,NaN\n0,0,1,-10,20,0,0,0,0,NaN\n\
         10,1,0,11,21,0,0.1,0.1,0,12.5\n10,1,1,-9,21,0,0.1,0.1,0,12.25\n\
         20,2,0,12,22,0,0.1,0.1,0,12.75\n",
    )
    .unwrap();
    std::fs::write(
        run.formation(),
        "t,k,id,contact,info_age_s,slot_error,nearest_ratio,in_formation\n\
         0,0,0,surfaced,,0.1,1,1\n0,0,1,submerged,,0.2,1,1\n\
         10,1,0,contact,5,0.1,1,1\n10,1,1,dead,,,,0\n",
    )
    .unwrap();
    std::fs::write(
        run.truth(),
        "t,k,V_true_over_VU,V_seen_over_VU,min_pair_ratio,max_slot_error,n_alive,n_in_formation,sdot_over_v0\n\
         0,0,0.1,0,1,0.2,2,2,0\n10,1,0.2,0.1,1,0.1,1,1,0.4\n20,2,0.3,0.1,1,0.1,1,1,0.4\n",
    )
    .unwrap();
}

fn f64s(r: &mut FileReader, name: &str) -> Vec<f64> {
    r.read_var_f64(name).unwrap()
}

fn text(r: &FileReader, var: &str, attr: &str) -> String {
    r.data_set()
        .get_var_attr_as_string(var, attr)
        .unwrap_or_else(|| panic!("{var}:{attr}"))
}

#[test]
fn a_run_becomes_cf_trajectories_of_the_vehicles_and_the_body() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    sim(
        "glider_surfacing.toml",
        &["mission.start=\"2026-08-01T00:00:00Z\""],
        &run,
    );
    let out = tmp.path().join("run.nc");
    let done = export_netcdf(&run, &out).unwrap();
    assert_eq!(
        (done.trajectories, done.ticks),
        (7, 3),
        "6 gliders + the body, 3 ticks"
    );
    let mut r = FileReader::open(&out).unwrap();
    let meta = FileReader::open(&out).unwrap();
    let ds = meta.data_set();
    assert_eq!(
        ds.get_global_attr_as_string("featureType").unwrap(),
        "trajectory"
    );
    assert_eq!(
        ds.get_global_attr_as_string("Conventions").unwrap(),
        "CF-1.8"
    );
    assert_eq!(
        text(&r, "time", "units"),
        "seconds since 2026-08-01T00:00:00Z"
    );
    assert_eq!(text(&r, "trajectory", "cf_role"), "trajectory_id");
    let names = r.read_var_u8("trajectory").unwrap();
    let strlen = ds.get_dim("name_strlen").unwrap().size();
    let name = |i: usize| String::from_utf8(names[i * strlen..(i + 1) * strlen].to_vec()).unwrap();
    assert_eq!(name(0).trim_end_matches('\0'), "vehicle_0");
    assert_eq!(name(6).trim_end_matches('\0'), "body");
    // time(trajectory, obs): the ticks' times on every trajectory.
    let time = f64s(&mut r, "time");
    assert_eq!(&time[..3], &[0.0, 10.0, 20.0]);
    assert_eq!(&time[18..21], &[0.0, 10.0, 20.0]);
    // Vehicles' true positions; the body's centre on the last trajectory.
    let x = f64s(&mut r, "x");
    assert_eq!(&x[0..3], &[10.0, 11.0, 12.0]);
    assert_eq!(
        &x[3..6],
        &[-10.0, -9.0, FILL_F64],
        "vehicle 1 has no row at tick 2"
    );
    assert_eq!(&x[18..21], &[0.0, 1.0, 2.0], "the body's r");
    assert_eq!(text(&r, "x", "units"), "m");
    // A reading: NaN (none yet) is the fill value; its unit from the field label.
    let m = f64s(&mut r, "measurement");
    assert_eq!(&m[0..3], &[FILL_F64, 12.5, 12.75]);
    assert_eq!(text(&r, "measurement", "units"), "degree_Celsius");
    assert_eq!(&m[18..21], &[FILL_F64; 3], "the body reads nothing");
    // The body's and the truth's columns, fill on the vehicles.
    let v = f64s(&mut r, "V_true_over_VU");
    assert_eq!(&v[18..21], &[0.1, 0.2, 0.3]);
    assert_eq!(&v[0..3], &[FILL_F64; 3]);
    assert_eq!(&f64s(&mut r, "grad_x")[18..21], &[0.0, 0.5, 0.5]);
    // 2-D: no z.
    assert!(ds.get_var("z").is_none() && ds.get_var("rz").is_none());
    // The formation: numbers and flags.
    let age = f64s(&mut r, "info_age_s");
    assert_eq!(&age[0..3], &[FILL_F64, 5.0, FILL_F64]);
    let contact = r.read_var_i32("contact").unwrap();
    assert_eq!(&contact[0..6], &[1, 0, FILL_I32, 2, 4, FILL_I32]);
    assert_eq!(
        text(&r, "contact", "flag_meanings"),
        "contact surfaced submerged link_down dead rejoining"
    );
    assert!(text(&r, "x", "coordinates").starts_with("time"));
    assert!(ds
        .get_global_attr_as_string("mission_toml")
        .unwrap()
        .contains("[vehicles]"));
}

#[test]
fn the_same_run_directory_exports_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    sim("paper.toml", &[], &run);
    let (a, b) = (tmp.path().join("a.nc"), tmp.path().join("b.nc"));
    export_netcdf(&run, &a).unwrap();
    export_netcdf(&run, &b).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let r = FileReader::open(&a).unwrap();
    assert!(
        text(&r, "time", "comment").contains("no start date"),
        "without mission.start the file says what its time origin stands for"
    );
    assert_eq!(text(&r, "x", "units"), "1", "non-dimensional");
}

#[test]
fn a_directory_that_is_not_a_run_is_refused_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.nc");
    std::fs::write(&out, b"kept").unwrap();
    let e = export_netcdf(tmp.path(), &out).unwrap_err();
    assert!(e.downcast_ref::<InvalidRunDir>().is_some(), "{e:#}");
    assert!(format!("{e:#}").contains("no mission.toml"), "{e:#}");
    assert_eq!(std::fs::read(&out).unwrap(), b"kept");
}

#[test]
fn field_units_are_read_from_the_label() {
    assert_eq!(field_units("T (°C)").as_deref(), Some("degree_Celsius"));
    assert_eq!(field_units("S (psu)").as_deref(), Some("1e-3"));
    assert_eq!(field_units("T"), None);
    assert_eq!(field_units("odd (furlongs)"), None);
}
