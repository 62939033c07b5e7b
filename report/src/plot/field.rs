//! The field under the mission plot: sampled on a grid, filled colour bands (viridis,
//! washed) and contour lines at the band edges (marching squares in [`super::contour`],
//! simplified).

use super::*;

/// Viridis sampled at t = 0, 0.1, ..., 1 (linearly interpolated between).
pub(super) const VIRIDIS: [(u8, u8, u8); 11] = [
    (0x44, 0x01, 0x54),
    (0x48, 0x24, 0x75),
    (0x41, 0x44, 0x87),
    (0x35, 0x5f, 0x8d),
    (0x2a, 0x78, 0x8e),
    (0x21, 0x91, 0x8c),
    (0x22, 0xa8, 0x84),
    (0x44, 0xbf, 0x70),
    (0x7a, 0xd1, 0x51),
    (0xbd, 0xdf, 0x26),
    (0xfd, 0xe7, 0x25),
];

/// Field samples at the centres of an nx × ny grid of equal cells covering the bounds.
pub(super) struct Grid {
    pub(super) bounds: Bounds,
    pub(super) nx: usize,
    pub(super) ny: usize,
    /// Row-major, `v[j * nx + i]` at (x_c(i), y_c(j)).
    pub(super) v: Vec<f64>,
}

impl Grid {
    pub(super) fn dx(&self) -> f64 {
        self.bounds.width() / self.nx as f64
    }
    pub(super) fn dy(&self) -> f64 {
        self.bounds.height() / self.ny as f64
    }
    pub(super) fn xc(&self, i: usize) -> f64 {
        self.bounds.x_min + (i as f64 + 0.5) * self.dx()
    }
    pub(super) fn yc(&self, j: usize) -> f64 {
        self.bounds.y_min + (j as f64 + 0.5) * self.dy()
    }
    pub(super) fn at(&self, i: usize, j: usize) -> f64 {
        self.v[j * self.nx + i]
    }
    pub(super) fn has_no_data(&self) -> bool {
        self.v.iter().any(|v| !v.is_finite())
    }
    pub(super) fn levels(&self) -> Option<Levels> {
        let mut r: Option<(f64, f64)> = None;
        for &v in self.v.iter().filter(|v| v.is_finite()) {
            r = Some(extend(r, v));
        }
        r.map(|(lo, hi)| nice_levels(lo, hi, FIELD_BANDS))
    }
}

/// Samples `field` on `cells` cells along the longer side of `bounds` (`aspect` = on-screen
/// width / height).
pub(super) fn sample_field(
    field: &dyn Fn(f64, f64) -> f64,
    bounds: Bounds,
    aspect: f64,
    cells: usize,
) -> Grid {
    let (nx, ny) = if aspect >= 1.0 {
        (cells, ((cells as f64 / aspect).round() as usize).max(2))
    } else {
        (((cells as f64 * aspect).round() as usize).max(2), cells)
    };
    let mut g = Grid {
        bounds,
        nx,
        ny,
        v: Vec::with_capacity(nx * ny),
    };
    for j in 0..ny {
        for i in 0..nx {
            let v = field(g.xc(i), g.yc(j));
            g.v.push(v);
        }
    }
    g
}

/// Colour bands of the field: `n` bands of width `step` from `base`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Levels {
    pub(super) base: f64,
    pub(super) step: f64,
    pub(super) n: usize,
}

impl Levels {
    pub(super) fn band(&self, v: f64) -> usize {
        let k = ((v - self.base) / self.step).floor();
        if k < 0.0 {
            0
        } else {
            (k as usize).min(self.n - 1)
        }
    }
    pub(super) fn edge(&self, k: usize) -> f64 {
        self.base + k as f64 * self.step
    }
    pub(super) fn colour(&self, k: usize) -> RGBColor {
        washed(viridis((k as f64 + 0.5) / self.n as f64), FIELD_WASH)
    }
}

/// Band edges at multiples of a "nice" step (1, 2, 2.5 or 5 × 10^k) giving at most about
/// `target` bands over [lo, hi].
pub(super) fn nice_levels(lo: f64, hi: f64, target: usize) -> Levels {
    let span = hi - lo;
    if span <= 0.0 || !span.is_finite() {
        let step = if lo == 0.0 {
            1.0
        } else {
            nice_step(0.1 * lo.abs())
        };
        return Levels {
            base: (lo / step).floor() * step,
            step,
            n: 1,
        };
    }
    let step = nice_step(span / target.max(1) as f64);
    let base = (lo / step).floor() * step;
    let n = (((hi - base) / step).ceil() as usize).max(1);
    // `hi` exactly on an edge would fall in a band of its own.
    let n = if base + n as f64 * step < hi {
        n + 1
    } else {
        n
    };
    Levels { base, step, n }
}

/// A filled field rectangle: two opposite corners (length unit) and its colour.
pub(super) type FieldRect = ((f64, f64), (f64, f64), RGBColor);

/// The grid's cells coloured by band, horizontal runs of one colour merged into one rectangle.
pub(super) fn field_rects(g: &Grid, levels: Option<&Levels>) -> Vec<FieldRect> {
    let (dx, dy) = (g.dx(), g.dy());
    let x_edge = |i: usize| g.bounds.x_min + i as f64 * dx;
    let y_edge = |j: usize| g.bounds.y_min + j as f64 * dy;
    let mut rects = Vec::new();
    for j in 0..g.ny {
        let colour_of = |i: usize| {
            let v = g.at(i, j);
            match levels {
                Some(l) if v.is_finite() => l.colour(l.band(v)),
                _ => NO_DATA,
            }
        };
        let mut start = 0;
        let mut current = colour_of(0);
        for i in 1..=g.nx {
            let c = if i < g.nx { Some(colour_of(i)) } else { None };
            if c != Some(current) {
                rects.push((
                    (x_edge(start), y_edge(j + 1)),
                    (x_edge(i), y_edge(j)),
                    current,
                ));
                if let Some(c) = c {
                    start = i;
                    current = c;
                }
            }
        }
    }
    rects
}

pub(super) fn draw_field(
    chart: &mut Chart<'_, '_>,
    g: &Grid,
    levels: Option<&Levels>,
    rects: Vec<FieldRect>,
    px: (f64, f64),
) -> Result<(), PlotError> {
    chart
        .draw_series(
            rects
                .into_iter()
                .map(|(a, b, c)| Rectangle::new([a, b], c.filled())),
        )
        .map_err(draw_err)?;
    let Some(l) = levels else { return Ok(()) };
    let mut lines = Vec::new();
    let mut n_points = 0;
    for k in 1..l.n {
        for line in contour_lines(g, l.edge(k)) {
            let line = simplify_path(&line, px, SIMPLIFY_PX);
            n_points += line.len();
            if n_points > CONTOUR_POINT_BUDGET {
                // A field this rough (noise) is better read from the bands alone.
                return Ok(());
            }
            lines.push(line);
        }
    }
    let style = BLACK.mix(0.35).stroke_width(1);
    chart
        .draw_series(lines.into_iter().map(|line| PathElement::new(line, style)))
        .map_err(draw_err)?;
    Ok(())
}

/// Viridis colormap at t ∈ [0, 1] (clamped).
pub(super) fn viridis(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (VIRIDIS.len() - 1) as f64;
    let k = (s.floor() as usize).min(VIRIDIS.len() - 2);
    let f = s - k as f64;
    let (a, b) = (VIRIDIS[k], VIRIDIS[k + 1]);
    let lerp = |p: u8, q: u8| (f64::from(p) + f * (f64::from(q) - f64::from(p))).round() as u8;
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// `c` mixed with white: `amount` = 0 keeps it, 1 gives white.
pub(super) fn washed(c: RGBColor, amount: f64) -> RGBColor {
    let m = |v: u8| (f64::from(v) + amount * (255.0 - f64::from(v))).round() as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

/// A band edge written with as many decimals as the step needs (scientific when very large or
/// very small).
pub(super) fn fmt_level(v: f64, step: f64) -> String {
    let mag = v.abs().max(step.abs());
    if mag >= 1e6 || step.abs() < 1e-4 {
        return format!("{v:.3e}");
    }
    let mut decimals = 0;
    while decimals < 6 {
        let scaled = step * 10f64.powi(decimals);
        if (scaled - scaled.round()).abs() < 1e-6 * scaled.abs().max(1.0) {
            break;
        }
        decimals += 1;
    }
    let s = format!("{v:.*}", decimals as usize);
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Douglas–Peucker simplification of a polyline, with the tolerance `tol_px` in pixels where a
/// pixel is `px.0` × `px.1` length units; endpoints are kept. Consecutive duplicates go first.
pub(super) fn simplify_path(points: &[(f64, f64)], px: (f64, f64), tol_px: f64) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for &p in points {
        if pts.last() != Some(&p) {
            pts.push(p);
        }
    }
    if pts.len() <= 2 || !(px.0 > 0.0 && px.1 > 0.0) {
        return pts;
    }
    let scaled: Vec<(f64, f64)> = pts.iter().map(|&(x, y)| (x / px.0, y / px.1)).collect();
    let mut keep = vec![false; pts.len()];
    keep[0] = true;
    keep[pts.len() - 1] = true;
    let mut stack = vec![(0usize, pts.len() - 1)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (scaled[a], scaled[b]);
        let (dx, dy) = (pb.0 - pa.0, pb.1 - pa.1);
        let len = dx.hypot(dy);
        let mut worst = (0.0, a);
        for (k, p) in scaled.iter().enumerate().take(b).skip(a + 1) {
            let d = if len > 0.0 {
                ((p.0 - pa.0) * dy - (p.1 - pa.1) * dx).abs() / len
            } else {
                (p.0 - pa.0).hypot(p.1 - pa.1)
            };
            if d > worst.0 {
                worst = (d, k);
            }
        }
        if worst.0 > tol_px {
            keep[worst.1] = true;
            stack.push((a, worst.1));
            stack.push((worst.1, b));
        }
    }
    pts.into_iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(p))
        .collect()
}
