//! The style every figure of a run shares, in one place: `plot.svg` ([`crate::plot`]) and
//! the charts of the time series, contact timeline and analysis ([`crate::plot::chart`],
//! [`crate::plot::canvas`]) use the same palette, the same colours and short labels for events, the same
//! "nice" tick steps and the same readable time labels ("36 h", "1.5 d", "250 ms", never
//! "129600 s" or "6e6 ms").

use vbap_wire::rundir::Event;

/// Qualitative palette (Tableau 10) for vehicles and series, as `#rrggbb`. Vehicle `id`
/// takes `PALETTE[id % 10]` in every figure.
pub const PALETTE: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

/// The palette colour of vehicle (or series) `id`.
pub fn palette(id: usize) -> &'static str {
    PALETTE[id % PALETTE.len()]
}

/// `#rrggbb` as (r, g, b). Panics (at compile time in a `const`) on anything else.
pub const fn rgb(hex: &str) -> (u8, u8, u8) {
    const fn nibble(c: u8) -> u8 {
        match c {
            b'0'..=b'9' => c - b'0',
            b'a'..=b'f' => c - b'a' + 10,
            b'A'..=b'F' => c - b'A' + 10,
            _ => panic!("not a hex digit"),
        }
    }
    let b = hex.as_bytes();
    assert!(b.len() == 7 && b[0] == b'#', "colour must be #rrggbb");
    (
        nibble(b[1]) * 16 + nibble(b[2]),
        nibble(b[3]) * 16 + nibble(b[4]),
        nibble(b[5]) * 16 + nibble(b[6]),
    )
}

// ---------------------------------------------------------------------------------------------
// Time.

/// A unit of time for axes and labels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeUnit {
    /// Its symbol: "ms", "s", "min", "h" or "d".
    pub symbol: &'static str,
    /// Its length, s.
    pub seconds: f64,
}

impl TimeUnit {
    /// Millisecond.
    pub const MS: TimeUnit = TimeUnit {
        symbol: "ms",
        seconds: 1e-3,
    };
    /// Second.
    pub const S: TimeUnit = TimeUnit {
        symbol: "s",
        seconds: 1.0,
    };
    /// Minute.
    pub const MIN: TimeUnit = TimeUnit {
        symbol: "min",
        seconds: 60.0,
    };
    /// Hour.
    pub const H: TimeUnit = TimeUnit {
        symbol: "h",
        seconds: 3600.0,
    };
    /// Day.
    pub const D: TimeUnit = TimeUnit {
        symbol: "d",
        seconds: 86_400.0,
    };

    /// The unit of a mission-time axis that runs over `span_s` seconds: s up to 15 min,
    /// min up to 3 h, h up to 4 days, days beyond (a 1.5-day glider mission reads in hours,
    /// 0 to 36 h).
    pub fn for_span(span_s: f64) -> TimeUnit {
        let s = span_s.abs();
        if !s.is_finite() || s <= 900.0 {
            Self::S
        } else if s <= 3.0 * 3600.0 {
            Self::MIN
        } else if s <= 4.0 * 86_400.0 {
            Self::H
        } else {
            Self::D
        }
    }

    /// The unit of a duration of typical size `magnitude_s` seconds (a delay, a gap): ms
    /// below 1 s, s below 2 min, min below 2 h, h below 2 days, days beyond.
    pub fn for_magnitude(magnitude_s: f64) -> TimeUnit {
        let s = magnitude_s.abs();
        if !s.is_finite() {
            Self::S
        } else if s < 1.0 {
            Self::MS
        } else if s < 120.0 {
            Self::S
        } else if s < 2.0 * 3600.0 {
            Self::MIN
        } else if s < 2.0 * 86_400.0 {
            Self::H
        } else {
            Self::D
        }
    }

    /// `t_s` (seconds) in this unit.
    pub fn of(&self, t_s: f64) -> f64 {
        t_s / self.seconds
    }

    /// `t_s` (seconds) written in this unit with its symbol, to 3 significant digits (at
    /// most 3 decimals), trailing zeros dropped: "36 h", "1.5 d", "12.4 s", "0.25 h".
    pub fn fmt(&self, t_s: f64) -> String {
        format!("{} {}", fmt_significant(self.of(t_s), 3, 3), self.symbol)
    }

    /// Axis label "`what` (unit)".
    pub fn axis_label(&self, what: &str) -> String {
        format!("{what} ({})", self.symbol)
    }

    /// A tick step, in this unit, giving about `target` ticks over `span` (in this unit),
    /// from steps that suit the unit: hours in 1, 2, 3, 6, 12 or 24, minutes and seconds in
    /// 1, 2, 5, 10, 15, 20, 30, 60, anything else (and beyond) 1–2–2.5–5 × 10^k.
    pub fn tick_step(&self, span: f64, target: usize) -> f64 {
        let raw = span.abs() / target.max(1) as f64;
        if !(raw.is_finite() && raw > 0.0) {
            return 1.0;
        }
        let steps: &[f64] = match self.symbol {
            "h" => &[1.0, 2.0, 3.0, 6.0, 12.0, 24.0],
            "min" | "s" => &[1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 60.0],
            _ => &[],
        };
        steps
            .iter()
            .copied()
            .find(|s| *s >= raw && raw >= 0.5)
            .unwrap_or_else(|| nice_step(raw))
    }
}

/// A single time `t_s` (seconds) in the unit that reads best for it alone: "42 s",
/// "12.5 min", "36 h", "1.5 d"; below a second in ms.
pub fn fmt_duration(t_s: f64) -> String {
    if t_s != 0.0 && t_s.abs() < 1.0 {
        return TimeUnit::MS.fmt(t_s);
    }
    TimeUnit::for_span(t_s).fmt(t_s)
}

/// `v` with at most `digits` significant digits and `max_decimals` decimals, trailing zeros
/// dropped, never "-0".
pub fn fmt_significant(v: f64, digits: i32, max_decimals: i32) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let decimals = if v == 0.0 {
        0
    } else {
        (digits - 1 - v.abs().log10().floor() as i32).clamp(0, max_decimals.max(0))
    } as usize;
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

// ---------------------------------------------------------------------------------------------
// Ticks.

/// The smallest "nice" step (1, 2, 2.5, 5 or 10 × 10^k) not below `raw` (> 0).
pub fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    let f = raw / mag;
    let m = if f <= 1.0 {
        1.0
    } else if f <= 2.0 {
        2.0
    } else if f <= 2.5 {
        2.5
    } else if f <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * mag
}

/// A tick label for value `v` on an axis whose ticks are `step` apart: as many decimals as
/// the step needs ("0.25", "7.5", "200"), scientific outside [1e-4, 1e6) with as many
/// mantissa digits as the step needs ("1.5e-5"; "1.001e-5" beside "1.002e-5"), never "-0":
/// two ticks never read the same. The viewer's `view/assets/ticks.js` follows the same
/// rules; `ticks_cases.json` holds the cases both are tested on.
pub fn fmt_tick(v: f64, step: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    // A step of 2.5 × 10^k needs one digit more than its power of ten (2.5, 7.5, ...).
    let quarter = |step: f64| {
        let m = step / 10f64.powf(step.log10().floor());
        usize::from((m - 2.5).abs() < 1e-6)
    };
    if !(1e-4..1e6).contains(&a) {
        let apart = (a.log10().floor() - step.abs().log10().floor()).max(0.0) as usize;
        let digits = (apart + quarter(step.abs())).clamp(1, 15);
        return format!("{v:.digits$e}").replace(".0e", "e");
    }
    let decimals = if step >= 1.0 {
        usize::from(step.fract().abs() > 1e-9)
    } else {
        (-step.log10() - 1e-9).ceil().max(0.0) as usize + quarter(step)
    };
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s.trim_start_matches(['-', '0', '.']).is_empty() {
        "0".into()
    } else {
        s
    }
}

/// An axis tick value on an axis of extent `span`: enough decimals for ticks about span / 10
/// apart, trailing zeros dropped ("200", "0.25", never "-0").
pub fn fmt_tick_span(v: f64, span: f64) -> String {
    let decimals = if span > 0.0 && span.is_finite() {
        (2.0 - span.log10().floor()).clamp(0.0, 9.0) as usize
    } else {
        3
    };
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

// ---------------------------------------------------------------------------------------------
// Events.

/// How one kind of event is drawn: its colour and its legend entry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventStyle {
    /// `#rrggbb`.
    pub colour: &'static str,
    /// Legend text for this kind.
    pub legend: &'static str,
}

/// The style of the events drawn as markers on time axes (None: not drawn, e.g. the
/// per-message `link_drop` and the periodic `surfaced` / `dived`, which the contact
/// timeline shows instead).
pub fn event_style(kind: &str) -> Option<EventStyle> {
    let (colour, legend) = match kind {
        "lost" => ("#d62728", "vehicle lost"),
        "rejoin" => ("#2ca02c", "vehicle rejoined"),
        "join" => ("#2ca02c", "vehicle joined"),
        "reconfigured" => ("#9467bd", "formation redesigned"),
        "fault" => ("#ff7f0e", "fault applied"),
        "holding" => ("#7f7f7f", "holding (too few vehicles)"),
        "resumed" => ("#bcbd22", "resumed"),
        "converged" => ("#17becf", "converged (within tolerance)"),
        "restart" | "restarted" => ("#8c564b", "process restarted"),
        "stall_began" => ("#a50f15", "fleet stalled"),
        "stall_ended" => ("#fb6a4a", "stall ended"),
        "formation_broken" => ("#e377c2", "formation broken"),
        "formation_restored" => ("#1b9e77", "formation restored"),
        "near_collision" => ("#ff00aa", "near collision"),
        "contact_lost" => ("#6a3d9a", "contact lost"),
        "contact_regained" => ("#b15928", "contact regained"),
        _ => return None,
    };
    Some(EventStyle { colour, legend })
}

/// Vehicle ids listed in an event's detail under `key` (an array of integers).
fn ids(e: &Event, key: &str) -> Vec<u64> {
    e.detail
        .get(key)
        .and_then(|v| v.as_array())
        .map(|a| a.iter().filter_map(|v| v.as_u64()).collect())
        .unwrap_or_default()
}

fn join_ids(ids: &[u64]) -> String {
    ids.iter()
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// A short label of an event, for markers and snapshots (the colour tells the kind):
/// "kill 2", "lost 2", "redesign", "rejoin 2", "stall (V above V_U)", "broken: 1, 5",
/// "near collision 1–4 (0.06)".
pub fn event_label(e: &Event) -> String {
    let str_of = |key: &str| e.detail.get(key).and_then(|v| v.as_str());
    let mut label = match e.kind.as_str() {
        // The fault's kind: `detail.fault` (the recorder's events) or `detail.kind`.
        "fault" => str_of("fault")
            .or_else(|| str_of("kind"))
            .unwrap_or("fault")
            .to_string(),
        "reconfigured" => "redesign".to_string(),
        "stall_began" => match str_of("why") {
            Some(why) => format!("stall ({why})"),
            None => "stall".to_string(),
        },
        "stall_ended" => "stall ended".to_string(),
        "formation_broken" => {
            let out = ids(e, "vehicles");
            if out.is_empty() {
                "formation broken".to_string()
            } else {
                format!("broken: {}", join_ids(&out))
            }
        }
        "formation_restored" => "restored".to_string(),
        "near_collision" => {
            let pair = near_collision_pair(e);
            let mut s = "near collision".to_string();
            if let Some((a, b)) = pair {
                s = format!("{s} {a}–{b}");
            }
            if let Some(r) = e.detail.get("ratio").and_then(|v| v.as_f64()) {
                s = format!("{s} ({})", fmt_significant(r, 2, 3));
            }
            s
        }
        "contact_lost" => "contact lost".to_string(),
        "contact_regained" => "contact back".to_string(),
        kind => kind.to_string(),
    };
    if let Some(v) = e.vehicle {
        label = format!("{label} {v}");
    }
    label
}

/// The two vehicles of a `near_collision` event: `detail.pair`, `detail.vehicles` or
/// `detail.ids` (two ids), or `detail.a` / `detail.b`, else the event's vehicle and
/// `detail.other`.
pub fn near_collision_pair(e: &Event) -> Option<(u64, u64)> {
    for key in ["pair", "vehicles", "ids"] {
        if let [a, b] = ids(e, key)[..] {
            return Some((a, b));
        }
    }
    let num = |k: &str| e.detail.get(k).and_then(|v| v.as_u64());
    match (num("a"), num("b")) {
        (Some(a), Some(b)) => Some((a, b)),
        _ => match (e.vehicle, num("other")) {
            (Some(a), Some(b)) => Some((u64::from(a), b)),
            _ => None,
        },
    }
}

/// Events at which `plot.svg` draws an extra formation snapshot, most telling first.
pub const SNAPSHOT_EVENTS: [&str; 6] = [
    "lost",
    "formation_broken",
    "stall_began",
    "near_collision",
    "rejoin",
    "reconfigured",
];

// ---------------------------------------------------------------------------------------------
// Contact states (formation.csv `contact`).

/// The contact states of `formation.csv`, in legend order, with their colour and legend.
pub const CONTACT_STATES: [(&str, &str, &str); 6] = [
    ("contact", "#a1d99b", "in contact (no schedule)"),
    ("surfaced", "#3182bd", "surfaced (can talk)"),
    ("submerged", "#c6dbef", "submerged (cannot talk)"),
    ("link_down", "#fd8d3c", "link down (fault)"),
    ("rejoining", "#9e9ac8", "rejoining"),
    ("dead", "#252525", "dead / lost"),
];

/// Index of a contact state in [`CONTACT_STATES`] (None: unknown).
pub fn contact_index(state: &str) -> Option<usize> {
    CONTACT_STATES.iter().position(|(s, _, _)| *s == state)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_units_by_span_read_like_a_report() {
        // A 1.5-day glider mission at dt of seconds: hours, "36 h".
        let u = TimeUnit::for_span(129_600.0);
        assert_eq!(u, TimeUnit::H);
        assert_eq!(u.fmt(129_600.0), "36 h");
        assert_eq!(u.fmt(21_600.0), "6 h");
        assert_eq!(u.fmt(5400.0), "1.5 h");
        assert_eq!(u.axis_label("mission time t"), "mission time t (h)");
        // Longer: days.
        assert_eq!(TimeUnit::for_span(10.0 * 86_400.0), TimeUnit::D);
        assert_eq!(TimeUnit::D.fmt(129_600.0), "1.5 d");
        // Short missions stay in seconds, with the tick's decimals.
        assert_eq!(TimeUnit::for_span(20.0), TimeUnit::S);
        assert_eq!(TimeUnit::S.fmt(12.35), "12.3 s");
        assert_eq!(TimeUnit::S.fmt(0.05), "0.05 s");
        assert_eq!(TimeUnit::H.fmt(15_768.0), "4.38 h");
        assert_eq!(TimeUnit::S.fmt(0.0), "0 s");
        assert_eq!(TimeUnit::for_span(900.0), TimeUnit::S);
        assert_eq!(TimeUnit::for_span(1800.0), TimeUnit::MIN);
        assert_eq!(TimeUnit::MIN.fmt(750.0), "12.5 min");
        // Never scientific, never a long string of digits.
        assert_eq!(TimeUnit::H.fmt(129_610.0), "36 h");
        assert_eq!(TimeUnit::H.fmt(-3600.0), "-1 h");
    }

    #[test]
    fn single_durations_pick_their_own_unit() {
        assert_eq!(fmt_duration(129_600.0), "36 h");
        assert_eq!(fmt_duration(6.0 * 86_400.0), "6 d");
        assert_eq!(fmt_duration(42.0), "42 s");
        assert_eq!(fmt_duration(0.25), "250 ms");
        assert_eq!(fmt_duration(0.0), "0 s");
    }

    #[test]
    fn delay_units_by_magnitude() {
        // The injected delay of a surfacing run reaches ~6e6 ms: that is 100 min.
        assert_eq!(TimeUnit::for_magnitude(6000.0), TimeUnit::MIN);
        assert_eq!(TimeUnit::MIN.fmt(6000.0), "100 min");
        assert_eq!(TimeUnit::for_magnitude(7200.0), TimeUnit::H);
        assert_eq!(TimeUnit::H.fmt(6000.0), "1.67 h");
        assert_eq!(TimeUnit::for_magnitude(0.5), TimeUnit::MS);
        assert_eq!(TimeUnit::for_magnitude(20.0), TimeUnit::S);
        assert_eq!(TimeUnit::for_magnitude(600.0), TimeUnit::MIN);
        assert_eq!(TimeUnit::for_magnitude(3.0 * 86_400.0), TimeUnit::D);
    }

    #[test]
    fn time_ticks_use_steps_of_the_clock() {
        // 0..36 h in about 8 ticks: every 6 h, not every 5.
        assert_eq!(TimeUnit::H.tick_step(36.0, 8), 6.0);
        assert_eq!(TimeUnit::H.tick_step(72.0, 8), 12.0);
        assert_eq!(TimeUnit::MIN.tick_step(120.0, 8), 15.0);
        assert_eq!(TimeUnit::S.tick_step(20.0, 10), 2.0);
        // Below one unit or beyond the table: 1-2-5.
        assert_eq!(TimeUnit::S.tick_step(2.0, 10), 0.2);
        assert_eq!(TimeUnit::D.tick_step(30.0, 8), 5.0);
        assert_eq!(TimeUnit::MS.tick_step(6000.0, 5), 2000.0);
    }

    #[test]
    fn ticks_and_numbers() {
        assert_eq!(nice_step(0.23), 0.25);
        assert_eq!(nice_step(3.7), 5.0);
        assert_eq!(nice_step(1.0), 1.0);
        assert_eq!(fmt_tick(0.25, 0.25), "0.25");
        assert_eq!(fmt_tick(7.5, 2.5), "7.5");
        assert_eq!(fmt_tick(-0.0001, 0.5), "0");
        assert_eq!(fmt_tick(2e6, 1e6), "2e6");
        // The mission plot's axes: decimals by the axis extent, trailing zeros dropped.
        assert_eq!(fmt_tick_span(200.0, 1000.0), "200");
        assert_eq!(fmt_tick_span(0.25, 1.0), "0.25");
        assert_eq!(fmt_tick_span(-0.0001, 10.0), "0");
        assert_eq!(fmt_significant(0.0612, 2, 3), "0.061");
        assert_eq!(fmt_significant(-0.0001, 2, 2), "0");
    }

    #[test]
    fn palette_parses() {
        assert_eq!(rgb(PALETTE[0]), (0x1f, 0x77, 0xb4));
        assert_eq!(rgb("#FFfe00"), (255, 254, 0));
        assert_eq!(palette(13), PALETTE[3]);
        for (state, colour, _) in CONTACT_STATES {
            let _ = rgb(colour);
            assert_eq!(CONTACT_STATES[contact_index(state).unwrap()].0, state);
        }
    }

    fn ev(kind: &str, vehicle: Option<u32>, detail: serde_json::Value) -> Event {
        Event {
            t: 1.0,
            k: 1,
            kind: kind.into(),
            vehicle,
            detail,
        }
    }

    #[test]
    fn event_labels_are_short_and_name_vehicles() {
        use serde_json::json;
        let e = ev("fault", Some(2), json!({"fault": "kill"}));
        assert_eq!(event_label(&e), "kill 2");
        assert_eq!(event_label(&ev("lost", Some(2), json!(null))), "lost 2");
        assert_eq!(
            event_label(&ev("reconfigured", None, json!({"vehicles": [0, 1]}))),
            "redesign"
        );
        assert_eq!(
            event_label(&ev("stall_began", None, json!({"why": "V above V_U"}))),
            "stall (V above V_U)"
        );
        assert_eq!(
            event_label(&ev("formation_broken", None, json!({"vehicles": [1, 5]}))),
            "broken: 1, 5"
        );
        let nc = ev(
            "near_collision",
            None,
            json!({"pair": [1, 4], "ratio": 0.0612}),
        );
        assert_eq!(event_label(&nc), "near collision 1–4 (0.061)");
        assert_eq!(near_collision_pair(&nc), Some((1, 4)));
        let nc = ev("near_collision", Some(3), json!({"other": 0}));
        assert_eq!(near_collision_pair(&nc), Some((3, 0)));
        assert!(event_style("surfaced").is_none());
        assert!(event_style("link_drop").is_none());
        for kind in SNAPSHOT_EVENTS {
            assert!(event_style(kind).is_some(), "{kind}");
        }
    }
}
