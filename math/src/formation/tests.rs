//! Tests of the formation designer.

use super::*;
use crate::control::{control_law, integrate};
use crate::rng::{keyed, Stream};
use approx::assert_relative_eq;
use rand::Rng;

/// The greedy order as first written, recounting each candidate against the whole
/// prefix (O(n³)): [`dense_order`] must pick exactly the same slots.
fn dense_order_recounted(slots: &[Vec3]) -> Vec<Vec3> {
    let n = slots.len();
    let d0 = closest_pair(slots).2;
    let adjacent = |i: usize, j: usize| (slots[i] - slots[j]).norm() <= d0 * (1.0 + 1e-6);
    let mut order = vec![0usize];
    let mut taken = vec![false; n];
    taken[0] = true;
    while order.len() < n {
        let mut best: Option<(usize, usize)> = None;
        for c in (0..n).filter(|&c| !taken[c]) {
            let score = order.iter().filter(|&&o| adjacent(o, c)).count();
            if best.is_none_or(|(_, s)| score > s) {
                best = Some((c, score));
            }
        }
        let (c, _) = best.unwrap();
        taken[c] = true;
        order.push(c);
    }
    order.into_iter().map(|i| slots[i]).collect()
}

#[test]
fn a_design_with_holes_keeps_the_vehicles_left_at_rest_with_v_zero() {
    for dim in [2, 3] {
        for n in 3..=16 {
            let full = design_regular(n, dim, 1.5, 60.0, 60.0).unwrap();
            for hole in [0, n / 2, n - 1] {
                let holed = full.without_slots(&[hole]);
                assert_eq!(holed.n(), n - 1);
                assert_eq!(holed.leaders, full.leaders);
                let e = potential_energy(&holed.slots, &holed.leaders, &holed.inter, &holed.leader);
                assert_eq!(e, holed.v_eq, "V = 0 with every vehicle in its slot");
                for (i, x) in holed.slots.iter().enumerate() {
                    let others: Vec<Vec3> = holed
                        .slots
                        .iter()
                        .enumerate()
                        .filter(|(j, _)| *j != i)
                        .map(|(_, p)| *p)
                        .collect();
                    let u = control_law(
                        x,
                        &Vec3::zeros(),
                        &others,
                        &holed.leaders,
                        &holed.inter,
                        &holed.leader,
                        5.0,
                    );
                    assert!(
                        u.norm() < 1e-6,
                        "n {n} dim {dim} hole {hole} slot {i}: u {u}"
                    );
                }
            }
        }
    }
}

#[test]
fn dense_order_is_the_recounted_greedy_order() {
    let mut shapes = vec![
        platonic(8),
        platonic(20),
        sphere_points(9),
        sphere_points(40),
    ];
    shapes.extend([3, 5, 16, 33].map(polygon));
    // A grid listed out of order: many ties, so the lowest-index rule decides.
    shapes.push(
        (0..30)
            .map(|i| (i * 7) % 30)
            .map(|i| Vec3::new((i % 6) as f64, (i / 6) as f64, 0.0))
            .collect(),
    );
    let mut reordered = 0;
    for slots in shapes {
        let fast = dense_order(slots.clone());
        assert_eq!(fast, dense_order_recounted(&slots), "{} slots", slots.len());
        reordered += usize::from(fast != slots);
    }
    assert!(reordered >= 2, "the shapes exercise the reordering");
}

/// Slots perturbed by up to `amp` per coordinate (z kept 0 in 2-D), keyed RNG.
fn perturbed(design: &FormationDesign, amp: f64, seed: u64) -> Vec<Vec3> {
    design
        .slots
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut rng = keyed(seed, Stream::Test, i as u64, 0);
            let mut d = Vec3::new(
                rng.random_range(-amp..amp),
                rng.random_range(-amp..amp),
                rng.random_range(-amp..amp),
            );
            if design.dim == 2 {
                d.z = 0.0;
            }
            p + d
        })
        .collect()
}

/// Simulates (II.1) with the design's leaders (body at rest, k = 1) until the
/// vehicles are at rest or `t_max` seconds. Returns the final positions.
fn relax(design: &FormationDesign, start: Vec<Vec3>, damping: f64, t_max: f64) -> Vec<Vec3> {
    let dt = 0.02;
    let mut x = start;
    let mut v = vec![Vec3::zeros(); x.len()];
    let steps = (t_max / dt) as usize;
    for step in 0..steps {
        let mut max_u: f64 = 0.0;
        // The whole swarm as neighbours: the control law skips the vehicle itself
        // (distance exactly 0).
        let u: Vec<Vec3> = (0..x.len())
            .map(|i| {
                control_law(
                    &x[i],
                    &v[i],
                    &x,
                    &design.leaders,
                    &design.inter,
                    &design.leader,
                    damping,
                )
            })
            .collect();
        for i in 0..x.len() {
            max_u = max_u.max(u[i].norm());
            (x[i], v[i]) = integrate(&x[i], &v[i], &u[i], dt);
        }
        let max_v = v.iter().map(|w| w.norm()).fold(0.0, f64::max);
        if step > 100 && max_u < 1e-8 && max_v < 1e-8 {
            break;
        }
    }
    x
}

fn forces_at_slots(design: &FormationDesign) -> f64 {
    let x = &design.slots;
    (0..x.len())
        .map(|i| {
            let others: Vec<Vec3> = x
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, p)| *p)
                .collect();
            control_law(
                &x[i],
                &Vec3::zeros(),
                &others,
                &design.leaders,
                &design.inter,
                &design.leader,
                1.0,
            )
            .norm()
        })
        .fold(0.0, f64::max)
}

#[test]
fn errors_are_values() {
    assert_eq!(
        design_regular(0, 2, 1.0, 1.0, 1.0),
        Err(FormationError::NoVehicles)
    );
    assert_eq!(
        design_regular(3, 4, 1.0, 1.0, 1.0),
        Err(FormationError::BadDimension(4))
    );
    assert!(matches!(
        design_regular(3, 2, -1.0, 1.0, 1.0),
        Err(FormationError::BadParameter { .. })
    ));
    assert!(matches!(
        design_regular(3, 2, 1.0, f64::NAN, 1.0),
        Err(FormationError::BadParameter { .. })
    ));
    assert_eq!(
        design_for_shape(&[], 2, 1.0, 1.0),
        Err(FormationError::NoVehicles)
    );
    assert_eq!(
        design_for_shape(&[Vec3::zeros()], 2, 1.0, 1.0),
        Err(FormationError::DegenerateShape)
    );
    let p = Vec3::new(1.0, 0.0, 0.0);
    assert_eq!(
        design_for_shape(&[p, p], 2, 1.0, 1.0),
        Err(FormationError::CoincidentSlots { i: 0, j: 1 })
    );
    assert!(matches!(
        design_for_shape(&[Vec3::new(0.0, 0.0, 1.0)], 2, 1.0, 1.0),
        Err(FormationError::NotPlanar { .. })
    ));
    assert!(matches!(
        design_for_shape(&[Vec3::new(0.0, f64::NAN, 0.0)], 3, 1.0, 1.0),
        Err(FormationError::NonFiniteSlot(0))
    ));
}

#[test]
fn polygon_parameters() {
    for n in 3..=12usize {
        let d = design_regular(n, 2, 1.5, 1.0, 2.0).unwrap();
        let side = 2.0 * 1.5 * (std::f64::consts::PI / n as f64).sin();
        assert_relative_eq!(d.neighbour_spacing(), side, max_relative = 1e-12);
        assert_eq!(d.n(), n);
        assert_eq!(d.leaders, vec![Vec3::zeros()]);
        assert_eq!((d.leader.d0, d.leader.alpha), (1.5, 2.0));
        if n == 3 {
            assert_relative_eq!(d.inter.d1, 1.5 * side, max_relative = 1e-12);
        } else {
            let second = 2.0 * 1.5 * (2.0 * std::f64::consts::PI / n as f64).sin();
            assert!(d.inter.d1 > side && d.inter.d1 < second);
        }
        // Ring order: consecutive slots are neighbours.
        for i in 0..n {
            assert_relative_eq!(
                (d.slots[i] - d.slots[(i + 1) % n]).norm(),
                side,
                max_relative = 1e-12
            );
        }
        // n(n−3)/2 non-adjacent pairs on the plateau, leader term 0.
        let far = (n * (n - 1) / 2 - n) as f64;
        assert_relative_eq!(d.v_eq, far * d.inter.plateau(), epsilon = 1e-12);
    }
}

#[test]
fn platonic_parameters() {
    // (n, edge/circumradius, next distance/circumradius or none)
    let phi = 0.5 * (1.0 + 5.0f64.sqrt());
    let ico_r = (1.0 + phi * phi).sqrt();
    let cases = [
        (4, (8.0f64 / 3.0).sqrt(), None),
        (6, 2.0f64.sqrt(), Some(2.0)),
        (
            8,
            2.0 / 3.0f64.sqrt(),
            Some(2.0 * 2.0f64.sqrt() / 3.0f64.sqrt()),
        ),
        (12, 2.0 / ico_r, Some(2.0 * phi / ico_r)),
        (20, 2.0 / phi / 3.0f64.sqrt(), Some(2.0 / 3.0f64.sqrt())),
    ];
    for (n, edge, next) in cases {
        let d = design_regular(n, 3, 2.0, 1.0, 1.0).unwrap();
        assert_relative_eq!(d.neighbour_spacing(), 2.0 * edge, max_relative = 1e-12);
        match next {
            None => assert_relative_eq!(d.inter.d1, 3.0 * edge, max_relative = 1e-12),
            Some(nx) => assert_relative_eq!(d.inter.d1, edge + nx, max_relative = 1e-12),
        }
        for p in &d.slots {
            assert_relative_eq!(p.norm(), 2.0, max_relative = 1e-12);
        }
    }
}

#[test]
fn every_design_is_an_equilibrium() {
    for dim in [2usize, 3] {
        for n in 1..=21usize {
            let d = design_regular(n, dim, 1.3, 1.0, 1.5).unwrap();
            assert_eq!(d.n(), n);
            assert!(
                forces_at_slots(&d) < 1e-9,
                "dim {dim} n {n}: {}",
                forces_at_slots(&d)
            );
            for p in &d.slots {
                assert_relative_eq!(p.norm(), 1.3, max_relative = 1e-12);
                if dim == 2 {
                    assert_eq!(p.z, 0.0);
                }
            }
            assert!(d.v_eq.is_finite() && d.v_eq >= 0.0);
            assert_eq!(d.equilibrium_energy(n), d.v_eq);
        }
    }
}

/// Relaxes design_regular(n, dim) from perturbed slots and checks distances to the
/// centre ≈ radius and neighbour distances ≈ d0 (1e-3 relative), others beyond d1.
fn check_regular_converges(n: usize, dim: usize) {
    let radius = 1.5;
    let d = design_regular(n, dim, radius, 2.0, 2.0).unwrap();
    let start = perturbed(&d, 0.1 * radius, 1 + n as u64);
    let x = relax(&d, start, 1.0, 200.0);
    let d0 = d.neighbour_spacing();
    for i in 0..n {
        assert_relative_eq!(x[i].norm(), radius, max_relative = 1e-3);
        for j in i + 1..n {
            let slot_dist = (d.slots[i] - d.slots[j]).norm();
            let dist = (x[i] - x[j]).norm();
            if slot_dist < d.inter.d1 {
                assert_relative_eq!(dist, d0, max_relative = 1e-3);
            } else {
                assert!(dist > d.inter.d1, "dim {dim} n {n} pair {i} {j}");
            }
        }
    }
}

#[test]
fn regular_polygons_converge_to_their_shape() {
    for n in 3..=8 {
        check_regular_converges(n, 2);
    }
}

#[test]
fn central_polyhedra_converge_to_their_shape() {
    for n in [4, 6, 12] {
        check_regular_converges(n, 3);
    }
}

#[test]
fn per_slot_polyhedra_converge_to_their_shape() {
    check_regular_converges(2, 2);
    for n in [2, 3, 5, 8] {
        check_regular_converges(n, 3);
    }
}

#[test]
fn dodecahedron_converges_to_its_shape() {
    check_regular_converges(20, 3);
}

/// Smallest over permutations of max_i |x_π(i) − slot_i| (brute force, n ≤ 7).
fn best_match(x: &[Vec3], slots: &[Vec3]) -> f64 {
    fn rec(x: &[Vec3], slots: &[Vec3], used: &mut Vec<bool>, i: usize, worst: f64, best: &mut f64) {
        if worst >= *best {
            return;
        }
        if i == slots.len() {
            *best = worst;
            return;
        }
        for j in 0..x.len() {
            if !used[j] {
                used[j] = true;
                rec(
                    x,
                    slots,
                    used,
                    i + 1,
                    worst.max((x[j] - slots[i]).norm()),
                    best,
                );
                used[j] = false;
            }
        }
    }
    let mut best = f64::INFINITY;
    rec(x, slots, &mut vec![false; x.len()], 0, 0.0, &mut best);
    best
}

#[test]
fn shapes_are_equilibria_and_attract() {
    let shapes: Vec<(usize, Vec<Vec3>)> = vec![
        // Lemma 5.3 right triangle (l1, 0), (0, l2), (0, 0).
        (
            2,
            vec![
                Vec3::new(1.2, 0.0, 0.0),
                Vec3::new(0.0, 0.7, 0.0),
                Vec3::zeros(),
            ],
        ),
        // Square squeezed into an ellipse (anisotropic H).
        (
            2,
            vec![
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 0.8, 0.0),
                Vec3::new(-2.0, 0.0, 0.0),
                Vec3::new(0.0, -0.8, 0.0),
            ],
        ),
        // Hexagon stretched along x.
        (
            2,
            polygon(6)
                .iter()
                .map(|p| Vec3::new(1.8 * p.x, 1.0 * p.y, 0.0))
                .collect(),
        ),
        // Flattened tetrahedron.
        (
            3,
            platonic(4)
                .iter()
                .map(|p| Vec3::new(1.5 * p.x, p.y, 0.6 * p.z))
                .collect(),
        ),
        // A single slot.
        (3, vec![Vec3::new(0.0, 1.0, 0.5)]),
    ];
    for (k, (dim, slots)) in shapes.into_iter().enumerate() {
        let d = design_for_shape(&slots, dim, 2.0, 2.0).unwrap();
        assert_eq!(d.slots, slots);
        assert!(forces_at_slots(&d) < 1e-12, "shape {k}");
        let dmin = d.neighbour_spacing();
        let start = perturbed(&d, 0.2 * dmin, 100 + k as u64);
        let x = relax(&d, start, 1.0, 100.0);
        let err = best_match(&x, &slots);
        assert!(err < 1e-3 * dmin, "shape {k}: {err}");
    }
}

#[test]
fn prefix_energies_for_lost_vehicles() {
    let d = design_regular(6, 2, 1.0, 1.0, 1.0).unwrap();
    // 5 contiguous vehicles on a hexagon: 4 adjacent pairs, 6 pairs on the plateau.
    assert_relative_eq!(
        d.equilibrium_energy(5),
        6.0 * d.inter.plateau(),
        epsilon = 1e-12
    );
    assert_eq!(d.equilibrium_energy(0), 0.0);
    let extra = d.equilibrium_energy(7) - d.v_eq;
    assert_relative_eq!(
        extra,
        d.leader.plateau() + 6.0 * d.inter.plateau(),
        epsilon = 1e-12
    );
    // The octahedron prefix of 3 is a triangle of neighbours.
    let o = design_regular(6, 3, 1.0, 1.0, 1.0).unwrap();
    assert!(o.equilibrium_energy(3).abs() < 1e-12);
}
