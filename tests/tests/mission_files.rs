//! Mission-file pitfalls through the real `vbap`: what is no mission (exit 2, nothing
//! written), the shipped commented examples, `[batch]`, keys without a default, an unstable
//! time step, and numbers written short.

use std::path::Path;

use tests::*;

fn mission_file(name: &str) -> std::path::PathBuf {
    workspace().join("deploy/missions").join(name)
}

/// `vbap ARGS` must exit 2 with every `needles` in its stderr; returns the stderr.
fn refused(args: &[&std::ffi::OsStr], needles: &[&str]) -> String {
    let out = vbap().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{args:?}: {n:?} not in {stderr}");
    }
    stderr
}

fn os(s: &str) -> &std::ffi::OsStr {
    std::ffi::OsStr::new(s)
}

#[test]
fn the_commented_fault_examples_of_the_shipped_missions_validate() {
    let tmp = TempDir::new("example");
    for name in [
        "glider.toml",
        "glider_surfacing.toml",
        "glider_iridium.toml",
        "glider_acoustic.toml",
    ] {
        let text = read(&mission_file(name));
        let uncommented = uncomment_example(&text);
        assert!(
            uncommented.contains("\n[[faults]]\nkind = \"kill\""),
            "{name}"
        );
        let file = write_mission(&tmp, name, &uncommented);
        let out = run_ok(vbap().arg("check").arg(&file));
        assert!(String::from_utf8_lossy(&out.stdout).contains("valid"));
    }
}

#[test]
fn what_is_no_mission_exits_2_and_writes_nothing() {
    let tmp = TempDir::new("nomission");
    let empty = write_mission(&tmp, "empty.toml", "");
    let comments = write_mission(&tmp, "comments.toml", "# nothing here\n\n  # at all\n");
    let no_amplitude = write_mission(
        &tmp,
        "amp.toml",
        "[mission]\nname = \"amp\"\n[field]\ncenter = [1.0, 2.0]\nwidth = 3.0\n",
    );
    let mut huge = String::from("[mission]\nname = \"huge\"\n");
    while huge.len() <= 1 << 20 {
        huge.push_str("# a very long comment line that pads the file past its limit\n");
    }
    let huge = write_mission(&tmp, "huge.toml", &huge);
    let cases: [(&Path, &[&str]); 5] = [
        (
            &empty,
            &["empty.toml", "mission.name = (missing): required"],
        ),
        (&comments, &["comments.toml", "mission.name = (missing)"]),
        (
            &no_amplitude,
            &[
                "amp.toml",
                "field.amplitude = (missing): required for field.kind = \"gaussian\"",
            ],
        ),
        (
            Path::new("/dev/zero"),
            &["/dev/zero", "larger than 1048576 bytes"],
        ),
        (&huge, &["huge.toml", "larger than 1048576 bytes"]),
    ];
    for (file, needles) in cases {
        refused(&[os("check"), file.as_os_str()], needles);
        for cmd in ["run", "sim"] {
            let out = tmp.join(&format!("out-{cmd}"));
            refused(
                &[
                    os(cmd),
                    file.as_os_str(),
                    os("--out"),
                    out.as_os_str(),
                    os("--quiet"),
                ],
                needles,
            );
            assert!(!out.exists(), "{cmd} {}: --out written", file.display());
        }
    }
}

#[test]
fn a_batch_table_does_not_stop_check_run_or_sim() {
    let tmp = TempDir::new("batchtable");
    let name = unique_name("batchtable");
    let text = format!(
        "[mission]\nname = \"{name}\"\nduration = 1.0\n[field]\ncenter = [6.0, 3.0]\namplitude = 10.0\nwidth = 6.0\n\n[batch]\nmin_convergence_rate = 0.5\nmax_final_distance = 100.0\n"
    );
    let file = write_mission(&tmp, "m.toml", &text);
    run_ok(vbap().arg("check").arg(&file));
    vbap_quiet("sim", &file, &tmp.join("sim"));
    vbap_quiet("run", &file, &tmp.join("run"));
    assert!(!read(&tmp.join("run/mission.toml")).contains("[batch]"));
    assert_same_tracks(&tmp.join("sim"), &tmp.join("run"));
    // A bad criterion is still found by check, naming it.
    let bad = write_mission(
        &tmp,
        "bad.toml",
        &text.replace("min_convergence_rate = 0.5", "min_convergence_rate = 2"),
    );
    refused(
        &[os("check"), bad.as_os_str()],
        &["batch.min_convergence_rate", "between 0 and 1"],
    );
    assert!(leftover_files(&name).is_empty());
}

#[test]
fn an_unstable_time_step_is_refused_unless_allowed() {
    let tmp = TempDir::new("unstable");
    let text = "[mission]\nname = \"unstable\"\ndt = 1.0\n[field]\ncenter = [6.0, 3.0]\namplitude = 10.0\nwidth = 6.0\n";
    let file = write_mission(&tmp, "m.toml", text);
    refused(
        &[os("check"), file.as_os_str()],
        &[
            "m.toml: mission.dt = 1: unstable: ω·dt = ",
            "mission.allow_unstable = true",
        ],
    );
    let out = tmp.join("out");
    refused(
        &[os("sim"), file.as_os_str(), os("--out"), out.as_os_str()],
        &["mission.dt"],
    );
    assert!(!out.exists());
    let allowed = write_mission(
        &tmp,
        "allowed.toml",
        &text.replace("dt = 1.0", "dt = 1.0\nallow_unstable = true"),
    );
    let ok = run_ok(vbap().arg("check").arg(&allowed));
    let stderr = String::from_utf8_lossy(&ok.stderr);
    assert!(
        stderr.contains("warning") && stderr.contains("allow_unstable"),
        "{stderr}"
    );
}

#[test]
fn numbers_near_zero_are_written_short_and_read_back_exactly() {
    let tmp = TempDir::new("tiny");
    let name = unique_name("tiny");
    // Noise-free, starting at the minimum: gradients and speeds are rounding residue.
    let text = format!(
        "[mission]\nname = \"{name}\"\nduration = 5.0\ngoal = \"min\"\n[field]\nkind = \"quadratic\"\ncenter = [0.0, 0.0]\nhessian = [[1.0, 0.0], [0.0, 1.0]]\nnoise_std = 0.0\n[vehicles]\nstart_spread = 0.0\n"
    );
    let file = write_mission(&tmp, "m.toml", &text);
    vbap_quiet("sim", &file, &tmp.join("sim"));
    vbap_quiet("run", &file, &tmp.join("run"));
    assert_same_tracks(&tmp.join("sim"), &tmp.join("run"));
    let mut exponents = 0;
    for f in ["body.csv", "vehicles.csv", "planner_inputs.csv"] {
        let text = read(&tmp.join("sim").join(f));
        for line in text.lines().skip(1) {
            for cell in line.split(',') {
                assert!(
                    cell.len() <= 24,
                    "{f}: a {}-character cell {cell}",
                    cell.len()
                );
                if let Ok(x) = cell.parse::<f64>() {
                    exponents += usize::from(cell.contains('e'));
                    assert_eq!(vbap_mission::rundir::Num(x).to_string(), cell, "{f}");
                }
            }
        }
    }
    assert!(exponents > 0, "the mission produced numbers below 1e-4");
}

/// `--set KEY=VALUE` sets a mission key on top of the file for check, sim and batch, is
/// validated as if the file said it (exit 2 naming the key and the set), and the resolved
/// mission.toml says what was set.
#[test]
fn set_overrides_a_key_and_is_validated_like_the_file() {
    let tmp = TempDir::new("set");
    let file = mission_file("lossy_kill.toml");
    let file = file.as_os_str();
    let out = run_ok(vbap().args([os("check"), file, os("--set"), os("links.loss=0.3")]));
    assert!(String::from_utf8_lossy(&out.stdout).contains("valid"));
    refused(
        &[os("check"), file, os("--set"), os("links.loss=3")],
        &["with --set links.loss=3", "links.loss"],
    );
    refused(
        &[os("check"), file, os("--set"), os("control.law=fast")],
        &["control.law"],
    );
    refused(
        &[os("check"), file, os("--set"), os("links")],
        &["KEY=VALUE"],
    );
    let dir = tmp.join("paper");
    run_ok(vbap().args([
        os("sim"),
        file,
        os("--set"),
        os("control.law=paper"),
        os("--set"),
        os("mission.duration=70.0"),
        os("--quiet"),
        os("--out"),
        dir.as_os_str(),
    ]));
    let resolved = read(&dir.join("mission.toml"));
    assert!(resolved.contains("law = \"paper\""), "{resolved}");
    assert!(resolved.contains("duration = 70.0"), "{resolved}");
    assert!(resolved.contains("with --set control.law"), "{resolved}");
    assert_eq!(
        line_count(&dir.join("truth.csv")),
        701,
        "70 s at dt 0.1 and a header"
    );
}
