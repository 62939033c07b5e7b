//! A vehicle's contact events: the surfacing schedule, `link_down` faults, and silences
//! (a vehicle that can talk by the schedule whose newest delivered state is older than
//! [`TruthStats::silence_after`](super::TruthStats), s).

use super::VehicleTruth;

/// The event (kind, detail) of a change of contact from `was` to `now` (the contact
/// names of `formation.csv`), if it is one: surfacing and diving, a link going down and
/// coming back.
pub(super) fn contact_event(was: &str, now: &str) -> Option<(&'static str, serde_json::Value)> {
    match (was, now) {
        ("submerged", "surfaced") => Some(("surfaced", serde_json::Value::Null)),
        ("surfaced", "submerged") => Some(("dived", serde_json::Value::Null)),
        (_, "link_down") => Some(("contact_lost", serde_json::json!({ "why": "link_down" }))),
        ("link_down", "contact" | "surfaced" | "submerged") => Some((
            "contact_regained",
            serde_json::json!({ "why": "link_down ended" }),
        )),
        _ => None,
    }
}

/// Follows a vehicle's silence at mission time `t` (s): `talks` when it can talk by the
/// schedule now, `info_age` the age of its newest delivered state (s), `silence_after`
/// the threshold (s). A vehicle that has been able to talk for `silence_after` and whose
/// newest state is older than that falls silent (`contact_lost`, why `silence`); it is in
/// touch again once a state that young is delivered while it can talk
/// (`contact_regained`). Out of contact for a reason of its own (dived, link down, lost),
/// a silence ends without an event: that reason has its own. Updates `vt` (`talk_since`,
/// `silent`) and returns the event (kind, detail), if any.
pub(super) fn follow_silence(
    vt: &mut VehicleTruth,
    talks: bool,
    info_age: Option<f64>,
    t: f64,
    silence_after: f64,
) -> Option<(&'static str, serde_json::Value)> {
    vt.talk_since = if talks {
        Some(vt.talk_since.unwrap_or(t))
    } else {
        None
    };
    let silent = talks
        && vt.talk_since.is_some_and(|s| t - s >= silence_after)
        && info_age.is_some_and(|a| a > silence_after);
    if silent {
        if !vt.silent {
            vt.silent = true;
            return Some((
                "contact_lost",
                serde_json::json!({ "why": "silence", "info_age_s": info_age }),
            ));
        }
    } else if vt.silent {
        vt.silent = false;
        if talks && info_age.is_some_and(|a| a <= silence_after) {
            return Some((
                "contact_regained",
                serde_json::json!({ "why": "reports delivered again", "info_age_s": info_age }),
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_changes_that_are_events() {
        assert_eq!(
            contact_event("submerged", "surfaced").unwrap().0,
            "surfaced"
        );
        assert_eq!(contact_event("surfaced", "submerged").unwrap().0, "dived");
        let (kind, detail) = contact_event("contact", "link_down").unwrap();
        assert_eq!(
            (kind, detail["why"].as_str()),
            ("contact_lost", Some("link_down"))
        );
        let (kind, detail) = contact_event("link_down", "surfaced").unwrap();
        assert_eq!(
            (kind, detail["why"].as_str()),
            ("contact_regained", Some("link_down ended"))
        );
        assert!(contact_event("contact", "rejoining").is_none());
        assert!(contact_event("rejoining", "contact").is_none());
        assert!(contact_event("link_down", "dead").is_none());
    }

    #[test]
    fn a_silence_begins_after_the_threshold_and_ends_with_a_young_state() {
        let after = 2.0;
        let mut vt = VehicleTruth::default();
        // Talking since t = 0 with no news: not silent before `after` has passed.
        assert!(follow_silence(&mut vt, true, Some(3.0), 0.0, after).is_none());
        assert!(follow_silence(&mut vt, true, Some(3.0), 1.9, after).is_none());
        assert_eq!(vt.talk_since, Some(0.0));
        let (kind, detail) = follow_silence(&mut vt, true, Some(3.0), 2.0, after).unwrap();
        assert_eq!(
            (kind, detail["why"].as_str()),
            ("contact_lost", Some("silence"))
        );
        assert!(vt.silent);
        // Reported once only.
        assert!(follow_silence(&mut vt, true, Some(4.0), 3.0, after).is_none());
        // A state as young as the threshold: back in touch.
        let (kind, _) = follow_silence(&mut vt, true, Some(2.0), 4.0, after).unwrap();
        assert_eq!(kind, "contact_regained");
        assert!(!vt.silent);
    }

    #[test]
    fn a_silence_ended_by_a_dive_has_no_event_of_its_own() {
        let after = 1.0;
        let mut vt = VehicleTruth::default();
        follow_silence(&mut vt, true, Some(5.0), 0.0, after);
        assert!(follow_silence(&mut vt, true, Some(5.0), 1.0, after).is_some());
        assert!(follow_silence(&mut vt, false, Some(5.0), 1.5, after).is_none());
        assert!(!vt.silent);
        assert_eq!(vt.talk_since, None);
    }
}
