//! Axis ranges, ticks and the data-to-pixel scale of a panel.

use super::super::style::{self, TimeUnit};
use super::Axis;

/// "Nice" linear ticks covering [lo, hi], about `target` of them (on a time axis, at steps
/// of the clock), and their step.
pub fn linear_ticks(
    lo: f64,
    hi: f64,
    target: usize,
    integer: bool,
    time: Option<TimeUnit>,
) -> (Vec<f64>, f64) {
    let span = (hi - lo).max(f64::MIN_POSITIVE);
    let mut step = match time {
        Some(unit) => unit.tick_step(span, target),
        None => style::nice_step(span / target.max(1) as f64),
    };
    if integer {
        step = step.max(1.0).round();
    }
    let mut ticks = Vec::new();
    // A bound a rounding error inside a tick keeps that tick.
    let mut v = (lo / step - 1e-9).ceil() * step;
    while v <= hi + step * 1e-9 {
        ticks.push(if v.abs() < step * 1e-9 { 0.0 } else { v });
        v += step;
    }
    (ticks, step)
}

/// Log ticks: (value, label shown) for [lo, hi] (both > 0).
pub fn log_ticks(lo: f64, hi: f64) -> Vec<(f64, bool)> {
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let decades = b - a;
    let every = (decades / 7 + 1).max(1);
    let mut out = Vec::new();
    for e in a..=b {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10f64.powi(e);
            if v < lo * (1.0 - 1e-9) || v > hi * (1.0 + 1e-9) {
                continue;
            }
            if m == 1.0 {
                out.push((v, (e - a) % every == 0));
            } else if decades <= 2 {
                out.push((v, true));
            } else if decades <= 5 {
                out.push((v, false));
            }
        }
    }
    out
}

/// A log-axis label: plain decimals from 10⁻³ to 10⁴, `10^{e}` outside.
pub fn fmt_log(v: f64) -> String {
    let e = v.log10().round() as i32;
    let m = v / 10f64.powi(e.min(v.log10().floor() as i32));
    if (-3..=4).contains(&e) || (m - 1.0).abs() > 1e-6 {
        let d = if v >= 1.0 {
            0
        } else {
            (-v.log10()).ceil() as usize
        };
        return format!("{v:.d$}");
    }
    format!("10^{{{e}}}")
}

/// Maps data to pixels on one axis.
#[derive(Clone, Copy, Debug)]
pub struct Scale {
    /// Data range.
    pub lo: f64,
    /// Data range.
    pub hi: f64,
    /// Logarithmic.
    pub log: bool,
    /// Pixel of `lo`.
    pub p0: f64,
    /// Pixel of `hi`.
    pub p1: f64,
}

impl Scale {
    /// The pixel of `v`; `None` for a non-finite value (or a non-positive one on a log axis).
    pub fn px(&self, v: f64) -> Option<f64> {
        if !v.is_finite() || (self.log && v <= 0.0) {
            return None;
        }
        let f = if self.log {
            (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        Some(self.p0 + f * (self.p1 - self.p0))
    }

    /// The ticks of `axis` on this scale: (value, label or none, major).
    pub fn ticks(&self, axis: &Axis, target: usize) -> Vec<(f64, Option<String>, bool)> {
        if axis.log && self.hi / self.lo < 10.0 {
            // Less than a decade: nice linear values, placed on the log scale.
            let (ticks, step) = linear_ticks(self.lo, self.hi, 5, axis.integer, None);
            ticks
                .into_iter()
                .filter(|v| *v > 0.0)
                .map(|v| (v, Some(style::fmt_tick(v, step)), true))
                .collect()
        } else if axis.log {
            log_ticks(self.lo, self.hi)
                .into_iter()
                .map(|(v, labelled)| (v, labelled.then(|| fmt_log(v)), labelled))
                .collect()
        } else {
            let (ticks, step) = linear_ticks(self.lo, self.hi, target, axis.integer, axis.time);
            let mut out: Vec<_> = ticks
                .into_iter()
                .map(|v| (v, Some(style::fmt_tick(v, step)), true))
                .collect();
            // A time axis without its label (a panel above the figure's last) still says
            // its unit: on its last tick ("36 h").
            if let (Some(unit), true) = (axis.time, axis.label.is_empty()) {
                if let Some((_, Some(last), _)) = out.last_mut() {
                    last.push(' ');
                    last.push_str(unit.symbol);
                }
            }
            out
        }
    }
}

/// The data range of an axis: its fixed range, or the finite `values` padded (from 0 when
/// asked; a flat range widened).
pub fn axis_range(axis: &Axis, values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    if let Some(r) = axis.range {
        return Some(r);
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for v in values {
        if v.is_finite() && (!axis.log || v > 0.0) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if lo > hi {
        return None;
    }
    if axis.log {
        if hi / lo < 1.5 {
            return Some((lo / 1.5, hi * 1.5));
        }
        let pad = (hi / lo).powf(0.04);
        return Some((lo / pad, hi * pad));
    }
    if axis.from_zero && lo >= 0.0 {
        lo = 0.0;
    }
    if hi - lo < 1e-12 * hi.abs().max(1.0) {
        let d = if hi == 0.0 { 1.0 } else { hi.abs() * 0.1 };
        return Some((lo - d, hi + d));
    }
    let pad = 0.05 * (hi - lo);
    let lo = if axis.from_zero && lo == 0.0 {
        0.0
    } else {
        lo - pad
    };
    let mut hi = hi + pad;
    if axis.integer {
        hi = hi.ceil();
    }
    Some((lo, hi))
}
