//! One axis of a rectilinear grid: its nodes (ascending), where each node's slope comes from,
//! and the interpolation stencil of a position ([`Stencil`]).

use vbap_math::gridmath::{hermite, quadratic_slope};

/// Fewest nodes an interpolated axis may have (the four-node stencil of the cubic).
pub const MIN_NODES: usize = 4;

/// The weights of the four nodes `start..start + 4` for the value and the first and second
/// derivatives of the C¹ cubic Hermite interpolant at one position (see
/// [`vbap_math::gridmath`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Stencil {
    /// First node of the stencil (ascending index).
    pub start: usize,
    /// Value weights.
    pub w: [f64; 4],
    /// First-derivative weights (per length unit).
    pub d1: [f64; 4],
    /// Second-derivative weights (per length unit²).
    pub d2: [f64; 4],
}

/// An axis: ascending nodes (length unit or seconds) and the slope rule of each node.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The nodes, strictly ascending.
    pub nodes: Vec<f64>,
    /// Node j's slope is c · f[first..first + 3] (the quadratic through three nodes).
    slopes: Vec<(usize, [f64; 3])>,
    /// (first node, 1 / spacing) when the nodes are evenly spaced (direct cell lookup).
    uniform: Option<(f64, f64)>,
}

impl Axis {
    /// An axis over `nodes` (strictly ascending, at least [`MIN_NODES`]: the caller checks).
    pub fn new(nodes: Vec<f64>) -> Axis {
        let n = nodes.len();
        let slopes = (0..n)
            .map(|j| {
                let first = j.saturating_sub(1).min(n.saturating_sub(3));
                let p = [nodes[first], nodes[first + 1], nodes[first + 2]];
                (first, quadratic_slope(p, nodes[j]))
            })
            .collect();
        let span = nodes[n - 1] - nodes[0];
        let step = span / (n - 1) as f64;
        let even = nodes
            .iter()
            .enumerate()
            .all(|(j, x)| (x - (nodes[0] + j as f64 * step)).abs() <= 1e-9 * span.abs());
        Axis {
            uniform: even.then_some((nodes[0], 1.0 / step)),
            nodes,
            slopes,
        }
    }

    /// Whether the nodes are evenly spaced (a cell is found without a search).
    pub fn is_even(&self) -> bool {
        self.uniform.is_some()
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the axis has no node (never, for a built grid).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// First and last node.
    pub fn range(&self) -> (f64, f64) {
        (self.nodes[0], self.nodes[self.nodes.len() - 1])
    }

    /// Whether `x` lies within the first and last node.
    pub fn contains(&self, x: f64) -> bool {
        let (lo, hi) = self.range();
        x >= lo && x <= hi
    }

    /// The cell i (nodes i, i + 1) holding `x`, clamped into the axis.
    pub fn cell(&self, x: f64) -> usize {
        let n = self.nodes.len();
        let i = match self.uniform {
            Some((x0, inv_dx)) => ((x - x0) * inv_dx).floor().max(0.0) as usize,
            None => self.nodes.partition_point(|v| *v <= x).saturating_sub(1),
        };
        i.min(n - 2)
    }

    /// The node nearest `x` (clamped).
    pub fn nearest(&self, x: f64) -> usize {
        let i = self.cell(x);
        if (x - self.nodes[i]).abs() <= (self.nodes[i + 1] - x).abs() {
            i
        } else {
            i + 1
        }
    }

    /// Cell i of `x`, its width h, the position s ∈ [0, 1] in it, the stencil's first node,
    /// and whether `x` lies within the axis.
    fn locate(&self, x: f64) -> (usize, f64, f64, usize, bool) {
        let (lo, hi) = self.range();
        let i = self.cell(x);
        let h = self.nodes[i + 1] - self.nodes[i];
        let s = ((x.clamp(lo, hi) - self.nodes[i]) / h).clamp(0.0, 1.0);
        let start = i.saturating_sub(1).min(self.nodes.len() - MIN_NODES);
        (i, h, s, start, x >= lo && x <= hi)
    }

    /// Node weights of the basis `b` = (end values' weights b₀, b₂; end slopes' weights b₁,
    /// b₃), the slopes expanded into their three nodes.
    fn spread(&self, i: usize, start: usize, b: [f64; 4]) -> [f64; 4] {
        let mut w = [0.0; 4];
        w[i - start] += b[0];
        w[i + 1 - start] += b[2];
        for (node, k) in [(i, 1), (i + 1, 3)] {
            let (first, c) = self.slopes[node];
            for (m, cm) in c.iter().enumerate() {
                w[first + m - start] += b[k] * cm;
            }
        }
        w
    }

    /// The value weights of `x` only (the hot path of a reading): (first node, weights).
    pub fn weights(&self, x: f64) -> (usize, [f64; 4]) {
        let (i, h, s, start, _) = self.locate(x);
        let (b, _, _) = hermite(s);
        (
            start,
            self.spread(i, start, [b[0], b[1] * h, b[2], b[3] * h]),
        )
    }

    /// The stencil of `x` (clamped into the axis: outside, the edge value, zero derivatives).
    pub fn stencil(&self, x: f64) -> Stencil {
        let (i, h, s, start, inside) = self.locate(x);
        let (b, db, d2b) = hermite(s);
        let (ih, ih2) = (1.0 / h, 1.0 / (h * h));
        let w = self.spread(i, start, [b[0], b[1] * h, b[2], b[3] * h]);
        if !inside {
            return Stencil {
                start,
                w,
                ..Stencil::default()
            };
        }
        Stencil {
            start,
            w,
            d1: self.spread(i, start, [db[0] * ih, db[1], db[2] * ih, db[3]]),
            d2: self.spread(
                i,
                start,
                [d2b[0] * ih2, d2b[1] * ih, d2b[2] * ih2, d2b[3] * ih],
            ),
        }
    }
}

/// Linear weights in time: (index k, weight of k + 1) with t between nodes k and k + 1,
/// clamped (before the first node: the first; after the last: the last).
pub fn linear(nodes: &[f64], t: f64) -> (usize, f64) {
    if nodes.len() < 2 || t <= nodes[0] {
        return (0, 0.0);
    }
    let n = nodes.len();
    if t >= nodes[n - 1] {
        return (n - 2, 1.0);
    }
    let k = nodes
        .partition_point(|v| *v <= t)
        .saturating_sub(1)
        .min(n - 2);
    (k, (t - nodes[k]) / (nodes[k + 1] - nodes[k]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stencil_reproduces_a_quadratic_and_its_derivatives_on_uneven_nodes() {
        let nodes = vec![-1.0, 0.0, 0.5, 1.7, 2.0, 3.5];
        let axis = Axis::new(nodes.clone());
        let f = |x: f64| 0.7 * x * x - 1.3 * x + 2.0;
        for k in 0..=69 {
            let x = -1.0 + k as f64 * 0.065;
            let st = axis.stencil(x);
            let v = |w: &[f64; 4]| (0..4).map(|m| w[m] * f(nodes[st.start + m])).sum::<f64>();
            assert!((v(&st.w) - f(x)).abs() < 1e-12, "value at {x}");
            assert!((v(&st.d1) - (1.4 * x - 1.3)).abs() < 1e-10, "slope at {x}");
            assert!((v(&st.d2) - 1.4).abs() < 1e-9, "curvature at {x}");
        }
    }

    #[test]
    fn cells_of_even_and_uneven_axes_agree() {
        let even = Axis::new((0..10).map(|j| j as f64 * 0.5).collect());
        let mut nodes: Vec<f64> = (0..10).map(|j| j as f64 * 0.5).collect();
        nodes[9] += 1e-3;
        let uneven = Axis::new(nodes);
        assert!(even.uniform.is_some() && uneven.uniform.is_none());
        for x in [-1.0, 0.0, 0.25, 0.5, 2.2, 4.5, 9.0] {
            assert_eq!(even.cell(x), uneven.cell(x), "{x}");
        }
        assert_eq!(linear(&[0.0, 10.0, 20.0], 15.0), (1, 0.5));
        assert_eq!(linear(&[0.0, 10.0], -5.0), (0, 0.0));
        assert_eq!(linear(&[0.0, 10.0], 50.0), (0, 1.0));
    }
}
