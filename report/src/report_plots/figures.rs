//! The two time-series figures of a run: formation and speed, gradient estimate.

use crate::plot::chart::{event_markers, Axis, Figure, Marker, Panel, RefLine, Series};
use crate::plot::style::{self, TimeUnit, PALETTE};
use vbap_mission::config::Mission;
use vbap_wire::rundir::Event;

use super::series::RunSeries;
use crate::truth_plots::{self, Formation, Truth};

/// What the figures are drawn from.
pub(super) struct Inputs<'a> {
    pub mission: &'a Mission,
    pub s: &'a RunSeries,
    pub events: &'a [Event],
    pub formation: Option<&'a Formation>,
    pub truth: Option<&'a Truth>,
}

/// What every panel of both figures shares: the time unit and range, titles, markers.
struct Ctx {
    unit: TimeUnit,
    t_range: Option<(f64, f64)>,
    markers: Vec<Marker>,
    subtitle: String,
    name: String,
}

impl Ctx {
    fn new(i: &Inputs<'_>) -> Self {
        let (m, s) = (&i.mission.mission, i.s);
        let unit = TimeUnit::for_span(s.last_t);
        let converged = i
            .events
            .iter()
            .find(|e| e.kind == "converged")
            .map(|e| format!("converged at t = {}", unit.fmt(e.t)))
            .unwrap_or_else(|| "not converged".into());
        let max_v = match i.truth {
            Some(tr) => format!(
                "max V/V_{{U}} true {}, seen {}",
                style::fmt_significant(tr.max_v_true, 3, 3),
                style::fmt_significant(tr.max_v_seen, 3, 3)
            ),
            None => format!("max V/V_{{U}} = {:.3}", s.max_v_over_vu),
        };
        let subtitle = format!(
            "{} vehicles, {} ticks of {} over {} · {max_v} · {converged}",
            i.mission.vehicles.count,
            s.rows,
            style::fmt_duration(m.dt),
            unit.fmt(s.last_t + m.dt - s.first_t),
        );
        Self {
            unit,
            // Tick k covers [k dt, (k + 1) dt): the axis ends where the last tick does.
            t_range: Some((unit.of(s.first_t), unit.of(s.last_t + m.dt))),
            markers: event_markers(i.events, unit),
            subtitle,
            name: format!("{} (seed {})", m.name, m.seed),
        }
    }
    fn rescale(&self, pts: &[(f64, f64)]) -> Vec<(f64, f64)> {
        pts.iter().map(|&(t, y)| (self.unit.of(t), y)).collect()
    }
    fn time_axis(&self, label: bool) -> Axis {
        Axis {
            label: if label {
                self.unit.axis_label("mission time t")
            } else {
                String::new()
            },
            range: self.t_range,
            time: Some(self.unit),
            ..Axis::default()
        }
    }
    fn figure(&self, what: &str, panels: Vec<Panel>) -> Figure {
        let mut fig = Figure {
            title: format!("{}: {what}", self.name),
            subtitle: self.subtitle.clone(),
            panels,
        };
        for p in &mut fig.panels {
            p.markers = self.markers.clone();
        }
        fig
    }
}

/// Splits `"T (°C)"` into the field's unit `"°C"`; `""` when there is none.
pub(super) fn field_unit(label: &str) -> String {
    match (label.rfind('('), label.rfind(')')) {
        (Some(a), Some(b)) if b > a + 1 => label[a + 1..b].trim().to_string(),
        _ => String::new(),
    }
}

/// The unit of the field's gradient, "°C/m"; F and L stand in for a unit not given;
/// `""` when neither is.
fn gradient_unit(mission: &Mission) -> String {
    let m = &mission.mission;
    let (funit, len) = (field_unit(&m.field_label), m.length_unit.as_str());
    match (funit.is_empty(), len.is_empty()) {
        (true, true) => String::new(),
        (false, false) => format!("{funit}/{len}"),
        (false, true) => format!("{funit}/L"),
        (true, false) => format!("F/{len}"),
    }
}

fn with_unit(what: &str, unit: &str) -> String {
    if unit.is_empty() {
        what.to_string()
    } else {
        format!("{what} ({unit})")
    }
}

/// `timeseries_formation.svg`: V/V_U, ṡ, k, slot errors and nearest pair (truth files),
/// vehicles in the formation.
pub(super) fn formation_figure(i: &Inputs<'_>) -> Figure {
    let cx = Ctx::new(i);
    let mut panels = vec![v_panel(&cx, i), sdot_panel(&cx, i), k_panel(&cx, i)];
    if let Some(f) = i.formation {
        panels.push(truth_plots::slot_error_panel(
            f,
            i.truth,
            cx.time_axis(false),
        ));
    }
    if let Some(tr) = i.truth {
        panels.push(truth_plots::nearest_pair_panel(tr, cx.time_axis(false)));
    }
    panels.push(n_panel(&cx, i));
    cx.figure("formation and speed", panels)
}

/// `timeseries_estimate.svg`: gradient-estimate error, tr P, link drops, distance to the
/// optimum.
pub(super) fn estimate_figure(i: &Inputs<'_>) -> Figure {
    let cx = Ctx::new(i);
    let m = &i.mission.mission;
    let panels = [
        Some(g_panel(&cx, i)),
        Some(p_panel(&cx, i)),
        drops_panel(i.events, i.s, m.dt, cx.unit),
        Some(d_panel(&cx, i)),
    ];
    cx.figure("gradient estimate", panels.into_iter().flatten().collect())
}

/// V of (II.2) ÷ V_U (true and seen with the truth files) against the bound.
fn v_panel(cx: &Ctx, i: &Inputs<'_>) -> Panel {
    let (s, truth) = (i.s, i.truth);
    let mut v_panel = Panel::new(
        "Lyapunov function of the formation (Theorem 4.1 keeps V ≤ V_{U})",
        cx.time_axis(false),
        Axis {
            label: "V / V_{U}".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    let max_v_shown = match truth {
        Some(tr) => {
            v_panel.title =
                "Lyapunov function V of (II.2), true and as the coordinator sees it (Theorem 4.1 keeps V ≤ V_{U})"
                    .into();
            v_panel.series.push(Series::line(
                "true (vehicles' true states)",
                cx.rescale(&tr.v_true.points()),
                PALETTE[0],
            ));
            v_panel.series.push(Series {
                dashed: true,
                ..Series::line(
                    "seen (coordinator's view)",
                    cx.rescale(&tr.v_seen.points()),
                    PALETTE[1],
                )
            });
            tr.max_v_true.max(tr.max_v_seen)
        }
        None => {
            v_panel.series.push(Series::line(
                "V / V_{U}",
                cx.rescale(&s.v_over_vu.points()),
                PALETTE[0],
            ));
            s.max_v_over_vu
        }
    };
    // Far above the bound (a broken formation): a log axis keeps the bound readable.
    if max_v_shown > 20.0 {
        v_panel.y.log = true;
        v_panel.y.from_zero = false;
    }
    if max_v_shown >= 0.25 {
        v_panel.hlines.push(RefLine {
            y: 1.0,
            label: "bound V = V_{U}".into(),
            colour: "#d62728",
        });
    } else {
        v_panel.notes.push(format!(
            "the bound V = V_{{U}} is off scale (max V/V_{{U}} = {:.3})",
            max_v_shown
        ));
    }
    v_panel
}

/// The body speed ṡ of (IV.4) against v₀.
fn sdot_panel(cx: &Ctx, i: &Inputs<'_>) -> Panel {
    let (mission, s) = (i.mission, i.s);
    let len = mission.mission.length_unit.as_str();
    let speed_unit = if len.is_empty() {
        String::new()
    } else {
        format!("{len}/s")
    };
    let mut sdot_panel = Panel::new(
        "Speed of the virtual body along its path, ṡ (IV.4)",
        cx.time_axis(false),
        Axis {
            label: with_unit("body speed ṡ", &speed_unit),
            from_zero: true,
            ..Axis::default()
        },
    );
    sdot_panel
        .series
        .push(Series::line("ṡ", cx.rescale(&s.sdot.points()), PALETTE[1]));
    sdot_panel.hlines.push(RefLine {
        y: mission.body.v0,
        label: format!("nominal v_{{0}} = {}", mission.body.v0),
        colour: "#555555",
    });
    sdot_panel
}

/// The formation scale k.
fn k_panel(cx: &Ctx, i: &Inputs<'_>) -> Panel {
    let s = i.s;
    let mut k_panel = Panel::new(
        "Formation scale k (resolution adaptation dk/ds)",
        cx.time_axis(false),
        Axis {
            label: "scale k (× design)".into(),
            ..Axis::default()
        },
    );
    k_panel.series.push(Series::line(
        "scale k",
        cx.rescale(&s.scale.points()),
        PALETTE[2],
    ));
    k_panel
}

/// Vehicles in the formation (members; alive and truly in formation with the truth files).
fn n_panel(cx: &Ctx, i: &Inputs<'_>) -> Panel {
    let (s, truth) = (i.s, i.truth);
    let mut n_panel = Panel::new(
        "Vehicles in the formation",
        cx.time_axis(true),
        Axis {
            label: "vehicles".into(),
            from_zero: true,
            integer: true,
            ..Axis::default()
        },
    );
    n_panel.series.push(Series {
        step: true,
        ..Series::line(
            if truth.is_some() {
                "members (coordinator's design)"
            } else {
                "vehicles in the formation"
            },
            cx.rescale(&s.vehicles.points()),
            PALETTE[4],
        )
    });
    if let Some(tr) = truth {
        n_panel.title = "Vehicles: members of the design, alive, truly in formation".into();
        n_panel.series.push(Series {
            step: true,
            dashed: true,
            ..Series::line("alive", cx.rescale(&tr.n_alive.points()), "#555555")
        });
        n_panel.series.push(Series {
            step: true,
            ..Series::line(
                "in formation (true slot error)",
                cx.rescale(&tr.n_in_formation.points()),
                PALETTE[2],
            )
        });
    }
    n_panel
}

/// The gradient-estimate error against the true gradient.
fn g_panel(cx: &Ctx, i: &Inputs<'_>) -> Panel {
    let s = i.s;
    let grad_unit = gradient_unit(i.mission);
    let mut g_panel = Panel::new(
        "Gradient estimate error at the body centre (Lemma 5.4 filter)",
        cx.time_axis(false),
        Axis {
            label: with_unit("gradient", &grad_unit),
            log: true,
            ..Axis::default()
        },
    );
    if s.has_truth {
        g_panel.series.push(Series::line(
            "‖∇T_{est} − ∇T‖",
            cx.rescale(&s.grad_error.points()),
            PALETTE[0],
        ));
        g_panel.series.push(Series {
            dashed: true,
            ..Series::line("true ‖∇T‖", cx.rescale(&s.grad_true.points()), "#555555")
        });
    } else {
        g_panel
            .notes
            .push("body.csv has no true gradient columns".into());
    }
    g_panel
}

/// The trace of the Kalman covariance P.
fn p_panel(cx: &Ctx, i: &Inputs<'_>) -> Panel {
    let s = i.s;
    // P is the covariance of (∇T, T): its trace adds gradient and field variances.
    let (funit, grad_unit) = (
        field_unit(&i.mission.mission.field_label),
        gradient_unit(i.mission),
    );
    let label = if funit.is_empty() {
        "tr P".to_string()
    } else {
        format!("tr P (({grad_unit})², {funit}²)")
    };
    let mut p_panel = Panel::new(
        "Trace of the Kalman covariance P",
        cx.time_axis(false),
        Axis {
            label,
            log: true,
            ..Axis::default()
        },
    );
    p_panel.series.push(Series::line(
        "tr P",
        cx.rescale(&s.p_trace.points()),
        PALETTE[3],
    ));
    p_panel
}

/// The distance of the body centre to the optimum against the tolerance.
fn d_panel(cx: &Ctx, i: &Inputs<'_>) -> Panel {
    let (m, s) = (&i.mission.mission, i.s);
    let len = m.length_unit.as_str();
    let mut d_panel = Panel::new(
        "Distance of the virtual body centre to the optimum",
        cx.time_axis(true),
        Axis {
            label: with_unit("distance", len),
            log: true,
            ..Axis::default()
        },
    );
    if s.distance.is_empty() {
        d_panel
            .notes
            .push("the field has no optimum to measure against".into());
    }
    d_panel.series.push(Series::line(
        "‖r − r*‖",
        cx.rescale(&s.distance),
        PALETTE[2],
    ));
    d_panel.hlines.push(RefLine {
        y: m.tolerance,
        label: format!("tolerance {}", m.tolerance),
        colour: "#17becf",
    });
    d_panel
}

/// Messages the link model dropped (`link_drop` events), as a rate per bucket of time;
/// `None` when there were none.
fn drops_panel(events: &[Event], s: &RunSeries, dt: f64, unit: TimeUnit) -> Option<Panel> {
    let tscale = unit.seconds;
    let drops: Vec<f64> = events
        .iter()
        .filter(|e| e.kind == "link_drop")
        .map(|e| e.t)
        .collect();
    if drops.is_empty() {
        return None;
    }
    let span = (s.last_t - s.first_t).max(f64::MIN_POSITIVE);
    let buckets = 60usize;
    let width = span / buckets as f64;
    let mut counts = vec![0u64; buckets];
    for t in &drops {
        let b = (((t - s.first_t) / width) as usize).min(buckets - 1);
        counts[b] += 1;
    }
    let points: Vec<(f64, f64)> = counts
        .iter()
        .enumerate()
        .map(|(i, c)| ((s.first_t + i as f64 * width) / tscale, *c as f64 / width))
        .chain(std::iter::once((
            s.last_t / tscale,
            counts[buckets - 1] as f64 / width,
        )))
        .collect();
    let mut p = Panel::new(
        "Messages dropped by the link model (link_drop events)",
        Axis {
            range: Some((s.first_t / tscale, (s.last_t + dt) / tscale)),
            time: Some(unit),
            ..Axis::default()
        },
        Axis {
            label: "drops per s".into(),
            from_zero: true,
            ..Axis::default()
        },
    );
    p.series.push(Series {
        step: true,
        ..Series::line(
            &format!("{} drops, rate per {}", drops.len(), unit.fmt(width)),
            points,
            PALETTE[5],
        )
    });
    Some(p)
}
