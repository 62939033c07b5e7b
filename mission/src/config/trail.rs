//! How far a formation damped against the water trails its moving body (the paper's law,
//! −K ẋ_i of (II.1)), for a design held to its body by one central leader.
//!
//! A central design (one virtual leader at the body centre, every slot at the leader's
//! equilibrium distance h0) resists a translation of the whole formation only through the
//! leader potential: shifted by δ, vehicle i's distance to the centre changes by δ cos θ_i
//! and V_h'' (h0) = α_h / h0², so the restoring force per vehicle averages α_h δ / (dim h0²)
//! over the symmetric slots (Σ cos² θ_i = N / dim for the regular polygons and the
//! Platonic solids). Moving at the body's speed v against the damping K ẋ_i, the formation
//! settles a distance
//!
//! (T.1) δ = dim · K · v · h0² / α_h
//!
//! behind its body; the neighbour potentials do not resist a translation. Damping
//! relative to the body (`control.follow_body`, −K (ẋ_i − ṙ)) has no such lag.

use super::Mission;
use vbap_math::fit::IN_FORMATION;

/// (T.1) for a mission: the lag and the design's neighbour spacing, at scale 1 and cruise
/// speed v0 (length unit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trail {
    /// δ of (T.1).
    pub lag: f64,
    /// The neighbour spacing d0 of the design.
    pub spacing: f64,
}

impl Mission {
    /// (T.1) for this mission's design at cruise speed, when its vehicles are damped
    /// against the water (not [`Mission::follows_body`]) and the design is central; None
    /// otherwise, or when it cannot be designed.
    pub fn body_trail(&self) -> Option<Trail> {
        if self.follows_body() {
            return None;
        }
        self.water_trail()
    }

    /// (T.1) for this mission's design at cruise speed were its vehicles damped against
    /// the water, whatever its law; None when the design is not central or cannot be
    /// designed.
    pub fn water_trail(&self) -> Option<Trail> {
        let design = self.formation_design().ok()?;
        if !design.is_central() || design.n() < 2 {
            return None;
        }
        let (h0, alpha_h) = (design.leader.d0, design.leader.alpha);
        if !(h0 > 0.0 && alpha_h > 0.0) {
            return None;
        }
        let dim = self.formation_dim() as f64;
        Some(Trail {
            lag: dim * self.vehicles.damping * self.body.v0 * h0 * h0 / alpha_h,
            spacing: design.neighbour_spacing(),
        })
    }

    /// The line `vbap check` prints with the envelope: (T.1)'s lag at cruise speed and in
    /// neighbour spacings (None when there is no lag: [`Mission::body_trail`]), or, where
    /// the robust law follows its body because of that lag ([`Mission::trails_its_body`]),
    /// the lag it avoids.
    pub fn trail_line(&self) -> Option<String> {
        if self.follows_body() && self.control.follow_body.is_none() && self.trails_its_body() {
            let t = self.water_trail()?;
            return Some(format!(
                "trail: none: the robust law damps relative to the body here; against the \
                 water (−K ẋ of (II.1)) the formation would settle {:.4} ({:.2} neighbour \
                 spacings) behind it at body.v0 = {}, more than the {} spacing above which \
                 the law follows its body (control.follow_body = false keeps the paper's \
                 damping)",
                t.lag,
                t.lag / t.spacing,
                self.body.v0,
                super::envelope::FOLLOW_TRAIL,
            ));
        }
        let t = self.body_trail()?;
        Some(format!(
            "trail: damped against the water, the formation settles {:.4} ({:.2} neighbour \
             spacings) behind its body at body.v0 = {} (in formation up to {IN_FORMATION} spacing; \
             control.follow_body = true damps relative to the body: no lag)",
            t.lag,
            t.lag / t.spacing,
            self.body.v0
        ))
    }

    /// A warning when (T.1)'s lag exceeds the quarter spacing that counts as in formation
    /// (`vbap_math::fit::IN_FORMATION`): such a formation cannot be in formation while it
    /// cruises, and on ideal links most such rings of the random-mission space broke
    /// (docs/STRESS.md). None otherwise.
    pub fn trail_warning(&self) -> Option<String> {
        let t = self.body_trail()?;
        let ratio = t.lag / t.spacing;
        (ratio > IN_FORMATION).then(|| {
            let remedy = match self.control.law {
                super::LawKind::Paper => "control.law = \"robust\" with control.follow_body = true",
                super::LawKind::Robust => "control.follow_body = true",
            };
            format!(
                "{}: the formation trails its body: damped against the water (−K ẋ of (II.1)) \
                 and held by one central leader, it settles δ = dim·K·v0·h0²/α_h = {:.4} \
                 ({:.2} neighbour spacings) behind the body at body.v0 = {}, more than the \
                 {IN_FORMATION} spacing that counts as in formation; set {remedy} (damping \
                 relative to the body: no lag), or lower body.v0 or vehicles.damping, or raise \
                 formation.alpha",
                self.origin, t.lag, ratio, self.body.v0,
            )
        })
    }
}
