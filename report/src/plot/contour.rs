//! Contour lines of a sampled field by marching squares: the crossing segments of each grid
//! cell, then joined into polylines through the grid edges they share.

use super::field::Grid;

/// Marks an empty slot of [`join_segments`]'s edge table.
const NONE: usize = usize::MAX;

/// Contour lines of the grid at `level` by marching squares over the sample points (cells with
/// a non-finite corner are skipped), joined into polylines; a closed loop repeats its first
/// point at the end.
pub(super) fn contour_lines(g: &Grid, level: f64) -> Vec<Vec<(f64, f64)>> {
    if g.nx < 2 || g.ny < 2 {
        return Vec::new();
    }
    let edges = Edges { nx: g.nx, ny: g.ny };
    let crossings = crossing_segments(g, &edges, level);
    join_segments(&crossings.segments, edges.count())
        .into_iter()
        .map(|chain| {
            chain
                .into_iter()
                .filter_map(|e| crossings.point_of_edge[e])
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Numbering of the edges between neighbouring sample points of an nx × ny grid: the
/// horizontal edges first (row by row), then the vertical ones.
struct Edges {
    nx: usize,
    ny: usize,
}

impl Edges {
    /// Number of horizontal edges.
    fn n_h(&self) -> usize {
        (self.nx - 1) * self.ny
    }
    /// Number of edges.
    fn count(&self) -> usize {
        self.n_h() + self.nx * (self.ny - 1)
    }
    /// The edge from sample (i, j) to (i + 1, j).
    fn h(&self, i: usize, j: usize) -> usize {
        j * (self.nx - 1) + i
    }
    /// The edge from sample (i, j) to (i, j + 1).
    fn v(&self, i: usize, j: usize) -> usize {
        self.n_h() + j * self.nx + i
    }
}

/// Where the field crosses a level in a grid.
struct Crossings {
    /// The crossing point on each edge crossed (length unit), by edge number.
    point_of_edge: Vec<Option<(f64, f64)>>,
    /// The crossing segments of every cell, as pairs of edge numbers, cell by cell.
    segments: Vec<(usize, usize)>,
}

/// The segments where the field crosses `level` in every cell, and the crossing point on each
/// edge crossed (linear interpolation between its two samples).
fn crossing_segments(g: &Grid, edges: &Edges, level: f64) -> Crossings {
    let interp = |(i0, j0): (usize, usize), (i1, j1): (usize, usize)| {
        let (a, b) = (g.at(i0, j0), g.at(i1, j1));
        let t = ((level - a) / (b - a)).clamp(0.0, 1.0);
        let (x0, y0, x1, y1) = (g.xc(i0), g.yc(j0), g.xc(i1), g.yc(j1));
        (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
    };
    let mut point_of_edge: Vec<Option<(f64, f64)>> = vec![None; edges.count()];
    let mut segments: Vec<(usize, usize)> = Vec::new();
    for j in 0..g.ny - 1 {
        for i in 0..g.nx - 1 {
            let c = [
                g.at(i, j),
                g.at(i + 1, j),
                g.at(i + 1, j + 1),
                g.at(i, j + 1),
            ];
            if c.iter().any(|v| !v.is_finite()) {
                continue;
            }
            // Edges: 0 bottom, 1 right, 2 top, 3 left.
            let ids = [
                edges.h(i, j),
                edges.v(i + 1, j),
                edges.h(i, j + 1),
                edges.v(i, j),
            ];
            let ends = [
                ((i, j), (i + 1, j)),
                ((i + 1, j), (i + 1, j + 1)),
                ((i, j + 1), (i + 1, j + 1)),
                ((i, j), (i, j + 1)),
            ];
            for &(a, b) in cell_segments(&c, level) {
                for e in [a, b] {
                    if point_of_edge[ids[e]].is_none() {
                        point_of_edge[ids[e]] = Some(interp(ends[e].0, ends[e].1));
                    }
                }
                segments.push((ids[a], ids[b]));
            }
        }
    }
    Crossings {
        point_of_edge,
        segments,
    }
}

/// The crossing segments of one cell with corner values `c` (bottom left, bottom right, top
/// right, top left), as pairs of its edges (0 bottom, 1 right, 2 top, 3 left). A saddle
/// (two opposite corners high) is resolved by the mean of the corners.
fn cell_segments(c: &[f64; 4], level: f64) -> &'static [(usize, usize)] {
    let case = c
        .iter()
        .enumerate()
        .fold(0usize, |acc, (k, &v)| acc | (usize::from(v >= level) << k));
    if case == 0 || case == 15 {
        return &[];
    }
    let centre_high = 0.25 * c.iter().sum::<f64>() >= level;
    match case {
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
    }
}

/// Joins `segments` (pairs of edge numbers below `n_edges`) into chains of edges: each chain
/// starts from the first segment not yet used and is walked both ways through the edges it
/// shares with other segments.
fn join_segments(segments: &[(usize, usize)], n_edges: usize) -> Vec<Vec<usize>> {
    // Each edge touches at most two segments (the two cells beside it).
    let mut at_edge: Vec<[usize; 2]> = vec![[NONE; 2]; n_edges];
    for (s, &(a, b)) in segments.iter().enumerate() {
        for e in [a, b] {
            let slot = &mut at_edge[e];
            if slot[0] == NONE {
                slot[0] = s;
            } else {
                slot[1] = s;
            }
        }
    }
    let mut used = vec![false; segments.len()];
    let mut chains = Vec::new();
    for s0 in 0..segments.len() {
        if used[s0] {
            continue;
        }
        used[s0] = true;
        let (a0, b0) = segments[s0];
        let forward = walk(segments, &at_edge, b0, &mut used);
        let backward = walk(segments, &at_edge, a0, &mut used);
        chains.push(
            backward
                .into_iter()
                .rev()
                .chain([a0, b0])
                .chain(forward)
                .collect(),
        );
    }
    chains
}

/// The edges reached from edge `from` through unused segments, one after the other (marking
/// them used), until no unused segment continues the chain.
fn walk(
    segments: &[(usize, usize)],
    at_edge: &[[usize; 2]],
    from: usize,
    used: &mut [bool],
) -> Vec<usize> {
    let mut chain = Vec::new();
    let mut edge = from;
    loop {
        let next = at_edge[edge]
            .iter()
            .copied()
            .find(|&s| s != NONE && !used[s]);
        let Some(s) = next else { break };
        used[s] = true;
        let (a, b) = segments[s];
        edge = if a == edge { b } else { a };
        chain.push(edge);
    }
    chain
}
