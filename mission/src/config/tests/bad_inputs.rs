//! Every bad input is refused naming its key; unknown keys, syntax errors, missing files.

use super::*;

/// (TOML text, key that must be named). Each is valid except for that one key.
const BAD: &[(&str, &str)] = &[
    ("[mission]\nname = \"a-b\"", "mission.name"),
    ("[mission]\nname = \"\"", "mission.name"),
    ("[mission]\nname = \"abcdefghijabcdefghijabcdefghij123\"", "mission.name"),
    ("[mission]\nseed = -1", "mission.seed"),
    ("[mission]\ndt = 0", "mission.dt"),
    ("[mission]\ndt = -0.1", "mission.dt"),
    ("[mission]\ndt = nan", "mission.dt"),
    ("[mission]\nduration = inf", "mission.duration"),
    ("[mission]\nduration = 0.01\ndt = 0.05", "mission.duration"),
    ("[mission]\nduration = 1e6\ndt = 0.05", "mission.duration"),
    ("[mission]\npace = 0", "mission.pace"),
    ("[mission]\npace = -2.0", "mission.pace"),
    ("[mission]\npace = nan", "mission.pace"),
    ("[mission]\ngoal = \"up\"", "mission.goal"),
    ("[mission]\ndim = 4", "mission.dim"),
    ("[mission]\ndim = 1", "mission.dim"),
    ("[mission]\ntolerance = 0", "mission.tolerance"),
    ("[mission]\nlength_unit = \"a\\nb\"", "mission.length_unit"),
    ("[mission]\nstart = \"2026-08-01\"", "mission.start"),
    ("[mission]\nstart = \"yesterday\"", "mission.start"),
    ("[mission]\nfield_label = \"abcdefghijabcdefghijabcdefghij123\"", "mission.field_label"),
    ("[mission]\ndim = 3", "field.center"),
    ("[field]\nkind = \"plane\"", "field.kind"),
    ("[field]\nwidth = -1", "field.width"),
    ("[field]\nwidth = 0", "field.width"),
    ("[field]\namplitude = 0", "field.amplitude"),
    ("[field]\namplitude = inf", "field.amplitude"),
    ("[field]\ncenter = [1.0]", "field.center"),
    ("[field]\ncenter = [1.0, nan]", "field.center[1]"),
    ("[field]\ncenter = [1.0, \"a\"]", "field.center[1]"),
    ("[field]\nnoise_std = -0.1", "field.noise_std"),
    ("[field]\nbackground = nan", "field.background"),
    ("[field]\nkind = \"quadratic\"\nhessian = [[1.0, 2.0], [0.0, 1.0]]", "field.hessian"),
    ("[field]\nkind = \"quadratic\"\nhessian = [[1.0, 0.0]]", "field.hessian"),
    ("[field]\nkind = \"quadratic\"\nhessian = [[1.0, 0.0], [0.0, inf]]", "field.hessian[1][1]"),
    ("[field]\nvelocity = [1.0, 0.0]", "field.velocity"),
    ("[field]\nkind = \"eddy\"", "field.velocity"),
    ("[field]\nkind = \"eddy\"\nvelocity = [1.0, 0.0, 0.0]", "field.velocity"),
    ("[field]\nkind = \"front\"", "field.normal"),
    ("[field]\nkind = \"front\"\nnormal = [0.0, 0.0]", "field.normal"),
    ("[field]\nnormal = [1.0, 0.0]", "field.normal"),
    ("[field]\nkind = \"front\"\nnormal = [1.0, 0.0]\nspeed = inf", "field.speed"),
    ("[field]\nkind = \"gaussian_sum\"", "field.bumps"),
    (
        "[field]\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0",
        "field.bumps",
    ),
    (
        "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = -1.0",
        "field.bumps[1].width",
    ),
    (
        "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0]\namplitude = 1.0\nwidth = 1.0",
        "field.bumps[0].center",
    ),
    (
        "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 0.0\nwidth = 1.0",
        "field.bumps[0].amplitude",
    ),
    (
        "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\nwidth = 1.0",
        "field.bumps[0].amplitude",
    ),
    (
        "[field]\nkind = \"front\"\nnormal = [1.0, 0.0]\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0",
        "field.bumps",
    ),
    ("[vehicles]\ncount = 2", "vehicles.count"),
    ("[vehicles]\ncount = 1025", "vehicles.count"),
    ("[vehicles]\ncount = -1", "vehicles.count"),
    ("[mission]\ndim = 3\n[field]\ncenter = [1.0, 2.0, 3.0]\n[vehicles]\nstart = [0.0, 0.0, 0.0]\ncount = 3", "vehicles.count"),
    // 100 vehicles in 3-D: 400 per-slot leaders, more than a body command carries.
    ("[mission]\ndim = 3\nallow_unstable = true\n[field]\ncenter = [1.0, 2.0, 3.0]\n[vehicles]\nstart = [0.0, 0.0, 0.0]\ncount = 100\n[formation]\nradius = 20.0", "vehicles.count"),
    ("[vehicles]\nstart = [0.0, 0.0, 0.0]", "vehicles.start"),
    ("[vehicles]\nstart_spread = -1", "vehicles.start_spread"),
    ("[vehicles]\ndamping = 0", "vehicles.damping"),
    ("[formation]\nradius = 0", "formation.radius"),
    ("[formation]\nadapt = \"yes\"", "formation.adapt"),
    ("[body]\ntrack_drift = 1", "body.track_drift"),
    ("[formation]\nadapt_gain = 0", "formation.adapt_gain"),
    ("[formation]\nadapt_gain = -1\nadapt = false", "formation.adapt_gain"),
    ("[formation]\nalpha = -1", "formation.alpha"),
    ("[formation]\nmin_scale = 0", "formation.min_scale"),
    ("[formation]\nmin_scale = 1.5", "formation.min_scale"),
    ("[formation]\nmax_scale = 0.5", "formation.max_scale"),
    ("[formation]\nsigma_h = 0", "formation.sigma_h"),
    ("[formation]\nhessian_guess = [[1.0, 0.1], [0.0, 1.0]]", "formation.hessian_guess"),
    ("[formation]\nhessian_guess = [[1.0, 0.0, 0.0]]", "formation.hessian_guess"),
    ("[formation]\nhessian_guess = [[0.0, 0.0], [0.0, 0.0]]", "formation.hessian_guess"),
    ("[body]\nv0 = 0", "body.v0"),
    ("[body]\nv_u = -1", "body.v_u"),
    ("[body]\ndelta = 0", "body.delta"),
    ("[body]\ngrad_saturation = 0", "body.grad_saturation"),
    ("[estimator]\nkalman_b = 0", "estimator.kalman_b"),
    ("[control]\ncurvature_memory = 0", "control.curvature_memory"),
    ("[control]\ncurvature_memory = nan", "control.curvature_memory"),
    ("[control]\ncurvature = \"guessed\"", "control.curvature"),
    ("[estimator]\nconfidence = 1.0", "estimator.confidence"),
    ("[estimator]\nconfidence = 0.0", "estimator.confidence"),
    ("[estimator]\ndelta_m = -0.1", "estimator.delta_m"),
    ("[estimator]\nsigma_m = 0.0", "estimator.sigma_m"),
    ("[estimator]\ninitial_variance = 0", "estimator.initial_variance"),
    ("[links]\ndelay = -1", "links.delay"),
    ("[links]\ndelay = 1\njitter = 2", "links.jitter"),
    ("[links]\nloss = 1.0", "links.loss"),
    ("[links]\nloss = -0.1", "links.loss"),
    ("[links]\nsurfacing_period = -1", "links.surfacing_period"),
    ("[links]\nsurfacing_period = 10\nsurfacing_window = 20", "links.surfacing_window"),
    ("[links]\nsurfacing_period = 10", "links.surfacing_window"),
    ("[links]\nburst_enter = 1.5", "links.burst_enter"),
    ("[links]\nburst_enter = 0.1\nburst_exit = 0.0", "links.burst_exit"),
    ("[links]\nposition_quantum = -0.01", "links.position_quantum"),
    ("[links]\nposition_quantum = 0.5", "links.position_quantum"),
    ("[links.iridium]\nsession_interval = 0", "links.iridium.session_interval"),
    ("[links.iridium]\nsession_failure = 1.0", "links.iridium.session_failure"),
    ("[links.iridium]\nsession_failure = -0.1", "links.iridium.session_failure"),
    ("[links.iridium]\nup_limit = 60", "links.iridium.up_limit"),
    ("[links.iridium]\ndown_limit = 100", "links.iridium.down_limit"),
    ("[links.iridium]\nlatency_short = -1.0", "links.iridium.latency_short"),
    ("[links.iridium]\nlatency_full = 1.0", "links.iridium.latency_full"),
    ("[links.iridium]\noversize = \"truncate\"", "links.iridium.oversize"),
    ("[links.iridium]\nsessions = 3", "links.iridium.sessions"),
    ("[acoustic]", "acoustic.frame_bytes"),
    ("[acoustic]\nframe_bytes = 64\nbit_rate = 0", "acoustic.bit_rate"),
    ("[acoustic]\nframe_bytes = 64\nsound_speed = -1.0", "acoustic.sound_speed"),
    ("[acoustic]\nframe_bytes = 64\ncommunication_range = 0", "acoustic.communication_range"),
    ("[acoustic]\nframe_bytes = 64\ndetection_range = 100.0", "acoustic.detection_range"),
    ("[acoustic]\nframe_bytes = 64\ninterference_range = 3500.0", "acoustic.interference_range"),
    ("[acoustic]\nframe_bytes = 64\ndecode_probability = 0", "acoustic.decode_probability"),
    ("[acoustic]\nframe_bytes = 64\ndecode_probability = 1.5", "acoustic.decode_probability"),
    ("[acoustic]\nframe_bytes = 64\ninterval = 5.0", "acoustic.interval"),
    ("[acoustic]\nframe_bytes = 64\ninterval = 0.01", "acoustic.interval"),
    ("[acoustic]\nframe_bytes = 64\nschedule = \"tdma\"\ninterval = 30.0", "acoustic.interval"),
    ("[acoustic]\nframe_bytes = 64\nschedule = \"csma\"", "acoustic.schedule"),
    ("[acoustic]\nframe_bytes = 64\nrange = 3.0", "acoustic.range"),
    ("[vehicles]\ncount = 65\n[acoustic]\nframe_bytes = 64", "vehicles.count"),
    ("[restart]\nbackoff = 0", "restart.backoff"),
    ("[restart]\nmax_backoff = -1", "restart.max_backoff"),
    ("[control]\nneighbour_memory = 0", "control.neighbour_memory"),
    ("[control]\nneighbour_memory = -3.0", "control.neighbour_memory"),
    ("[restart]\nvehicles = \"sometimes\"", "restart.vehicles"),
    ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 10.0\nuntil = 20.0", "faults[0].until"),
    ("[[faults]]\nkind = \"kill\"\nvehicle = 4\nat = 1.0", "faults[0].vehicle"),
    ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = -1.0", "faults[0].at"),
    ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 301.0", "faults[0].at"),
    ("[[faults]]\nkind = \"link_down\"\nvehicle = 1\nat = 10.0\nuntil = 5.0", "faults[0].until"),
    ("[[faults]]\nkind = \"link_down\"\nvehicle = 1\nat = 10.0\nuntil = 400.0", "faults[0].until"),
    ("[[faults]]\nkind = \"sensor_bias\"\nvehicle = 1\nat = 10.0", "faults[0].value"),
    ("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 10.0\nvalue = 2.0", "faults[0].value"),
    ("[[faults]]\nkind = \"sensor_stuck\"\nvehicle = 1\nat = 10.0\nvalue = nan", "faults[0].value"),
    ("[[faults]]\nkind = \"explode\"\nvehicle = 1\nat = 10.0", "faults[0].kind"),
    ("[[faults]]\nkind = \"kill\"\nvehicle = 1", "faults[0].at"),
    (
        "[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 1.0\n[[faults]]\nkind = \"kill\"\nat = 2.0",
        "faults[1].vehicle",
    ),
    ("[mission]\nname = 3", "mission.name"),
    ("mission = 3", "mission"),
    ("[mission]\ndt = 1.0", "mission.dt"),
    ("[mission]\nallow_unstable = 1", "mission.allow_unstable"),
    ("[vehicles]\ndamping = 45.0", "mission.dt"),
    ("[field]\nwidth = -1e-300", "field.width"),
    ("[batch]\nmin_convergence_rate = 0.5\n[mission]\nname = \"a.b\"", "mission.name"),
];

#[test]
fn every_bad_input_is_refused_naming_its_key() {
    for (text, key) in BAD {
        let err = parse(text).expect_err(text);
        assert_eq!(err.key(), Some(*key), "{text:?} gave: {err}");
        let msg = err.to_string();
        assert!(msg.starts_with("missions/x.toml: "), "{msg}");
        assert!(msg.contains(key), "{msg}");
    }
}

#[test]
fn invalid_message_has_the_documented_form() {
    let err = parse("[field]\nwidth = -1").unwrap_err();
    assert_eq!(
        err.to_string(),
        "missions/x.toml: field.width = -1: must be > 0"
    );
}

#[test]
fn unknown_keys_are_refused_by_name_and_line() {
    let err = parse_raw("[mission]\nname = \"a\"\n[field]\nwidht = 3.0\n").unwrap_err();
    assert_eq!(err.key(), Some("field.widht"), "{err}");
    let msg = err.to_string();
    assert!(msg.contains("unknown field `widht`"), "{msg}");
    assert!(msg.contains("line 4, column 1"), "{msg}");
    let err = parse_raw("speed = 3.0\n").unwrap_err();
    assert_eq!(err.key(), Some("speed"), "{err}");
    let err = parse_raw("[fields]\nkind = \"gaussian\"\n").unwrap_err();
    assert_eq!(err.key(), Some("fields"), "{err}");
    let err =
        parse_raw("[[faults]]\nkind = \"kill\"\nvehicle = 1\nat = 1.0\nwhen = 2.0\n").unwrap_err();
    assert_eq!(err.key(), Some("faults[0].when"), "{err}");
    let err = parse_raw(
        "[field]\nkind = \"gaussian_sum\"\n[[field.bumps]]\ncenter = [0.0, 0.0]\namplitude = 1.0\nwidth = 1.0\nsigma = 2\n",
    )
    .unwrap_err();
    assert_eq!(err.key(), Some("field.bumps[0].sigma"), "{err}");
}

#[test]
fn syntax_errors_keep_line_and_column() {
    let err = parse_raw("[mission]\nname = 'x\n").unwrap_err();
    match &err {
        ConfigError::Syntax { line, column, .. } => assert_eq!((*line, *column), (2, 10)),
        other => panic!("not a syntax error: {other}"),
    }
    assert!(err
        .to_string()
        .starts_with("missions/x.toml: line 2, column 10: invalid TOML"));
    let err = parse_raw("[mission]\nseed = 1\n[mission]\n").unwrap_err();
    assert!(matches!(err, ConfigError::Syntax { line: 3, .. }), "{err}");
}

#[test]
fn missing_file_names_it() {
    let err = Mission::load(Path::new("/nonexistent/m.toml")).unwrap_err();
    assert!(matches!(err, ConfigError::Read { .. }));
    assert!(
        err.to_string()
            .starts_with("/nonexistent/m.toml: cannot read"),
        "{err}"
    );
}
