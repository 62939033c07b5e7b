//! Who a vehicle needs to hear of: the neighbours within reach of each vehicle (Sec. II:
//! "each vehicle … is influenced only by near neighbor vehicles, i.e., those within a ball
//! of radius `d1`, and nearby virtual leaders, i.e., those within a ball of radius `h1`").
//!
//! The coordinator tells each vehicle only about those, so what a vehicle's command
//! carries, and what the vehicle does with it, does not grow with the fleet.
//!
//! The reach is the cut-off plus margins ([`reach`], [`drift_margin`]): the vehicle
//! evaluates its law away from where the coordinator last knew it. It evaluates it a
//! little ahead (a glider at its braking point, at most half a spacing ahead,
//! `vehicle::VehicleModel::braking_point`), and it flies on a command until it hears
//! again, moving relative to the body meanwhile: a pair is listed when it is within the
//! cut-off plus half a spacing plus how far each of the two may move relative to the body
//! before its vehicle hears again. In a formation at rest in the body that is the paper's
//! ball and half a spacing; while the vehicles still move through the formation (a bunched
//! start, a redesign, a rejoin) it widens to what they can reach.
//!
//! [`Neighbourhoods::of`] sorts the points into a uniform grid of cells one reach wide and
//! looks only at the cells within each point's reach: O(N·K) for N points with K neighbours
//! each, against O(N²) for every pair (a point whose reach spans more cells than there are
//! points is compared with every point). The lists are exactly those of every pair
//! ([`Neighbourhoods::every_pair`], the reference of the tests), in ascending index.

use crate::Vec3;

/// Margin added to a cut-off, in spacings `d0` (see [`reach`]).
pub const REACH_MARGIN: f64 = 0.5;

/// Most neighbours a vehicle is told of: the nearest ones within reach when more are
/// (a fleet bunched at its start); ties by index.
pub const MAX_NEAR: usize = 32;

/// The reach of a pair potential with cut-off `cutoff` and spacing `d0` (length): the
/// cut-off plus [`REACH_MARGIN`] spacings.
pub fn reach(cutoff: f64, d0: f64) -> f64 {
    cutoff + REACH_MARGIN * d0
}

/// How far a vehicle may move relative to the body before it hears again (length): its
/// speed relative to the body `relative_speed` (length/s) times the age of what the
/// coordinator knows of it, `age` (s), and the longest it may fly on one command,
/// `horizon` (s; `vbap_mission::horizon::plan_horizon` of the links). 0 for anything not
/// finite or negative.
pub fn drift_margin(relative_speed: f64, age: f64, horizon: f64) -> f64 {
    let m = relative_speed * (age.max(0.0) + horizon.max(0.0));
    if m.is_finite() && m > 0.0 {
        m
    } else {
        0.0
    }
}

/// The neighbour lists of a set of points: for each point, the indices of the others
/// within reach, in ascending index, at most [`MAX_NEAR`] (the nearest).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Neighbourhoods {
    /// `starts[i]..starts[i + 1]` is point `i`'s range of `near`.
    pub starts: Vec<u32>,
    /// The lists, one after the other.
    pub near: Vec<u32>,
}

impl Neighbourhoods {
    /// Neighbour lists of `points` within `reach` (length; non-finite points and a
    /// non-finite or non-positive reach give empty lists), by a grid of cells `reach` wide.
    pub fn of(points: &[Vec3], reach: f64) -> Self {
        Self::with_margins(points, reach, &[])
    }

    /// Neighbour lists of `points` where `j` is in `i`'s list when
    /// `|x_i − x_j| ≤ reach + margins[i] + margins[j]` (margins: [`drift_margin`]; missing
    /// ones are 0).
    pub fn with_margins(points: &[Vec3], reach: f64, margins: &[f64]) -> Self {
        let n = points.len();
        let mut out = Self {
            starts: Vec::with_capacity(n + 1),
            near: Vec::new(),
        };
        out.starts.push(0);
        if !(reach.is_finite() && reach > 0.0) {
            out.starts.resize(n + 1, 0);
            return out;
        }
        let margin = |i: usize| margins.get(i).copied().filter(|m| *m > 0.0).unwrap_or(0.0);
        let widest = (0..n).map(margin).fold(0.0, f64::max);
        let cell_of = |p: &Vec3| -> Option<[i64; 3]> {
            let c = [p.x / reach, p.y / reach, p.z / reach];
            c.iter().all(|v| v.is_finite() && v.abs() < 1e15).then(|| {
                [
                    c[0].floor() as i64,
                    c[1].floor() as i64,
                    c[2].floor() as i64,
                ]
            })
        };
        // Every point with a cell, sorted by cell (then index): a cell's points are one
        // run of it, found by bisection. (The lists do not depend on the order in which
        // the cells are looked at: `push_list` sorts what was found.)
        let mut cells: Vec<([i64; 3], u32)> = Vec::with_capacity(n);
        let mut flat = true;
        for (i, p) in points.iter().enumerate() {
            if let Some(c) = cell_of(p) {
                flat &= c[2] == 0;
                cells.push((c, i as u32));
            }
        }
        cells.sort_unstable();
        // The points of the cells from `lo` to `hi` in the cells' (lexicographic) order.
        let between = |lo: [i64; 3], hi: [i64; 3]| {
            let from = cells.partition_point(|(c, _)| *c < lo);
            let to = from + cells[from..].partition_point(|(c, _)| *c <= hi);
            &cells[from..to]
        };
        let mut found: Vec<(f64, u32)> = Vec::new();
        let keep = |i: usize, j: u32, p: &Vec3, found: &mut Vec<(f64, u32)>| {
            let d = (points[j as usize] - p).norm();
            if j as usize != i && d <= reach + margin(i) + margin(j as usize) {
                found.push((d, j));
            }
        };
        for (i, p) in points.iter().enumerate() {
            found.clear();
            if let Some(c) = cell_of(p) {
                // Cells to look at on each side: the point's reach, its margin and the
                // widest margin of any other point.
                let span = ((reach + margin(i) + widest) / reach).ceil();
                let side = 2.0 * span + 1.0;
                let looked = if flat {
                    side * side
                } else {
                    side * side * side
                };
                if looked > n as f64 {
                    for j in 0..n as u32 {
                        keep(i, j, p, &mut found);
                    }
                } else {
                    // The cells within `s` of `c` on each axis: one run of the sorted
                    // cells per row of them (x and y fixed, z from −s to s; in a flat
                    // grid, where every z is 0, x fixed and y from −s to s).
                    let s = span as i64;
                    for dx in -s..=s {
                        let x = c[0] + dx;
                        if flat {
                            for &(_, j) in between([x, c[1] - s, 0], [x, c[1] + s, 0]) {
                                keep(i, j, p, &mut found);
                            }
                            continue;
                        }
                        for dy in -s..=s {
                            let y = c[1] + dy;
                            for &(_, j) in between([x, y, c[2] - s], [x, y, c[2] + s]) {
                                keep(i, j, p, &mut found);
                            }
                        }
                    }
                }
            }
            out.push_list(&mut found);
        }
        out
    }

    /// The same lists by testing every pair: O(N²), the reference [`Neighbourhoods::of`]
    /// and [`Neighbourhoods::with_margins`] are tested against.
    pub fn every_pair(points: &[Vec3], reach: f64, margins: &[f64]) -> Self {
        let margin = |i: usize| margins.get(i).copied().filter(|m| *m > 0.0).unwrap_or(0.0);
        let mut out = Self {
            starts: vec![0],
            near: Vec::new(),
        };
        let mut found = Vec::new();
        for (i, p) in points.iter().enumerate() {
            found.clear();
            for (j, q) in points.iter().enumerate() {
                let d = (q - p).norm();
                if j != i && d <= reach + margin(i) + margin(j) {
                    found.push((d, j as u32));
                }
            }
            out.push_list(&mut found);
        }
        out
    }

    /// Appends one point's list: the nearest [`MAX_NEAR`] of `found` (distance, index),
    /// ties by index, in ascending index.
    fn push_list(&mut self, found: &mut [(f64, u32)]) {
        if found.len() > MAX_NEAR {
            found.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        }
        let len = found.len().min(MAX_NEAR);
        let kept = &mut found[..len];
        kept.sort_unstable_by_key(|f| f.1);
        self.near.extend(kept.iter().map(|f| f.1));
        self.starts.push(self.near.len() as u32);
    }

    /// Point `i`'s neighbours, ascending (empty past the end).
    pub fn of_point(&self, i: usize) -> &[u32] {
        match (self.starts.get(i), self.starts.get(i + 1)) {
            (Some(&a), Some(&b)) => &self.near[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// The indices of `points` within `reach` (length) of `x`, ascending: the virtual leaders
/// a vehicle at `x` is told of (the leaders are few, at most a few hundred).
pub fn within(points: &[Vec3], x: &Vec3, reach: f64) -> Vec<u32> {
    points
        .iter()
        .enumerate()
        .filter(|(_, p)| (*p - x).norm() <= reach)
        .map(|(i, _)| i as u32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Random points in 2-D and 3-D, bunched and spread, with duplicates: the grid gives
    /// exactly the lists of every pair.
    #[test]
    fn the_grid_finds_exactly_the_pairs_within_reach() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for case in 0..40 {
            let n = rng.random_range(0..300);
            let spread = [0.5, 3.0, 20.0, 200.0][case % 4];
            let dims = if case % 2 == 0 { 2 } else { 3 };
            let mut points: Vec<Vec3> = (0..n)
                .map(|_| {
                    let z = if dims == 3 {
                        rng.random_range(-spread..spread)
                    } else {
                        0.0
                    };
                    Vec3::new(
                        rng.random_range(-spread..spread),
                        rng.random_range(-spread..spread),
                        z,
                    )
                })
                .collect();
            if n > 3 {
                points[1] = points[0];
            }
            let reach = rng.random_range(0.3..4.0);
            assert_eq!(
                Neighbourhoods::of(&points, reach),
                Neighbourhoods::every_pair(&points, reach, &[]),
                "case {case}: n {n}, spread {spread}, reach {reach}"
            );
            // Margins: most points at rest in the body, a few moving far.
            let margins: Vec<f64> = (0..n)
                .map(|_| match rng.random_range(0..10) {
                    0 => rng.random_range(0.0..3.0 * reach),
                    1 => rng.random_range(0.0..40.0 * reach),
                    _ => 0.0,
                })
                .collect();
            assert_eq!(
                Neighbourhoods::with_margins(&points, reach, &margins),
                Neighbourhoods::every_pair(&points, reach, &margins),
                "case {case} with margins"
            );
        }
    }

    /// A bunched fleet: each point hears of its nearest [`MAX_NEAR`], ascending.
    #[test]
    fn a_bunched_fleet_is_cut_to_the_nearest() {
        let points: Vec<Vec3> = (0..100)
            .map(|i| Vec3::new(i as f64 * 0.01, 0.0, 0.0))
            .collect();
        let hoods = Neighbourhoods::of(&points, 10.0);
        let first = hoods.of_point(0);
        assert_eq!(first, &(1..=MAX_NEAR as u32).collect::<Vec<_>>()[..]);
        let middle = hoods.of_point(50);
        assert_eq!(middle.len(), MAX_NEAR);
        assert!(middle.windows(2).all(|w| w[0] < w[1]));
        assert!(middle
            .iter()
            .all(|&j| (j as i64 - 50).abs() <= 16 && j != 50));
    }

    /// A hexagonal lattice of spacing 1 with the reach of d1 = 1.6: each inner point
    /// hears of its 6 + 6 + 6 nearest (distances 1, √3 and 2), however large the lattice.
    #[test]
    fn a_lattice_point_hears_of_the_same_few_at_any_size() {
        for side in [5, 12, 40] {
            let mut points = Vec::new();
            for a in 0..side {
                for b in 0..side {
                    points.push(Vec3::new(
                        a as f64 + 0.5 * b as f64,
                        b as f64 * 0.75f64.sqrt(),
                        0.0,
                    ));
                }
            }
            let hoods = Neighbourhoods::of(&points, reach(1.6, 1.0));
            let inner = (side / 2) * side + side / 2;
            assert_eq!(hoods.of_point(inner).len(), 18, "side {side}");
        }
    }

    /// A row spaced 1, reach 1.5: a point moving relative to the body hears of those it can
    /// reach before it hears again, and they of it.
    #[test]
    fn a_moving_point_hears_of_what_it_can_reach() {
        let points: Vec<Vec3> = (0..10).map(|i| Vec3::new(i as f64, 0.0, 0.0)).collect();
        let mut margins = vec![0.0; 10];
        margins[0] = drift_margin(0.5, 1.0, 3.0);
        assert_eq!(margins[0], 2.0);
        let hoods = Neighbourhoods::with_margins(&points, 1.5, &margins);
        assert_eq!(hoods.of_point(0), &[1, 2, 3]);
        assert_eq!(hoods.of_point(3), &[0, 2, 4]);
        assert_eq!(hoods.of_point(5), &[4, 6]);
        for bad in [f64::NAN, f64::INFINITY, -1.0] {
            assert_eq!(drift_margin(bad, 1.0, 1.0), 0.0);
        }
    }

    #[test]
    fn no_reach_no_neighbours() {
        let points = vec![Vec3::zeros(), Vec3::zeros()];
        for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let h = Neighbourhoods::of(&points, r);
            assert!(h.of_point(0).is_empty() && h.of_point(1).is_empty());
        }
        assert!(Neighbourhoods::of(&[], 1.0).of_point(0).is_empty());
        assert_eq!(within(&points, &Vec3::new(1.0, 0.0, 0.0), 1.0), vec![0, 1]);
    }
}
