//! The declared space of missions a stress campaign samples from ([`Space`]), printed by
//! `vbap stress --space` and documented in docs/STRESS.md.
//!
//! Every mission is in the non-dimensional setting of the paper (`deploy/missions/paper.toml`:
//! length unit L, seconds, field unit F, dt = 0.05 s), so the whole space flies fast in the
//! in-process simulator; the glider model is flown at that scale too, its limits given in
//! multiples of the body's speed.

use std::fmt;

use serde::Serialize;

/// A closed range of a real parameter and how it is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Range {
    /// Lowest value drawn.
    pub lo: f64,
    /// Highest value drawn.
    pub hi: f64,
    /// Log-uniform (the range spans a decade or more) instead of uniform.
    pub log: bool,
}

impl Range {
    /// Uniform on [lo, hi].
    pub const fn uniform(lo: f64, hi: f64) -> Range {
        Range { lo, hi, log: false }
    }
    /// Log-uniform on [lo, hi] (lo > 0).
    pub const fn log(lo: f64, hi: f64) -> Range {
        Range { lo, hi, log: true }
    }
    /// A draw from `u`, a uniform number in [0, 1).
    pub fn at(&self, u: f64) -> f64 {
        if self.log {
            (self.lo.ln() + u * (self.hi.ln() - self.lo.ln())).exp()
        } else {
            self.lo + u * (self.hi - self.lo)
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} .. {} ({})",
            self.lo,
            self.hi,
            if self.log { "log-uniform" } else { "uniform" }
        )
    }
}

/// The declared space of a campaign: what a sampled mission may be. Units: L (length unit),
/// s, F (field unit); "× v0" is a multiple of the body's nominal speed `body.v0`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Space {
    /// Vehicles N, uniform over the whole numbers lo..=hi.
    pub vehicles: (usize, usize),
    /// Dimensions, each equally likely.
    pub dims: Vec<usize>,
    /// `field.kind`s, each equally likely (`grid` only in 2-D: the campaign's grid file is
    /// 2-D; in 3-D a grid draw becomes a `gaussian`).
    pub field_kinds: Vec<&'static str>,
    /// Distance from the body's start to the optimum (or to the front), L.
    pub distance: Range,
    /// Gaussian-type fields: peak height above the background, F.
    pub amplitude: Range,
    /// Gaussian-type fields: width ÷ the distance to the optimum (the start lies on the
    /// slope, where the gradient is informative).
    pub width_over_distance: Range,
    /// Quadratic fields: each eigenvalue of the Hessian, F/L² (random rotation).
    pub hessian_eigenvalue: Range,
    /// Front: thickness (`field.width`), L.
    pub front_width: Range,
    /// Eddy: drift speed, × v0 (random direction).
    pub eddy_drift: Range,
    /// Sensor noise σ_M ÷ the field's range over the mission area (between the start and
    /// the optimum: the peak height of a Gaussian, ½ λ̄ D² of a quadratic, 2 × amplitude of
    /// a front, the grid's range).
    pub noise_fraction: Range,
    /// Probability that the links have no delay at all.
    pub p_no_delay: f64,
    /// One-way link delay when there is one, s.
    pub delay: Range,
    /// Probability of jitter when there is a delay; the jitter is then uniform in
    /// [0, delay] (the validator's bound).
    pub p_jitter: f64,
    /// Probability of lossless links.
    pub p_no_loss: f64,
    /// Loss probability when lossy (`links.loss`; the good state's under bursts).
    pub loss: Range,
    /// Probability that a lossy link is bursty (Gilbert–Elliott).
    pub p_bursty: f64,
    /// Gilbert–Elliott: `links.burst_enter`, per message.
    pub burst_enter: Range,
    /// Gilbert–Elliott: `links.burst_exit`, per message.
    pub burst_exit: Range,
    /// Gilbert–Elliott: `links.burst_loss`.
    pub burst_loss: Range,
    /// Probability of surfacing windows (`links.surfacing_period` > 0).
    pub p_surfacing: f64,
    /// Surfacing period, s.
    pub surfacing_period: Range,
    /// Surfacing window ÷ the period.
    pub surfacing_window_fraction: Range,
    /// Probability that a surfacing link is Iridium sessions (`[links.iridium]`), drawn
    /// last, so the other draws of a mission are those of a space without it.
    pub p_iridium: f64,
    /// Iridium: sessions per surfacing window (the window ÷ `session_interval`).
    pub sessions_per_window: Range,
    /// Iridium: `session_failure`.
    pub session_failure: Range,
    /// Iridium: `latency_short` ÷ the window (`latency_full` is 4 times it).
    pub session_latency_fraction: Range,
    /// Probability that a surfacing link of at most 64 vehicles also has acoustic modems
    /// (`[acoustic]`), drawn after Iridium, so the other draws of a mission are those of a
    /// space without them.
    pub p_acoustic: f64,
    /// Acoustic: `interval` in ticks.
    pub acoustic_interval_ticks: Range,
    /// Acoustic: `communication_range` ÷ the formation radius (detection 1.3 ×,
    /// interference 1.6 × it).
    pub acoustic_range: Range,
    /// Acoustic: probability of a TDMA schedule (else random offsets).
    pub p_tdma: f64,
    /// Acoustic: a frame's air time, and its propagation over the interference range, ÷
    /// the time they must share (a TDMA slot, or half the interval).
    pub acoustic_air: Range,
    /// Acoustic: `decode_probability`.
    pub decode_probability: Range,
    /// Number of faults 0..=3 and the probability of each count.
    pub fault_counts: [f64; 4],
    /// Probability a fault is a rejoin (a kill with `until`, `[restart] vehicles =
    /// "on-failure"`) rather than a permanent kill; permanent kills leave at least dim + 2
    /// vehicles.
    pub p_rejoin: f64,
    /// A fault's start, ÷ the duration.
    pub fault_at: Range,
    /// A rejoin's outage, ÷ the duration.
    pub rejoin_outage: Range,
    /// Probability of formation adaptation (`formation.adapt`).
    pub p_adapt: f64,
    /// `formation.alpha`, L²/s².
    pub alpha: Range,
    /// `vehicles.damping`, 1/s.
    pub damping: Range,
    /// `body.v0`, L/s.
    pub v0: Range,
    /// The laws `--law` chooses among (`both`: every mission flies under each).
    pub laws: Vec<&'static str>,
    /// Probability of the glider model (`vehicles.model = "glider"`).
    pub p_glider: f64,
    /// Glider: `vehicles.max_speed`, × v0.
    pub glider_max_speed: Range,
    /// Glider: `vehicles.max_accel`, L/s².
    pub glider_max_accel: Range,
    /// Glider: `vehicles.max_turn_rate`, rad/s.
    pub glider_max_turn_rate: Range,
    /// Probability of a uniform current for a glider (`current_estimate = true` then, as
    /// real gliders do; ideal vehicles fly in still water).
    pub p_current: f64,
    /// Current speed, × v0 (random direction).
    pub current_speed: Range,
    /// Control step, s (fixed: paper.toml's).
    pub dt: f64,
    /// Duration = margin × distance / v0 + `duration_extra` s: time to get there with room
    /// for the formation's start, the final approach and the outages.
    pub duration_margin: f64,
    /// Added to every duration, s.
    pub duration_extra: f64,
    /// `formation.min_scale`: how far adaptation may shrink the formation (every stiffness
    /// grows as 1/k², (III.3); what broke `lossy_kill` at half its noise). Drawn after
    /// every other key, so the rest of a mission does not depend on it.
    pub min_scale: Range,
    /// `formation.radius` ÷ the spacing-preserving radius of N vehicles: below 1 a
    /// tighter ring, as a user flies who raises `vehicles.count` without
    /// `formation.radius`. Drawn last, so the rest of a mission does not depend on it.
    pub radius_factor: Range,
}

impl Default for Space {
    fn default() -> Self {
        Space {
            vehicles: (3, 16),
            dims: vec![2, 3],
            field_kinds: vec![
                "gaussian",
                "quadratic",
                "eddy",
                "front",
                "gaussian_sum",
                "grid",
            ],
            distance: Range::uniform(10.0, 30.0),
            amplitude: Range::log(5.0, 20.0),
            width_over_distance: Range::uniform(0.6, 1.2),
            hessian_eigenvalue: Range::log(0.5, 2.0),
            front_width: Range::log(2.0, 8.0),
            eddy_drift: Range::uniform(0.02, 0.1),
            noise_fraction: Range::log(0.01, 0.3),
            p_no_delay: 0.3,
            delay: Range::log(0.05, 2.0),
            p_jitter: 0.5,
            p_no_loss: 0.3,
            loss: Range::log(0.01, 0.3),
            p_bursty: 0.4,
            burst_enter: Range::log(0.01, 0.1),
            burst_exit: Range::uniform(0.1, 0.5),
            burst_loss: Range::uniform(0.3, 0.8),
            p_surfacing: 0.25,
            surfacing_period: Range::log(2.0, 10.0),
            surfacing_window_fraction: Range::uniform(0.2, 0.5),
            p_iridium: 0.5,
            sessions_per_window: Range::uniform(1.0, 6.0),
            session_failure: Range::uniform(0.0, 0.3),
            session_latency_fraction: Range::uniform(0.01, 0.05),
            p_acoustic: 0.5,
            acoustic_interval_ticks: Range::uniform(1.0, 10.0),
            acoustic_range: Range::uniform(0.8, 3.0),
            p_tdma: 0.5,
            acoustic_air: Range::uniform(0.1, 0.4),
            decode_probability: Range::uniform(0.6, 1.0),
            fault_counts: [0.5, 0.25, 0.15, 0.1],
            p_rejoin: 0.5,
            fault_at: Range::uniform(0.1, 0.6),
            rejoin_outage: Range::uniform(0.05, 0.25),
            p_adapt: 0.5,
            alpha: Range::log(20.0, 150.0),
            damping: Range::log(2.0, 10.0),
            v0: Range::log(0.2, 1.0),
            laws: vec!["robust", "paper"],
            p_glider: 0.25,
            glider_max_speed: Range::uniform(1.5, 3.0),
            glider_max_accel: Range::log(2.0, 10.0),
            glider_max_turn_rate: Range::log(1.0, 5.0),
            p_current: 0.5,
            current_speed: Range::uniform(0.1, 0.3),
            dt: 0.05,
            duration_margin: 4.0,
            duration_extra: 40.0,
            min_scale: Range::log(0.15, 0.7),
            radius_factor: Range::uniform(0.5, 1.5),
        }
    }
}

impl Space {
    /// The rows of the table of [`Space`]'s `Display` about the fleet and the field.
    fn fleet_and_field_rows(&self) -> Vec<(&'static str, String)> {
        vec![
            (
                "vehicles N",
                format!("{} ..= {} (uniform)", self.vehicles.0, self.vehicles.1),
            ),
            ("dim", format!("{:?} (equally likely)", self.dims)),
            (
                "field.kind",
                format!("{:?} (equally likely; grid 2-D only)", self.field_kinds),
            ),
            ("start → optimum, L", self.distance.to_string()),
            ("gaussian amplitude, F", self.amplitude.to_string()),
            (
                "gaussian width ÷ distance",
                self.width_over_distance.to_string(),
            ),
            (
                "quadratic eigenvalues, F/L²",
                self.hessian_eigenvalue.to_string(),
            ),
            ("front width, L", self.front_width.to_string()),
            ("eddy drift, × v0", self.eddy_drift.to_string()),
            ("noise σ_M ÷ field range", self.noise_fraction.to_string()),
        ]
    }

    /// The rows about the links and the faults.
    fn link_and_fault_rows(&self) -> Vec<(&'static str, String)> {
        vec![
            (
                "links.delay, s",
                format!("0 with p = {}, else {}", self.p_no_delay, self.delay),
            ),
            (
                "links.jitter, s",
                format!("uniform in [0, delay] with p = {}, else 0", self.p_jitter),
            ),
            (
                "links.loss",
                format!("0 with p = {}, else {}", self.p_no_loss, self.loss),
            ),
            (
                "bursty loss (Gilbert–Elliott)",
                format!(
                    "p = {} of lossy links: enter {}, exit {}, burst_loss {}",
                    self.p_bursty, self.burst_enter, self.burst_exit, self.burst_loss
                ),
            ),
            (
                "surfacing",
                format!(
                    "p = {}: period {} s, window {} of the period",
                    self.p_surfacing, self.surfacing_period, self.surfacing_window_fraction
                ),
            ),
            (
                "Iridium sessions",
                format!(
                    "p = {} of surfacing links: {} sessions a window, session_failure {}, latency_short {} of the window (latency_full 4 times it), SBD byte limits",
                    self.p_iridium, self.sessions_per_window, self.session_failure, self.session_latency_fraction
                ),
            ),
            (
                "acoustic modems",
                format!(
                    "p = {} of surfacing links with N ≤ 64: a frame every {} ticks, TDMA with p = {} (else random offsets), communication range {} × the radius (detection 1.3 ×, interference 1.6 ×), air time and propagation each {} of a slot (or of half the interval), decode_probability {}",
                    self.p_acoustic, self.acoustic_interval_ticks, self.p_tdma, self.acoustic_range, self.acoustic_air, self.decode_probability
                ),
            ),
            (
                "faults",
                format!(
                    "0/1/2/3 with p = {:?}; rejoin (kill + until) with p = {}, else a permanent kill (≥ dim + 2 survive); at {} × duration, outage {} × duration",
                    self.fault_counts, self.p_rejoin, self.fault_at, self.rejoin_outage
                ),
            ),
        ]
    }

    /// The rows about the formation, the vehicles, the body and the mission's time, and what
    /// is derived from the draws.
    fn flight_rows(&self) -> Vec<(&'static str, String)> {
        vec![
            ("formation.adapt", format!("on with p = {}", self.p_adapt)),
            ("formation.alpha, L²/s²", self.alpha.to_string()),
            ("vehicles.damping, 1/s", self.damping.to_string()),
            ("body.v0, L/s", self.v0.to_string()),
            ("control.law", format!("{:?} (--law)", self.laws)),
            (
                "vehicles.model = glider",
                format!(
                    "p = {}: max_speed {} × v0, max_accel {} L/s², max_turn_rate {} rad/s",
                    self.p_glider,
                    self.glider_max_speed,
                    self.glider_max_accel,
                    self.glider_max_turn_rate
                ),
            ),
            (
                "[current] (gliders)",
                format!(
                    "uniform with p = {}, speed {} × v0, current_estimate = true",
                    self.p_current, self.current_speed
                ),
            ),
            ("mission.dt, s", format!("{}", self.dt)),
            ("formation.min_scale", format!("{}", self.min_scale)),
            (
                "formation.radius ÷ 1.229 (N/4)^(1/dim)",
                format!("{}", self.radius_factor),
            ),
            (
                "mission.duration, s",
                format!(
                    "{} × distance / v0 + {}",
                    self.duration_margin, self.duration_extra
                ),
            ),
            (
                "derived",
                "radius the factor above × 1.229·(N/4)^(1/dim); hessian_guess = |curvature at the optimum|·I; \
                 v_u = α/6 · (N(N−1)/2)/6 + N·v0²; grad_saturation, kalman_b from the field's gradient scale"
                    .into(),
            ),
        ]
    }
}

impl fmt::Display for Space {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut rows = self.fleet_and_field_rows();
        rows.extend(self.link_and_fault_rows());
        rows.extend(self.flight_rows());
        let width = rows
            .iter()
            .map(|(k, _)| k.chars().count())
            .max()
            .unwrap_or(0);
        writeln!(f, "The declared space of `vbap stress` (units: L, s, F):")?;
        for (k, v) in rows {
            let pad = width - k.chars().count();
            writeln!(f, "  {k}{}  {v}", " ".repeat(pad))?;
        }
        Ok(())
    }
}
