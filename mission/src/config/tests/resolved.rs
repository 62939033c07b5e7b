//! The resolved mission: short exact floats, round trips, overrides, the shipped missions.

use super::*;

const FULL: &str = r#"
[mission]
name = "full_3d"
seed = 9223372036854775807
duration = 100.0
dt = 0.1
pace = 2.5
goal = "min"
dim = 3
tolerance = 0.3
length_unit = "km"
field_label = "S (psu)"

[field]
kind = "front"
center = [1.0, 2.0, 3.0]
amplitude = -1.5
width = 0.30000000000000004
normal = [0.0, 1.0, 1.0]
speed = 0.01
offset = -2.0
background = 12.0
noise_std = 0.0

[[field.bumps]]
center = [1.0, 1.0, 1.0]
amplitude = -2.0
width = 1e-3

[vehicles]
count = 6
start = [0.1, 0.2, 0.3]

[formation]
adapt = false
adapt_gain = 0.0
hessian_guess = [[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]]

[estimator]
sigma_m = 0.2

[links]
delay = 1.0
jitter = 0.5
loss = 0.1
surfacing_period = 60.0
surfacing_window = 6.0
surfacing_phase = "together"
burst_enter = 0.01

[restart]
vehicles = "on-failure"
backoff = 0.5

[[faults]]
kind = "kill"
vehicle = 2
at = 20.0
until = 40.0

[[faults]]
kind = "sensor_stuck"
vehicle = 5
at = 0.0

[[faults]]
kind = "sensor_bias"
vehicle = 0
at = 100.0
value = -0.5
"#;

#[test]
fn resolved_floats_are_short_and_exact() {
    let text =
        "[mission]\nname = \"tiny\"\nfield_label = \"T 0.0000000000000000000001 '#\\\" x\"\n\
                [field]\ncenter = [1e300, -1e-300]\namplitude = 2.5e-7\nwidth = 9000.0\n\
                [formation]\nadapt_gain = 1e-300\nhessian_guess = [[2.5e-8, 0.0], [0.0, 1e-320]]\n";
    let m = parse_raw(text).unwrap();
    let resolved = m.to_toml_string();
    for line in resolved.lines() {
        assert!(line.len() < 120, "{line}");
    }
    assert!(resolved.contains("adapt_gain = 1e-300"), "{resolved}");
    assert!(resolved.contains("amplitude = 2.5e-7"), "{resolved}");
    assert!(resolved.contains("width = 9000.0"), "{resolved}");
    assert!(resolved.contains("center = [1e300, -1e-300]"), "{resolved}");
    assert!(
        resolved.contains("T 0.0000000000000000000001 '#"),
        "strings untouched: {resolved}"
    );
    let back = parse_raw(&resolved).unwrap_or_else(|e| panic!("{e}\n{resolved}"));
    assert_eq!(back, m);
    assert_eq!(
        back.mission.field_label,
        "T 0.0000000000000000000001 '#\" x"
    );
    assert_eq!(
        back.formation.hessian_guess.unwrap()[1][1].to_bits(),
        1e-320f64.to_bits()
    );
}

#[test]
fn resolved_mission_round_trips() {
    for m in [Mission::default(), parse(FULL).unwrap()] {
        let text = m.to_toml_string();
        let back = Mission::from_toml_str(&text, "resolved.toml")
            .unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(back, m, "{text}");
        // Every section is written out in full.
        for section in [
            "[mission]",
            "[field]",
            "[vehicles]",
            "[formation]",
            "[body]",
            "[estimator]",
            "[links]",
        ] {
            assert!(text.contains(section), "{section} missing in\n{text}");
        }
        assert!(text.contains("grad_saturation = "), "{text}");
    }
    let full = parse(FULL).unwrap();
    assert_eq!(full.faults.len(), 3);
    assert_eq!(full.faults[0].until, Some(40.0));
    assert_eq!(full.start_vec(), Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(full.hessian_guess_mat()[(0, 1)], 0.5);
    assert_eq!(full.hessian_guess_mat()[(2, 2)], 1.0);
    assert_eq!(full.ticks(), 1000);
    assert_eq!(full.mission.pace, Pace::Factor(2.5));
}

#[test]
fn overrides_apply_and_revalidate() {
    let m = parse(FULL).unwrap();
    let o = Overrides {
        seed: Some(5),
        vehicles: Some(8),
        duration: Some(200.0),
        pace: Some(Pace::Lockstep),
    };
    let m2 = m.clone().with_overrides(&o).unwrap();
    assert_eq!(m2.mission.seed, 5);
    assert_eq!(m2.vehicles.count, 8);
    assert_eq!(m2.mission.duration, 200.0);
    assert_eq!(m2.mission.pace, Pace::Lockstep);
    assert_eq!(m2.ticks(), 2000);
    assert_eq!(m.clone().with_overrides(&Overrides::default()).unwrap(), m);
    // Fewer vehicles than a fault refers to.
    let err = m
        .clone()
        .with_overrides(&Overrides {
            vehicles: Some(5),
            ..Overrides::default()
        })
        .unwrap_err();
    assert_eq!(err.key(), Some("faults[1].vehicle"), "{err}");
    assert!(err.to_string().contains("--vehicles 5"), "{err}");
    // Too few for 3-D least squares.
    let err = m
        .clone()
        .with_overrides(&Overrides {
            vehicles: Some(3),
            ..Overrides::default()
        })
        .unwrap_err();
    assert_eq!(err.key(), Some("vehicles.count"), "{err}");
    // A shorter mission than a fault time; a seed TOML cannot hold; a bad pace.
    for (o, key) in [
        (
            Overrides {
                duration: Some(50.0),
                ..Overrides::default()
            },
            "faults[2].at",
        ),
        (
            Overrides {
                seed: Some(u64::MAX),
                ..Overrides::default()
            },
            "mission.seed",
        ),
        (
            Overrides {
                pace: Some(Pace::Factor(0.0)),
                ..Overrides::default()
            },
            "mission.pace",
        ),
    ] {
        let err = m.clone().with_overrides(&o).unwrap_err();
        assert_eq!(err.key(), Some(key), "{err}");
    }
}

#[test]
fn shipped_missions_parse_and_validate() {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions"));
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .expect("deploy/missions exists")
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 3, "{files:?}");
    for path in &files {
        let m = Mission::load(path).unwrap_or_else(|e| panic!("{e}"));
        let back = Mission::from_toml_str(&m.to_toml_string(), "resolved")
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(back, m, "{}", path.display());
        assert!(
            m.ticks() <= 50_000,
            "{}: {} ticks",
            path.display(),
            m.ticks()
        );
    }
}
