//! [`Stiffness`]: the time step against the formation's stiffness, for the semi-implicit
//! Euler integration of (II.1).

use super::toml_text::num;
use super::validate::{Check, Checked};
use super::{Mission, UNSTABLE_STEP};

/// ω·dt and damping·dt of a mission ([`Mission::stiffness`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stiffness {
    /// ω·dt of the stiffest formation mode at the smallest scale.
    pub omega_dt: f64,
    /// vehicles.damping · mission.dt.
    pub damping_dt: f64,
    /// Neighbour spacing at the smallest scale flown (length unit).
    pub spacing: f64,
    /// The smallest scale flown ([`Mission::held_min_scale`]).
    pub scale: f64,
}

impl Stiffness {
    /// Above [`UNSTABLE_STEP`]: the integration diverges.
    pub fn unstable(&self) -> bool {
        self.omega_dt > UNSTABLE_STEP || self.damping_dt > UNSTABLE_STEP
    }
}

impl Mission {
    /// How stiff the formation is for the time step: ω·dt and damping·dt. The semi-implicit
    /// Euler integration of (II.1) is stable for ω·dt < 2 and damping·dt < 2, and accurate
    /// only well below. ω² ≈ 2 α/d0² + α_h/h0² (two neighbours and a leader at their
    /// equilibrium distances, f'(d0) = α/d0²; `α_h` the design's leader strength), at the smallest formation scale flown
    /// ([`Mission::held_min_scale`]). None when the
    /// formation cannot be designed (validation says why).
    pub fn stiffness(&self) -> Option<Stiffness> {
        let design = self.formation_design().ok()?;
        // The smallest scale flown: min_scale, or the stability envelope's when the planner
        // is held to it (robust law over impaired links; docs/ENVELOPE.md), which keeps
        // the step accurate by construction.
        let k = self.held_min_scale();
        let (d0, h0) = (design.inter.d0 * k, design.leader.d0 * k);
        let alpha = self.formation.alpha;
        let alpha_h = design.leader.alpha;
        let omega = (2.0 * alpha / (d0 * d0) + alpha_h / (h0 * h0)).sqrt();
        let dt = self.mission.dt;
        Some(Stiffness {
            omega_dt: omega * dt,
            damping_dt: self.vehicles.damping * dt,
            spacing: d0,
            scale: k,
        })
    }

    /// A warning when the formation is stiff for the time step (ω·dt or damping·dt above 1:
    /// inaccurate; above 2, allowed by `mission.allow_unstable`: unstable). `None` when
    /// ω·dt ≤ 1 and damping·dt ≤ 1.
    pub fn stiffness_warning(&self) -> Option<String> {
        let st = self.stiffness()?;
        let dt = self.mission.dt;
        let at = self.smallest_scale_words(&st);
        (st.omega_dt > 1.0 || st.damping_dt > 1.0).then(|| {
            format!(
                "{}: the formation is stiff for mission.dt = {dt}: ω·dt = {:.2}, damping·dt = {:.2} \
                 (neighbour spacing {:.4} at {at}); above 1 the integration is \
                 inaccurate, above 2 unstable{}: lower formation.alpha or mission.dt, or raise \
                 formation.radius",
                self.origin,
                st.omega_dt,
                st.damping_dt,
                st.spacing,
                if st.unstable() {
                    " (run only because mission.allow_unstable = true)"
                } else {
                    ""
                }
            )
        })
    }

    /// "formation.min_scale = 0.2", or "the envelope's smallest scale k = 0.34" when the
    /// planner is held above `min_scale`.
    fn smallest_scale_words(&self, st: &Stiffness) -> String {
        if st.scale == self.formation.min_scale {
            format!("formation.min_scale = {}", num(st.scale))
        } else {
            format!(
                "the envelope's smallest scale k = {} (formation.min_scale = {})",
                num(st.scale),
                num(self.formation.min_scale)
            )
        }
    }

    /// Refuses a time step that makes the integration unstable, unless
    /// `mission.allow_unstable`.
    pub(super) fn check_stability(&self, c: &Check) -> Checked {
        let m = &self.mission;
        if let Some(st) = self.stiffness() {
            if !m.allow_unstable && st.unstable() {
                return Err(c.fail(
                    "mission.dt",
                    num(m.dt),
                    format!(
                        "unstable: ω·dt = {:.2}, damping·dt = {:.2}; above {UNSTABLE_STEP} the integration of \
                         (II.1) diverges (neighbour spacing {} at {}): lower \
                         mission.dt or formation.alpha, raise formation.radius, or set \
                         mission.allow_unstable = true to run it anyway",
                        st.omega_dt,
                        st.damping_dt,
                        num(st.spacing),
                        self.smallest_scale_words(&st)
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Overrides;

    #[test]
    fn shipped_missions_are_not_stiff_and_a_crowded_formation_is() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions");
        for name in [
            "paper.toml",
            "glider.toml",
            "glider_surfacing.toml",
            "quadratic3d.toml",
        ] {
            let m = Mission::load(&std::path::Path::new(dir).join(name)).unwrap();
            assert_eq!(m.stiffness_warning(), None, "{name}");
        }
        let m = Mission::load(&std::path::Path::new(dir).join("paper.toml")).unwrap();
        let crowded = Overrides {
            vehicles: Some(32),
            ..Overrides::default()
        };
        // 32 vehicles on the paper's radius: unstable, refused naming the time step...
        let err = m.clone().with_overrides(&crowded).unwrap_err();
        assert_eq!(err.key(), Some("mission.dt"), "{err}");
        assert!(err.to_string().contains("--vehicles 32"), "{err}");
        // ...unless allowed, and then still warned about.
        let mut allowed = m.clone();
        allowed.mission.allow_unstable = true;
        let w = allowed
            .with_overrides(&crowded)
            .unwrap()
            .stiffness_warning()
            .expect("32 vehicles on the paper's radius are stiff");
        assert!(
            w.contains("formation.alpha")
                && w.contains("mission.dt")
                && w.contains("allow_unstable"),
            "{w}"
        );
        // Between the two limits: valid, with a warning.
        let stiff = (5..32)
            .map(|n| {
                let mut c = m.clone();
                c.vehicles.count = n;
                c
            })
            .find(|c| {
                c.stiffness()
                    .is_some_and(|s| s.omega_dt > 1.0 && !s.unstable())
            })
            .expect("a fleet size between the limits");
        assert_eq!(stiff.validate().map_err(|e| e.to_string()), Ok(()));
        assert!(stiff.stiffness_warning().is_some());
    }
}
