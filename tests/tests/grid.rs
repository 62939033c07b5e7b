//! `[field] kind = "grid"` end to end: an analytic field sampled onto a grid runs as the
//! analytic field does; the shipped ocean mission; bad files exit 2.

use tests::*;

fn mission(name: &str, field: &str) -> String {
    format!(
        r#"
[mission]
name = "{name}"
seed = 7
duration = 100.0
dt = 0.05
goal = "max"
dim = 2
tolerance = 1.0

[field]
{field}
noise_std = 0.1

[vehicles]
count = 4
start = [0.0, 0.0]
start_spread = 0.3
"#
    )
}

#[test]
fn an_analytic_field_sampled_onto_a_grid_gives_the_same_run_within_one_percent() {
    let tmp = TempDir::new("gridsame");
    let nc = tmp.join("g.nc");
    // Sampled at a tenth of the formation radius (the mission's resolution).
    tests::grid::write_gaussian_grid(&nc, 0.15);
    let analytic = write_mission(
        &tmp,
        "analytic.toml",
        &mission(
            "grid_a",
            "kind = \"gaussian\"\ncenter = [6.0, 3.0]\namplitude = 10.0\nwidth = 6.0",
        ),
    );
    let grid = write_mission(
        &tmp,
        "grid.toml",
        &mission("grid_g", "kind = \"grid\"\nfile = \"g.nc\""),
    );
    vbap_quiet("sim", &analytic, &tmp.join("a"));
    vbap_quiet("sim", &grid, &tmp.join("g"));
    let (a, g) = (summary(&tmp.join("a")), summary(&tmp.join("g")));
    let num = |s: &serde_json::Value, k: &str| {
        s[k].as_f64()
            .unwrap_or_else(|| panic!("{k} in summary.json: {s}"))
    };
    for key in ["time_to_converge_s", "final_distance_to_optimum"] {
        let (x, y) = (num(&a, key), num(&g, key));
        println!("{key}: analytic {x}, grid {y}");
        let scale = if key == "final_distance_to_optimum" {
            x.abs().max(0.01)
        } else {
            x.abs()
        };
        assert!(
            (x - y).abs() <= 0.01 * scale,
            "{key}: analytic {x}, grid {y}: more than 1 % apart"
        );
    }
    assert_eq!(a["verdict"], g["verdict"]);
}

#[test]
fn the_shipped_ocean_mission_checks_and_bad_files_exit_2() {
    let ocean = workspace().join("deploy/missions/ocean_grid.toml");
    let ok = vbap().arg("check").arg(&ocean).output().unwrap();
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );

    let tmp = TempDir::new("gridbad");
    std::fs::write(tmp.join("junk.nc"), b"CDF\x01 but not really").unwrap();
    let cases = [
        ("file = \"missing.nc\"", "no such file"),
        ("file = \"junk.nc\"", "not a NetCDF"),
        ("file = \"g.nc\"\nvariable = \"salt\"", "missing variable"),
    ];
    tests::grid::write_gaussian_grid(&tmp.join("g.nc"), 0.5);
    for (i, (field, what)) in cases.iter().enumerate() {
        let m = write_mission(
            &tmp,
            &format!("bad{i}.toml"),
            &mission(&format!("bad{i}"), &format!("kind = \"grid\"\n{field}")),
        );
        for cmd in ["check", "sim"] {
            let mut c = vbap();
            c.arg(cmd).arg(&m);
            if cmd == "sim" {
                c.arg("--out").arg(tmp.join(&format!("out{i}")));
            }
            let out = c.output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{cmd} {field}: {err}");
            assert!(
                err.contains("field.file") && err.contains(what),
                "{cmd}: {err}"
            );
        }
    }
}
