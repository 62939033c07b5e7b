//! One axis of a rectilinear grid: its nodes (ascending), where each node's slope comes from,
//! and the interpolation stencil of a position ([`Stencil`]).

use vbap_math::gridmath::{quadratic_slope, HERMITE_COEFFS};

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

/// The interpolant on one cell as polynomials in the cell's coordinate s ∈ [0, 1]: the weight
/// of stencil node `start + m` is Σₖ `c[m][k]` sᵏ (precomputed at load, so that a reading
/// evaluates four cubics instead of rebuilding the Hermite basis and spreading the node
/// slopes into it).
#[derive(Clone, Copy, Debug, PartialEq)]
struct CellPoly {
    /// First node of the stencil.
    start: usize,
    /// `c[m][k]`: coefficient of sᵏ in the weight of node `start + m`.
    c: [[f64; 4]; 4],
    /// 1 / cell width.
    inv_h: f64,
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
    /// The weight polynomials of each cell (n − 1 cells; 136 bytes each).
    cells: Vec<CellPoly>,
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
        let mut axis = Axis {
            uniform: even.then_some((nodes[0], 1.0 / step)),
            nodes,
            slopes,
            cells: Vec::new(),
        };
        axis.cells = (0..n - 1).map(|i| axis.cell_poly(i)).collect();
        axis
    }

    /// The weight polynomials of cell i: each power of s of the basis, spread into nodes.
    fn cell_poly(&self, i: usize) -> CellPoly {
        let h = self.nodes[i + 1] - self.nodes[i];
        let start = i.saturating_sub(1).min(self.nodes.len() - MIN_NODES);
        let mut c = [[0.0; 4]; 4];
        for k in 0..4 {
            let b = HERMITE_COEFFS.map(|p| p[k]);
            let w = self.spread(i, start, [b[0], b[1] * h, b[2], b[3] * h]);
            for m in 0..4 {
                c[m][k] = w[m];
            }
        }
        CellPoly {
            start,
            c,
            inv_h: 1.0 / h,
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
            // `as usize` truncates: floor for the non-negative (NaN: 0).
            Some((x0, inv_dx)) => ((x - x0) * inv_dx).max(0.0) as usize,
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

    /// The cell of `x`, the position s ∈ [0, 1] in it, and whether `x` lies within the axis.
    fn locate(&self, x: f64) -> (&CellPoly, f64, bool) {
        let (lo, hi) = self.range();
        let i = self.cell(x);
        let cell = &self.cells[i];
        let s = ((x.clamp(lo, hi) - self.nodes[i]) * cell.inv_h).clamp(0.0, 1.0);
        (cell, s, x >= lo && x <= hi)
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
    #[inline]
    pub fn weights(&self, x: f64) -> (usize, [f64; 4]) {
        let (cell, s, _) = self.locate(x);
        (
            cell.start,
            cell.c.map(|c| ((c[3] * s + c[2]) * s + c[1]) * s + c[0]),
        )
    }

    /// The stencil of `x` (clamped into the axis: outside, the edge value, zero derivatives).
    pub fn stencil(&self, x: f64) -> Stencil {
        let (cell, s, inside) = self.locate(x);
        let w = cell.c.map(|c| ((c[3] * s + c[2]) * s + c[1]) * s + c[0]);
        if !inside {
            return Stencil {
                start: cell.start,
                w,
                ..Stencil::default()
            };
        }
        let ih = cell.inv_h;
        Stencil {
            start: cell.start,
            w,
            d1: cell
                .c
                .map(|c| ((3.0 * c[3] * s + 2.0 * c[2]) * s + c[1]) * ih),
            d2: cell.c.map(|c| (6.0 * c[3] * s + 2.0 * c[2]) * ih * ih),
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

    /// The stencil from the cell polynomials equals the Hermite basis spread at the reading
    /// (how it was computed before the polynomials were precomputed) within 1e-12.
    #[test]
    fn cell_polynomials_equal_the_basis_spread_at_the_reading() {
        use vbap_math::gridmath::hermite;
        let axis = Axis::new(vec![-3.0, -1.0, 0.0, 0.5, 1.7, 2.0, 3.5, 7.0]);
        for k in 0..=500 {
            let x = -3.0 + 10.0 * f64::from(k) / 500.0;
            let i = axis.cell(x);
            let h = axis.nodes[i + 1] - axis.nodes[i];
            let s = ((x - axis.nodes[i]) / h).clamp(0.0, 1.0);
            let start = i.saturating_sub(1).min(axis.len() - MIN_NODES);
            let (b, db, d2b) = hermite(s);
            let w = axis.spread(i, start, [b[0], b[1] * h, b[2], b[3] * h]);
            let d1 = axis.spread(i, start, [db[0] / h, db[1], db[2] / h, db[3]]);
            let d2 = axis.spread(
                i,
                start,
                [d2b[0] / h / h, d2b[1] / h, d2b[2] / h / h, d2b[3] / h],
            );
            let st = axis.stencil(x);
            assert_eq!(st.start, start);
            for m in 0..4 {
                assert!((st.w[m] - w[m]).abs() <= 1e-12, "w at {x}");
                assert!((st.d1[m] - d1[m]).abs() <= 1e-12, "d1 at {x}");
                assert!((st.d2[m] - d2[m]).abs() <= 1e-12, "d2 at {x}");
                assert_eq!(axis.weights(x).1[m], st.w[m]);
            }
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
