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
    /// (first node, spacing) when the nodes are evenly spaced (direct cell lookup).
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
            uniform: even.then_some((nodes[0], step)),
            nodes,
            slopes,
        }
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
            Some((x0, dx)) => ((x - x0) / dx).floor().max(0.0) as usize,
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

    /// The stencil of `x` (clamped into the axis: outside, the edge value, zero derivatives).
    pub fn stencil(&self, x: f64) -> Stencil {
        let n = self.nodes.len();
        let (lo, hi) = self.range();
        let inside = x >= lo && x <= hi;
        let i = self.cell(x);
        let h = self.nodes[i + 1] - self.nodes[i];
        let s = ((x.clamp(lo, hi) - self.nodes[i]) / h).clamp(0.0, 1.0);
        let (b, db, d2b) = hermite(s);
        let start = i.saturating_sub(1).min(n - MIN_NODES);
        let mut st = Stencil {
            start,
            ..Stencil::default()
        };
        let mut add = |node: usize, bv: f64, bd: f64, bdd: f64| {
            st.w[node - start] += bv;
            st.d1[node - start] += bd / h;
            st.d2[node - start] += bdd / (h * h);
        };
        add(i, b[0], db[0], d2b[0]);
        add(i + 1, b[2], db[2], d2b[2]);
        for (node, k) in [(i, 1), (i + 1, 3)] {
            let (first, c) = self.slopes[node];
            for (m, cm) in c.iter().enumerate() {
                add(first + m, b[k] * h * cm, db[k] * h * cm, d2b[k] * h * cm);
            }
        }
        if !inside {
            st.d1 = [0.0; 4];
            st.d2 = [0.0; 4];
        }
        st
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
