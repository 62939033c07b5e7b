//! Land and missing data of a grid: which horizontal nodes are land, how the interpolant is
//! kept defined next to them, and the [`LandMask`] the motion side uses.
//!
//! A node is land where the variable is missing (`_FillValue`, `missing_value`, NaN) or
//! above `field.land_above`, at the level nearest the surface (|z| smallest) of the first
//! time step. Missing values are then filled from the water around them (three passes of
//! averaging the filled 8-neighbours, then the mean of the slice; rounded to f32 when the
//! file's values are all floats, so the grid is held as f32), so that the bicubic
//! stencil of a point in the water next to the coast reads no hole; a reading on land is
//! refused by the field server, never read as these fill values. A position is land when its
//! nearest node is, and outside the grid.

use super::{GridError, GridField};
use crate::land::LandMask;
use vbap_math::Vec3;

/// How far (in grid nodes, each way) [`LandMask::clearance`] looks for land.
pub const SEARCH_NODES: usize = 24;

impl GridField {
    pub(crate) fn node_index(&self, jx: usize, jy: usize, jz: usize, jt: usize) -> usize {
        let l = &self.layout;
        (l.first[0]
            + jx as isize * l.step[0]
            + l.first[1]
            + jy as isize * l.step[1]
            + l.first[2]
            + jz as isize * l.step[2]
            + l.first[3]
            + jt as isize * l.step[3]) as usize
    }

    /// The z index nearest the surface (0 in 2-D).
    pub(crate) fn surface_level(&self) -> usize {
        self.z.as_ref().map_or(0, |z| {
            (0..z.len())
                .min_by(|a, b| z.nodes[*a].abs().total_cmp(&z.nodes[*b].abs()))
                .unwrap_or(0)
        })
    }

    /// Whether horizontal node (jx, jy) is land.
    pub(crate) fn land_node(&self, jx: usize, jy: usize) -> bool {
        self.land[jy * self.x.len() + jx]
    }

    /// Whether position `p` is land (its nearest node is land, or it is outside the grid).
    pub fn is_land(&self, p: &Vec3) -> bool {
        if !(self.x.contains(p.x) && self.y.contains(p.y)) {
            return true;
        }
        self.land_node(self.x.nearest(p.x), self.y.nearest(p.y))
    }
}

/// Marks land, then fills every missing value.
pub(super) fn mark_and_fill(g: &mut GridField, land_above: Option<f64>) -> Result<(), GridError> {
    let (nx, ny) = (g.x.len(), g.y.len());
    let nz = g.z.as_ref().map_or(1, |z| z.len());
    let top = g.surface_level();
    g.land = vec![false; nx * ny];
    for jy in 0..ny {
        for jx in 0..nx {
            let v = g.data.get(g.node_index(jx, jy, top, 0));
            g.land[jy * nx + jx] = v.is_nan() || land_above.is_some_and(|a| v > a);
        }
    }
    if g.data.iter().all(|v| v.is_nan()) {
        return Err(GridError::new(
            std::path::Path::new(&g.file),
            &g.variable,
            "no data: every value is missing",
        ));
    }
    if !g.data.iter().any(|v| v.is_nan()) {
        return Ok(());
    }
    let global = mean(g.data.iter()).unwrap_or(0.0);
    // Floats in the file: fills rounded to floats too, so the grid is held as f32.
    let floats = g
        .data
        .iter()
        .all(|v| v.is_nan() || f64::from(v as f32) == v);
    let fill = Fill { global, floats };
    for jt in 0..g.times.len() {
        for jz in 0..nz {
            fill_slice(g, jz, jt, fill);
        }
    }
    Ok(())
}

/// The mean of the values that are not NaN, if any.
fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (s, n) = values
        .filter(|v| !v.is_nan())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| s / n as f64)
}

/// How holes are filled: `global` where a slice has no water; `floats`: round every filled
/// value to the nearest f32 (the file's values are all floats).
#[derive(Clone, Copy)]
struct Fill {
    global: f64,
    floats: bool,
}

impl Fill {
    fn round(self, v: f64) -> f64 {
        if self.floats {
            f64::from(v as f32)
        } else {
            v
        }
    }
}

fn fill_slice(g: &mut GridField, jz: usize, jt: usize, fill: Fill) {
    let (nx, ny) = (g.x.len(), g.y.len());
    let mut holes: Vec<(usize, usize)> = Vec::new();
    for jy in 0..ny {
        for jx in 0..nx {
            if g.data.get(g.node_index(jx, jy, jz, jt)).is_nan() {
                holes.push((jx, jy));
            }
        }
    }
    if holes.is_empty() {
        return;
    }
    for _ in 0..3 {
        let mut updates = Vec::new();
        for &(jx, jy) in &holes {
            let mut around = Vec::with_capacity(8);
            for dy in -1isize..=1 {
                for dx in -1isize..=1 {
                    let (x, y) = (jx as isize + dx, jy as isize + dy);
                    if (dx, dy) != (0, 0)
                        && x >= 0
                        && y >= 0
                        && (x as usize) < nx
                        && (y as usize) < ny
                    {
                        around.push(g.data.get(g.node_index(x as usize, y as usize, jz, jt)));
                    }
                }
            }
            if let Some(m) = mean(around.into_iter()) {
                updates.push((g.node_index(jx, jy, jz, jt), fill.round(m)));
            }
        }
        for (i, v) in &updates {
            g.data.build_mut()[*i] = *v;
        }
        holes.retain(|&(jx, jy)| g.data.get(g.node_index(jx, jy, jz, jt)).is_nan());
    }
    let rest = mean(
        (0..ny)
            .flat_map(|jy| (0..nx).map(move |jx| (jx, jy)))
            .map(|(jx, jy)| g.data.get(g.node_index(jx, jy, jz, jt))),
    );
    let rest = fill.round(rest.unwrap_or(fill.global));
    for (jx, jy) in holes {
        let i = g.node_index(jx, jy, jz, jt);
        g.data.build_mut()[i] = rest;
    }
}

impl LandMask for GridField {
    fn is_land(&self, p: &Vec3) -> bool {
        GridField::is_land(self, p)
    }

    /// The nearest land node (or the grid's edge) within [`SEARCH_NODES`] nodes of `p`.
    fn clearance(&self, p: &Vec3) -> Option<(f64, Vec3)> {
        let (nx, ny) = (self.x.len(), self.y.len());
        let (cx, cy) = (self.x.nearest(p.x), self.y.nearest(p.y));
        let mut best: Option<(f64, Vec3)> = None;
        let mut land_sum = Vec3::zeros();
        let mut land_n = 0.0;
        let mut consider = |d: f64, away: Vec3| {
            if best.is_none_or(|(b, _)| d < b) {
                best = Some((d, away));
            }
        };
        let (x0, x1) = self.x.range();
        let (y0, y1) = self.y.range();
        let reach =
            SEARCH_NODES as f64 * ((x1 - x0) / (nx - 1) as f64).min((y1 - y0) / (ny - 1) as f64);
        for (d, away) in [
            (p.x - x0, Vec3::x()),
            (x1 - p.x, -Vec3::x()),
            (p.y - y0, Vec3::y()),
            (y1 - p.y, -Vec3::y()),
        ] {
            if d <= reach {
                consider(d.max(0.0), away);
            }
        }
        let (jx0, jx1) = (
            cx.saturating_sub(SEARCH_NODES),
            (cx + SEARCH_NODES).min(nx - 1),
        );
        let (jy0, jy1) = (
            cy.saturating_sub(SEARCH_NODES),
            (cy + SEARCH_NODES).min(ny - 1),
        );
        for jy in jy0..=jy1 {
            for jx in jx0..=jx1 {
                if !self.land_node(jx, jy) {
                    continue;
                }
                let q = Vec3::new(self.x.nodes[jx], self.y.nodes[jy], p.z);
                let off = Vec3::new(p.x - q.x, p.y - q.y, 0.0);
                let d = off.norm();
                land_sum += q;
                land_n += 1.0;
                if d <= reach {
                    let away = if d > 0.0 { off / d } else { Vec3::zeros() };
                    consider(d, away);
                }
            }
        }
        // On a land node: away from the land around it.
        best.map(|(d, away)| {
            if away != Vec3::zeros() || land_n == 0.0 {
                return (d, away);
            }
            let off = Vec3::new(p.x, p.y, p.z) - land_sum / land_n;
            let off = Vec3::new(off.x, off.y, 0.0);
            let n = off.norm();
            (d, if n > 0.0 { off / n } else { Vec3::x() })
        })
    }
}
