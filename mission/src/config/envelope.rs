//! A mission's stability envelope over its links (`vbap_math::envelope`,
//! docs/ENVELOPE.md): what the planner is held to, what `vbap check` shows and refuses.

use vbap_math::envelope::{envelope, Envelope, EnvelopeInputs, EnvelopeLaw, ScaleLimit};

use super::toml_text::num;
use super::validate::{Check, Checked};
use super::{LawKind, Mission};
use crate::horizon::plan_horizon;

/// Above this many vehicles the envelope is not computed (its linearisation is a dense
/// (dim·N)² eigenproblem per scale and age); the planner then keeps `formation.min_scale`.
pub const MAX_ENVELOPE_VEHICLES: usize = 64;

/// Above this lag of (T.1), in neighbour spacings at scale 1 and cruise speed, the robust
/// law follows the body on ideal links too ([`Mission::follows_body`]).
pub const FOLLOW_TRAIL: f64 = 0.125;

impl Mission {
    /// True when the links are not ideal: some delay, jitter, loss or surfacing.
    pub fn links_impaired(&self) -> bool {
        plan_horizon(&self.links, self.mission.dt) > 0.0
    }

    /// The range of a neighbour's information age a vehicle steps on, s: the coordinator's
    /// (one uplink) plus its command's own (one downlink), each a delay ± jitter, and at
    /// worst the plan horizon's run of losses or surfacing gap on each (`crate::horizon`).
    /// None on ideal links.
    pub fn neighbour_ages(&self) -> Option<(f64, f64)> {
        let horizon = plan_horizon(&self.links, self.mission.dt);
        if horizon <= 0.0 {
            return None;
        }
        let l = &self.links;
        let dt = self.mission.dt;
        let low = 2.0 * (l.delay - l.jitter).max(0.0) + dt;
        let high = (2.0 * horizon).max(low);
        Some((low, high))
    }

    /// What a vehicle can give its slot, length/s: a glider's horizontal speed through
    /// the water (a current helps as often as it hinders, and the planner's speed law
    /// slows the body when the formation lags: the current is not taken off). None for
    /// the paper's vehicle.
    pub fn speed_budget(&self) -> Option<f64> {
        let v = &self.vehicles;
        if v.model.is_ideal() {
            return None;
        }
        let top = v.max_speed?;
        Some(match (self.diving(), v.dive_rate) {
            (true, Some(rate)) => (top * top - rate * rate).max(0.0).sqrt(),
            _ => top,
        })
    }

    /// The envelope of this mission under its own law (None when the formation cannot be
    /// designed or it has more than [`MAX_ENVELOPE_VEHICLES`] vehicles).
    pub fn envelope(&self) -> Option<Envelope> {
        self.envelope_for(self.control.law)
    }

    /// The envelope of this mission flown under `law`.
    pub fn envelope_for(&self, law: LawKind) -> Option<Envelope> {
        if self.vehicles.count > MAX_ENVELOPE_VEHICLES {
            return None;
        }
        let dim = self.formation_dim();
        let fo = &self.formation;
        let design = self.formation_design().ok()?;
        let law = match law {
            LawKind::Paper => EnvelopeLaw::Paper,
            LawKind::Robust => EnvelopeLaw::Robust {
                memory: self.control.neighbour_memory,
            },
        };
        let inputs = EnvelopeInputs {
            design: &design,
            dim,
            damping: self.vehicles.damping,
            dt: self.mission.dt,
            ages: self.neighbour_ages(),
            law,
            speed_budget: self.speed_budget(),
            max_scale: fo.max_scale,
            v0: self.body.v0,
        };
        Some(memo(&inputs))
    }

    /// True when the planner is held to the envelope: the robust law over links that are
    /// not ideal (on ideal links the robust law flies the paper's formation law, and the
    /// paper's law is flown as written).
    pub fn envelope_holds(&self) -> bool {
        self.control.law == LawKind::Robust && self.links_impaired()
    }

    /// True when the robust law damps each vehicle relative to the body
    /// (`control.follow_body`; absent: where the envelope holds, [`Mission::envelope_holds`]).
    pub fn follows_body(&self) -> bool {
        self.control.law == LawKind::Robust
            && self
                .control
                .follow_body
                .unwrap_or_else(|| self.envelope_holds() || self.trails_its_body())
    }

    /// True when the paper's damping against the water would leave the formation more
    /// than [`FOLLOW_TRAIL`] neighbour spacings behind its cruising body ((T.1),
    /// [`Mission::water_trail`]).
    pub fn trails_its_body(&self) -> bool {
        self.water_trail()
            .is_some_and(|t| t.lag > FOLLOW_TRAIL * t.spacing)
    }

    /// The envelope the planner is held to ([`Mission::envelope_holds`]), if any.
    pub fn held_envelope(&self) -> Option<Envelope> {
        if self.envelope_holds() {
            self.envelope()
        } else {
            None
        }
    }

    /// The smallest scale the planner flies: `formation.min_scale`, raised to the
    /// envelope's when it holds (never above `formation.max_scale`).
    pub fn held_min_scale(&self) -> f64 {
        self.scale_floor(self.held_envelope().as_ref())
    }

    /// [`Mission::held_min_scale`] for the held envelope `held` already computed.
    pub fn scale_floor(&self, held: Option<&Envelope>) -> f64 {
        let own = self.formation.min_scale;
        match held {
            Some(env) if !env.empty => own.max(env.min_scale).min(self.formation.max_scale),
            _ => own,
        }
    }

    /// The links in words, for the envelope's messages: "0.5 s ± 0.2 s, 10 % loss".
    pub fn links_in_words(&self) -> String {
        let l = &self.links;
        let mut out = format!("{} s ± {} s", num(l.delay), num(l.jitter));
        if l.loss > 0.0 {
            out.push_str(&format!(", {} % loss", num(l.loss * 100.0)));
        }
        if l.burst_enter > 0.0 {
            out.push_str(&format!(", bursts of {} % loss", num(l.burst_loss * 100.0)));
        }
        if l.surfacing_period > 0.0 {
            out.push_str(&format!(
                ", surfacing {} s every {} s",
                num(l.surfacing_window),
                num(l.surfacing_period)
            ));
        }
        out
    }

    /// The envelope as `vbap check` prints it, a line each (empty on ideal links with the
    /// paper's vehicle, where only the time step bounds anything).
    pub fn envelope_lines(&self) -> Vec<String> {
        let Some(env) = self.envelope() else {
            return if self.vehicles.count > MAX_ENVELOPE_VEHICLES {
                vec![format!(
                    "envelope: not computed above {MAX_ENVELOPE_VEHICLES} vehicles"
                )]
            } else {
                vec![]
            };
        };
        let mut out = Vec::new();
        let ages = match self.neighbour_ages() {
            Some((lo, hi)) => format!(
                "neighbours {} to {} s old",
                num(round3(lo)),
                num(round3(hi))
            ),
            None => "ideal links".into(),
        };
        let law = match self.control.law {
            LawKind::Paper => "paper",
            LawKind::Robust => "robust",
        };
        let why = match env.limit {
            ScaleLimit::Links => "the links",
            ScaleLimit::Step => "the time step",
            ScaleLimit::None => "nothing",
        };
        if env.empty {
            out.push(format!(
                "envelope ({law} law, {ages}): no scale up to formation.max_scale = {} is held",
                num(self.formation.max_scale)
            ));
        } else {
            out.push(format!(
                "envelope ({law} law, {ages}): smallest scale k = {} (set by {why}; formation.min_scale = {}{}), loop gain {} at k = 1",
                num(round3(env.min_scale)),
                num(self.formation.min_scale),
                if self.envelope_holds() && env.min_scale > self.formation.min_scale {
                    ": the planner holds the scale at the envelope's"
                } else {
                    ""
                },
                num(round3(env.gain_at_one)),
            ));
        }
        if env.max_body_speed.is_finite() {
            out.push(format!(
                "envelope: body speed at most {} (body.v0 = {})",
                num(round3(env.max_body_speed)),
                num(self.body.v0)
            ));
        }
        if self.formation.adapt {
            let radius = self.formation.radius;
            out.push(format!(
                "envelope: |dk/dt| at most {} /s at k = 1, {} /s at the smallest scale",
                num(round3(env.max_scale_rate(1.0, radius))),
                num(round3(env.max_scale_rate(env.min_scale.max(1e-9), radius)))
            ));
        }
        out
    }

    /// Refuses a mission whose formation the robust law cannot hold over its links (the
    /// envelope is empty, excludes the configured formation, k = 1, or the body's speed),
    /// unless `mission.allow_unstable`. The paper's law is not refused (it is the baseline
    /// shown failing), and a `min_scale` below the envelope is not refused either: the
    /// planner holds the scale at the envelope's.
    pub(super) fn check_envelope(&self, c: &Check) -> Checked {
        if self.mission.allow_unstable || !self.envelope_holds() {
            return Ok(());
        }
        let Some(env) = self.envelope() else {
            return Ok(());
        };
        let links = self.links_in_words();
        if env.empty || env.min_scale > 1.0 {
            return Err(c.fail(
                "formation.radius",
                num(self.formation.radius),
                format!(
                    "the formation cannot be held over these links ({links}): {}; raise \
                     formation.radius or vehicles.damping, lower formation.alpha or \
                     mission.dt, or set mission.allow_unstable = true to fly it anyway",
                    if env.empty {
                        "no scale up to formation.max_scale is held".to_string()
                    } else {
                        format!(
                            "the smallest scale held is k = {} > 1 (set by {})",
                            num(round3(env.min_scale)),
                            match env.limit {
                                ScaleLimit::Links => "the links",
                                _ => "mission.dt: √μ_max·dt ≤ 1",
                            }
                        )
                    }
                ),
            ));
        }
        if self.body.v0 > env.max_body_speed {
            return Err(c.fail(
                "body.v0",
                num(self.body.v0),
                format!(
                    "the vehicles cannot follow the body: their horizontal speed through the \
                     water is {}; lower body.v0 or set mission.allow_unstable = true",
                    num(round3(env.max_body_speed))
                ),
            ));
        }
        Ok(())
    }
}

/// What an envelope is computed from, as bits: the key of [`memo`].
type MemoKey = Vec<u64>;

fn memo_key(i: &EnvelopeInputs<'_>) -> MemoKey {
    let mut key: Vec<u64> = vec![i.design.slots.len() as u64, i.dim as u64];
    let (memory, paper) = match i.law {
        EnvelopeLaw::Paper => (None, 1),
        EnvelopeLaw::Robust { memory } => (memory, 0),
    };
    key.push(paper);
    for x in [
        i.design.inter.alpha,
        i.design.inter.d0,
        i.design.inter.d1,
        i.design.leader.alpha,
        i.design.leader.d0,
        i.design.leader.d1,
        i.damping,
        i.dt,
        i.ages.map_or(-1.0, |a| a.0),
        i.ages.map_or(-1.0, |a| a.1),
        memory.unwrap_or(-1.0),
        i.speed_budget.unwrap_or(-1.0),
        i.max_scale,
        i.v0,
    ] {
        key.push(x.to_bits());
    }
    key
}

thread_local! {
    /// The envelopes this thread computed last: validation, the planner and the recorder
    /// of one run all ask for the same one (a few tens of ms each at N = 16).
    static MEMO: std::cell::RefCell<Vec<(MemoKey, Envelope)>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// [`envelope`] of `inputs`, remembered per thread for the last few inputs (the same
/// inputs give the same envelope: it is a pure function of them).
fn memo(inputs: &EnvelopeInputs<'_>) -> Envelope {
    let key = memo_key(inputs);
    if let Some(env) = MEMO.with(|m| {
        m.borrow()
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, e)| e.clone())
    }) {
        return env;
    }
    let env = envelope(inputs);
    MEMO.with(|m| {
        let mut m = m.borrow_mut();
        if m.len() >= 4 {
            m.remove(0);
        }
        m.push((key, env.clone()));
    });
    env
}

/// `x` to 3 significant digits, for messages.
fn round3(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let digits = 2 - x.abs().log10().floor() as i32;
    let f = 10f64.powi(digits);
    (x * f).round() / f
}
