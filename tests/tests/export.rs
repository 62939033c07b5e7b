//! `vbap export RUN_DIR --netcdf FILE.nc` through the real binaries: the file of a
//! multi-process run equals the simulator's byte for byte, it holds what the run
//! directory holds, and what is no run directory exits 2 and overwrites nothing.

use tests::*;

fn export(dir: &std::path::Path, nc: &std::path::Path) {
    run_ok(vbap().arg("export").arg(dir).arg("--netcdf").arg(nc));
}

#[test]
fn a_multi_process_run_exports_the_file_the_simulator_exports() {
    let tmp = TempDir::new("export");
    let mission = workspace().join("deploy/missions/glider_iridium.toml");
    let name = unique_name("export");
    let args = |cmd: &str, out: &str| {
        let mut c = vbap();
        c.arg(cmd)
            .arg(&mission)
            .arg("--duration")
            .arg("7200")
            .arg("--set")
            .arg(format!("mission.name=\"{name}\""))
            .arg("--set")
            .arg("mission.start=\"2026-08-01T06:00:00Z\"")
            .arg("--out")
            .arg(tmp.join(out))
            .arg("--quiet");
        c
    };
    run_ok(&mut args("sim", "sim"));
    run_ok(&mut args("run", "run"));
    export(&tmp.join("sim"), &tmp.join("sim.nc"));
    export(&tmp.join("run"), &tmp.join("run.nc"));
    let (sim, run) = (
        std::fs::read(tmp.join("sim.nc")).unwrap(),
        std::fs::read(tmp.join("run.nc")).unwrap(),
    );
    assert!(sim == run, "vbap run and vbap sim export different files");

    // What it holds: every glider's true x of vehicles.csv, by (id, k), bit for bit.
    let mut r = netcdf3::FileReader::open(tmp.join("run.nc")).unwrap();
    let ticks = r.data_set().get_dim("obs").unwrap().size();
    assert_eq!(
        r.data_set()
            .get_var_attr_as_string("time", "units")
            .unwrap(),
        "seconds since 2026-08-01T06:00:00Z"
    );
    let x = r.read_var_f64("x").unwrap();
    let vehicles = tests::columns::Table::read(&tmp.join("run/vehicles.csv"));
    assert!(vehicles.len() > 100);
    for row in vehicles.rows() {
        let (id, k) = (row.parse::<usize>("id"), row.parse::<usize>("k"));
        assert_eq!(
            x[id * ticks + k].to_bits(),
            row.num("x").to_bits(),
            "id {id} k {k}"
        );
    }
    let leftovers = leftover_files(&name);
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn what_is_no_run_directory_exits_2_and_overwrites_nothing() {
    let tmp = TempDir::new("export-bad");
    let out = tmp.join("kept.nc");
    std::fs::write(&out, b"kept").unwrap();
    std::fs::create_dir_all(tmp.join("empty")).unwrap();
    for dir in [tmp.join("empty"), tmp.join("absent")] {
        let o = vbap()
            .arg("export")
            .arg(&dir)
            .arg("--netcdf")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains("not a run directory (no mission.toml)"),
            "{stderr}"
        );
        assert_eq!(std::fs::read(&out).unwrap(), b"kept");
    }
}
