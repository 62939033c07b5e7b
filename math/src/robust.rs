//! Control with stale information (beyond the paper): the law [`RobustLaw`] of
//! `control.law = "robust"`.
//!
//! Theorem 4.1 assumes every vehicle senses its neighbours continuously. Over real links a
//! vehicle only knows the neighbour states the coordinator relayed, each `a_j` seconds old
//! (the coordinator's information age plus the age of the command it steps on). A spring
//! of stiffness `κ` acting on a position `a` seconds old pulls towards where the neighbour
//! was: for small `a` its force carries a term `+κ a ẋ_rel`, an anti-damping that beats the
//! damping `K` of (II.1) once `κ a > K`. That is how 0.5 s old neighbours destabilise a
//! formation shrunk to a fifth of its size (`κ` grows as `1/k²`).
//!
//! The law here weighs the inter-vehicle term of each neighbour `j` of (II.1) by
//! `w_j = exp(−a_j/τ)` ([`fade`]) and hands what is lost to a spring towards the vehicle's
//! own slot `p_i` (its place in the design `k R p̄_i + r`, which the vehicle computes
//! exactly from the body it dead-reckons; it is the virtual leader that holds the
//! vehicle's angle about a central leader, free under `V_h` alone):
//!
//! `u_i = −Σ_j w_j ∇V_I(x_i − x̂_j) − Σ_l ∇V_h(x_i − b_l)
//!        − (1 − w̄) [κ_s (x_i − p_i) − K ṙ] − K ẋ_i`,
//!
//! with `x̂_j` the predicted neighbour ([`predict_neighbour`]), `w̄` the mean of the `w_j`,
//! `κ_s = α_h/h0²` the stiffness of the scaled leader potential at its equilibrium
//! ([`slot_stiffness`]) and `ṙ` the body's velocity (the slot spring is damped relative to
//! the body, so a vehicle holding its slot does not lag it). Rejoining vehicles and
//! neighbours blend in as in `super::rejoin` (the ghost `p*_j` of a rejoining neighbour is
//! body-fixed, hence exact, and is not faded; a rejoining neighbour itself, `σ_j > 0`,
//! flies its own homing path and is not predicted).
//!
//! The memory `τ` (s) is `control.neighbour_memory`, or by default [`derived_memory`]
//! `τ = K d0²/α_I = K/κ_I` of the scaled inter-vehicle potential: the anti-damping
//! `w(a) κ_I a` is largest at `a = τ`, where it is `κ_I τ/e = K/e`, below the damping by
//! a factor `e` whatever the ages. Fresh information (`a_j = 0`, ideal links) gives
//! `w_j = 1`, no slot term and no prediction: the law is then [`super::law::PaperLaw`],
//! bit for bit (unless it follows the body, below,
//! or a lost vehicle's hull is within reach: every vehicle keeps clear of those, `super::hull`).
//!
//! **Following the body.** (II.1) damps each vehicle relative to the water, `−K ẋ_i`, so a
//! formation whose body moves at `ṙ` trails it in steady state by `K |ṙ| / κ_T`, `κ_T` the
//! leaders' stiffness against a translation (half the leader spring `α_h/h0²` for a central
//! ring). `κ_T` goes as `1/k²`: a formation grown by adaptation to twice its size trails
//! four times as far, a quarter of a spacing and more at the stress campaign's speeds,
//! and a ring that far off its leader re-forms out of its slots (measured). Where the
//! envelope holds (the robust law over impaired links), or where that lag would pass an
//! eighth of a spacing on ideal links (`RobustLaw::follow_body`, chosen by the mission),
//! the law damps relative to the motion of the vehicle's slot instead,
//! `−K (ẋ_i − ṗ_i)` with `ṗ_i = ṙ + (k̇/k)(p_i − r)` ([`ControlInputs::slot_velocity`]):
//! the slot spring's share of `K ṙ` above becomes the whole of it, on fresh information as
//! well, and a growing formation's slots are followed as they move outwards. A formation
//! moving with its body then feels exactly the forces it feels at rest: no steady lag,
//! whatever the scale. Each vehicle knows `ṙ`, `k̇` and `r` from the body it
//! dead-reckons (`k̇` only along a committed path; `ṙ` alone otherwise). A glider is
//! given its velocity through the water; with its estimate `ĉ` of the current it damps
//! over the ground instead, `−K (ẋ_i + ĉ − ṗ_i)` ([`ControlInputs::follow_velocity`]):
//! damped against the water, a formation holding still in a current settles downstream
//! of its slots exactly as a cruising one trails its body, by (T.1) with `v = |ĉ|`
//! (a 16-glider ring on 0.25 L/s of current: 0.4–0.55 L, two gliders squeezed out).

use super::hull::add_hull_barriers;
use super::law::{ControlInputs, ControlLaw, PaperLaw};
use super::potential::PairPotential;
use super::rejoin::add_repulsion;
use super::Vec3;

/// The fade `w(a) = exp(−a/τ)` of information `age` seconds old for a memory `memory` =
/// τ (s, > 0): 1 for `age ≤ 0` (exactly), decreasing to 0; an infinite memory never fades.
/// Dimensionless.
pub fn fade(age: f64, memory: f64) -> f64 {
    if age.is_nan() || age <= 0.0 || memory == f64::INFINITY {
        return 1.0;
    }
    (-age / memory).exp()
}

/// The default memory `τ = K d0²/α` (s) of the scaled inter-vehicle potential `inter`
/// (`α` in (length/s)², `d0` length) and damping `K = damping` (1/s): the damping time of
/// one neighbour spring `κ_I = α/d0²` (module docs). +∞ when `α ≤ 0` (no spring).
pub fn derived_memory(inter: &PairPotential, damping: f64) -> f64 {
    if inter.alpha.is_nan() || inter.alpha <= 0.0 {
        return f64::INFINITY;
    }
    damping * inter.d0 * inter.d0 / inter.alpha
}

/// The stiffness `κ_s = α/h0²` (1/s²) of the slot spring: that of the scaled leader
/// potential `leader` at its equilibrium distance (`f'(h0)` of the Leonard–Fiorelli force).
pub fn slot_stiffness(leader: &PairPotential) -> f64 {
    leader.alpha / (leader.d0 * leader.d0)
}

/// How far a neighbour drifts relative to the body in `age` seconds (length): its last
/// relative velocity `velocity − body_velocity` (length/s), decaying at the damping rate
/// `K = damping` (1/s) as a damped vehicle's does with no force acting,
/// `(v_j − ṙ)(1 − e^{−K a})/K` (`(v_j − ṙ) a` when `K = 0`). Zero for `age ≤ 0`.
pub fn relative_drift(velocity: &Vec3, body_velocity: &Vec3, age: f64, damping: f64) -> Vec3 {
    if age.is_nan() || age <= 0.0 {
        return Vec3::zeros();
    }
    let reach = if damping > 0.0 {
        -(-damping * age).exp_m1() / damping
    } else {
        age
    };
    (velocity - body_velocity) * reach
}

/// A neighbour's predicted position (length): its last known position already moved with
/// the body (`moved`: the relayed position plus the body's shift since it was taken, as
/// the coordinator and the vehicle dead-reckon it) plus its [`relative_drift`] over its
/// information age `age` (s), from its last velocity `velocity` and the body's velocity
/// `body_velocity` (length/s), damping `damping` (1/s). `moved` itself when `age ≤ 0`.
pub fn predict_neighbour(
    moved: &Vec3,
    velocity: &Vec3,
    body_velocity: &Vec3,
    age: f64,
    damping: f64,
) -> Vec3 {
    if age.is_nan() || age <= 0.0 {
        return *moved;
    }
    moved + relative_drift(velocity, body_velocity, age, damping)
}

/// The law of `control.law = "robust"` (module docs): (II.1) with faded, predicted
/// neighbour terms and a slot spring that takes over as they fade.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RobustLaw {
    /// τ of [`fade`], s (`control.neighbour_memory`); None: [`derived_memory`] of each
    /// step's potentials.
    pub memory: Option<f64>,
    /// Damp each vehicle relative to the body, `−K (ẋ_i − ṙ)`, rather than relative to the
    /// water, `−K ẋ_i` (module docs, "Following the body"). Set where the envelope holds
    /// (impaired links); off, the law on fresh information is the paper's.
    pub follow_body: bool,
}

impl RobustLaw {
    /// The robust law with memory `memory` (s; None: derived from the formation), damping
    /// relative to the water.
    pub fn new(memory: Option<f64>) -> Self {
        Self {
            memory,
            follow_body: false,
        }
    }

    /// The same law damping relative to the body when `follow_body`
    /// ([`RobustLaw::follow_body`]).
    pub fn following(self, follow_body: bool) -> Self {
        Self {
            follow_body,
            ..self
        }
    }
}

impl ControlLaw for RobustLaw {
    fn control(&self, position: &Vec3, velocity: &Vec3, inputs: &ControlInputs<'_>) -> Vec3 {
        let mut u = if inputs
            .neighbour_ages
            .iter()
            .all(|a| a.is_nan() || *a <= 0.0)
        {
            let u = PaperLaw.control(position, velocity, inputs);
            if self.follow_body {
                let own = 1.0 - inputs.homing.map_or(0.0, |h| h.sigma);
                u + own * inputs.damping * inputs.follow_velocity()
            } else {
                u
            }
        } else {
            let memory = self
                .memory
                .unwrap_or_else(|| derived_memory(&inputs.inter, inputs.damping));
            robust_control_law(position, velocity, inputs, memory, self.follow_body)
        };
        add_hull_barriers(&mut u, position, inputs.hulls, &inputs.inter);
        u
    }
}

/// `u_i` of the module docs (length/s²) for a vehicle at `x_i` (length) with velocity
/// `v_i` (length/s), with neighbour memory `memory` (s). Neighbour `j` is at
/// `inputs.neighbours[j]` moved with the body, `inputs.neighbour_ages[j]` s old (0 when
/// absent), predicted with `inputs.neighbour_velocities[j]` (not when absent). With
/// `follow_body`, damped relative to the body: `+ K ṙ` whole, not only the slot spring's
/// share.
pub fn robust_control_law(
    x_i: &Vec3,
    v_i: &Vec3,
    inputs: &ControlInputs<'_>,
    memory: f64,
    follow_body: bool,
) -> Vec3 {
    let k = inputs.damping;
    let own = 1.0 - inputs.homing.map_or(0.0, |h| h.sigma);
    let mut u = Vec3::zeros();
    let mut kept = 0.0;
    for (j, x_j) in inputs.neighbours.iter().enumerate() {
        let age = inputs.neighbour_ages.get(j).copied().unwrap_or(0.0);
        let w = fade(age, memory);
        kept += w;
        let sigma_j = inputs.neighbour_sigmas.get(j).copied().unwrap_or(0.0);
        // A rejoining neighbour flies its own homing path (round the formation, slowing
        // into its slot), not the formation's: extrapolating its velocity put it 0.24
        // spacing from a member it was 0.87 from, whose repulsion then threw the member at
        // 40 spacings per second (seen in random missions). It counts where it was seen.
        let seen = match inputs.neighbour_velocities.get(j) {
            Some(v_j) if sigma_j == 0.0 => {
                predict_neighbour(x_j, v_j, &inputs.body_velocity, age, k)
            }
            _ => *x_j,
        };
        add_force(&mut u, x_i, &seen, &inputs.inter, own * w * (1.0 - sigma_j));
        // The repulsion kept while someone rejoins acts where the neighbour was seen, not
        // where its last velocity extrapolates it: a member ringing at 3 L/s was predicted
        // 0.7 L ahead over 0.8 s, 0.2 L from a homing vehicle it was 0.9 L from, whose
        // repulsion then threw that vehicle at 23 L/s (stress seed 29, m0015: true V
        // 2.5 V_U). The extrapolation serves the faded spring, which weighs it by `w`.
        add_repulsion(&mut u, x_i, x_j, &inputs.inter, 1.0 - own * (1.0 - sigma_j));
        if sigma_j > 0.0 {
            let ghost = inputs.neighbour_slots.get(j).copied().unwrap_or(seen);
            add_force(&mut u, x_i, &ghost, &inputs.inter, own * sigma_j);
        }
    }
    for b in inputs.leaders {
        add_force(&mut u, x_i, b, &inputs.leader, own);
    }
    let n = inputs.neighbours.len();
    let lost = if n == 0 { 0.0 } else { 1.0 - kept / n as f64 };
    // The body's velocity fed forward: with the slot spring's share (the slot spring is
    // damped relative to the body), or whole when following the body.
    if let Some(slot) = inputs.slot {
        if lost > 0.0 {
            let kappa = slot_stiffness(&inputs.leader);
            let feed = if follow_body {
                Vec3::zeros()
            } else {
                k * inputs.body_velocity
            };
            u += own * lost * (feed - kappa * (x_i - slot));
        }
    }
    if follow_body {
        u += own * k * inputs.follow_velocity();
    }
    if let Some(h) = inputs.homing {
        if h.sigma > 0.0 {
            u += h.sigma * k * h.velocity;
        }
    }
    u - k * v_i
}

/// Adds `− w f(|x − p|) (x − p)/|x − p|` to `u` (nothing for `w ≤ 0`, at distance 0 or
/// beyond the cut-off).
fn add_force(u: &mut Vec3, x: &Vec3, p: &Vec3, pot: &PairPotential, w: f64) {
    if w.is_nan() || w <= 0.0 {
        return;
    }
    let d = x - p;
    let dist = d.norm();
    if dist <= 0.0 || dist >= pot.d1 {
        return;
    }
    *u -= (w * pot.force(dist) / dist) * d;
}

/// One source of what a vehicle knows of a neighbour (the coordinator's relay, a frame its
/// acoustic modem decoded): the neighbour's position moved with the body to now (length),
/// its last velocity (length/s) and the information's age (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Position, length unit.
    pub position: Vec3,
    /// Velocity, length unit/s.
    pub velocity: Vec3,
    /// Age, s.
    pub age: f64,
}

/// Two sources of one neighbour fused, each weighed by its own fade `w = exp(−age/τ)`
/// ([`fade`], memory τ = `memory` s): the weighted mean of their positions and velocities,
/// as old as the fresher (the law then fades the term by the fresher's weight). When both
/// have faded to nothing (or τ is 0), the fresher alone.
pub fn fuse(a: &Source, b: &Source, memory: f64) -> Source {
    let (wa, wb) = (fade(a.age, memory), fade(b.age, memory));
    let fresher = if b.age < a.age { b } else { a };
    let total = wa + wb;
    if total.is_nan() || total <= 0.0 || total.is_infinite() {
        return *fresher;
    }
    Source {
        position: (wa * a.position + wb * b.position) / total,
        velocity: (wa * a.velocity + wb * b.velocity) / total,
        age: fresher.age,
    }
}

#[cfg(test)]
mod tests;
