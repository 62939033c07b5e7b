//! The optimal assignment of vehicles to the slots of a formation design (beyond the
//! paper, which never reassigns: its vehicles are anonymous to the potentials of (II.1),
//! but a redesign must say which slot each is meant to take, and the pose of the new
//! design is fitted to that correspondence, `procrustes`).
//!
//! The linear sum assignment problem `min_π Σ_i c(i, π(i))` over injective maps `π` from
//! rows to columns (rows ≤ columns) is solved by the Hungarian (Kuhn–Munkres) algorithm of
//! the `pathfinding` crate, `O(n² m)`. That solver works on integers: the costs are
//! quantised to `2⁴⁰` levels of the largest cost, so the assignment found is optimal for
//! the real costs to within `rows · c_max · 2⁻⁴⁰` (far below any distance that matters).

use pathfinding::kuhn_munkres::kuhn_munkres_min;
use pathfinding::matrix::Matrix;

use super::Vec3;

/// Quantisation levels of the largest cost (see the module docs).
const LEVELS: f64 = (1u64 << 40) as f64;

/// The assignment `π` (`π[i]` the column of row `i`, all distinct) minimising
/// `Σ_i cost[i][π(i)]`, for a rectangular cost matrix given by rows (every row as long,
/// `rows ≤ columns`, every cost finite and ≥ 0). `None` when the matrix is not such.
/// No rows: an empty assignment.
pub fn assign_min_cost(cost: &[Vec<f64>]) -> Option<Vec<usize>> {
    let rows = cost.len();
    if rows == 0 {
        return Some(Vec::new());
    }
    let cols = cost[0].len();
    if rows > cols
        || cost
            .iter()
            .any(|r| r.len() != cols || r.iter().any(|c| !c.is_finite() || *c < 0.0))
    {
        return None;
    }
    let max = cost.iter().flatten().fold(0.0_f64, |m, c| m.max(*c));
    let unit = if max > 0.0 { LEVELS / max } else { 0.0 };
    let weights = Matrix::from_rows(cost.iter().map(|r| {
        r.iter()
            .map(|c| (c * unit).round() as i64)
            .collect::<Vec<_>>()
    }))
    .ok()?;
    let (_, assignment) = kuhn_munkres_min(&weights);
    Some(assignment)
}

/// The assignment of `points` to `slots` (length unit; `points.len() ≤ slots.len()`)
/// minimising the sum of squared distances `Σ_i |x_i − p_π(i)|²`: `π[i]` is the slot of
/// point `i`. `None` with more points than slots or a non-finite coordinate.
pub fn assign_nearest(points: &[Vec3], slots: &[Vec3]) -> Option<Vec<usize>> {
    let cost: Vec<Vec<f64>> = points
        .iter()
        .map(|x| slots.iter().map(|p| (x - p).norm_squared()).collect())
        .collect();
    if points.is_empty() {
        return Some(Vec::new());
    }
    assign_min_cost(&cost)
}

/// `Σ_i |x_i − p_π(i)|²` of an assignment `pi` of `points` to `slots`, length².
///
/// # Panics
/// If `pi` is shorter than `points` or names a slot that does not exist.
pub fn assignment_cost(points: &[Vec3], slots: &[Vec3], pi: &[usize]) -> f64 {
    points
        .iter()
        .zip(pi)
        .map(|(x, &m)| (x - slots[m]).norm_squared())
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{keyed, Stream};
    use rand::Rng;

    /// Every injective map of `rows` rows into `cols` columns, by brute force.
    fn all_maps(rows: usize, cols: usize) -> Vec<Vec<usize>> {
        let mut out = Vec::new();
        let mut cur = Vec::new();
        fn go(rows: usize, cols: usize, cur: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
            if cur.len() == rows {
                out.push(cur.clone());
                return;
            }
            for c in 0..cols {
                if !cur.contains(&c) {
                    cur.push(c);
                    go(rows, cols, cur, out);
                    cur.pop();
                }
            }
        }
        go(rows, cols, &mut cur, &mut out);
        out
    }

    #[test]
    fn the_assignment_is_optimal_against_brute_force() {
        let mut rng = keyed(7, Stream::Test, 0, 0);
        for trial in 0..300 {
            let cols = 1 + trial % 7;
            let rows = 1 + (trial / 7) % cols;
            let points: Vec<Vec3> = (0..rows)
                .map(|_| {
                    Vec3::new(
                        rng.random_range(-3.0..3.0),
                        rng.random_range(-3.0..3.0),
                        0.0,
                    )
                })
                .collect();
            let slots: Vec<Vec3> = (0..cols)
                .map(|_| {
                    Vec3::new(
                        rng.random_range(-3.0..3.0),
                        rng.random_range(-3.0..3.0),
                        rng.random_range(-1.0..1.0),
                    )
                })
                .collect();
            let pi = assign_nearest(&points, &slots).unwrap();
            assert_eq!(pi.len(), rows);
            let mut seen = pi.clone();
            seen.sort_unstable();
            seen.dedup();
            assert_eq!(seen.len(), rows, "distinct slots: {pi:?}");
            let best = all_maps(rows, cols)
                .iter()
                .map(|m| assignment_cost(&points, &slots, m))
                .fold(f64::INFINITY, f64::min);
            let got = assignment_cost(&points, &slots, &pi);
            assert!(
                got <= best * (1.0 + 1e-9) + 1e-12,
                "trial {trial}: {got} > {best}"
            );
        }
    }

    #[test]
    fn a_greedy_choice_is_not_what_it_makes() {
        // Greedy (nearest pair first) puts point 0 on slot 0 and sends point 1 to slot 2
        // (cost 0 + 9 = 9); the optimum swaps them (1 + 1 = 2).
        let points = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0)];
        let slots = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
        ];
        let pi = assign_nearest(&points, &slots).unwrap();
        assert_eq!(pi, vec![1, 0]);
        assert_eq!(assignment_cost(&points, &slots, &pi), 2.0);
    }

    #[test]
    fn bad_matrices_are_refused() {
        assert_eq!(assign_min_cost(&[]), Some(vec![]));
        assert_eq!(assign_min_cost(&[vec![1.0], vec![2.0]]), None);
        assert_eq!(assign_min_cost(&[vec![1.0, 2.0], vec![2.0]]), None);
        assert_eq!(assign_min_cost(&[vec![f64::NAN, 2.0]]), None);
        assert_eq!(assign_min_cost(&[vec![-1.0, 2.0]]), None);
        assert_eq!(assign_min_cost(&[vec![0.0, 0.0]]).map(|p| p.len()), Some(1));
        let x = [Vec3::new(f64::INFINITY, 0.0, 0.0)];
        assert_eq!(assign_nearest(&x, &[Vec3::zeros()]), None);
    }
}
