//! The field under the mission plot: sampled on a grid, filled colour bands (viridis,
//! washed) and contour lines at the band edges (marching squares, simplified).

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

/// Contour lines of the grid at `level` by marching squares over the sample points (cells with
/// a non-finite corner are skipped), joined into polylines; a closed loop repeats its first
/// point at the end.
pub(super) fn contour_lines(g: &Grid, level: f64) -> Vec<Vec<(f64, f64)>> {
    let (nx, ny) = (g.nx, g.ny);
    if nx < 2 || ny < 2 {
        return Vec::new();
    }
    let n_h = (nx - 1) * ny;
    let h_edge = |i: usize, j: usize| j * (nx - 1) + i;
    let v_edge = |i: usize, j: usize| n_h + j * nx + i;
    let n_edges = n_h + nx * (ny - 1);
    let interp = |(i0, j0): (usize, usize), (i1, j1): (usize, usize)| {
        let (a, b) = (g.at(i0, j0), g.at(i1, j1));
        let t = ((level - a) / (b - a)).clamp(0.0, 1.0);
        let (x0, y0, x1, y1) = (g.xc(i0), g.yc(j0), g.xc(i1), g.yc(j1));
        (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
    };

    let mut point_of_edge: Vec<Option<(f64, f64)>> = vec![None; n_edges];
    let mut segments: Vec<(usize, usize)> = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let c = [
                g.at(i, j),
                g.at(i + 1, j),
                g.at(i + 1, j + 1),
                g.at(i, j + 1),
            ];
            if c.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let case = c
                .iter()
                .enumerate()
                .fold(0usize, |acc, (k, &v)| acc | (usize::from(v >= level) << k));
            if case == 0 || case == 15 {
                continue;
            }
            // Edges: 0 bottom, 1 right, 2 top, 3 left.
            let ids = [
                h_edge(i, j),
                v_edge(i + 1, j),
                h_edge(i, j + 1),
                v_edge(i, j),
            ];
            let ends = [
                ((i, j), (i + 1, j)),
                ((i + 1, j), (i + 1, j + 1)),
                ((i, j + 1), (i + 1, j + 1)),
                ((i, j), (i, j + 1)),
            ];
            let centre_high = 0.25 * c.iter().sum::<f64>() >= level;
            let pairs: &[(usize, usize)] = match case {
                1 | 14 => &[(3, 0)],
                2 | 13 => &[(0, 1)],
                3 | 12 => &[(3, 1)],
                4 | 11 => &[(1, 2)],
                6 | 9 => &[(0, 2)],
                7 | 8 => &[(2, 3)],
                5 if centre_high => &[(0, 1), (2, 3)],
                5 => &[(3, 0), (1, 2)],
                10 if centre_high => &[(3, 0), (1, 2)],
                10 => &[(0, 1), (2, 3)],
                _ => &[],
            };
            for &(a, b) in pairs {
                for e in [a, b] {
                    if point_of_edge[ids[e]].is_none() {
                        point_of_edge[ids[e]] = Some(interp(ends[e].0, ends[e].1));
                    }
                }
                segments.push((ids[a], ids[b]));
            }
        }
    }

    // Each edge touches at most two segments (the two cells beside it).
    let mut at_edge: Vec<[usize; 2]> = vec![[usize::MAX; 2]; n_edges];
    for (s, &(a, b)) in segments.iter().enumerate() {
        for e in [a, b] {
            let slot = &mut at_edge[e];
            if slot[0] == usize::MAX {
                slot[0] = s;
            } else {
                slot[1] = s;
            }
        }
    }
    let mut used = vec![false; segments.len()];
    let mut lines = Vec::new();
    for s0 in 0..segments.len() {
        if used[s0] {
            continue;
        }
        used[s0] = true;
        let (a0, b0) = segments[s0];
        let walk = |from: usize, used: &mut Vec<bool>| {
            let mut chain = Vec::new();
            let mut edge = from;
            loop {
                let next = at_edge[edge]
                    .iter()
                    .copied()
                    .find(|&s| s != usize::MAX && !used[s]);
                let Some(s) = next else { break };
                used[s] = true;
                let (a, b) = segments[s];
                edge = if a == edge { b } else { a };
                chain.push(edge);
            }
            chain
        };
        let forward = walk(b0, &mut used);
        let backward = walk(a0, &mut used);
        let edges: Vec<usize> = backward
            .into_iter()
            .rev()
            .chain([a0, b0])
            .chain(forward)
            .collect();
        lines.push(
            edges
                .into_iter()
                .filter_map(|e| point_of_edge[e])
                .collect::<Vec<_>>(),
        );
    }
    lines
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
