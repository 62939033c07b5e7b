//! Tests of `fit.rs`.

use super::*;
use crate::formation::design_regular;
use crate::rng::{keyed, Stream};
use nalgebra::Rotation3;
use rand::Rng;

fn body_at(r: Vec3, scale: f64) -> VirtualBody {
    VirtualBody {
        scale,
        ..VirtualBody::at(r)
    }
}

/// The slots of `design` at `body`, turned by `turn` about the centre, shuffled.
fn placed(design: &FormationDesign, body: &VirtualBody, turn: &Mat3, seed: u64) -> Vec<Vec3> {
    let mut pts: Vec<Vec3> = design
        .slots
        .iter()
        .map(|p| body.r + turn * (body.scale * p))
        .collect();
    let mut rng = keyed(seed, Stream::Test, 0, 0);
    for i in (1..pts.len()).rev() {
        let j = rng.random_range(0..=i);
        pts.swap(i, j);
    }
    pts
}

#[test]
fn rotated_shuffled_polygon_fits_exactly() {
    let d = design_regular(6, 2, 1.5, 1.0, 1.0).unwrap();
    let body = body_at(Vec3::new(3.0, -2.0, 0.0), 1.7);
    let x = placed(&d, &body, &rot_z(0.3), 1);
    let f = fit_slots(&x, &d, &body, 2);
    for e in &f.errors {
        assert!(*e < 1e-9, "{e}");
    }
    let mut slots: Vec<usize> = f.slot.iter().map(|s| s.unwrap()).collect();
    slots.sort_unstable();
    assert_eq!(slots, (0..6).collect::<Vec<_>>());
}

#[test]
fn a_flung_vehicle_alone_is_out_of_formation() {
    let d = design_regular(5, 2, 1.5, 1.0, 1.0).unwrap();
    let body = body_at(Vec3::new(10.0, 5.0, 0.0), 1.0);
    let mut x = placed(&d, &body, &rot_z(-1.1), 2);
    let away = Vec3::new(20.0, -7.0, 0.0);
    x[2] += away;
    let f = fit_slots(&x, &d, &body, 2);
    let spacing = spacing(&d, &body);
    for (i, e) in f.errors.iter().enumerate() {
        if i == 2 {
            // Its own slot or another one: at least its offset less the ring's diameter.
            assert!(*e >= away.norm() - 3.0 - 1e-9, "{e}");
            assert!(*e / spacing > IN_FORMATION);
        } else {
            assert!(*e < 1e-9, "vehicle {i}: {e}");
        }
    }
}

/// Vehicles in their slots of a design with a hole, the whole turned about the centre:
/// every one fits its slot, whichever slot is the hole and however far it is turned
/// (in 2-D a 15-gon, in 3-D an icosahedron; stress seed 23, m0993, judged one of 14
/// vehicles of a 15-gon 4.8 spacings off, anchored on the wrong slot).
#[test]
fn a_design_with_a_hole_fits_its_vehicles_however_it_is_turned() {
    let cases = [
        (design_regular(15, 2, 3.47, 1.0, 1.0).unwrap(), 2),
        (design_regular(12, 3, 2.0, 1.0, 1.0).unwrap(), 3),
    ];
    for (full, dim) in cases {
        let body = body_at(Vec3::new(-12.3, -19.3, 0.0), 1.0);
        for hole in 0..full.slots.len() {
            let d = full.without_slots(&[hole]);
            for (seed, angle) in [(1u64, 0.4), (2, 1.3), (3, -2.2), (4, 3.0)] {
                let turn = if dim == 2 {
                    rot_z(angle)
                } else {
                    *Rotation3::from_axis_angle(
                        &nalgebra::Unit::new_normalize(Vec3::new(0.3, -0.5, 0.8)),
                        angle,
                    )
                    .matrix()
                };
                let x = placed(&d, &body, &turn, seed);
                let f = fit_slots(&x, &d, &body, dim);
                for (i, e) in f.errors.iter().enumerate() {
                    assert!(
                        *e < 1e-6,
                        "dim {dim}, hole {hole}, turn {angle}: vehicle {i} {e}"
                    );
                }
            }
        }
    }
}

/// A ring of 13 in which vehicles 0 and 1 have each been thrown 0.6 of the way towards
/// the other's slot: assigned afresh they swap slots; kept, every vehicle keeps its
/// slot while within a spacing of it.
#[test]
fn a_kept_assignment_changes_only_when_it_must() {
    let d = design_regular(13, 2, 1.18, 1.0, 1.0).unwrap();
    let body = body_at(Vec3::zeros(), 1.0);
    let own = *body.rotation.matrix();
    let at = |j: usize| body.scale * (own * d.slots[j]);
    let spacing = spacing(&d, &body);
    let mut x: Vec<Vec3> = (0..13).map(at).collect();
    x[1] += 0.6 * (at(0) - at(1));
    x[0] += 0.6 * (at(1) - at(0));
    let fresh = held_slots(&x, &d, &body, 2);
    assert_eq!(
        (fresh.slot[0], fresh.slot[1]),
        (Some(1), Some(0)),
        "swapped afresh"
    );
    let last: Vec<Option<usize>> = (0..13).map(Some).collect();
    let kept = keep_slots(&x, &d, &body, &own, &last, || unreachable!());
    assert_eq!(kept, last);
    // Beyond a spacing it chooses again, among the free slots.
    let mut far = x.clone();
    far[1] = at(7) + 0.1 * (at(8) - at(7));
    assert!((far[1] - at(1)).norm() > spacing);
    let again = keep_slots(&far, &d, &body, &own, &last, || unreachable!());
    assert_eq!(again.iter().filter(|s| s.is_some()).count(), 13);
    assert_eq!(again[7], Some(7), "vehicle 7 keeps its own");
    assert_eq!(again[1], Some(1), "the only slot left free");
    // Without a last assignment, the fresh one.
    assert_eq!(
        keep_slots(&x, &d, &body, &own, &[None; 13], || fresh.slot.clone()),
        fresh.slot
    );
}

/// The greedy of `keep_slots` as it was first written: every free (distance, vehicle,
/// slot) pair sorted, then taken in order when both are free (the reference).
fn greedy_by_sorting(
    positions: &[Vec3],
    at: &[Vec3],
    slot: &mut [Option<usize>],
    used: &mut [bool],
) {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, x) in positions.iter().enumerate() {
        if slot[i].is_none() {
            for (j, _) in used.iter().enumerate().filter(|(_, u)| !**u) {
                pairs.push(((x - at[j]).norm(), i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    for (_, i, j) in pairs {
        if slot[i].is_none() && !used[j] {
            slot[i] = Some(j);
            used[j] = true;
        }
    }
}

#[test]
fn the_lazy_greedy_takes_the_pairs_of_the_sorted_greedy() {
    let mut rng = keyed(11, Stream::Test, 2, 0);
    for trial in 0..3000 {
        let n = rng.random_range(0..40usize);
        let m = rng.random_range(0..40usize);
        // A coarse lattice makes equal distances (ties) common; some trials bunch
        // every vehicle onto a few points.
        let coarse = trial % 3 == 0;
        let point = |rng: &mut rand_chacha::ChaCha8Rng| {
            if coarse {
                Vec3::new(
                    rng.random_range(-2..3) as f64,
                    rng.random_range(-2..3) as f64,
                    0.0,
                )
            } else {
                Vec3::new(
                    rng.random_range(-5.0..5.0),
                    rng.random_range(-5.0..5.0),
                    rng.random_range(-1.0..1.0),
                )
            }
        };
        // Some trials far below 1 (squared distances subnormal), some with a NaN.
        let scale = [1.0, 1e-160, 1e-155, 3.0][trial % 4];
        let mut x: Vec<Vec3> = (0..n).map(|_| scale * point(&mut rng)).collect();
        let at: Vec<Vec3> = (0..m).map(|_| scale * point(&mut rng)).collect();
        if trial % 17 == 5 && n > 0 {
            x[trial % n].y = f64::NAN;
        }
        let mut used = vec![false; m];
        let mut slot = vec![None; n];
        for s in slot.iter_mut() {
            let j = rng.random_range(0..m.max(1) * 2);
            if j < m && !used[j] && rng.random_bool(0.5) {
                used[j] = true;
                *s = Some(j);
            }
        }
        let (mut s1, mut u1) = (slot.clone(), used.clone());
        greedy_by_sorting(&x, &at, &mut s1, &mut u1);
        let (mut s2, mut u2) = (slot, used);
        greedy_nearest_pairs(&x, &at, &mut s2, &mut u2);
        assert_eq!(s1, s2, "trial {trial}");
        assert_eq!(u1, u2, "trial {trial}");
    }
}

#[test]
fn platonic_solids_fit_under_any_rotation() {
    for n in [4, 6, 12] {
        let d = design_regular(n, 3, 2.0, 1.0, 1.0).unwrap();
        assert!(d.is_central());
        let body = body_at(Vec3::new(1.0, 2.0, 3.0), 0.8);
        for seed in 0..5 {
            let mut rng = keyed(seed, Stream::Test, 1, 0);
            let axis = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let turn = *Rotation3::new(axis * 2.5).matrix();
            let x = placed(&d, &body, &turn, seed);
            let f = fit_slots(&x, &d, &body, 3);
            for e in &f.errors {
                assert!(*e < 1e-9, "n = {n}, seed {seed}: {e}");
            }
        }
    }
}

#[test]
fn noisy_positions_give_errors_of_the_noise() {
    let d = design_regular(12, 3, 2.0, 1.0, 1.0).unwrap();
    let body = body_at(Vec3::zeros(), 1.0);
    let mut x = placed(&d, &body, &rot_z(0.7), 3);
    let mut rng = keyed(3, Stream::Test, 2, 0);
    for p in &mut x {
        *p += Vec3::new(
            rng.random_range(-0.05..0.05),
            rng.random_range(-0.05..0.05),
            rng.random_range(-0.05..0.05),
        );
    }
    let f = fit_slots(&x, &d, &body, 3);
    let worst = f.errors.iter().copied().fold(0.0, f64::max);
    // Each offset is at most 0.05·√3 ≈ 0.087; the fitted rotation can only do better
    // on the sum of squares, so no error should be far beyond it.
    assert!(worst < 0.12, "{worst}");
}

#[test]
fn per_slot_designs_do_not_rotate() {
    let d = design_regular(8, 3, 2.0, 1.0, 1.0).unwrap();
    assert!(!d.is_central());
    let body = body_at(Vec3::zeros(), 1.0);
    let exact = placed(&d, &body, &Mat3::identity(), 4);
    assert!(fit_slots(&exact, &d, &body, 3)
        .errors
        .iter()
        .all(|e| *e < 1e-12));
    let turned = placed(&d, &body, &rot_z(std::f64::consts::FRAC_PI_4), 4);
    let f = fit_slots(&turned, &d, &body, 3);
    assert_eq!(f.rotation, Mat3::identity());
    assert!(f.errors.iter().all(|e| *e > 0.5), "{:?}", f.errors);
}

#[test]
fn extra_vehicles_are_measured_to_their_nearest_slot() {
    let d = design_regular(4, 2, 1.0, 1.0, 1.0).unwrap();
    let body = body_at(Vec3::zeros(), 1.0);
    let mut x = placed(&d, &body, &Mat3::identity(), 5);
    x.push(Vec3::new(1.0, 0.3, 0.0));
    let f = fit_slots(&x, &d, &body, 2);
    assert_eq!(f.slot[4], None);
    assert!((f.errors[4] - 0.3).abs() < 1e-9, "{}", f.errors[4]);
    assert!(f.errors[..4].iter().all(|e| *e < 1e-9));
}

#[test]
fn large_formations_fit() {
    let d = design_regular(256, 2, 50.0, 1.0, 1.0).unwrap();
    let body = body_at(Vec3::new(-4.0, 9.0, 0.0), 1.0);
    let x = placed(&d, &body, &rot_z(0.004), 6);
    let f = fit_slots(&x, &d, &body, 2);
    assert!(f.errors.iter().all(|e| *e < 1e-9));
}

#[test]
fn nearest_slot_by_angle_equals_the_scan() {
    let d = design_regular(9, 2, 2.0, 1.0, 1.0).unwrap();
    let slots = rotate(&rot_z(0.4), &d.slots);
    let mut rng = keyed(7, Stream::Test, 3, 0);
    let q: Vec<Vec3> = (0..500)
        .map(|_| {
            Vec3::new(
                rng.random_range(-6.0..6.0),
                rng.random_range(-6.0..6.0),
                0.0,
            )
        })
        .collect();
    let centred = Centred::new(&q, Vec3::zeros());
    let circle = circle_order(&slots);
    let fast = nearest_all(&centred, &slots, circle.as_deref());
    for (x, (j, d)) in q.iter().zip(&fast) {
        let (k, e) = nearest(x, &slots);
        assert_eq!(*d, e, "{x:?}");
        assert!(*j == k || (x - slots[*j]).norm_squared() == e);
    }
    // The nearest free slot by angle equals the scan's.
    let mut used = vec![false; slots.len()];
    for (i, x) in q.iter().enumerate() {
        let angle = angle_in_plane(x);
        let by_angle = nearest_free(x, angle, &slots, &used, circle.as_deref());
        let by_scan = nearest_free(x, angle, &slots, &used, None);
        let dist = |j: Option<usize>| j.map(|j| (x - slots[j]).norm_squared());
        assert_eq!(dist(by_angle), dist(by_scan), "{x:?}");
        if i % 60 == 0 {
            if let Some(j) = by_scan {
                used[j] = true;
            }
        }
    }
}

#[test]
fn sparse_sums_equal_the_full_ones() {
    use crate::lyapunov::potential_energy;
    for (n, dim) in [(7, 2), (20, 3), (64, 2)] {
        let d = design_regular(n, dim, 3.0, 1.0, 2.0).unwrap();
        let mut rng = keyed(n as u64, Stream::Test, 4, 0);
        let mut x: Vec<Vec3> = d.slots.clone();
        for p in &mut x {
            *p += Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                if dim == 3 {
                    rng.random_range(-1.0..1.0)
                } else {
                    0.0
                },
            );
        }
        x[0] += Vec3::new(40.0, 0.0, 0.0);
        let full = potential_energy(&x, &d.leaders, &d.inter, &d.leader);
        let sparse = potential_energy_sparse(&x, &d.leaders, &d.inter, &d.leader);
        assert!(
            (full - sparse).abs() <= 1e-9 * full.abs().max(1.0),
            "{full} vs {sparse}"
        );
        let fast = nearest_neighbours(&x);
        for (i, got) in fast.iter().enumerate() {
            let want = (0..x.len())
                .filter(|&j| j != i)
                .map(|j| ((x[i] - x[j]).norm(), j))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                .map(|(d, j)| (j, d));
            assert_eq!(*got, want, "vehicle {i}");
        }
    }
}

#[test]
fn nearest_neighbours_of_a_line() {
    let x = [0.0, 1.0, 3.0, 3.5].map(|a| Vec3::new(a, 0.0, 0.0));
    let n = nearest_neighbours(&x);
    assert_eq!(n[0], Some((1, 1.0)));
    assert_eq!(n[1], Some((0, 1.0)));
    assert_eq!(n[2], Some((3, 0.5)));
    assert_eq!(n[3], Some((2, 0.5)));
    assert_eq!(nearest_neighbours(&x[..1]), vec![None]);
}
