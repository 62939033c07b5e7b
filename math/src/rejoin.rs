//! Bringing a vehicle back into the formation from anywhere: an extension of the control
//! law (II.1) and of the power `(∂V/∂x)ᵀẋ` that the speed law (IV.4) uses.
//!
//! The potentials of (II.1) have a finite reach: beyond the cut-offs `d1`, `h1` a vehicle
//! feels no force at all, so a vehicle that comes back (a restarted agent) far from the
//! formation would never move again. And a vehicle that comes back where it was lost may
//! find a neighbour almost on top of it, whose singular repulsion throws both out of reach.
//!
//! A *rejoining* vehicle `j` is given a target: a free slot `p*_j` of the formation
//! (chosen once by [`choose_slot`] among [`turned_slots`]; it moves, turns and scales with
//! the virtual body, and for a 2-D central design also follows the others as they turn
//! about the centre, [`fit_turn`]). It has a homing weight
//! `σ_j = σ(|x_j − p*_j|)` ([`homing_weight`]: 1 far from the slot, 0 within [`CAPTURE`]
//! of the spacing). The formation sees it as a mixture: weight `1 − σ_j` at its true
//! position `x_j`, weight `σ_j` at its slot `p*_j` (a *ghost* holding the slot open). So
//! the others arrange around the slot as if it were already there, and the vehicle flies
//! into the hole its ghost keeps. The potential part of (II.2) becomes
//!
//! `V_w = ½ Σ|ẋ_i|² + Σ_{i<j} Σ_{a,b} μ_i^a μ_j^b V_I(|y_i^a − y_j^b|)
//!        + Σ_i Σ_a μ_i^a Σ_l V_h(|y_i^a − b_l|) − E_n`,
//!
//! with `y_i^0 = x_i`, `μ_i^0 = 1 − σ_i`, `y_i^1 = p*_i`, `μ_i^1 = σ_i` (a member has
//! `σ_i = 0`: only its true position). Its control ([`blended_control_law`]) is the
//! gradient of `V_w` in `x_i` (σ held fixed) plus the homing term:
//!
//! `u_i = −(1 − σ_i) [Σ_j ((1 − σ_j) ∇V_I(x_i − x_j) + σ_j ∇V_I(x_i − p*_j))
//!        + Σ_l ∇V_h(x_i − b_l)] + σ_i K v_ref,i − K ẋ_i`,
//!
//! where `v_ref,i = ṙ + sat_w(g (p*_i − x_i))` ([`homing_velocity`]) flies the vehicle
//! towards its slot at most `w` faster than the body moves. Far away (`σ_i = 1`) this is
//! `u_i = −K (ẋ_i − v_ref,i)`: the damping of (II.1) kept, the velocity relaxing to `v_ref`
//! with time constant 1/K, no potential (no collision with anyone it crosses, no trap in
//! another slot's well); near its slot (`σ_i = 0`) it is exactly (II.1). `σ` is a smooth
//! function of the position: no switching, no chattering. With no vehicle rejoining every
//! `σ = 0`, `V_w` is `V` of (II.2) and the law is (II.1), term for term.
//!
//! The speed law (IV.4) is fed `V_w`, its `∂/∂s` and its power
//! `Σ_i [−K|ẋ_i|² + σ_i K ẋ_i·v_ref,i]` ([`blended_lyapunov_terms`]; the rate of `σ`
//! itself is left out: it only acts inside the blend band), and the body *waits* for the
//! vehicle: `ṡ` of (IV.4) is multiplied by [`waiting_factor`] `= 1 − max_j σ_j`, 0 while a
//! vehicle is out beyond the band, back to (IV.4) as it settles. A slower body never
//! breaks Theorem 4.1's bound (the proof needs only `0 ≤ ṡ ≤` the bracket), and the
//! vehicle closes on its slot at the homing speed whatever the absence lasted.

use super::barrier::Barrier;
use super::body::{BodyRates, VirtualBody};
use super::formation::FormationDesign;
use super::lyapunov::LyapunovTerms;
use super::potential::PairPotential;
use super::Vec3;

/// Capture radius as a fraction of the neighbour spacing `k d̄0`: within it of its slot a
/// vehicle flies pure (II.1) (`σ = 0`); the blend spans `[CAPTURE, 2 CAPTURE]` spacings.
/// Small, because the hand-over costs energy: at `σ = 0` `V` counts the vehicle's true
/// offset from its slot, about `½ κ e²` per potential of stiffness `κ ≈ α/d0²`, i.e. a
/// few percent of a pair's plateau at a tenth of the spacing (so well under `V_U`, which
/// the mission keeps below the plateaus); large enough that a vehicle lagging its slot as
/// the body moves (`K ṙ/ω²`, a few percent of the spacing in a well-tuned mission) is
/// still captured.
pub const CAPTURE: f64 = 0.1;

/// How far the repulsion kept between real vehicles while some rejoin reaches, as a
/// fraction of `d0` ([`add_repulsion`], a soft barrier of this reach). At `d0` itself it
/// would wall a hole off: a vehicle coming into its slot from inside a ring passes about
/// 6 % inside `d0` of both of the slot's neighbours, and was held there, its pull home
/// balanced by their repulsion, while the body waited for it (seen in random missions).
/// Half a spacing still stops a vehicle flying home at its homing speed well short of a
/// near collision (the barrier's energy from `d0/2` to `d0/10` is
/// `½ · 4 α/d0² · (0.4 d0)² = 0.32 α`, against `½ |v_ref|²` of a homing vehicle,
/// `|v_ref| ≤ v0 + w`).
pub const REPULSION_REACH: f64 = 0.5;

/// A slot is free for a rejoining vehicle when no member or slot already given to another
/// lies within this fraction of the spacing of it ([`choose_slot`]).
pub const FREE: f64 = 0.75;

/// The homing weight `σ(e)` of a vehicle at distance `e` (length) from its slot, for a
/// neighbour spacing `spacing = k d̄0` (length, > 0): 0 for `e ≤ CAPTURE·spacing`, 1 for
/// `e ≥ 2 CAPTURE·spacing`, the smoothstep `3t² − 2t³` of `t = e/(CAPTURE·spacing) − 1` in
/// between (C¹ in `e`). Dimensionless. A non-finite `e` counts as far (1).
pub fn homing_weight(e: f64, spacing: f64) -> f64 {
    let a = CAPTURE * spacing;
    if !e.is_finite() {
        return 1.0;
    }
    if a.is_nan() || a <= 0.0 || e <= a {
        return 0.0;
    }
    let t = ((e - a) / a).min(1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The homing reference velocity `v_ref = ṙ + sat_w(g (p* − x))`, length/s: the body's
/// velocity `body_velocity` (= dr/ds·ṡ) plus an approach towards the slot `target` (from
/// `x`, length) with gain `g = K/4` (`K = damping`, 1/s; `g = K/4` makes the position
/// error of `ẍ = −K(ẋ − v_ref)` critically damped) saturated at the speed `speed` (length/s,
/// ≥ 0) relative to the body: `|v_ref − ṙ| ≤ speed`.
pub fn homing_velocity(
    x: &Vec3,
    target: &Vec3,
    body_velocity: &Vec3,
    damping: f64,
    speed: f64,
) -> Vec3 {
    let e = target - x;
    let dist = e.norm();
    if dist.is_nan() || dist <= 0.0 || !dist.is_finite() {
        return *body_velocity;
    }
    let approach = (0.25 * damping * dist).min(speed.max(0.0));
    body_velocity + e * (approach / dist)
}

/// Where a vehicle at `x` flying home to its slot `target` aims now (length), around the
/// formation of the `others` (the other vehicles' positions) and not through it, for a
/// neighbour spacing `spacing` (length, > 0).
///
/// The blend keeps every pair's repulsion ([`add_repulsion`]), and a straight line from
/// outside to a slot on the far side crosses the formation: the vehicle would stop against
/// a member's repulsion, balanced by its own pull home, and the body would wait for it for
/// ever (seen in random missions). So, with `c` the centre of the others and the slot and
/// `R` their largest distance from it plus a spacing: when the segment from `x` to the
/// slot passes farther than half a spacing from every other vehicle, or `x` is inside the
/// formation (`|x − c| < R − spacing`), it aims at the slot; else at the point of the
/// sphere of radius `R` about `c` halfway (in direction) between `x` and the slot, which
/// walks it round the formation to the slot's side, where it comes in from outside.
pub fn approach_point(x: &Vec3, target: &Vec3, others: &[Vec3], spacing: f64) -> Vec3 {
    if others.is_empty() || spacing.is_nan() || spacing <= 0.0 {
        return *target;
    }
    let clear = others
        .iter()
        .all(|p| distance_to_segment(p, x, target) > 0.5 * spacing);
    let count = others.len() as f64 + 1.0;
    let c = (others.iter().sum::<Vec3>() + target) / count;
    let reach = others
        .iter()
        .chain(std::iter::once(target))
        .map(|p| (p - c).norm())
        .fold(0.0, f64::max)
        + spacing;
    let from = x - c;
    let to = target - c;
    if clear || from.norm() < reach - spacing || to.norm() <= 0.0 || from.norm() <= 0.0 {
        return *target;
    }
    let (u_x, u_s) = (from.normalize(), to.normalize());
    let mut w = u_x + u_s;
    if w.norm() < 1e-3 {
        // Opposite sides: go round in the plane of the formation (about z), or about x.
        let axis = if u_x.cross(&Vec3::z()).norm() > 1e-3 {
            Vec3::z()
        } else {
            Vec3::x()
        };
        w = axis.cross(&u_x);
    }
    c + reach * w.normalize()
}

/// The distance (length) from `p` to the segment from `a` to `b`.
fn distance_to_segment(p: &Vec3, a: &Vec3, b: &Vec3) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + t * ab)).norm()
}

/// How vehicle `i` rejoins: its homing weight `σ_i` and reference velocity `v_ref,i`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homing {
    /// `σ_i` of [`homing_weight`], in [0, 1].
    pub sigma: f64,
    /// `v_ref,i` of [`homing_velocity`], length/s.
    pub velocity: Vec3,
}

impl Homing {
    /// The homing of a vehicle at `x` flying to `target` (length) in a formation of
    /// spacing `spacing` (length), the body moving at `body_velocity` (length/s), damping
    /// `K = damping` (1/s), approach speed `speed` (length/s).
    pub fn towards(
        x: &Vec3,
        target: &Vec3,
        spacing: f64,
        body_velocity: &Vec3,
        damping: f64,
        speed: f64,
    ) -> Self {
        Self {
            sigma: homing_weight((target - x).norm(), spacing),
            velocity: homing_velocity(x, target, body_velocity, damping, speed),
        }
    }
}

impl Homing {
    /// [`Homing::towards`] the slot `target`, its reference velocity aimed at the
    /// [`approach_point`] round the `others` (length): `σ` is that of the distance to the
    /// slot itself.
    pub fn around(
        x: &Vec3,
        target: &Vec3,
        others: &[Vec3],
        spacing: f64,
        body_velocity: &Vec3,
        damping: f64,
        speed: f64,
    ) -> Self {
        let aim = approach_point(x, target, others, spacing);
        Self {
            sigma: homing_weight((target - x).norm(), spacing),
            velocity: homing_velocity(x, &aim, body_velocity, damping, speed),
        }
    }
}

/// Another vehicle as vehicle `i` sees it: its position, its homing weight `σ_j` (0 for
/// a member) and its slot `p*_j` (its ghost; unused when `σ_j = 0`), length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    /// Position `x_j`, length.
    pub position: Vec3,
    /// `σ_j` of [`homing_weight`], 0 for a member.
    pub sigma: f64,
    /// The slot `p*_j` it flies to, length.
    pub slot: Vec3,
}

impl Neighbour {
    /// A member of the formation at `position` (no ghost).
    pub fn member(position: Vec3) -> Self {
        Self {
            position,
            sigma: 0.0,
            slot: position,
        }
    }
}

/// The control acceleration `u_i` of the blended law (module docs), length/s²: vehicle at
/// `x_i` with velocity `v_i`; `homing` its own homing (None: not rejoining, `σ_i = 0`);
/// `neighbours` the other vehicles; `leaders`, `inter`, `leader`, `damping` as in
/// [`super::control::control_law`].
///
/// With `homing = None` and every neighbour a member the result equals
/// [`super::control::control_law`] bit for bit (same terms, same order). Pairs at distance
/// 0 are skipped; a term weighted 0 contributes nothing (even when singular).
#[allow(clippy::too_many_arguments)]
pub fn blended_control_law(
    x_i: &Vec3,
    v_i: &Vec3,
    homing: Option<&Homing>,
    neighbours: &[Neighbour],
    leaders: &[Vec3],
    inter: &PairPotential,
    leader: &PairPotential,
    damping: f64,
) -> Vec3 {
    let sigma_i = homing.map_or(0.0, |h| h.sigma);
    let own = 1.0 - sigma_i;
    let mut u = Vec3::zeros();
    for n in neighbours {
        let real = own * (1.0 - n.sigma);
        add_repulsion(&mut u, x_i, &n.position, inter, 1.0 - real);
    }
    if own > 0.0 {
        for n in neighbours {
            let real = own * (1.0 - n.sigma);
            if real > 0.0 {
                add_force(&mut u, x_i, &n.position, inter, real);
            }
            if n.sigma > 0.0 {
                add_force(&mut u, x_i, &n.slot, inter, own * n.sigma);
            }
        }
        for b in leaders {
            add_force(&mut u, x_i, b, leader, own);
        }
    }
    if let Some(h) = homing {
        if h.sigma > 0.0 {
            u += h.sigma * damping * h.velocity;
        }
    }
    u - damping * v_i
}

/// Adds `− w f(|x − p|) (x − p)/|x − p|` to `u` (as [`super::control::control_law`] does for
/// `w = 1`: `w = 1` multiplies exactly, so the sum is the same bit for bit).
fn add_force(u: &mut Vec3, x: &Vec3, p: &Vec3, pot: &PairPotential, w: f64) {
    let d = x - p;
    let dist = d.norm();
    if dist <= 0.0 || dist >= pot.d1 {
        return;
    }
    let f = pot.force(dist);
    if w == 1.0 {
        *u -= (f / dist) * d;
    } else {
        *u -= (w * f / dist) * d;
    }
}

/// Adds the repulsion `w` times the soft barrier of reach [`REPULSION_REACH`] · `d0`
/// round `p` ([`Barrier`], for the scaled inter-vehicle potential `pot`) to `u`: nothing at or
/// beyond the reach, for `w ≤ 0` or at distance 0.
///
/// Collision avoidance while vehicles rejoin (beyond the paper): the blend weighs the
/// pair term of a rejoining vehicle and a true neighbour by `(1 − σ_i)(1 − σ_j) < 1`,
/// down to 0 far from the slot, which would let a vehicle flying home pass through
/// another. The weight the blend takes away, `w = 1 − (1 − σ_i)(1 − σ_j)`, is given back
/// to the repulsion, so every pair of real vehicles repels inside `REPULSION_REACH · d0`,
/// whatever their homing; with nobody rejoining `w = 0` and nothing is added. It is the
/// gradient of the term [`blended_lyapunov_terms`] adds to `V_w` (that repulsion's
/// energy, weighted by `w`), so the speed law (IV.4) sees it.
///
/// A spring, not the repulsive part of `V_I` (a `1/x` wall, as before): a vehicle is
/// admitted back where it died, possibly a quarter of a spacing from a member, and the
/// wall threw both apart at 10–12 spacings per second in one step (`super::barrier`).
pub(crate) fn add_repulsion(u: &mut Vec3, x: &Vec3, p: &Vec3, pot: &PairPotential, w: f64) {
    Barrier::of(pot, REPULSION_REACH).push(u, x, p, w);
}

/// The energy of the repulsion the blend gives back ([`add_repulsion`]), energy per unit
/// mass, and its `∂/∂k` at fixed positions: `Σ_{i<j} c_ij V_b(d_ij)` over the pairs of true
/// positions closer than `d_r = REPULSION_REACH · d0`, `V_b` the soft barrier of that
/// reach ([`Barrier`]), `c_ij = 1 − (1 − σ_i)(1 − σ_j)` (`V_b(d_r) = 0`, so the term and
/// its force vanish at `d_r`: `V_w` plus this term is the potential whose gradient the
/// blended law follows, and the power of [`blended_lyapunov_terms`] stays exact; `V_b`
/// scales with `k` as `V_I` does). Zero when nobody rejoins.
fn repulsion_energy(
    positions: &[Vec3],
    homings: &[Option<(Homing, Vec3)>],
    inter: &PairPotential,
) -> (f64, f64) {
    let sigma = |h: &Option<(Homing, Vec3)>| h.as_ref().map_or(0.0, |(h, _)| h.sigma);
    let barrier = Barrier::of(inter, REPULSION_REACH);
    let (mut energy, mut d_scale) = (0.0, 0.0);
    for (i, (xi, hi)) in positions.iter().zip(homings).enumerate() {
        for (xj, hj) in positions[i + 1..].iter().zip(&homings[i + 1..]) {
            let c = 1.0 - (1.0 - sigma(hi)) * (1.0 - sigma(hj));
            let dist = (xi - xj).norm();
            if c > 0.0 && dist < barrier.reach {
                energy += c * barrier.value(dist);
                d_scale += c * barrier.d_value_d_scale(dist);
            }
        }
    }
    (energy, d_scale)
}

/// The factor on `ṡ` of (IV.4) while vehicles rejoin: `1 − max_j σ_j` over the
/// rejoining vehicles' homing weights (1 with none). Dimensionless, in [0, 1], as smooth
/// as `σ`: the body waits while a vehicle is out beyond the blend band.
pub fn waiting_factor(homings: &[Option<(Homing, Vec3)>]) -> f64 {
    1.0 - homings
        .iter()
        .flatten()
        .map(|(h, _)| h.sigma)
        .fold(0.0, f64::max)
}

/// `V_w`, `∂V_w/∂s` and the power of the blended loop (module docs), the terms (IV.4)
/// needs, for vehicles at `positions` with `velocities` (length, length/s), each with its
/// homing and slot `p*` (inertial, length) when it rejoins (`homings`, None for members),
/// the body `body` moving along `rates`, the design `design` and damping `damping` (1/s).
///
/// - `v = max(0, V_w)` with `E_n = design.equilibrium_energy(n)`, as in
///   [`super::lyapunov::lyapunov_terms`];
/// - `dv_ds`: every term's `∂/∂s`, with the slots moving rigidly with the body
///   (`dp*/ds = (k'/k)(p* − r) + ω × (p* − r) + dr/ds`): a true position against a leader
///   or a slot is differentiated like a leader term of (IV.4), two body-fixed points
///   (slot–slot, slot–leader) give 0 (scale invariance (III.3));
/// - `dv_dx_xdot = Σ_i [−K|ẋ_i|² + σ_i K ẋ_i·v_ref,i]`, the power of the blended law with
///   `σ` held fixed.
///
/// With every entry of `homings` None it equals `lyapunov_terms` (up to rounding).
///
/// # Panics
/// If the three slices differ in length (a programming error).
pub fn blended_lyapunov_terms(
    positions: &[Vec3],
    velocities: &[Vec3],
    homings: &[Option<(Homing, Vec3)>],
    body: &VirtualBody,
    rates: &BodyRates,
    design: &FormationDesign,
    damping: f64,
) -> LyapunovTerms {
    assert!(
        positions.len() == velocities.len() && positions.len() == homings.len(),
        "one velocity and one homing per position"
    );
    let k = body.scale;
    let inter = body.scaled_inter(design);
    let leader = body.scaled_leader(design);
    let (leaders, db_ds) = super::lyapunov::leader_motion(body, rates, design);
    // Rate of a body-fixed point p per unit s.
    let moving = |p: &Vec3| {
        let rel = p - body.r;
        rates.dk_ds / k * rel + rates.omega_ds.cross(&rel) + rates.dr_ds
    };
    // The weighted points of each vehicle: (point, weight, body-fixed).
    let points: Vec<Vec<(Vec3, f64, bool)>> = positions
        .iter()
        .zip(homings)
        .map(|(x, h)| match h {
            Some((h, slot)) if h.sigma > 0.0 => {
                vec![(*x, 1.0 - h.sigma, false), (*slot, h.sigma, true)]
            }
            _ => vec![(*x, 1.0, false)],
        })
        .collect();
    // One weighted pair term: value and ∂/∂s, for points a (rate da, or body-fixed) and
    // b (rate db, or body-fixed), under potential pot.
    let term = |a: &Vec3,
                fixed_a: bool,
                b: &Vec3,
                fixed_b: bool,
                db: &Vec3,
                pot: &PairPotential|
     -> (f64, f64) {
        let h = a - b;
        let dist = h.norm();
        let value = pot.value(dist);
        if !(dist > 0.0 && dist < pot.d1) || (fixed_a && fixed_b) {
            return (value, 0.0);
        }
        // Scale dependence of the potential, then motion of the body-fixed end(s).
        let mut d = pot.d_value_d_scale(dist) / k * rates.dk_ds;
        let f = pot.force(dist) / dist;
        if fixed_b {
            d -= f * h.dot(db);
        } else if fixed_a {
            d += f * h.dot(&moving(a));
        }
        (value, d)
    };
    let mut kinetic = 0.0;
    let mut power = 0.0;
    for (v, h) in velocities.iter().zip(homings) {
        kinetic += v.norm_squared();
        power -= damping * v.norm_squared();
        if let Some((h, _)) = h {
            power += h.sigma * damping * v.dot(&h.velocity);
        }
    }
    let mut potential = 0.0;
    let mut dv_ds = 0.0;
    for (i, pi) in points.iter().enumerate() {
        for pj in &points[i + 1..] {
            for (a, wa, fa) in pi {
                for (b, wb, fb) in pj {
                    let (val, d) = term(a, *fa, b, *fb, &moving(b), &inter);
                    potential += wa * wb * val;
                    dv_ds += wa * wb * d;
                }
            }
        }
        for (a, wa, fa) in pi {
            for (b, db) in leaders.iter().zip(&db_ds) {
                let (val, d) = term(a, *fa, b, true, db, &leader);
                potential += wa * val;
                dv_ds += wa * d;
            }
        }
    }
    let (repulsion, d_repulsion) = repulsion_energy(positions, homings, &inter);
    potential += repulsion;
    dv_ds += d_repulsion / k * rates.dk_ds;
    let raw = 0.5 * kinetic + potential - design.equilibrium_energy(positions.len());
    LyapunovTerms {
        v: raw.max(0.0),
        dv_ds,
        dv_dx_xdot: power,
    }
}

/// The turn `θ` (rad, about z in the body frame) that best lays the slots of a 2-D central
/// design, whose equilibrium is only defined up to a turn about the centre, on the vehicles
/// at `members` (length): the n-fold circular mean `θ = arg(Σ_i e^{i n (φ_i − φ̄_0)}) / n`
/// (`φ_i` the members' bearings in the body frame, `φ̄_0` that of slot 0, `n` the number
/// of slots; exact when the members sit on `n`-gon vertices), taken on the branch nearest
/// `previous` (θ is defined modulo 2π/n; following one branch keeps a slot from jumping to
/// its neighbour's place as the group turns). When the members do not lie on an `n`-gon
/// (`|Σ| < ½·count`, e.g. a regular pentagon against a hexagon), or with no member,
/// `previous` is kept. 0 for every other design (their slots are fixed in the body frame).
pub fn fit_turn(
    design: &FormationDesign,
    body: &VirtualBody,
    members: &[Vec3],
    previous: f64,
) -> f64 {
    let n = design.n();
    if !(design.dim == 2 && design.is_central() && n > 0) {
        return 0.0;
    }
    let phi0 = design.slots[0].y.atan2(design.slots[0].x);
    let inverse = body.rotation.inverse();
    let (mut c, mut s, mut count) = (0.0, 0.0, 0.0);
    for x in members {
        let q = inverse * (x - body.r);
        if q.x == 0.0 && q.y == 0.0 {
            continue;
        }
        let a = n as f64 * (q.y.atan2(q.x) - phi0);
        c += a.cos();
        s += a.sin();
        count += 1.0;
    }
    if count == 0.0 || (c * c + s * s).sqrt() < 0.5 * count {
        return previous;
    }
    let fit = s.atan2(c) / n as f64;
    let period = std::f64::consts::TAU / n as f64;
    let d = fit - previous;
    previous + (d - period * (d / period).round())
}

/// The slots of `design` in the inertial frame at `body` (`k R p̄ + r`, (III.3)), length,
/// turned first by `turn` (rad, about z in the body frame, [`fit_turn`]) for a 2-D central
/// design.
pub fn turned_slots(design: &FormationDesign, body: &VirtualBody, turn: f64) -> Vec<Vec3> {
    let rot = if design.dim == 2 && design.is_central() {
        nalgebra::Rotation3::from_axis_angle(&Vec3::z_axis(), turn)
    } else {
        nalgebra::Rotation3::identity()
    };
    design
        .slots
        .iter()
        .map(|p| body.to_inertial(&(rot * p)))
        .collect()
}

/// Distance from `slot` to the nearest of `occupants` (length; +∞ with none).
pub fn clearance(slot: &Vec3, occupants: &[Vec3]) -> f64 {
    occupants
        .iter()
        .map(|o| (slot - o).norm())
        .fold(f64::INFINITY, f64::min)
}

/// The slot (index into `slots`, inertial, length) for a rejoining vehicle at `x`: the
/// nearest to `x` of the free slots (clearance from every occupant — a member, or a slot
/// already given to another rejoining vehicle — at least `FREE·spacing`); when none is
/// free, the one with the largest clearance. Ties go to the lower index. `None` when
/// `slots` is empty.
pub fn choose_slot(slots: &[Vec3], occupants: &[Vec3], x: &Vec3, spacing: f64) -> Option<usize> {
    let clear: Vec<f64> = slots.iter().map(|p| clearance(p, occupants)).collect();
    let nearest_free = (0..slots.len())
        .filter(|&m| clear[m] >= FREE * spacing)
        .min_by(|&a, &b| (slots[a] - x).norm().total_cmp(&(slots[b] - x).norm()));
    nearest_free.or_else(|| {
        (0..slots.len()).reduce(|best, m| if clear[m] > clear[best] { m } else { best })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::{control_law, integrate};
    use crate::formation::{design_for_shape, design_regular};
    use crate::lyapunov::lyapunov_terms;
    use approx::assert_relative_eq;

    #[test]
    fn weight_is_zero_inside_one_outside_and_smooth() {
        let s = 0.5 / CAPTURE;
        assert_eq!(homing_weight(0.0, s), 0.0);
        assert_eq!(homing_weight(0.5, s), 0.0);
        assert_eq!(homing_weight(1.0, s), 1.0);
        assert_eq!(homing_weight(1e9, s), 1.0);
        assert_eq!(homing_weight(f64::INFINITY, s), 1.0);
        assert_relative_eq!(homing_weight(0.75, s), 0.5, max_relative = 1e-15);
        // Monotone, and C¹: the slope vanishes at both ends of the band.
        let mut last = 0.0;
        for i in 0..=1000 {
            let e = 0.4 + 0.7 * f64::from(i) / 1000.0;
            let w = homing_weight(e, s);
            assert!(w >= last && (0.0..=1.0).contains(&w));
            last = w;
        }
        let h = 1e-7;
        for e in [0.5, 1.0] {
            let slope = (homing_weight(e + h, s) - homing_weight(e - h, s)) / (2.0 * h);
            assert!(slope.abs() < 1e-5, "slope at {e}: {slope}");
        }
    }

    #[test]
    fn reference_velocity_is_saturated_relative_to_the_body() {
        let body = Vec3::new(0.3, 0.0, 0.0);
        let far = homing_velocity(&Vec3::zeros(), &Vec3::new(0.0, 100.0, 0.0), &body, 4.0, 0.5);
        assert_relative_eq!(far, Vec3::new(0.3, 0.5, 0.0), epsilon = 1e-15);
        // Near the slot: g e with g = K/4.
        let near = homing_velocity(&Vec3::zeros(), &Vec3::new(0.1, 0.0, 0.0), &body, 4.0, 0.5);
        assert_relative_eq!(near, Vec3::new(0.4, 0.0, 0.0), epsilon = 1e-15);
        assert_eq!(homing_velocity(&body, &body, &body, 4.0, 0.5), body);
    }

    struct Scene {
        design: FormationDesign,
        body: VirtualBody,
        x: Vec<Vec3>,
        v: Vec<Vec3>,
    }

    fn scene() -> Scene {
        let design = design_regular(6, 2, 1.5, 3.0, 2.0).unwrap();
        let body = VirtualBody {
            s: 0.0,
            r: Vec3::new(0.2, -0.1, 0.0),
            rotation: nalgebra::Rotation3::from_axis_angle(&Vec3::z_axis(), 0.4),
            scale: 1.3,
        };
        let x: Vec<Vec3> = body
            .slot_positions(&design)
            .iter()
            .enumerate()
            .map(|(i, p)| p + Vec3::new(0.05 * i as f64, -0.03 * i as f64, 0.0))
            .collect();
        let v: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(0.1 * i as f64 - 0.2, 0.05 * i as f64, 0.0))
            .collect();
        Scene { design, body, x, v }
    }

    fn rates() -> BodyRates {
        BodyRates {
            dr_ds: Vec3::new(0.6, -0.8, 0.0),
            omega_ds: Vec3::new(0.0, 0.0, 0.3),
            dk_ds: -0.2,
        }
    }

    #[test]
    fn with_nobody_rejoining_it_is_the_papers_law_and_v() {
        let Scene { design, body, x, v } = scene();
        let leaders = body.leader_positions(&design);
        let (inter, leader) = (body.scaled_inter(&design), body.scaled_leader(&design));
        for i in 0..x.len() {
            let others: Vec<Vec3> = (0..x.len()).filter(|&j| j != i).map(|j| x[j]).collect();
            let members: Vec<Neighbour> = others.iter().map(|p| Neighbour::member(*p)).collect();
            let a = control_law(&x[i], &v[i], &others, &leaders, &inter, &leader, 0.7);
            let b =
                blended_control_law(&x[i], &v[i], None, &members, &leaders, &inter, &leader, 0.7);
            assert_eq!(a, b);
        }
        let none = vec![None; x.len()];
        let w = blended_lyapunov_terms(&x, &v, &none, &body, &rates(), &design, 0.7);
        let t = lyapunov_terms(&x, &v, &body, &rates(), &design, 0.7);
        assert_relative_eq!(w.v, t.v, max_relative = 1e-12);
        assert_relative_eq!(w.dv_ds, t.dv_ds, max_relative = 1e-12);
        assert_relative_eq!(w.dv_dx_xdot, t.dv_dx_xdot, max_relative = 1e-12);
        assert_eq!(waiting_factor(&none), 1.0);
    }

    #[test]
    fn far_from_its_slot_a_vehicle_feels_no_potential_and_tracks_v_ref() {
        let (inter, leader) = (
            PairPotential::new(1.0, 1.0, 1.5).unwrap(),
            PairPotential::new(1.0, 1.0, 4.0).unwrap(),
        );
        let homing = Homing::towards(
            &Vec3::zeros(),
            &Vec3::new(50.0, 0.0, 0.0),
            1.0,
            &Vec3::zeros(),
            2.0,
            0.5,
        );
        assert_eq!(homing.sigma, 1.0);
        // A neighbour within reach but beyond d0 and a leader close by: no force from
        // either (the attraction is blended away).
        let u = blended_control_law(
            &Vec3::zeros(),
            &Vec3::new(0.0, 1.0, 0.0),
            Some(&homing),
            &[Neighbour::member(Vec3::new(1.2, 0.0, 0.0))],
            &[Vec3::new(0.0, 0.5, 0.0)],
            &inter,
            &leader,
            2.0,
        );
        assert_relative_eq!(
            u,
            2.0 * (Vec3::new(0.5, 0.0, 0.0) - Vec3::new(0.0, 1.0, 0.0))
        );
        // A neighbour closer than REPULSION_REACH·d0 still repels it at full strength (no
        // collision), with the soft barrier of that reach.
        let close = |at: f64| {
            blended_control_law(
                &Vec3::zeros(),
                &Vec3::zeros(),
                Some(&homing),
                &[Neighbour::member(Vec3::new(at, 0.0, 0.0))],
                &[],
                &inter,
                &leader,
                2.0,
            )
        };
        let barrier = Barrier::of(&inter, REPULSION_REACH);
        let push = barrier.kappa * (barrier.reach - 0.3);
        assert!(push > 0.0);
        assert_relative_eq!(
            close(0.3),
            2.0 * Vec3::new(0.5, 0.0, 0.0) - Vec3::new(push, 0.0, 0.0),
            max_relative = 1e-12
        );
        // Between the reach and d0 it feels nothing from it: a hole's neighbours at d0 from
        // the slot do not wall it off.
        assert_eq!(close(0.6), 2.0 * Vec3::new(0.5, 0.0, 0.0));
        assert!(inter.force(0.6) < 0.0);
        // A member next to a far rejoining vehicle (beyond d0) feels its ghost in the
        // slot, not it.
        let ghost = Neighbour {
            position: Vec3::new(-1.3, 0.0, 0.0),
            sigma: 1.0,
            slot: Vec3::new(1.2, 0.0, 0.0),
        };
        let u = blended_control_law(
            &Vec3::zeros(),
            &Vec3::zeros(),
            None,
            &[ghost],
            &[],
            &inter,
            &leader,
            2.0,
        );
        assert_relative_eq!(
            u,
            Vec3::new(inter.force(1.2), 0.0, 0.0),
            max_relative = 1e-15
        );
    }

    /// With one vehicle rejoining inside the blend band: the power is the time derivative
    /// of V_w along the blended loop (σ and the slot held fixed), and ∂V_w/∂s is its
    /// derivative along the body rates (the slot moving with the body).
    #[test]
    fn blended_terms_are_the_derivatives_of_v_w() {
        let Scene {
            design,
            body,
            mut x,
            v,
        } = scene();
        let spacing = body.scale * design.neighbour_spacing();
        let slots = body.slot_positions(&design);
        x[3] = slots[3]
            + body.rotation * Vec3::new(1.4 * CAPTURE * spacing, 0.4 * CAPTURE * spacing, 0.0);
        let damping = 1.5;
        let h = Homing::towards(&x[3], &slots[3], spacing, &Vec3::zeros(), damping, 0.4);
        assert!(h.sigma > 0.0 && h.sigma < 1.0, "σ = {}", h.sigma);
        let mut homings = vec![None; 6];
        homings[3] = Some((h, slots[3]));
        let leaders = body.leader_positions(&design);
        let (inter, leader) = (body.scaled_inter(&design), body.scaled_leader(&design));
        let u: Vec<Vec3> = (0..6)
            .map(|i| {
                let nb: Vec<Neighbour> = (0..6)
                    .filter(|&j| j != i)
                    .map(|j| match &homings[j] {
                        Some((h, slot)) => Neighbour {
                            position: x[j],
                            sigma: h.sigma,
                            slot: *slot,
                        },
                        None => Neighbour::member(x[j]),
                    })
                    .collect();
                let own = homings[i].as_ref().map(|(h, _)| *h);
                blended_control_law(
                    &x[i],
                    &v[i],
                    own.as_ref(),
                    &nb,
                    &leaders,
                    &inter,
                    &leader,
                    damping,
                )
            })
            .collect();
        let t = blended_lyapunov_terms(&x, &v, &homings, &body, &rates(), &design, damping);
        let at = |x: &[Vec3], v: &[Vec3], b: &VirtualBody, slot: Vec3| {
            let mut hs = homings.clone();
            hs[3] = Some((h, slot));
            let z = BodyRates::zero();
            // The unclamped value: V_w + E_n (the clamp is inactive here).
            blended_lyapunov_terms(x, v, &hs, b, &z, &design, damping).v
        };
        let dt = 1e-6;
        let step = |sign: f64| -> (Vec<Vec3>, Vec<Vec3>) {
            (
                (0..6).map(|i| x[i] + sign * v[i] * dt).collect(),
                (0..6).map(|i| v[i] + sign * u[i] * dt).collect(),
            )
        };
        let (x1, v1) = step(1.0);
        let (x0, v0) = step(-1.0);
        let fd = (at(&x1, &v1, &body, slots[3]) - at(&x0, &v0, &body, slots[3])) / (2.0 * dt);
        assert!(t.v > 0.0);
        assert_relative_eq!(t.dv_dx_xdot, fd, max_relative = 1e-5, epsilon = 1e-7);
        let ds = 1e-6;
        let slot_at = |b: &VirtualBody| b.slot_positions(&design)[3];
        let b1 = body.advance(&rates(), ds);
        let b0 = body.advance(&rates(), -ds);
        let fd = (at(&x, &v, &b1, slot_at(&b1)) - at(&x, &v, &b0, slot_at(&b0))) / (2.0 * ds);
        assert_relative_eq!(t.dv_ds, fd, max_relative = 1e-5, epsilon = 1e-7);
        assert_relative_eq!(waiting_factor(&homings), 1.0 - h.sigma);
    }

    /// A vehicle 47 lengths away, at rest, on the far side of a hexagon whose five others
    /// hold their slots, flies the blended law to its slot: round the formation, not into
    /// a member's repulsion; it arrives within the capture radius, never faster than the
    /// approach speed, and settles in the slot.
    #[test]
    fn a_far_vehicle_is_brought_into_its_slot() {
        let design = design_regular(6, 2, 1.0, 2.0, 2.0).unwrap();
        let body = VirtualBody::at(Vec3::zeros());
        let leaders = body.leader_positions(&design);
        let (inter, leader) = (body.scaled_inter(&design), body.scaled_leader(&design));
        let spacing = inter.d0;
        let slots = body.slot_positions(&design);
        let members: Vec<Neighbour> = slots[..5].iter().map(|p| Neighbour::member(*p)).collect();
        let target = slots[5];
        let (damping, speed, dt) = (2.0, 0.5, 0.01);
        let mut x = target + Vec3::new(-40.0, 25.0, 0.0);
        let mut v = Vec3::zeros();
        let mut max_speed: f64 = 0.0;
        let mut captured_at = None;
        for step in 0..40_000 {
            let others: Vec<Vec3> = members.iter().map(|m| m.position).collect();
            let h = Homing::around(
                &x,
                &target,
                &others,
                spacing,
                &Vec3::zeros(),
                damping,
                speed,
            );
            if h.sigma == 0.0 && captured_at.is_none() {
                captured_at = Some(step);
            }
            let u = blended_control_law(
                &x,
                &v,
                Some(&h),
                &members,
                &leaders,
                &inter,
                &leader,
                damping,
            );
            (x, v) = integrate(&x, &v, &u, dt);
            max_speed = max_speed.max(v.norm());
        }
        assert!(captured_at.is_some(), "never captured, at {x}");
        assert!(max_speed <= speed * (1.0 + 1e-9), "max speed {max_speed}");
        // Distance 47.2 at ≤ 0.5: at least 94 s; the law gets there within 30 % more.
        let t = captured_at.unwrap() as f64 * dt;
        assert!(t < 1.3 * 47.2 / speed, "captured after {t} s");
        assert!(
            (x - target).norm() < 0.05 * spacing,
            "final error {}",
            (x - target).norm()
        );
    }

    #[test]
    fn slots_are_turned_to_the_members_of_a_central_2d_design() {
        let design = design_regular(6, 2, 2.0, 1.0, 1.0).unwrap();
        let body = VirtualBody::at(Vec3::new(5.0, 1.0, 0.0));
        let period = std::f64::consts::TAU / 6.0;
        for angle in [0.3, -0.4, 0.3 + 2.0 * period] {
            let turn = nalgebra::Rotation3::from_axis_angle(&Vec3::z_axis(), angle);
            // Five vehicles on five vertices of the hexagon turned by `angle`.
            let members: Vec<Vec3> = design.slots[..5]
                .iter()
                .map(|p| body.r + turn * p)
                .collect();
            // Followed from a nearby turn: the branch of `angle` nearest it.
            let theta = fit_turn(&design, &body, &members, angle - 0.1);
            assert_relative_eq!(theta, angle, epsilon = 1e-12);
            let slots = turned_slots(&design, &body, theta);
            for (m, p) in slots.iter().zip(&design.slots) {
                assert_relative_eq!(*m, body.r + turn * p, epsilon = 1e-12);
            }
            let spacing = design.neighbour_spacing();
            let chosen = choose_slot(&slots, &members, &Vec3::new(-50.0, 0.0, 0.0), spacing);
            assert_eq!(chosen, Some(5));
        }
        // No n-gon to fit (a regular pentagon against a hexagon): the previous turn stays.
        let pentagon = design_regular(5, 2, 2.0, 1.0, 1.0).unwrap();
        let members: Vec<Vec3> = pentagon.slots.iter().map(|p| body.r + p).collect();
        assert_eq!(fit_turn(&design, &body, &members, 0.2), 0.2);
        // Per-slot designs are not turned.
        let shape = design_for_shape(
            &[
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(-1.0, 0.5, 0.0),
                Vec3::zeros(),
            ],
            2,
            1.0,
            1.0,
        )
        .unwrap();
        assert!(!shape.is_central());
        assert_eq!(fit_turn(&shape, &body, &members, 0.2), 0.0);
        assert_eq!(
            turned_slots(&shape, &body, 0.2),
            body.slot_positions(&shape)
        );
    }

    #[test]
    fn the_nearest_free_slot_is_chosen_and_claims_count() {
        let slots = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
        ];
        let members = [Vec3::new(0.05, 0.0, 0.0), Vec3::new(3.0, 0.1, 0.0)];
        let x = Vec3::new(10.0, 0.0, 0.0);
        assert_eq!(choose_slot(&slots, &members, &x, 1.0), Some(2));
        let claimed = [members[0], members[1], slots[2]];
        assert_eq!(choose_slot(&slots, &claimed, &x, 1.0), Some(1));
        // Nothing free: the largest clearance.
        let crowded = [
            Vec3::new(0.0, 0.1, 0.0),
            Vec3::new(1.0, 0.1, 0.0),
            Vec3::new(2.0, 0.3, 0.0),
            Vec3::new(3.0, 0.1, 0.0),
        ];
        assert_eq!(choose_slot(&slots, &crowded, &x, 1.0), Some(2));
        assert_eq!(choose_slot(&[], &crowded, &x, 1.0), None);
    }
}
