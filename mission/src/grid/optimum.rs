//! The optimum of a grid field, found numerically: the best water node of the nearest time
//! slice (found once at load), refined by Newton steps on the interpolant at time t (a
//! gradient step where the Hessian has the wrong sign), each kept within the grid, in water,
//! and within one cell of the node it started from.

use super::GridField;
use crate::config::Goal;
use vbap_math::Vec3;

fn goal_index(goal: Goal) -> usize {
    match goal {
        Goal::Max => 0,
        Goal::Min => 1,
    }
}

impl GridField {
    fn at_node(&self, n: [usize; 3]) -> Vec3 {
        Vec3::new(
            self.x.nodes[n[0]],
            self.y.nodes[n[1]],
            self.z.as_ref().map_or(0.0, |z| z.nodes[n[2]]),
        )
    }

    /// The optimum (maximum for `Goal::Max`) of the interpolant at time `t` over the grid's
    /// water, or `None` when the grid has no water.
    pub fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        let (k, tau) = super::axis::linear(&self.times, t);
        let node = self.best.get(if tau > 0.5 { k + 1 } else { k })?[goal_index(goal)];
        let start = self.at_node(node);
        let sign = goal.sign();
        let cell = Vec3::new(
            cell_width(&self.x.nodes, node[0]),
            cell_width(&self.y.nodes, node[1]),
            self.z
                .as_ref()
                .map_or(0.0, |z| cell_width(&z.nodes, node[2])),
        );
        let dim = self.dim;
        let mut p = start;
        let mut best = sign * self.value(&p, t);
        for _ in 0..40 {
            let g = self.gradient(&p, t) * sign;
            let h = self.hessian(&p, t) * sign;
            let (g, h) = if dim == 2 {
                (Vec3::new(g.x, g.y, 0.0), block2(&h))
            } else {
                (g, h)
            };
            let newton = h
                .try_inverse()
                .map(|hi| -(hi * g))
                .filter(|s| s.dot(&g) > 0.0);
            let step = newton.unwrap_or_else(|| g.component_mul(&cell).component_mul(&cell) * 0.5);
            let mut moved = false;
            let mut s = step;
            for _ in 0..20 {
                let q = clamp_box(p + s, start - cell, start + cell);
                let v = sign * self.value(&q, t);
                if v > best && !self.is_land(&q) {
                    p = q;
                    best = v;
                    moved = true;
                    break;
                }
                s *= 0.5;
            }
            if !moved || s.norm() < 1e-9 * cell.norm() {
                break;
            }
        }
        Some(p)
    }
}

fn block2(h: &vbap_math::Mat3) -> vbap_math::Mat3 {
    let mut out = *h;
    for i in 0..3 {
        out[(2, i)] = 0.0;
        out[(i, 2)] = 0.0;
    }
    out[(2, 2)] = 1.0;
    out
}

fn cell_width(nodes: &[f64], j: usize) -> f64 {
    let n = nodes.len();
    if n < 2 {
        return 0.0;
    }
    let a = nodes[j.saturating_sub(1)];
    let b = nodes[(j + 1).min(n - 1)];
    (b - a) / ((j + 1).min(n - 1) - j.saturating_sub(1)) as f64
}

fn clamp_box(p: Vec3, lo: Vec3, hi: Vec3) -> Vec3 {
    Vec3::new(
        p.x.clamp(lo.x, hi.x),
        p.y.clamp(lo.y, hi.y),
        p.z.clamp(lo.z, hi.z),
    )
}

/// Finds, once, the best water node of every time slice and counts the strict local extrema
/// of the first slice (for the verdict: several maxima mean the formation may stop at a local
/// one).
pub(super) fn prepare(g: &mut GridField) {
    let (nx, ny) = (g.x.len(), g.y.len());
    let nz = g.z.as_ref().map_or(1, |z| z.len());
    g.best = (0..g.times.len())
        .map(|jt| {
            let mut hi = (f64::NEG_INFINITY, [0; 3]);
            let mut lo = (f64::INFINITY, [0; 3]);
            for jz in 0..nz {
                for jy in 0..ny {
                    for jx in 0..nx {
                        if g.land_node(jx, jy) {
                            continue;
                        }
                        let v = g.data.get(g.node_index(jx, jy, jz, jt));
                        if v > hi.0 {
                            hi = (v, [jx, jy, jz]);
                        }
                        if v < lo.0 {
                            lo = (v, [jx, jy, jz]);
                        }
                    }
                }
            }
            [hi.1, lo.1]
        })
        .collect();
    if g.land.iter().all(|l| *l) {
        g.best.clear();
    }
    g.extrema = count_extrema(g);
}

/// Strict local maxima and minima among the water nodes of the surface level at t = 0
/// (8-neighbours, interior nodes only).
fn count_extrema(g: &GridField) -> [usize; 2] {
    let (nx, ny) = (g.x.len(), g.y.len());
    let mut out = [0, 0];
    let top = g.surface_level();
    for jy in 1..ny.saturating_sub(1) {
        for jx in 1..nx.saturating_sub(1) {
            if g.land_node(jx, jy) {
                continue;
            }
            let v = g.data.get(g.node_index(jx, jy, top, 0));
            let (mut above, mut below) = (true, true);
            for (dx, dy) in [
                (-1, -1),
                (0, -1),
                (1, -1),
                (-1, 0),
                (1, 0),
                (-1, 1),
                (0, 1),
                (1, 1),
            ] {
                let (x, y) = ((jx as isize + dx) as usize, (jy as isize + dy) as usize);
                let w = g.data.get(g.node_index(x, y, top, 0));
                above &= v > w;
                below &= v < w;
            }
            out[0] += above as usize;
            out[1] += below as usize;
        }
    }
    out
}
