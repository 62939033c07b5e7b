//! The extent of the mission plot: everything drawn, with a margin, at the chart's aspect.

use super::*;

/// Bounds covering every track, the body path, the snapshots, the optimum and the events, with
/// a margin of [`BOUNDS_MARGIN`] × the larger extent, widened in one direction so that
/// width / height = `aspect` (the plotting area's pixel aspect ratio: equal scales on x and y).
pub fn choose_bounds(plot: &MissionPlot<'_>, aspect: f64) -> Result<Bounds, PlotError> {
    let points = plot
        .tracks
        .iter()
        .flat_map(|t| t.points.iter().copied())
        .chain(plot.body_path.iter().copied())
        .chain(
            plot.snapshots
                .iter()
                .flat_map(|s| s.positions.iter().copied().chain(std::iter::once(s.centre))),
        )
        .chain(plot.optimum)
        .chain(plot.events.iter().map(|(x, y, _)| (*x, *y)));
    bounds_around(points, BOUNDS_MARGIN, aspect)
}

/// The smallest rectangle holding `points`, grown by `margin_frac` × its larger extent on every
/// side and then widened about its centre to width / height = `aspect`. A single point (zero
/// extent) gets a half-width of max(1, 0.1 |coordinate|) in the length unit.
pub fn bounds_around(
    points: impl IntoIterator<Item = (f64, f64)>,
    margin_frac: f64,
    aspect: f64,
) -> Result<Bounds, PlotError> {
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(PlotError::InvalidParameter(format!(
            "aspect ratio must be finite and > 0, got {aspect}"
        )));
    }
    if !(margin_frac.is_finite() && margin_frac >= 0.0) {
        return Err(PlotError::InvalidParameter(format!(
            "margin must be finite and >= 0, got {margin_frac}"
        )));
    }
    let mut xr: Option<(f64, f64)> = None;
    let mut yr: Option<(f64, f64)> = None;
    for (i, (x, y)) in points.into_iter().enumerate() {
        if !x.is_finite() || !y.is_finite() {
            return Err(PlotError::NonFinite {
                what: "plotted points".into(),
                index: i,
            });
        }
        xr = Some(extend(xr, x));
        yr = Some(extend(yr, y));
    }
    let (Some((x0, x1)), Some((y0, y1))) = (xr, yr) else {
        return Err(PlotError::Empty(
            "no track, body path, snapshot, optimum or event".into(),
        ));
    };
    let (w, h) = (x1 - x0, y1 - y0);
    let (mut hw, mut hh) = if w == 0.0 && h == 0.0 {
        let d = 1.0_f64.max(0.1 * x0.abs().max(y0.abs()));
        (d, d)
    } else {
        let m = margin_frac * w.max(h);
        (0.5 * w + m, 0.5 * h + m)
    };
    // One side can still be zero (collinear points, no margin): the aspect fix gives it size.
    let tiny = 1e-9 * hw.max(hh);
    hw = hw.max(tiny);
    hh = hh.max(tiny);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    if hw / hh < aspect {
        hw = hh * aspect;
    } else {
        hh = hw / aspect;
    }
    Ok(Bounds {
        x_min: cx - hw,
        x_max: cx + hw,
        y_min: cy - hh,
        y_max: cy + hh,
    })
}
