use super::land::{repulsion, slide, Avoidance};
use super::*;
use crate::control::integrate;

fn glider() -> VehicleModel {
    VehicleModel::Glider(GliderLimits {
        max_speed: 0.3,
        max_accel: 0.01,
        max_turn_rate: 0.1,
    })
}

#[test]
fn ideal_with_no_current_is_the_papers_integration_bit_for_bit() {
    let m = Motion {
        position: Vec3::new(1.5, -2.25, 0.0),
        belief: Vec3::new(1.5, -2.25, 0.0),
        water: Vec3::new(0.3, 0.7, 0.0),
        ground: Vec3::new(0.3, 0.7, 0.0),
    };
    let u = Vec3::new(-0.123, 4.5, 0.0);
    let (x, v) = integrate(&m.position, &m.water, &u, 0.05);
    let next = advance(
        &VehicleModel::Ideal,
        &m,
        &u,
        &Vec3::zeros(),
        0.05,
        3,
        |_, to| *to,
    );
    assert_eq!(next.position, x);
    assert_eq!(next.water, v);
    assert_eq!(next.belief, x);
    assert_eq!(next.ground, v);
}

#[test]
fn a_glider_never_exceeds_its_speed_accel_or_turn_limits() {
    let model = glider();
    let mut w = Vec3::zeros();
    let dt = 10.0;
    for i in 0..500 {
        let a = i as f64 * 0.7;
        let u = Vec3::new(a.cos(), a.sin(), 0.0) * (i % 7) as f64;
        let next = model.water_velocity(&w, &u, dt);
        assert!(next.norm() <= 0.3, "speed {} at step {i}", next.norm());
        if w.norm() > 0.003 && next.norm() > 0.0 {
            let cos = (w.dot(&next) / (w.norm() * next.norm())).clamp(-1.0, 1.0);
            assert!(cos.acos() <= 1.0 + 1e-9, "turned {} rad", cos.acos());
        }
        assert!((next - w).norm() <= 0.1 + 0.3 * 1.0 + 1e-12);
        w = next;
    }
    // Full command along the heading: speeds up by at most max_accel·dt.
    let w0 = Vec3::new(0.1, 0.0, 0.0);
    let n = model.water_velocity(&w0, &Vec3::new(5.0, 0.0, 0.0), dt);
    assert!((n.x - 0.2).abs() < 1e-15 && n.y == 0.0);
    // A reversal within reach of the brakes stops the glider: it does not carry its speed
    // along a heading turned by max_turn_rate·dt only, away from where it is asked to go.
    let r = model.water_velocity(&Vec3::new(0.05, 0.0, 0.0), &Vec3::new(-1.0, 0.0, 0.0), dt);
    assert_eq!(r, Vec3::zeros());
}

#[test]
fn a_glider_asked_to_turn_further_than_it_can_flies_the_nearest_velocity_it_can() {
    let model = glider(); // turns 1 rad, speeds up 0.1 in dt = 10 s
    let dt = 10.0;
    // Asked to turn 1.06 rad (within its acceleration): it turns 1 rad and flies the
    // projection of the wanted velocity on its new heading.
    let w = Vec3::new(0.05, 0.0, 0.0);
    let u = Vec3::new(0.0, 0.009, 0.0);
    let wanted = w + u * dt;
    let next = model.water_velocity(&w, &u, dt);
    let heading = next.y.atan2(next.x);
    assert!((heading - 1.0).abs() < 1e-12, "turned {heading}");
    let h = Vec3::new(1f64.cos(), 1f64.sin(), 0.0);
    assert!((next - h * wanted.dot(&h)).norm() < 1e-15, "{next:?}");
    assert!(next.norm() < wanted.norm());
    // Within its turn it flies what it is asked.
    let small = Vec3::new(0.0, 0.001, 0.0);
    assert_eq!(model.water_velocity(&w, &small, dt), w + small * dt);
}

#[test]
fn the_current_moves_the_truth_but_not_the_belief() {
    let m = Motion {
        position: Vec3::zeros(),
        belief: Vec3::zeros(),
        water: Vec3::new(0.2, 0.0, 0.0),
        ground: Vec3::new(0.2, 0.0, 0.0),
    };
    let c = Vec3::new(0.0, 0.1, 0.0);
    let mut s = m;
    for _ in 0..100 {
        s = advance(&glider(), &s, &Vec3::zeros(), &c, 10.0, 2, |_, to| *to);
    }
    assert!((s.belief - Vec3::new(200.0, 0.0, 0.0)).norm() < 1e-9);
    assert!((s.position - Vec3::new(200.0, 100.0, 0.0)).norm() < 1e-9);
}

#[test]
fn cap_speed_never_leaves_the_norm_above_the_cap() {
    for i in 1..2000 {
        let v = Vec3::new(i as f64 * 0.37, -(i as f64) * 0.11, 0.013 * i as f64);
        let c = cap_speed(&v, 0.3);
        assert!(c.norm() <= 0.3);
        assert!(c.norm() > 0.3 * (1.0 - 1e-12));
    }
}

#[test]
fn repulsion_is_continuous_and_points_away() {
    let a = Avoidance {
        distance: 100.0,
        gain: 0.05,
    };
    let n = Vec3::new(0.0, 1.0, 0.0);
    assert_eq!(repulsion(None, &a), Vec3::zeros());
    assert_eq!(repulsion(Some((100.0, n)), &a), Vec3::zeros());
    assert!(repulsion(Some((99.999, n)), &a).norm() < 1e-9);
    assert!((repulsion(Some((0.0, n)), &a) - n * 0.05).norm() < 1e-15);
    assert!(repulsion(Some((50.0, n)), &a).y > 0.0);
}

#[test]
fn slide_keeps_a_move_off_land() {
    // Land is y < 0.
    let land = |p: &Vec3| p.y < 0.0;
    let from = Vec3::new(0.0, 1.0, 0.0);
    let n = Some(Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(
        slide(&from, &Vec3::new(1.0, 2.0, 0.0), land, n),
        Vec3::new(1.0, 2.0, 0.0)
    );
    assert_eq!(
        slide(&from, &Vec3::new(3.0, -1.0, 0.0), land, n),
        Vec3::new(3.0, 1.0, 0.0)
    );
    assert_eq!(slide(&from, &Vec3::new(3.0, -1.0, 0.0), land, None), from);
}

#[test]
fn the_body_turns_and_speeds_up_no_faster_than_gliders_follow() {
    let gliders = GliderLimits {
        max_speed: 2.0,
        max_accel: 4.0,
        max_turn_rate: 1.0,
    };
    let l = BodyLimits::for_gliders(&gliders, 0.5).unwrap();
    assert_eq!(l.max_turn_rate, 0.5);
    assert!((l.max_accel - 0.5 / std::f64::consts::PI).abs() < 1e-15);
    // Fast gliders: a quarter of their acceleration.
    let quick = GliderLimits {
        max_turn_rate: 100.0,
        ..gliders
    };
    assert_eq!(BodyLimits::for_gliders(&quick, 0.5).unwrap().max_accel, 1.0);
    // A reversal stops the body (it does not carry on past an optimum it overshot).
    let reversed = l.turn(&Vec3::new(1.0, 0.0, 0.0), &Vec3::new(-3.0, 0.0, 0.0), 0.1);
    assert_eq!(reversed, Vec3::zeros());
    // A turn at right angles turns by max_turn_rate·dt, at the wanted rate's projection.
    let turned = l.turn(&Vec3::new(1.0, 0.0, 0.0), &Vec3::new(0.0, 3.0, 0.0), 0.1);
    assert!((turned.y.atan2(turned.x) - 0.05).abs() < 1e-12);
    assert!((turned.norm() - 3.0 * 0.05f64.sin()).abs() < 1e-12);
    // From rest, any direction; a small turn is not touched.
    let wanted = Vec3::new(0.0, 2.0, 0.0);
    assert_eq!(l.turn(&Vec3::zeros(), &wanted, 0.1), wanted);
    let small = Vec3::new(1.0, 0.01, 0.0);
    assert_eq!(l.turn(&Vec3::new(1.0, 0.0, 0.0), &small, 0.1), small);
    assert_eq!(l.speed_after(0.2, 0.5), 0.2 + 0.5 * l.max_accel);
    let bad = GliderLimits {
        max_turn_rate: 0.0,
        ..gliders
    };
    assert_eq!(BodyLimits::for_gliders(&bad, 0.5), None);
}

/// The fastest speed over the ground (L/s) over the last 10 s of 30 of ten gliders of a
/// 3-D formation (α = 44 L²/s², radius 1.17 L, damping 2.5/s: m0964 of the stress
/// campaign's seed 11) in a 0.135 L/s current, under the robust law with neighbours 3 s
/// old (its slot spring then adds to the leaders: formation modes near 20 rad/s) and
/// 6.1 L/s² of acceleration, stepped at 0.05 s; two of them start 0.06 L off their
/// slots. `brake`: the law is evaluated at the braking point.
fn fastest_glider_after_20_s(brake: bool) -> f64 {
    use crate::formation::design_regular;
    use crate::law::{ControlInputs, ControlLaw};
    use crate::robust::RobustLaw;
    let alpha = 44.45;
    let design = design_regular(10, 3, 1.173, alpha, alpha).unwrap();
    let model = VehicleModel::Glider(GliderLimits {
        max_speed: 2.44,
        max_accel: 6.12,
        max_turn_rate: 1.86,
    });
    let current = Vec3::new(-0.116, 0.063, 0.030);
    let (damping, dt) = (2.51, 0.05);
    let law = RobustLaw::new(None).following(true);
    let mut fleet: Vec<Motion> = design
        .slots
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let off = if i < 2 {
                Vec3::new(0.05, -0.03, 0.02)
            } else {
                Vec3::zeros()
            };
            Motion {
                position: p + off,
                belief: p + off,
                water: -current,
                ground: Vec3::zeros(),
            }
        })
        .collect();
    let (ages, velocities) = (vec![3.0; 9], vec![Vec3::zeros(); 9]);
    let mut fastest = 0.0_f64;
    for tick in 0..600 {
        let seen: Vec<Vec3> = fleet.iter().map(|m| m.position).collect();
        fleet = (0..fleet.len())
            .map(|i| {
                let neighbours: Vec<Vec3> = (0..seen.len())
                    .filter(|j| *j != i)
                    .map(|j| seen[j])
                    .collect();
                let inputs = ControlInputs {
                    current,
                    neighbour_ages: &ages,
                    neighbour_velocities: &velocities,
                    slot: Some(design.slots[i]),
                    ..ControlInputs::paper(
                        &design.leaders,
                        &neighbours,
                        design.inter,
                        design.leader,
                        damping,
                    )
                };
                let m = &fleet[i];
                let at = if brake {
                    model.braking_point(&m.position, &(m.water + current), 0.25)
                } else {
                    m.position
                };
                let u = law.control(&at, &m.water, &inputs);
                advance(&model, m, &u, &current, dt, 3, |_, to| *to)
            })
            .collect();
        if tick >= 400 {
            fastest = fleet.iter().fold(fastest, |a, m| a.max(m.ground.norm()));
        }
    }
    fastest
}

#[test]
fn gliders_that_brake_for_their_braking_point_settle_where_gliders_that_do_not_swing() {
    let swinging = fastest_glider_after_20_s(false);
    assert!(swinging > 0.1, "without braking: {swinging} L/s");
    let settled = fastest_glider_after_20_s(true);
    assert!(settled < 0.001, "braking: {settled} L/s");
}

#[test]
fn the_braking_point_of_the_ideal_vehicle_is_where_it_is() {
    let p = Vec3::new(1.0, 2.0, 3.0);
    let v = Vec3::new(4.0, 0.0, 0.0);
    assert_eq!(VehicleModel::Ideal.braking_point(&p, &v, 1.0), p);
    let g = VehicleModel::Glider(GliderLimits {
        max_speed: 5.0,
        max_accel: 2.0,
        max_turn_rate: 1.0,
    });
    // 4 L/s braked at 2 L/s² stops 4 L on; at most `reach` on.
    assert_eq!(g.braking_point(&p, &v, 10.0), Vec3::new(5.0, 2.0, 3.0));
    assert_eq!(g.braking_point(&p, &v, 0.5), Vec3::new(1.5, 2.0, 3.0));
    assert_eq!(g.braking_point(&p, &Vec3::zeros(), 0.5), p);
}
