//! One panel of a figure: title, grid and tick labels, event markers, reference lines, the
//! data clipped to the plot area, the frame and axis labels, and its legend column.

use super::super::canvas::{text_width, Anchor, Canvas, TextOpts};
use super::super::PlotError;
use super::ticks::{axis_range, Scale};
use super::{legend, Marker, Panel, Series, MARGIN_LEFT, PANEL_TITLE_H, PLOT_H, PLOT_W};

/// Height of a panel in the figure, px.
pub fn panel_height(p: &Panel) -> f64 {
    PANEL_TITLE_H + PLOT_H + 28.0 + if p.x.label.is_empty() { 0.0 } else { 24.0 } + 12.0
}

/// The plot area of a panel whose top is at `top`: (x0, y0, x1, y1), px.
fn plot_area(top: f64) -> (f64, f64, f64, f64) {
    let y0 = top + PANEL_TITLE_H;
    (MARGIN_LEFT, y0, MARGIN_LEFT + PLOT_W, y0 + PLOT_H)
}

/// Draws panel `p` with its top at `top` px; event labels (and their legend) only when
/// `label_markers`.
pub fn draw_panel(
    c: &Canvas<'_>,
    p: &Panel,
    top: f64,
    label_markers: bool,
) -> Result<(), PlotError> {
    let (x0, y0, x1, y1) = plot_area(top);
    c.text((x0, top + 20.0), &p.title, TextOpts::new(15.0).bold())?;
    let xs = p.series.iter().flat_map(|s| s.points.iter().map(|q| q.0));
    let ys = p
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|q| q.1))
        .chain(p.hlines.iter().map(|h| h.y));
    let (Some(xr), Some(yr)) = (axis_range(&p.x, xs), axis_range(&p.y, ys)) else {
        c.rect((x0, y0), (PLOT_W, PLOT_H), "#fafafa", 1.0)?;
        c.frame((x0, y0), (PLOT_W, PLOT_H), "#000000")?;
        let mid = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        let o = TextOpts::new(14.0).colour("#777777").anchor(Anchor::Middle);
        return c.text(mid, "no data", o);
    };
    let xs = Scale {
        lo: xr.0,
        hi: xr.1,
        log: p.x.log,
        p0: x0,
        p1: x1,
    };
    let ys = Scale {
        lo: yr.0,
        hi: yr.1,
        log: p.y.log,
        p0: y1,
        p1: y0,
    };
    draw_grid(c, p, &xs, &ys, top)?;
    draw_markers(c, &p.markers, &xs, top, label_markers)?;
    for h in &p.hlines {
        if let Some(y) = ys.px(h.y).filter(|y| *y >= y0 - 0.5 && *y <= y1 + 0.5) {
            c.line((x0, y), (x1, y), h.colour, 2, Some((8, 4)))?;
        }
    }
    for s in &p.series {
        draw_series(c, s, &xs, &ys, top)?;
    }
    c.frame((x0, y0), (PLOT_W, PLOT_H), "#000000")?;
    if !p.y.label.is_empty() {
        let o = TextOpts::new(14.0).anchor(Anchor::Middle).vertical();
        c.text((x0 - 68.0, (y0 + y1) / 2.0), &p.y.label, o)?;
    }
    if !p.x.label.is_empty() {
        let o = TextOpts::new(14.0).anchor(Anchor::Middle);
        c.text(((x0 + x1) / 2.0, y1 + 42.0), &p.x.label, o)?;
    }
    legend::draw_panel_legend(c, p, (x1 + 22.0, y0 + 12.0), label_markers)
}

/// Grid lines and tick labels of both axes.
fn draw_grid(c: &Canvas<'_>, p: &Panel, xs: &Scale, ys: &Scale, top: f64) -> Result<(), PlotError> {
    let (x0, y0, x1, y1) = plot_area(top);
    for (v, label, major) in xs.ticks(&p.x, 10) {
        let Some(x) = xs.px(v) else { continue };
        c.line((x, y0), (x, y1), grid_colour(major), 1, None)?;
        if let Some(l) = label {
            c.text(
                (x, y1 + 18.0),
                &l,
                TextOpts::new(13.0).anchor(Anchor::Middle),
            )?;
        }
    }
    for (v, label, major) in ys.ticks(&p.y, 5) {
        let Some(y) = ys.px(v) else { continue };
        c.line((x0, y), (x1, y), grid_colour(major), 1, None)?;
        if let Some(l) = label {
            c.text(
                (x0 - 7.0, y + 4.5),
                &l,
                TextOpts::new(13.0).anchor(Anchor::End),
            )?;
        }
    }
    Ok(())
}

fn grid_colour(major: bool) -> &'static str {
    if major {
        "#dddddd"
    } else {
        "#eeeeee"
    }
}

/// Event markers as dashed vertical lines; labels (when `labelled`) of events closer than
/// 15 px joined into one, written down the line from the top.
fn draw_markers(
    c: &Canvas<'_>,
    markers: &[Marker],
    xs: &Scale,
    top: f64,
    labelled: bool,
) -> Result<(), PlotError> {
    let (x0, y0, x1, y1) = plot_area(top);
    let mut labels: Vec<(f64, &'static str, Vec<&str>)> = Vec::new();
    for m in markers {
        let Some(x) = xs.px(m.x).filter(|x| *x >= x0 - 0.5 && *x <= x1 + 0.5) else {
            continue;
        };
        c.line((x, y0), (x, y1), m.colour, 2, Some((5, 3)))?;
        if !labelled || m.label.is_empty() {
            continue;
        }
        match labels.last_mut() {
            Some((lx, _, texts)) if x - *lx < 15.0 => {
                if !texts.contains(&m.label.as_str()) {
                    texts.push(&m.label);
                }
            }
            _ => labels.push((x, m.colour, vec![&m.label])),
        }
    }
    for (x, colour, texts) in labels {
        let mut text = texts.join(", ");
        // Keep the label inside the plot's height.
        let room = ((PLOT_H - 8.0) / (11.0 * 0.58)) as usize;
        if text.chars().count() > room {
            text = text
                .chars()
                .take(room.saturating_sub(1))
                .collect::<String>()
                + "…";
        }
        let w = text_width(&text, 11.0) + 6.0;
        c.rect((x - 7.0, y0 + 1.0), (13.0, w), "#ffffff", 0.85)?;
        let o = TextOpts::new(11.0)
            .colour(colour)
            .anchor(Anchor::End)
            .vertical();
        c.text((x + 3.0, y0 + 4.0), &text, o)?;
    }
    Ok(())
}

/// A series as polylines (a dot for an isolated point), clipped to the plot area.
fn draw_series(
    c: &Canvas<'_>,
    s: &Series,
    xs: &Scale,
    ys: &Scale,
    top: f64,
) -> Result<(), PlotError> {
    let (x0, y0, x1, y1) = plot_area(top);
    let dash = s.dashed.then_some((7, 4));
    for run in pixel_runs(s, xs, ys) {
        if let [p] = run[..] {
            if p.0 >= x0 && p.0 <= x1 && p.1 >= y0 && p.1 <= y1 {
                c.dot(p, 2, s.colour)?;
            }
            continue;
        }
        for piece in clip_run(&run, (x0, y0, x1, y1)) {
            c.polyline(&piece, s.colour, 2, dash)?;
        }
    }
    Ok(())
}

/// The pixel polylines of a series: runs of drawable points (a non-finite value, or a
/// non-positive one on a log axis, ends a run).
pub(super) fn pixel_runs(s: &Series, xs: &Scale, ys: &Scale) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    let mut prev_y: Option<f64> = None;
    for &(x, y) in &s.points {
        match (xs.px(x), ys.px(y)) {
            (Some(px), Some(py)) => {
                if s.step {
                    if let Some(py0) = prev_y {
                        cur.push((px, py0));
                    }
                }
                // Skip points closer than 0.3 px to the previous one on both axes.
                if let Some(&(lx, ly)) = cur.last() {
                    if (px - lx).abs() < 0.3 && (py - ly).abs() < 0.3 {
                        continue;
                    }
                }
                cur.push((px, py));
                prev_y = Some(py);
            }
            _ => {
                if !cur.is_empty() {
                    runs.push(std::mem::take(&mut cur));
                }
                prev_y = None;
            }
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// `run` clipped to the rectangle `(x0, y0, x1, y1)`: the pieces inside (Liang–Barsky on
/// each segment).
pub(super) fn clip_run(run: &[(f64, f64)], rect: (f64, f64, f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut pieces: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for w in run.windows(2) {
        match clip_segment(w[0], w[1], rect) {
            Some((a, b)) => {
                if cur.last() != Some(&a) {
                    if cur.len() > 1 {
                        pieces.push(std::mem::take(&mut cur));
                    }
                    cur.clear();
                    cur.push(a);
                }
                cur.push(b);
            }
            None => {
                if cur.len() > 1 {
                    pieces.push(std::mem::take(&mut cur));
                }
                cur.clear();
            }
        }
    }
    if cur.len() > 1 {
        pieces.push(cur);
    }
    pieces
}

fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    (x0, y0, x1, y1): (f64, f64, f64, f64),
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - x0),
        (dx, x1 - a.0),
        (-dy, a.1 - y0),
        (dy, y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
            continue;
        }
        let r = q / p;
        if p < 0.0 {
            t0 = t0.max(r);
        } else {
            t1 = t1.min(r);
        }
        if t0 > t1 {
            return None;
        }
    }
    let at = |t: f64| (a.0 + t * dx, a.1 + t * dy);
    let (p, q) = (
        if t0 > 0.0 { at(t0) } else { a },
        if t1 < 1.0 { at(t1) } else { b },
    );
    Some((p, q))
}
