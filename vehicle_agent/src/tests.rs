//! Unit tests of the agent's pure steps: [`Agent::step`] against the control law (II.1),
//! the equilibrium of a formation at rest, and the lookahead rule of
//! [`Vehicle::ready_to_step`].

use std::sync::Arc;

use vbap_math::body::VirtualBody;
use vbap_math::law::{ControlInputs, ControlLaw, PaperLaw};
use vbap_math::potential::PairPotential;
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::link::LinkModel;

use crate::{initial_design, Agent, AgentInputs, Guidance, Telling, Vehicle};

/// The paper's mission (Table I) shipped with the repository, with `links` in place of its
/// ideal `[links]` table.
fn paper_mission(links: Option<&str>) -> Mission {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/missions/paper.toml");
    let mut text = std::fs::read_to_string(path).expect("deploy/missions/paper.toml");
    if let Some(links) = links {
        let at = text.find("[links]").expect("a [links] table");
        text.truncate(at);
        text.push_str(links);
    }
    Mission::from_toml_str(&text, "paper.toml").expect("a valid mission")
}

fn no_one<'a>(leaders: &'a [Vec3], leader: PairPotential, damping: f64) -> AgentInputs<'a> {
    AgentInputs::paper(
        leaders,
        &[],
        PairPotential::new(1.0, 1.0, 1.5).unwrap(),
        leader,
        damping,
    )
}

#[test]
fn one_step_follows_ii_1_and_the_double_integrator() {
    // One vehicle, one virtual leader: u = −∇_x V_h(|x − b|) − K ẋ (II.1), K = damping·I,
    // the gradient of the potential taken by central differences (independent of the
    // force the law uses), then v' = v + u dt, x' = x + v' dt.
    let leader = PairPotential::new(60.0, 1.2, 6.0).unwrap();
    let b = [Vec3::new(2.0, 1.0, 0.0)];
    let damping = 5.0;
    let dt = 0.05;
    let x = Vec3::new(0.3, -0.4, 0.0);
    let v = Vec3::new(0.2, 0.1, 0.0);
    let mut agent = Agent {
        id: 0,
        dim: 2,
        position: x,
        velocity: v,
    };
    let u = agent.step(&no_one(&b, leader, damping), dt);

    let potential = |p: &Vec3| leader.value((p - b[0]).norm());
    let h = 1e-6;
    let mut grad = Vec3::zeros();
    for i in 0..2 {
        let mut e = Vec3::zeros();
        e[i] = h;
        grad[i] = (potential(&(x + e)) - potential(&(x - e))) / (2.0 * h);
    }
    let expected = -grad - damping * v;
    assert!(
        (u - expected).norm() <= 1e-6 * expected.norm().max(1.0),
        "u = {u:?}, (II.1) gives {expected:?}"
    );
    let v_next = v + u * dt;
    assert!((agent.velocity - v_next).norm() <= 1e-12);
    assert!((agent.position - (x + v_next * dt)).norm() <= 1e-12);
    assert_eq!(agent.position.z, 0.0, "2-D stays in the plane");
}

#[test]
fn a_formation_at_its_slots_with_a_still_body_stays() {
    // The initial design of the paper's mission, every vehicle exactly at its slot around
    // the body at rest: the slots are an equilibrium of (II.1), nobody moves.
    let mission = paper_mission(None);
    let design = initial_design(&mission).unwrap();
    let body = VirtualBody {
        s: 0.0,
        r: mission.start_vec(),
        rotation: nalgebra::Rotation3::identity(),
        scale: 1.0,
    };
    let leaders = body.leader_positions(&design);
    let slots: Vec<Vec3> = design.slots.iter().map(|s| body.r + s).collect();
    let dt = mission.mission.dt;
    for (i, slot) in slots.iter().enumerate() {
        let neighbours: Vec<Vec3> = slots
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, p)| *p)
            .collect();
        let inputs = AgentInputs::paper(
            &leaders,
            &neighbours,
            body.scaled_inter(&design),
            body.scaled_leader(&design),
            mission.vehicles.damping,
        );
        let mut agent = Agent {
            id: i as u32,
            dim: 2,
            position: *slot,
            velocity: Vec3::zeros(),
        };
        for k in 0..20 {
            let u = agent.step(&inputs, dt);
            assert!(u.norm() <= 1e-9, "vehicle {i}, step {k}: u = {u:?}");
        }
        assert!(
            (agent.position - slot).norm() <= 1e-9,
            "vehicle {i} drifted to {:?} from {slot:?}",
            agent.position
        );
    }
}

/// A law of our own: the paper's, with every acceleration doubled.
#[derive(Debug)]
struct Doubled;

impl ControlLaw for Doubled {
    fn control(&self, x: &Vec3, v: &Vec3, inputs: &ControlInputs<'_>) -> Vec3 {
        2.0 * PaperLaw.control(x, v, inputs)
    }
}

#[test]
fn the_vehicle_flies_the_law_it_is_given() {
    // A pull whose step stays a single step under both laws (|2u| dt² < SUBSTEP_REACH d0).
    let leader = PairPotential::new(20.0, 1.2, 6.0).unwrap();
    let b = [Vec3::new(2.0, 1.0, 0.0)];
    let start = Agent {
        id: 0,
        dim: 2,
        position: Vec3::new(0.3, -0.4, 0.0),
        velocity: Vec3::zeros(),
    };
    let (mut paper, mut doubled) = (start, start);
    let u = paper.step(&no_one(&b, leader, 5.0), 0.05);
    let u2 = doubled.step_with(&Doubled, &no_one(&b, leader, 5.0), 0.05);
    assert!(u.norm() > 1.0, "a real pull: {u:?}");
    assert!((u2 - 2.0 * u).norm() <= 1e-12);
    assert!((doubled.velocity - 2.0 * paper.velocity).norm() <= 1e-12);

    // A Vehicle given the law steps by it; the default is the paper's.
    let mission = paper_mission(None);
    let design = initial_design(&mission).unwrap();
    let initial = Guidance::initial(&mission, &design);
    // Off its slot by a tenth of a unit: a pull that stays a single step, doubled too.
    let mut near = crate::initial_agent(&mission, &design, 0);
    near.position += Vec3::new(0.1, -0.05, 0.0);
    let mut by_paper = Vehicle::new(near, initial.clone(), 0);
    let mut by_ours = Vehicle::new(near, initial, 0).with_law(Arc::new(Doubled));
    by_paper.step(0, mission.mission.dt);
    by_ours.step(0, mission.mission.dt);
    let (dv, dv2) = (by_paper.agent.velocity, by_ours.agent.velocity);
    assert!(dv.norm() > 0.0);
    assert!((dv2 - 2.0 * dv).norm() <= 1e-12 * dv.norm().max(1.0));
}

/// Vehicle 0 with the commands of ticks 0..=`c` received, under `mission`'s links.
fn received_up_to(mission: &Mission, model: &LinkModel, c: u64) -> Vehicle {
    let design = initial_design(mission).unwrap();
    let initial = Guidance::initial(mission, &design);
    let agent = crate::initial_agent(mission, &design, 0);
    let mut vehicle = Vehicle::new(agent, initial.clone(), 0);
    for k in 0..=c {
        let fate = vehicle.receive(model, initial.clone(), 0, k, mission.mission.dt);
        assert!(fate.is_some(), "command {k} is new");
    }
    vehicle
}

#[test]
fn ideal_links_step_only_on_the_command_of_the_tick() {
    // Delivered at once: the step from tick j needs command j itself.
    let mission = paper_mission(None);
    let model = LinkModel::new(&mission);
    let dt = mission.mission.dt;
    let mut vehicle = received_up_to(&mission, &model, 10);
    for j in 0..=10 {
        assert!(
            vehicle.ready_to_step(&model, j, dt),
            "tick {j}: its command is in"
        );
    }
    assert!(
        !vehicle.ready_to_step(&model, 11, dt),
        "command 11 is due at t_11"
    );
}

#[test]
fn a_delayed_link_lets_the_vehicle_run_ahead_exactly_as_far_as_the_delay() {
    // Every command arrives 0.21 s = 4.2 ticks after it is sent: the step from tick j
    // cannot miss command i when t_i + 0.21 > t_j, i.e. j − i ≤ 4. With commands 0..=c
    // in, the vehicle may step up to tick c + 5 and not beyond.
    let links = "[links]\ndelay = 0.21\njitter = 0.0\nloss = 0.0\n";
    let mission = paper_mission(Some(links));
    let model = LinkModel::new(&mission);
    let dt = mission.mission.dt;
    for c in [0u64, 10, 37] {
        let mut vehicle = received_up_to(&mission, &model, c);
        for j in 0..=c + 5 {
            assert!(vehicle.ready_to_step(&model, j, dt), "c = {c}, j = {j}");
        }
        assert!(
            !vehicle.ready_to_step(&model, c + 6, dt),
            "c = {c}: command {} is due",
            c + 1
        );
        // The missing command arrives: the vehicle may go on.
        let design = initial_design(&mission).unwrap();
        vehicle.receive(&model, Guidance::initial(&mission, &design), 0, c + 1, dt);
        assert!(vehicle.ready_to_step(&model, c + 6, dt));
    }
}

/// The neighbour vectors of [`Guidance::with_neighbours`] as they were before it left the
/// empty ones empty: all five, one entry per neighbour.
fn full_neighbours(
    mut g: Guidance,
    id: u32,
    snapshot: &[vbap_ipc::msg::coordinator_to_agent::SnapshotEntry],
) -> Guidance {
    use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
    use vbap_ipc::msg::to_vec3;
    let spacing = g.inter.d0;
    g.neighbours.clear();
    g.neighbour_sigmas.clear();
    g.neighbour_slots.clear();
    g.neighbour_velocities.clear();
    g.neighbour_ages.clear();
    for e in snapshot
        .iter()
        .filter(|e| e.id != id && e.alive != SnapshotEntry::LOST)
    {
        let position = to_vec3(&e.position);
        let (sigma, slot) = if e.rejoining != 0 {
            let target = to_vec3(&e.target);
            (
                vbap_math::rejoin::homing_weight((position - target).norm(), spacing),
                target,
            )
        } else {
            (0.0, position)
        };
        g.neighbours.push(position);
        g.neighbour_sigmas.push(sigma);
        g.neighbour_slots.push(slot);
        g.neighbour_velocities.push(to_vec3(&e.velocity));
        g.neighbour_ages.push(e.age);
    }
    let own = snapshot
        .iter()
        .find(|e| e.id == id && e.alive != SnapshotEntry::LOST);
    g.target = own.filter(|e| e.rejoining != 0).map(|e| to_vec3(&e.target));
    g.slot = own.filter(|e| e.has_slot != 0).map(|e| to_vec3(&e.slot));
    g.hulls = snapshot
        .iter()
        .filter(|e| e.id != id && e.alive == SnapshotEntry::LOST)
        .map(|e| to_vec3(&e.position))
        .collect();
    g
}

/// A lost vehicle of the snapshot is a hull: the robust law pushes a vehicle a tenth of a
/// spacing from it away from it (`vbap_math::hull`); the paper's law does not
/// know of it; the vehicle's own lost entry is no hull.
#[test]
fn the_robust_law_keeps_clear_of_the_hulls_of_lost_vehicles() {
    use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
    use vbap_mission::config::LawKind;
    let mission = paper_mission(None);
    let design = initial_design(&mission).unwrap();
    let base = Guidance::initial(&mission, &design);
    let spacing = base.inter.d0;
    let x = Vec3::new(0.3, -0.2, 0.0);
    let hull = x - Vec3::new(0.1 * spacing, 0.0, 0.0);
    let entry = |id, alive, p: Vec3| SnapshotEntry {
        id,
        alive,
        position: [p.x, p.y, p.z],
        ..SnapshotEntry::default()
    };
    let snapshot = [
        entry(0, SnapshotEntry::LOST, x),
        entry(1, SnapshotEntry::LOST, hull),
        entry(2, SnapshotEntry::MEMBER, x + Vec3::new(0.0, 50.0, 0.0)),
    ];
    let g = base.with_neighbours(0, &snapshot);
    assert_eq!(g.hulls, vec![hull]);
    let pushed = |law: LawKind, g: &Guidance| {
        let mut m = mission.clone();
        m.control.law = law;
        let agent = Agent {
            id: 0,
            dim: 2,
            position: x,
            velocity: Vec3::zeros(),
        };
        let mut v = Vehicle::new(agent, g.clone(), 0).with_law(crate::mission_law(&m));
        v.step(0, 0.05);
        v.agent.velocity
    };
    let without = Guidance {
        hulls: vec![],
        ..g.clone()
    };
    let away = pushed(LawKind::Robust, &g) - pushed(LawKind::Robust, &without);
    // Away along +x (the vehicle's own motion model bends the sum a little).
    assert!(away.x > 0.0 && away.y.abs() < 0.25 * away.x, "{away:?}");
    assert_eq!(pushed(LawKind::Paper, &g), pushed(LawKind::Paper, &without));
}

#[test]
fn compact_guidance_flies_as_the_full_one() {
    use rand::Rng;
    use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
    use vbap_math::rng::{keyed, Stream};
    use vbap_mission::config::LawKind;

    let mission = paper_mission(None);
    let design = initial_design(&mission).unwrap();
    let dt = 0.05;
    for case in 0..400u64 {
        let mut rng = keyed(17, Stream::Test, case, 0);
        let n = rng.random_range(1..12usize);
        let id = rng.random_range(0..n as u32);
        // Which fields vary in this case: rejoining neighbours, ages, lost vehicles.
        let rejoins = rng.random_bool(0.5);
        let aged = rng.random_bool(0.5);
        let mut p = |amp: f64| {
            [
                rng.random_range(-amp..amp),
                rng.random_range(-amp..amp),
                0.0,
            ]
        };
        let mut snapshot: Vec<SnapshotEntry> = (0..n as u32)
            .map(|i| SnapshotEntry {
                id: i,
                alive: SnapshotEntry::MEMBER,
                position: p(2.0),
                velocity: p(0.5),
                target: p(2.0),
                slot: p(2.0),
                has_slot: 1,
                ..SnapshotEntry::default()
            })
            .collect();
        for e in &mut snapshot {
            let draw: f64 = keyed(17, Stream::Test, case, u64::from(e.id) + 1).random();
            if rejoins && draw < 0.3 {
                e.rejoining = 1;
            }
            if aged && draw > 0.6 {
                e.age = if draw > 0.9 { -0.0 } else { 0.1 * draw };
            }
            if draw > 0.45 && draw < 0.55 {
                e.alive = SnapshotEntry::LOST;
            }
        }
        let base = Guidance::initial(&mission, &design);
        let compact = base.clone().with_neighbours(id, &snapshot);
        let full = full_neighbours(base, id, &snapshot);
        assert_eq!(compact.neighbours, full.neighbours);
        assert_eq!(compact.neighbour_velocities, full.neighbour_velocities);
        assert_eq!(compact.target, full.target);
        assert_eq!(compact.slot, full.slot);
        if !rejoins {
            assert!(compact.neighbour_sigmas.is_empty() && compact.neighbour_slots.is_empty());
        }
        if !aged {
            assert!(compact.neighbour_ages.is_empty());
        }
        for law in [LawKind::Paper, LawKind::Robust] {
            let mut m = mission.clone();
            m.control.law = law;
            let law = crate::mission_law(&m);
            let agent = Agent {
                id,
                dim: 2,
                position: Vec3::new(0.3, -0.2, 0.0),
                velocity: Vec3::new(0.1, 0.05, 0.0),
            };
            // On the command of the tick (age 0) and on one 3 ticks old (dead reckoning).
            for k in [0u64, 3] {
                let fly = |g: &Guidance| {
                    let mut v = Vehicle::new(agent, g.clone(), 0).with_law(law.clone());
                    v.step(k, dt);
                    (v.agent.position, v.agent.velocity)
                };
                let (xc, vc) = fly(&compact);
                let (xf, vf) = fly(&full);
                for (a, b) in xc.iter().chain(vc.iter()).zip(xf.iter().chain(vf.iter())) {
                    assert_eq!(a.to_bits(), b.to_bits(), "case {case}, tick {k}");
                }
            }
        }
    }
}

/// `dive3d.toml` shipped with the repository (gliders diving in a uniform current they do
/// not know, a fix at the top of each 12 s dive), with `current_estimate` set.
fn diving_glider_mission(current_estimate: bool) -> Mission {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../deploy/missions/dive3d.toml"
    );
    let text = std::fs::read_to_string(path).expect("deploy/missions/dive3d.toml");
    let text = text.replace(
        "current_estimate = true",
        &format!("current_estimate = {current_estimate}"),
    );
    Mission::from_toml_str(&text, "dive3d.toml").expect("a valid mission")
}

/// Dead-reckons a deployed glider for the first 10 s of its dive (no fix before 12 s)
/// under (II.1) towards a leader, returning the distance between its true and believed
/// positions at the end.
fn first_dive_error(current_estimate: bool) -> f64 {
    use crate::motion::{Kinematics, Moving};
    let mission = diving_glider_mission(current_estimate);
    let dt = mission.mission.dt;
    let kin = Kinematics::of(&mission).expect("gliders in a current");
    let mut agent = Agent {
        id: 0,
        dim: 3,
        position: Vec3::new(1.0, 0.5, 0.0),
        velocity: Vec3::zeros(),
    };
    let mut moving = Moving::start(kin.clone(), &mut agent, 0, dt);
    if current_estimate {
        assert_eq!(moving.estimate, kin.current_at(&agent.position, 0.0));
    } else {
        assert_eq!(moving.estimate, Vec3::zeros());
    }
    let leaders = [Vec3::new(4.0, 2.0, 0.0)];
    let leader = PairPotential::new(60.0, 1.0, 4.0).unwrap();
    let inputs = ControlInputs::paper(
        &leaders,
        &[],
        PairPotential::new(1.0, 1.0, 1.5).unwrap(),
        leader,
        5.0,
    );
    for k in 0..(10.0 / dt) as u64 {
        assert!(!kin.fix_at(0, k + 1, dt), "a fix at tick {}", k + 1);
        moving.step(&mut agent, &PaperLaw, &inputs, k, dt);
    }
    (agent.position - moving.belief).norm()
}

#[test]
fn a_glider_that_estimates_the_current_starts_with_its_surface_drift() {
    // The current is uniform (0.2, 0.1) L/s: with the drift measured at deployment the
    // belief follows the truth under water; without it, it falls 10 s × 0.22 L/s behind.
    let known = first_dive_error(true);
    let blind = first_dive_error(false);
    assert!(
        known < 1e-9,
        "dead reckoning with the surface drift is off by {known}"
    );
    assert!(
        (blind - 10.0 * 0.05f64.sqrt()).abs() < 0.05,
        "blind error {blind}"
    );
}

#[test]
fn a_restarted_vehicle_that_has_heard_nothing_brakes_where_it_is() {
    // Admitted back at tick 3000 (150 s) near the mission's start: before its first
    // command it must not be pulled towards the start's leaders (the guidance it was
    // deployed with), only braked by its damping: its velocity keeps its direction and
    // decays.
    let mission = paper_mission(None);
    let design = initial_design(&mission).unwrap();
    let dt = mission.mission.dt;
    let (x0, v0) = (
        mission.start_vec() + Vec3::new(0.8, 0.3, 0.0),
        Vec3::new(0.2, 0.1, 0.0),
    );
    let restored = Agent {
        id: 0,
        dim: 2,
        position: x0,
        velocity: v0,
    };
    let mut vehicle = Vehicle::new(restored, Guidance::restarted(&mission, &design, 3000), 3000);
    let mut deployed = Vehicle::new(restored, Guidance::initial(&mission, &design), 3000);
    for k in 3000..3040 {
        vehicle.step(k, dt);
        deployed.step(k, dt);
    }
    let v = vehicle.agent.velocity;
    assert!(v.norm() < 0.5 * v0.norm(), "braked: {v:?}");
    assert!(
        v.cross(&v0).norm() <= 1e-12 && v.dot(&v0) > 0.0,
        "kept its heading: {v:?}"
    );
    let moved = (vehicle.agent.position - x0).norm();
    assert!(
        moved <= v0.norm() / mission.vehicles.damping + 1e-9,
        "coasted {moved}"
    );
    // The guidance it was deployed with pulls it about (towards the start's leaders).
    let apart = (deployed.agent.position - vehicle.agent.position).norm();
    assert!(apart > 0.01, "the deployed guidance pulls it: {apart}");
}

#[test]
fn a_step_deep_inside_a_repulsion_is_split_and_gains_no_energy() {
    // A vehicle at rest 0.15 d0 from a neighbour (a restarted vehicle next to a member):
    // one Euler step of (II.1)'s singular repulsion threw it at ~24 spacings per second.
    // Split into substeps, its kinetic energy after the step stays below the potential
    // energy the continuous law could have released over the distance it moved (the
    // damping only takes energy away).
    let inter = PairPotential::new(60.0, 1.0, 1.5).unwrap();
    let neighbour = [Vec3::zeros()];
    let inputs = AgentInputs::paper(&[], &neighbour, inter, inter, 5.0);
    let x0 = Vec3::new(0.15, 0.0, 0.0);
    let dt = 0.05;
    let mut agent = Agent {
        id: 0,
        dim: 2,
        position: x0,
        velocity: Vec3::zeros(),
    };
    let u = agent.step(&inputs, dt);
    assert!(
        u.norm() * dt * dt > crate::agent::SUBSTEP_REACH * inter.d0,
        "a split step: {u:?}"
    );
    let released = inter.value(x0.norm()) - inter.value(agent.position.norm());
    let kinetic = 0.5 * agent.velocity.norm_squared();
    assert!(agent.position.x > x0.x, "pushed away: {:?}", agent.position);
    assert!(
        kinetic <= released,
        "kinetic {kinetic} > released {released}"
    );
    // One Euler step of the same force: the energy the split removes.
    let euler_v = u * dt;
    assert!(0.5 * euler_v.norm_squared() > 10.0 * kinetic.max(released));
}

/// Told by its own entry and a list holding every other entry, exactly, a vehicle has the
/// guidance of the whole snapshot (leaders near it); told a shorter list, only those
/// neighbours; told at a quantum, the positions it reads are within half of it.
#[test]
fn a_vehicle_told_its_list_reads_what_the_whole_snapshot_says_of_those() {
    use vbap_ipc::compact::Precision;
    use vbap_ipc::msg::coordinator_to_agent::{own_index, SnapshotEntry};
    let mission = paper_mission(None);
    let design = initial_design(&mission).unwrap();
    let base = Guidance::initial(&mission, &design);
    let centre = base.leaders[0];
    let at = |dx: f64, dy: f64| centre + Vec3::new(dx, dy, 0.0);
    let entry = |id, alive, p: Vec3, age: f64| SnapshotEntry {
        id,
        alive,
        position: [p.x, p.y, p.z],
        velocity: [0.01 * id as f64, 0.0, 0.0],
        age,
        ..SnapshotEntry::default()
    };
    let mut snapshot = vec![
        entry(0, SnapshotEntry::MEMBER, at(0.0, 0.0), 0.0),
        entry(1, SnapshotEntry::MEMBER, at(0.7, 0.1), 0.5),
        entry(2, SnapshotEntry::LOST, at(-0.6, 0.2), 0.0),
        entry(3, SnapshotEntry::MEMBER, at(0.1, -0.8), 1.0),
        entry(4, SnapshotEntry::MEMBER, at(0.3, 0.4), 0.0),
    ];
    snapshot[3].rejoining = 1;
    snapshot[3].target = [centre.x + 0.2, centre.y - 0.6, 0.0];
    let exact = Telling {
        horizon: 0.0,
        precision: Precision::Exact,
        origin: centre,
    };
    let own = own_index(&snapshot, 0);
    let (whole, own_whole) = base.clone().with_neighbours_and_own(0, &snapshot);
    let (told, own_told) = base.clone().with_near(0, &snapshot, own, 1..5, &exact);
    assert_eq!(told, whole);
    assert_eq!(own_told, own_whole);
    let (short, _) = base.clone().with_near(0, &snapshot, own, [1, 4], &exact);
    assert_eq!(short.neighbours, vec![at(0.7, 0.1), at(0.3, 0.4)]);
    assert!(short.hulls.is_empty());
    let q = 0.01;
    let quantised = Telling {
        precision: Precision::Quantised(q),
        ..exact
    };
    let (rounded, _) = base.with_near(0, &snapshot, own, 1..5, &quantised);
    assert_eq!(rounded.neighbours.len(), whole.neighbours.len());
    for (a, b) in rounded.neighbours.iter().zip(&whole.neighbours) {
        assert!((a - b).amax() <= 0.5 * q + 1e-12, "{a} read as {b}");
    }
    assert_ne!(rounded.neighbours, whole.neighbours);
}
