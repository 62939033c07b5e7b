use super::*;
use crate::control::integrate;
use crate::rejoin::Homing;

fn pots() -> (PairPotential, PairPotential) {
    // A hexagon of radius 1.5: side d0 = 1.5, leader h0 = 1.5.
    (
        PairPotential::new(1.0, 1.5, 2.25).unwrap(),
        PairPotential::new(1.0, 1.5, 6.0).unwrap(),
    )
}

fn inputs<'a>(
    leaders: &'a [Vec3],
    neighbours: &'a [Vec3],
    velocities: &'a [Vec3],
    ages: &'a [f64],
    slot: Option<Vec3>,
) -> ControlInputs<'a> {
    let (inter, leader) = pots();
    ControlInputs {
        neighbour_velocities: velocities,
        neighbour_ages: ages,
        slot,
        body_velocity: Vec3::new(0.3, 0.1, 0.0),
        ..ControlInputs::paper(leaders, neighbours, inter, leader, 1.0)
    }
}

/// A vehicle off its slot among two moving neighbours, one leader near the centre.
struct Scene {
    x: Vec3,
    v: Vec3,
    leaders: [Vec3; 1],
    nb: [Vec3; 2],
    vel: [Vec3; 2],
    slot: Option<Vec3>,
}

impl Scene {
    fn off_slot() -> Self {
        Self {
            x: Vec3::new(1.4, 0.2, 0.0),
            v: Vec3::new(0.2, -0.1, 0.0),
            leaders: [Vec3::new(0.05, 0.0, 0.0)],
            nb: [Vec3::new(0.8, 1.2, 0.0), Vec3::new(0.7, -1.4, 0.0)],
            vel: [Vec3::new(0.5, 0.0, 0.0), Vec3::new(-0.2, 0.4, 0.0)],
            slot: Some(Vec3::new(1.5, 0.0, 0.0)),
        }
    }
}

#[test]
fn fresh_information_gives_the_paper_law_bit_for_bit() {
    let sc = Scene::off_slot();
    let (x, v, leaders, nb, vel, slot) = (sc.x, sc.v, sc.leaders, sc.nb, sc.vel, sc.slot);
    for ages in [&[0.0, 0.0][..], &[][..]] {
        let inp = inputs(&leaders, &nb, &vel, ages, slot);
        for memory in [None, Some(3.0)] {
            let u = RobustLaw::new(memory).control(&x, &v, &inp);
            assert_eq!(u, PaperLaw.control(&x, &v, &inp), "ages {ages:?}");
        }
    }
    // While a neighbour rejoins too (the blended law of `rejoin`).
    let mut inp = inputs(&leaders, &nb, &vel, &[0.0, 0.0], slot);
    let ghosts = [Vec3::new(0.75, 1.3, 0.0), Vec3::zeros()];
    inp.neighbour_sigmas = &[0.6, 0.0];
    inp.neighbour_slots = &ghosts;
    inp.homing = Some(Homing {
        sigma: 0.3,
        velocity: Vec3::new(0.1, 0.2, 0.0),
    });
    let u = RobustLaw::default().control(&x, &v, &inp);
    assert_eq!(u, PaperLaw.control(&x, &v, &inp));
}

#[test]
fn fading_is_monotone_and_takes_the_neighbour_force_with_it() {
    let tau = 2.0;
    assert_eq!(fade(0.0, tau), 1.0);
    assert_eq!(fade(-1.0, tau), 1.0);
    assert_eq!(fade(5.0, f64::INFINITY), 1.0);
    let mut last = 1.0;
    for i in 1..200 {
        let w = fade(0.05 * i as f64, tau);
        assert!(
            w < last && w > 0.0,
            "age {}: {w} after {last}",
            0.05 * i as f64
        );
        last = w;
    }
    assert!((fade(tau, tau) - (-1.0f64).exp()).abs() < 1e-15);
    // One neighbour too close, no leader, no slot, at rest: the repulsion alone, which
    // shrinks with the age of the neighbour's position.
    let x = Vec3::zeros();
    let nb = [Vec3::new(1.0, 0.0, 0.0)];
    let mut last = f64::INFINITY;
    for age in [0.0, 0.1, 0.5, 1.0, 3.0, 10.0] {
        let ages = [age];
        let inp = inputs(&[], &nb, &[], &ages, None);
        let u = RobustLaw::new(Some(tau)).control(&x, &Vec3::zeros(), &inp);
        let expected = fade(age, tau) * pots().0.force(1.0).abs();
        assert!(
            (u.norm() - expected).abs() < 1e-12 * expected.max(1.0),
            "{age}"
        );
        assert!(u.x < 0.0 && u.norm() < last, "repelled, less with age");
        last = u.norm();
    }
}

#[test]
fn a_vehicle_with_only_stale_neighbours_holds_its_slot() {
    // One central leader (a hexagon's): its potential alone leaves the vehicle's angle free.
    // Neighbours known only from hours ago, wrongly placed: the slot spring brings the
    // vehicle to its slot, moving with the body, and keeps it there.
    let (inter, leader) = pots();
    let body_velocity = Vec3::new(0.3, 0.1, 0.0);
    let slot0 = Vec3::new(0.0, 1.5, 0.0);
    let (mut x, mut v) = (Vec3::new(1.2, 0.6, 0.0), Vec3::zeros());
    let stale = [Vec3::new(0.9, 0.9, 0.0), Vec3::new(-1.0, 0.3, 0.0)];
    let vel = [Vec3::new(0.4, 0.0, 0.0), Vec3::zeros()];
    let ages = [3600.0, 7200.0];
    let dt = 0.02;
    let law = RobustLaw::default();
    let mut paper = (x, v);
    for step in 0..6000 {
        let shift = body_velocity * (step as f64 * dt);
        let leaders = [shift];
        let neighbours: Vec<Vec3> = stale.iter().map(|p| p + shift).collect();
        let mut inp = inputs(&leaders, &neighbours, &vel, &ages, Some(slot0 + shift));
        inp.inter = inter;
        inp.leader = leader;
        let u = law.control(&x, &v, &inp);
        (x, v) = integrate(&x, &v, &u, dt);
        let u = PaperLaw.control(&paper.0, &paper.1, &inp);
        paper = integrate(&paper.0, &paper.1, &u, dt);
    }
    let shift = body_velocity * (6000.0 * dt);
    let error = (x - (slot0 + shift)).norm();
    assert!(error < 0.01 * 1.5, "slot error {error}");
    assert!(
        (v - body_velocity).norm() < 1e-3,
        "moves with the body: {v}"
    );
    // The paper's law, acting on the same stale neighbours, stays far from the slot.
    let paper_error = (paper.0 - (slot0 + shift)).norm();
    assert!(
        paper_error > 0.25 * 1.5,
        "paper law slot error {paper_error}"
    );
}

#[test]
fn the_prediction_follows_the_relative_velocity_as_damping_takes_it() {
    let v = Vec3::new(1.0, -2.0, 0.0);
    let body = Vec3::new(0.5, 0.0, 0.0);
    let moved = Vec3::new(3.0, 4.0, 0.0);
    assert_eq!(predict_neighbour(&moved, &v, &body, 0.0, 0.5), moved);
    // Short ages: (v − ṙ) a; long ages: (v − ṙ)/K.
    let short = relative_drift(&v, &body, 1e-4, 0.5);
    // The next term is −K a²/2 (v − ṙ): 5e-9 here.
    assert!((short - (v - body) * 1e-4).norm() < 1e-8);
    let long = relative_drift(&v, &body, 1e3, 0.5);
    assert!((long - (v - body) / 0.5).norm() < 1e-12);
    assert_eq!(relative_drift(&v, &body, 2.0, 0.0), (v - body) * 2.0);
    let p = predict_neighbour(&moved, &v, &body, 2.0, 0.5);
    let reach = (1.0 - (-1.0f64).exp()) / 0.5;
    assert!((p - (moved + (v - body) * reach)).norm() < 1e-14);
}

#[test]
fn the_default_memory_is_the_damping_time_of_a_neighbour_spring() {
    let (inter, leader) = pots();
    // K = 1/s, κ_I = α/d0² = 1/2.25 per s²: τ = 2.25 s.
    assert!((derived_memory(&inter, 1.0) - 2.25).abs() < 1e-15);
    // A formation shrunk to k = 0.2 is 25 × stiffer: it forgets 25 × sooner.
    let small = PairPotential::new(1.0, 0.3, 0.45).unwrap();
    assert!((derived_memory(&small, 1.0) - 0.09).abs() < 1e-15);
    assert!((slot_stiffness(&leader) - 1.0 / 2.25).abs() < 1e-15);
    // The anti-damping κ a w(a) never exceeds K/e.
    let kappa = inter.alpha / (inter.d0 * inter.d0);
    let tau = derived_memory(&inter, 1.0);
    let worst = (1..10_000)
        .map(|i| {
            let a = 0.001 * i as f64;
            kappa * a * fade(a, tau)
        })
        .fold(0.0, f64::max);
    assert!(worst <= 1.0 / std::f64::consts::E + 1e-12, "{worst}");
}

#[test]
fn following_the_body_damps_relative_to_it() {
    let sc = Scene::off_slot();
    let (x, v, leaders, nb, vel, slot) = (sc.x, sc.v, sc.leaders, sc.nb, sc.vel, sc.slot);
    for ages in [&[0.0, 0.0][..], &[0.3, 1.2][..]] {
        let inp = inputs(&leaders, &nb, &vel, ages, slot);
        for memory in [None, Some(3.0)] {
            let law = RobustLaw::new(memory).following(true);
            // Seen from the body (every velocity less ṙ, ṙ then zero), the law is the
            // plain one: the same forces, the damping −K(ẋ − ṙ).
            let vr: Vec<Vec3> = vel.iter().map(|w| w - inp.body_velocity).collect();
            let body_frame = ControlInputs {
                neighbour_velocities: &vr,
                body_velocity: Vec3::zeros(),
                ..inp
            };
            let plain = RobustLaw::new(memory).control(&x, &(v - inp.body_velocity), &body_frame);
            let u = law.control(&x, &v, &inp);
            assert!((u - plain).norm() < 1e-12, "ages {ages:?}: {u} vs {plain}");
        }
    }
    // A vehicle in its place, moving with the body, among neighbours doing the same and
    // fresh: no force at all (under −K ẋ it would be braked by K ṙ and fall behind).
    let (inter, leader) = pots();
    let ring: Vec<Vec3> = (0..6)
        .map(|i| {
            let a = i as f64 * std::f64::consts::PI / 3.0;
            Vec3::new(1.5 * a.cos(), 1.5 * a.sin(), 0.0)
        })
        .collect();
    let body_v = Vec3::new(0.3, 0.1, 0.0);
    let centre = [Vec3::zeros()];
    let mut inp = ControlInputs::paper(&centre, &ring[1..], inter, leader, 1.0);
    inp.body_velocity = body_v;
    let u = RobustLaw::default()
        .following(true)
        .control(&ring[0], &body_v, &inp);
    assert!(u.norm() < 1e-9, "{u}");
    let trailing = RobustLaw::default().control(&ring[0], &body_v, &inp);
    assert!((trailing + body_v).norm() < 1e-9, "{trailing}");
}

#[test]
fn following_a_growing_body_damps_relative_to_the_slots_motion() {
    // A hexagon whose body grows at k̇/k = 0.2 /s about a centre moving at ṙ: each slot
    // moves at ṙ + 0.2 (p − r). A vehicle in its slot moving with it, among neighbours in
    // theirs, feels no force; one at the centre's velocity only is pushed outwards by K
    // times the difference.
    let (inter, leader) = pots();
    let centre = Vec3::new(0.5, -0.2, 0.0);
    let ring: Vec<Vec3> = (0..6)
        .map(|i| {
            let a = i as f64 * std::f64::consts::PI / 3.0;
            centre + Vec3::new(1.5 * a.cos(), 1.5 * a.sin(), 0.0)
        })
        .collect();
    let body_v = Vec3::new(0.3, 0.1, 0.0);
    let leaders = [centre];
    let inp = ControlInputs {
        body_velocity: body_v,
        body_growth: 0.2,
        body_centre: centre,
        slot: Some(ring[0]),
        ..ControlInputs::paper(&leaders, &ring[1..], inter, leader, 2.0)
    };
    let slot_v = body_v + 0.2 * (ring[0] - centre);
    assert!((inp.slot_velocity() - slot_v).norm() < 1e-12);
    let law = RobustLaw::default().following(true);
    let u = law.control(&ring[0], &slot_v, &inp);
    assert!(u.norm() < 1e-9, "{u}");
    let u = law.control(&ring[0], &body_v, &inp);
    assert!((u - 2.0 * 0.2 * (ring[0] - centre)).norm() < 1e-9, "{u}");
    // Without its slot the vehicle follows the centre only.
    let no_slot = ControlInputs { slot: None, ..inp };
    assert_eq!(no_slot.slot_velocity(), body_v);
    // In a current ĉ the law is given the velocity through the water: holding its moving
    // slot over the ground (through the water at ṗ − ĉ) is again free of force, where the
    // paper's damping on the water velocity would push it downstream by K ĉ.
    let c = Vec3::new(0.1, -0.25, 0.0);
    let drifting = ControlInputs { current: c, ..inp };
    assert_eq!(drifting.follow_velocity(), slot_v - c);
    let u = law.control(&ring[0], &(slot_v - c), &drifting);
    assert!(u.norm() < 1e-9, "{u}");
}

#[test]
fn a_rejoining_neighbour_counts_where_it_was_seen_not_where_its_velocity_points() {
    // Neighbour 0 rejoins (σ = 1) flying fast towards the vehicle, 0.5 s old: predicted
    // like a member it would sit next to the vehicle and repel it hard; it flies its own
    // homing path, so the law takes it where it was seen, whatever its velocity. A member
    // with the same velocity and age is still predicted.
    let sc = Scene::off_slot();
    let ghosts = [Vec3::new(0.75, 1.3, 0.0), sc.nb[1]];
    let towards = (sc.x - sc.nb[0]) * 1.6;
    let fast = [towards, sc.vel[1]];
    let still = [Vec3::new(0.3, 0.1, 0.0), sc.vel[1]]; // the body's velocity
    let ages = [0.5, 0.0];
    let law = RobustLaw::new(Some(3.0));
    let with = |vel: &[Vec3], sigmas: &'static [f64]| {
        let mut inp = inputs(&sc.leaders, &sc.nb, vel, &ages, sc.slot);
        inp.neighbour_sigmas = sigmas;
        inp.neighbour_slots = &ghosts;
        law.control(&sc.x, &sc.v, &inp)
    };
    // Rejoining: its velocity changes nothing (the `still` one moves with the body, so its
    // prediction is where it was seen).
    assert_eq!(with(&fast, &[1.0, 0.0]), with(&still, &[1.0, 0.0]));
    // A member is predicted: the same velocity moves it, and the force with it.
    assert_ne!(with(&fast, &[0.0, 0.0]), with(&still, &[0.0, 0.0]));
}

#[test]
fn the_repulsion_kept_during_a_rejoin_acts_where_a_member_was_seen() {
    // The vehicle flies home (σ = 1: only the repulsion of the others and its homing act
    // on it); member 0, 0.8 s old, was seen 0.6 away, its last velocity pointing at the
    // vehicle. Extrapolated, it would sit next to the vehicle and throw it (stress seed 29,
    // m0015); the repulsion takes it where it was seen, whatever its velocity.
    let sc = Scene::off_slot();
    let seen = [sc.x + Vec3::new(0.0, 0.6, 0.0), sc.nb[1]];
    let towards = Vec3::new(0.0, -3.0, 0.0);
    let fast = [towards, sc.vel[1]];
    let still = [Vec3::new(0.3, 0.1, 0.0), sc.vel[1]];
    let ages = [0.8, 0.8];
    let law = RobustLaw::new(Some(0.25));
    let with = |vel: &[Vec3]| {
        let mut inp = inputs(&sc.leaders, &seen, vel, &ages, sc.slot);
        inp.homing = Some(Homing {
            sigma: 1.0,
            velocity: Vec3::new(0.3, 0.1, 0.0),
        });
        law.control(&sc.x, &sc.v, &inp)
    };
    let u = with(&fast);
    assert_eq!(u, with(&still));
    // And it does repel: away from the member, against the homing velocity's y.
    assert!(u.y < 0.0, "{u:?}");
}

#[test]
fn fused_sources_weigh_each_by_its_own_age() {
    let at = |x: f64, age: f64| Source {
        position: Vec3::new(x, 0.0, 0.0),
        velocity: Vec3::new(0.0, x, 0.0),
        age,
    };
    // Equal ages: the mean; the result is as old as the fresher.
    let f = fuse(&at(0.0, 5.0), &at(2.0, 5.0), 10.0);
    assert!((f.position.x - 1.0).abs() < 1e-12 && (f.velocity.y - 1.0).abs() < 1e-12);
    // A fresh source and one of age τ: weights 1 and 1/e.
    let f = fuse(&at(0.0, 0.0), &at(1.0, 10.0), 10.0);
    let w = (-1.0f64).exp();
    assert!((f.position.x - w / (1.0 + w)).abs() < 1e-12);
    assert_eq!(f.age, 0.0);
    // Symmetric, and the fresher alone when both have faded away.
    assert_eq!(
        fuse(&at(3.0, 1.0), &at(7.0, 4.0), 2.0),
        fuse(&at(7.0, 4.0), &at(3.0, 1.0), 2.0)
    );
    assert_eq!(fuse(&at(3.0, 1e6), &at(7.0, 2e6), 1.0), at(3.0, 1e6));
    assert_eq!(fuse(&at(3.0, 1.0), &at(7.0, 2.0), 0.0).position.x, 3.0);
}
