//! Tests of parsing: what no mission is, required keys, defaults, the pace, file limits.
//! The table of bad inputs is in `bad_inputs.rs`, the resolved mission in `resolved.rs`.

mod bad_inputs;
mod resolved;

use super::*;
use std::path::Path;

/// Parses `text` exactly as written.
fn parse_raw(text: &str) -> Result<Mission, ConfigError> {
    Mission::from_toml_str(text, "missions/x.toml")
}

/// `text` with the keys every mission must give added where it lacks them (`[mission]
/// name = "demo"`, the `[field]` keys of a gaussian, quadratic, eddy or front, at their
/// struct defaults), so a fragment tests the one key it is about. Text that is not TOML
/// (or whose `mission`/`field` is no table) is left as it is.
fn complete(text: &str) -> String {
    use toml::Value;
    let Ok(mut doc) = toml::from_str::<toml::Table>(text) else {
        return text.to_string();
    };
    let mut changed = false;
    let d = FieldConfig::default();
    let floats = |v: &[f64]| Value::Array(v.iter().map(|x| Value::Float(*x)).collect());
    for (section, keys) in [("mission", vec!["name"]), ("field", vec![])] {
        let table = doc
            .entry(section)
            .or_insert_with(|| Value::Table(toml::Table::new()));
        let Value::Table(t) = table else { continue };
        let mut keys: Vec<&str> = keys;
        if section == "field" {
            keys = match t.get("kind").and_then(Value::as_str).unwrap_or("gaussian") {
                "quadratic" => vec!["center", "hessian"],
                "gaussian" | "eddy" | "front" => vec!["center", "amplitude", "width"],
                _ => vec![],
            };
        }
        for key in keys {
            if t.contains_key(key) {
                continue;
            }
            let value = match key {
                "name" => Value::String("demo".into()),
                "center" => floats(&d.center),
                "amplitude" => Value::Float(d.amplitude),
                "width" => Value::Float(d.width),
                _ => Value::Array(d.hessian.iter().map(|r| floats(r)).collect()),
            };
            t.insert(key.to_string(), value);
            changed = true;
        }
    }
    if changed {
        toml::to_string(&doc).expect("a TOML table serialises")
    } else {
        text.to_string()
    }
}

/// Parses `text` [`complete`]d with the keys every mission must give.
fn parse(text: &str) -> Result<Mission, ConfigError> {
    parse_raw(&complete(text))
}

/// The smallest valid mission: the required keys, at the struct defaults.
const MINIMAL: &str =
    "[mission]\nname = \"demo\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n";

#[test]
fn empty_and_comment_only_files_are_no_mission() {
    for text in ["", "# a comment\n\n   # another\n", "[mission]\nseed = 3\n"] {
        let err = parse_raw(text).expect_err(text);
        assert_eq!(err.key(), Some("mission.name"), "{err}");
        let msg = err.to_string();
        assert!(
            msg.starts_with("missions/x.toml: mission.name = (missing): required"),
            "{msg}"
        );
        assert!(msg.contains("center, amplitude, width"), "{msg}");
    }
}

#[test]
fn field_keys_without_a_meaningful_default_are_required() {
    let name = "[mission]\nname = \"a\"\n";
    for (field, key, kind) in [
        ("", "field.center", "\"gaussian\" (the default kind)"),
        (
            "[field]\ncenter = [1.0, 2.0]\nwidth = 3.0\n",
            "field.amplitude",
            "\"gaussian\"",
        ),
        (
            "[field]\ncenter = [1.0, 2.0]\namplitude = 3.0\n",
            "field.width",
            "\"gaussian\"",
        ),
        (
            "[field]\nkind = \"quadratic\"\ncenter = [1.0, 2.0]\n",
            "field.hessian",
            "\"quadratic\"",
        ),
        (
            "[field]\nkind = \"eddy\"\ncenter = [1.0, 2.0]\namplitude = 1.0\nwidth = 2.0\n",
            "field.velocity",
            "\"eddy\"",
        ),
        (
            "[field]\nkind = \"front\"\nnormal = [1.0, 0.0]\nwidth = 2.0\n",
            "field.amplitude",
            "\"front\"",
        ),
        (
            "[field]\nkind = \"gaussian_sum\"\n",
            "field.bumps",
            "\"gaussian_sum\"",
        ),
    ] {
        let text = format!("{name}{field}");
        let err = parse_raw(&text).expect_err(&text);
        assert_eq!(err.key(), Some(key), "{text:?}: {err}");
        let msg = err.to_string();
        assert!(
            msg.contains("(missing): required for field.kind = "),
            "{msg}"
        );
        assert!(msg.contains(kind), "{msg}");
    }
    // Given, they are enough.
    let q = parse_raw("[mission]\nname = \"a\"\ngoal = \"min\"\n[field]\nkind = \"quadratic\"\ncenter = [1.0, 2.0]\nhessian = [[1.0, 0.0], [0.0, 1.0]]\n").unwrap();
    assert_eq!(q.field.kind, FieldKind::Quadratic);
}

#[test]
fn a_batch_table_is_accepted_and_not_resolved() {
    let text =
        format!("{MINIMAL}[batch]\nmin_convergence_rate = 0.9\nmax_final_distance = 1_000.0\n");
    let m = parse_raw(&text).unwrap();
    assert_eq!(m, parse_raw(MINIMAL).unwrap());
    assert!(!m.to_toml_string().contains("batch"));
}

#[test]
fn an_unstable_time_step_is_refused_unless_allowed() {
    // Defaults: ω ≈ 4.7 rad/s at the smallest scale; dt = 1 s gives ω·dt ≈ 4.7.
    let err = parse("[mission]\ndt = 1.0").unwrap_err();
    assert_eq!(err.key(), Some("mission.dt"), "{err}");
    let msg = err.to_string();
    assert!(msg.contains("unstable: ω·dt = 4.7"), "{msg}");
    assert!(msg.contains("mission.allow_unstable = true"), "{msg}");
    // damping·dt above 2 alone.
    let err = parse("[mission]\ndt = 0.05\n[vehicles]\ndamping = 50.0").unwrap_err();
    assert_eq!(err.key(), Some("mission.dt"), "{err}");
    assert!(err.to_string().contains("damping·dt = 2.50"), "{err}");
    let m = parse("[mission]\ndt = 1.0\nallow_unstable = true").unwrap();
    let w = m.stiffness_warning().expect("still warned");
    assert!(w.contains("allow_unstable"), "{w}");
    // Stiff but stable (1 < ω·dt ≤ 2): a warning only.
    let m = parse("[mission]\ndt = 0.3").unwrap();
    let st = m.stiffness().unwrap();
    assert!(st.omega_dt > 1.0 && st.omega_dt <= 2.0, "{st:?}");
    assert!(m.stiffness_warning().is_some());
    // An override that makes the step unstable is refused, naming the key.
    let err = parse(MINIMAL)
        .unwrap()
        .with_overrides(&Overrides {
            vehicles: Some(64),
            ..Overrides::default()
        })
        .unwrap_err();
    assert_eq!(err.key(), Some("mission.dt"), "{err}");
}

#[test]
fn a_huge_or_endless_file_is_refused_without_reading_it_all() {
    let err = Mission::load(Path::new("/dev/zero")).unwrap_err();
    assert!(matches!(err, ConfigError::TooLarge { .. }), "{err}");
    assert!(
        err.to_string()
            .starts_with("/dev/zero: the mission file is larger than 1048576 bytes"),
        "{err}"
    );
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.toml");
    let mut text = String::from(MINIMAL);
    while text.len() as u64 <= MAX_FILE_BYTES {
        text.push_str("# padding padding padding padding padding padding padding padding\n");
    }
    std::fs::write(&big, &text).unwrap();
    assert!(matches!(
        Mission::load(&big).unwrap_err(),
        ConfigError::TooLarge { .. }
    ));
    // Just under the limit is read.
    text.truncate(MAX_FILE_BYTES as usize - 1);
    let cut = text.rfind('\n').unwrap() + 1;
    text.truncate(cut);
    std::fs::write(&big, &text).unwrap();
    assert!(Mission::load(&big).is_ok());
    // Not text.
    std::fs::write(&big, [0xff, 0xfe, 0x00]).unwrap();
    let err = Mission::load(&big).unwrap_err();
    assert!(err.to_string().contains("not UTF-8"), "{err}");
}

#[test]
fn the_glider_fault_examples_validate_when_uncommented() {
    for name in ["glider.toml", "glider_surfacing.toml"] {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions/");
        let text = std::fs::read_to_string(format!("{dir}{name}")).unwrap();
        let uncommented = uncomment_example(&text);
        assert_ne!(uncommented, text, "{name} has a commented example");
        let m = Mission::from_toml_str(&uncommented, name)
            .unwrap_or_else(|e| panic!("{e}\n{uncommented}"));
        assert_eq!(m.faults.len(), 1, "{name}");
        assert_eq!(m.faults[0].kind, FaultKind::Kill);
        assert_eq!(m.faults[0].until, Some(43200.0));
        assert_eq!(m.restart.vehicles, RestartPolicy::OnFailure);
    }
}

/// Uncomments the trailing example of a mission file: from its first line `# [` on,
/// every line `# x` becomes `x` (`## x` stays a comment).
pub(super) fn uncomment_example(text: &str) -> String {
    let mut on = false;
    let mut out = String::new();
    for line in text.lines() {
        on |= line.starts_with("# [");
        match line.strip_prefix("# ") {
            Some(code) if on => out.push_str(code),
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

#[test]
fn a_minimal_file_gives_every_default() {
    let m = parse_raw(MINIMAL).expect("defaults are valid");
    let s = &m.mission;
    assert_eq!(s.name, "demo");
    assert_eq!(s.seed, 1);
    assert_eq!(s.duration, 300.0);
    assert_eq!(s.dt, 0.05);
    assert_eq!(s.pace, Pace::Lockstep);
    assert_eq!(s.goal, Goal::Max);
    assert_eq!(s.dim, 2);
    assert_eq!(s.tolerance, 1.0);
    assert_eq!(s.length_unit, "");
    assert_eq!(s.field_label, "T");
    let f = &m.field;
    assert_eq!(f.kind, FieldKind::Gaussian);
    assert_eq!(f.center, vec![20.0, 10.0]);
    assert_eq!(f.amplitude, 10.0);
    assert_eq!(f.width, 15.0);
    assert_eq!(f.hessian, vec![vec![1.0, 0.0], vec![0.0, 1.0]]);
    assert_eq!(f.noise_std, 0.1);
    assert_eq!(f.background, 0.0);
    assert_eq!(f.offset, 0.0);
    assert!(f.velocity.is_empty() && f.normal.is_empty() && f.bumps.is_empty());
    assert_eq!(f.speed, 0.0);
    let v = &m.vehicles;
    assert_eq!(v.count, 4);
    assert_eq!(v.start, vec![0.0, 0.0]);
    assert_eq!(v.start_spread, 0.5);
    assert_eq!(v.damping, 1.0);
    let fo = &m.formation;
    assert_eq!(fo.radius, 1.5);
    assert!(fo.adapt);
    assert_eq!(fo.adapt_gain, 0.5);
    assert_eq!(fo.alpha, 1.0);
    assert_eq!(fo.min_scale, 0.2);
    assert_eq!(fo.max_scale, 5.0);
    assert_eq!(fo.sigma_h, 1.0);
    assert_eq!(fo.hessian_guess, None);
    let b = &m.body;
    assert_eq!(
        (b.v0, b.v_u, b.delta, b.grad_saturation),
        (0.5, 1.0, 0.01, 1.0)
    );
    let e = &m.estimator;
    assert_eq!(e.kalman_b, 0.05);
    assert_eq!(e.confidence, 0.99);
    assert_eq!(e.delta_m, None);
    assert_eq!(e.sigma_m, None);
    assert_eq!(e.initial_variance, 1.0);
    let l = &m.links;
    assert_eq!(
        (
            l.delay,
            l.jitter,
            l.loss,
            l.surfacing_period,
            l.surfacing_window
        ),
        (0.0, 0.0, 0.0, 0.0, 0.0)
    );
    assert!(m.faults.is_empty());
    assert!(!s.allow_unstable);
    assert_eq!(m, Mission::default());
    assert_eq!(m.ticks(), 6000);
    assert_eq!(m.start_vec(), Vec3::zeros());
    assert_eq!(
        m.hessian_guess_mat(),
        Mat3::from_diagonal(&Vec3::new(1.0, 1.0, 0.0))
    );
    assert_eq!(m.origin, "missions/x.toml");
}

#[test]
fn a_missing_section_takes_its_defaults_and_others_keep_theirs() {
    let m = parse("[body]\nv0 = 0.25\n").unwrap();
    assert_eq!(m.body.v0, 0.25);
    assert_eq!(m.body.v_u, 1.0);
    assert_eq!(m.mission, MissionSection::default());
}

#[test]
fn pace_accepts_lockstep_floats_and_integers() {
    assert_eq!(
        parse("[mission]\npace = \"lockstep\"")
            .unwrap()
            .mission
            .pace,
        Pace::Lockstep
    );
    assert_eq!(
        parse("[mission]\npace = 60").unwrap().mission.pace,
        Pace::Factor(60.0)
    );
    assert_eq!(
        parse("[mission]\npace = 0.5").unwrap().mission.pace,
        Pace::Factor(0.5)
    );
    let e = parse("[mission]\npace = \"fast\"").unwrap_err();
    assert_eq!(e.key(), Some("mission.pace"), "{e}");
    assert!(e.to_string().contains("lockstep"), "{e}");
    assert_eq!("lockstep".parse::<Pace>(), Ok(Pace::Lockstep));
    assert_eq!("2.5".parse::<Pace>(), Ok(Pace::Factor(2.5)));
    assert!("0".parse::<Pace>().is_err());
    assert!("-1".parse::<Pace>().is_err());
    assert!("inf".parse::<Pace>().is_err());
    assert!("NaN".parse::<Pace>().is_err());
    assert_eq!(Pace::Factor(60.0).to_string(), "60");
}

#[test]
fn suffixed_names_fit_and_keep_the_suffix() {
    assert_eq!(suffixed_name("paper", "_s3"), "paper_s3");
    let long = suffixed_name(&"a".repeat(3 * MAX_NAME_LEN), "_c012");
    assert_eq!(long.len(), MAX_NAME_LEN);
    assert!(long.ends_with("_c012"));
}

/// The robust law follows its body where the envelope holds (links not ideal) unless
/// `control.follow_body` says otherwise; the paper's law never does.
#[test]
fn the_robust_law_follows_its_body_where_the_envelope_holds_or_where_told() {
    let follows = |extra: &str| {
        parse_raw(&complete(extra))
            .unwrap_or_else(|e| panic!("{extra}: {e}"))
            .follows_body()
    };
    // The defaults cruise at v0 = 0.5 and trail 1.06 spacings: followed. At v0 = 0.05
    // (0.106 spacing) the paper's law is kept on ideal links.
    assert!(follows(""), "the defaults trail their body");
    assert!(
        !follows("[body]\nv0 = 0.05\n"),
        "ideal links, little trail: the paper's law"
    );
    assert!(follows("[links]\ndelay = 0.5\n"));
    assert!(follows("[control]\nfollow_body = true\n"));
    assert!(!follows(
        "[control]\nfollow_body = false\n[links]\ndelay = 0.5\n"
    ));
    assert!(!follows(
        "[control]\nlaw = \"paper\"\nfollow_body = true\n[links]\ndelay = 0.5\n"
    ));
    // On ideal links where damping against the water would leave the ring more than an
    // eighth of a spacing behind (T.1): 2 · 4 · v0 · 2² / 20 = 1.6 v0 against a spacing
    // of 0.7804, so above v0 = 0.061.
    let ring = |v0: f64| {
        format!(
            "[vehicles]\ncount = 16\ndamping = 4.0\n[formation]\nradius = 2.0\nalpha = 20.0\n\
             min_scale = 0.7\n[body]\nv0 = {v0}\n"
        )
    };
    assert!(!follows(&ring(0.06)), "0.123 spacing");
    assert!(follows(&ring(0.07)), "0.144 spacing");
    assert!(!follows(&(ring(0.5) + "[control]\nfollow_body = false\n")));
    assert!(!follows(&(ring(0.5) + "[control]\nlaw = \"paper\"\n")));
}

/// (T.1) of `config/trail.rs`: a ring damped against the water lags its body by
/// dim·K·v0·h0²/α_h; warned beyond a quarter spacing, never when it follows its body.
#[test]
fn a_ring_that_trails_its_body_by_more_than_a_quarter_spacing_is_warned_about() {
    let ring = |v0: f64, extra: &str| {
        parse_raw(&complete(&format!(
            "[vehicles]\ncount = 16\ndamping = 4.0\n[formation]\nradius = 2.0\nalpha = 20.0\nmin_scale = 0.7\n\
             [body]\nv0 = {v0}\n{extra}"
        )))
        .unwrap_or_else(|e| panic!("{extra}: {e}"))
    };
    // The robust law (the default) follows a body it would trail by this much, and
    // `vbap check` says so.
    assert!(ring(0.5, "").body_trail().is_none());
    assert!(ring(0.5, "").trail_warning().is_none());
    let line = ring(0.5, "").trail_line().unwrap();
    assert!(
        line.starts_with("trail: none: the robust law damps relative to the body")
            && line.contains("0.8000 (1.03 neighbour spacings)"),
        "{line}"
    );
    let m = ring(0.5, "[control]\nfollow_body = false\n");
    let t = m
        .body_trail()
        .expect("a central ring on ideal links trails");
    // 2 · 4 · 0.5 · 2² / 20 = 0.8; spacing 2 · 2 · sin(π/16) = 0.7804.
    assert!((t.lag - 0.8).abs() < 1e-12, "{t:?}");
    assert!(
        (t.spacing - 4.0 * (std::f64::consts::PI / 16.0).sin()).abs() < 1e-9,
        "{t:?}"
    );
    let w = m.trail_warning().expect("1.03 spacings is warned about");
    assert!(w.contains("1.03 neighbour spacings"), "{w}");
    assert!(w.contains("control.follow_body = true"), "{w}");
    assert_eq!(m.water_trail(), Some(t));
    let line = m.trail_line().unwrap();
    assert!(line.contains("0.8000 (1.03 neighbour spacings)"), "{line}");
    // Slower, within a quarter spacing: no warning, the lag still shown.
    assert!(ring(0.05, "").trail_warning().is_none());
    assert!(ring(0.05, "")
        .trail_line()
        .unwrap()
        .contains("0.0800 (0.10"));
    // Damping relative to the body: no lag at all.
    assert!(ring(0.5, "[control]\nfollow_body = true\n")
        .body_trail()
        .is_none());
    // The paper's law is told to change law.
    let w = ring(0.5, "[control]\nlaw = \"paper\"\n")
        .trail_warning()
        .unwrap();
    assert!(w.contains("control.law = \"robust\""), "{w}");
}
