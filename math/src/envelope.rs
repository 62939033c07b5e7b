//! The stability envelope of a formation over its links (beyond the paper): the smallest
//! scale `k`, the largest body speed and the largest rate of adaptation `|dk/dt|` that
//! the potentials of (II.1) can hold when every neighbour's position is seconds old.
//! The derivation, with its assumptions, is `docs/ENVELOPE.md`; in short:
//!
//! **The linearised law.** About the designed equilibrium (slots `p̄_i` at scale 1) the
//! law of a vehicle is `ẍ = −M x − K ẋ − Q (x̂ − x)`, with `x̂` the neighbours' positions
//! as the vehicle knows them: an age `a` old and, under the robust law, predicted over
//! that age from their last velocity, `x̂ = x(t − a) + c ẋ(t − a)`,
//! `c = (1 − e^{−K a})/K` (`super::robust::relative_drift`). With `H_I` the Hessian of the
//! inter-vehicle terms (`O_I` its off-diagonal blocks: what the neighbours' positions
//! enter), `H_L` that of the leader terms and `κ_s` the slot spring
//! (`super::robust::slot_stiffness`), every one at scale 1, a neighbour term weighed by
//! `w = exp(−a/τ)` (`super::robust::fade`), at scale `k` (stiffnesses go as `1/k²`, (III.3)):
//!
//! - robust law: `M = (w H_I + H_L + (1 − w) κ_s I)/k²`, `Q = w O_I/k²`;
//! - paper law: `M = (H_I + H_L)/k²`, `Q = O_I/k²`, `c = 0`.
//!
//! **The test.** The delayed neighbours are a perturbation `Δ(s) = Q (e^{−sa}(1 + cs) − 1)`
//! of the undelayed loop `(s² + Ks + M)⁻¹`. By the small-gain theorem the formation is
//! stable for every age in `[a_min, a_max]` when the loop gain
//!
//! `g = sup_{ω > 0, a} ‖Q‖ |e^{−iωa}(1 + icω) − 1| / min_m |μ_m − ω² + iKω| < 1`
//!
//! (`μ_m` the eigenvalues of `M`). It is a sufficient condition: a scale it passes is held
//! whatever the ages in the range do, modes and phases included. A scale also needs an
//! accurate integration of (II.1): `√μ_max · dt ≤ 1` (the semi-implicit Euler step is
//! stable below 2, accurate well below).
//!
//! **Speed and adaptation.** A vehicle must follow its slot `k R p̄_i + r`: the body at
//! `ṙ` and the slot's own motion `k̇ p̄_i`. Its speed budget (a glider's speed through the
//! water less the current) bounds `|ṙ| + |k̇| max|p̄_i|`; the slot spring, damped relative to
//! the body, follows a slot that moves at `k̇ p̄_i` with a lag `K |k̇| |p̄_i| / μ_b`
//! (`μ_b` the stiffness of the breathing mode `x_i ∝ p̄_i`), which must stay within
//! [`LAG_SPACINGS`] of the spacing `k d̄0`.

use nalgebra::{Complex, DMatrix, SymmetricEigen};

use super::formation::FormationDesign;
use super::potential::PairPotential;
use super::robust::{derived_memory, fade, slot_stiffness};
use super::Vec3;

/// The lag behind a moving slot (s of adaptation) allowed, in design spacings `k d̄0`.
pub const LAG_SPACINGS: f64 = 0.1;

/// Loop gain below which a scale counts as held: 1 by the small-gain theorem, less a
/// margin for the linearisation (the pair forces are not linear a fraction of a spacing
/// away from equilibrium).
pub const GAIN_LIMIT: f64 = 0.8;

/// `√μ_max · dt` at most: an accurate step of (II.1).
pub const STEP_LIMIT: f64 = 1.0;

/// Which law the envelope is for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EnvelopeLaw {
    /// The paper's law: every neighbour term acts on the relayed position, unweighed.
    Paper,
    /// `control.law = "robust"` (`super::robust`): faded, predicted neighbour terms and
    /// the slot spring that takes over.
    Robust {
        /// `control.neighbour_memory`, s (None: [`derived_memory`] at each scale).
        memory: Option<f64>,
    },
}

/// What a mission's envelope is computed from.
#[derive(Clone, Debug)]
pub struct EnvelopeInputs<'a> {
    /// The formation design at scale 1 (slots, leaders, potentials).
    pub design: &'a FormationDesign,
    /// Dimension of the formation (2 or 3).
    pub dim: usize,
    /// Damping `K` of (II.1), 1/s.
    pub damping: f64,
    /// Control step, s.
    pub dt: f64,
    /// Range of the neighbours' information ages `[a_min, a_max]`, s (None: ideal links,
    /// every age 0).
    pub ages: Option<(f64, f64)>,
    /// The law flown.
    pub law: EnvelopeLaw,
    /// What a vehicle can do for its slot, length/s: its speed through the water less the
    /// strongest current (None: no limit, the paper's vehicle).
    pub speed_budget: Option<f64>,
    /// Largest scale the mission allows.
    pub max_scale: f64,
    /// The body's nominal speed `v0`, length/s.
    pub v0: f64,
}

/// What sets the smallest scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScaleLimit {
    /// The links: below it, the small-gain test fails for some age.
    Links,
    /// The time step: below it, `√μ_max · dt` exceeds [`STEP_LIMIT`].
    Step,
    /// Nothing above the smallest scale tried.
    None,
}

/// The envelope of a mission.
#[derive(Clone, Debug, PartialEq)]
pub struct Envelope {
    /// Smallest scale `k` held (the scale below which the formation is not held).
    pub min_scale: f64,
    /// What sets it.
    pub limit: ScaleLimit,
    /// True when no scale up to `max_scale` is held.
    pub empty: bool,
    /// The loop gain `g` at the scale 1 (the formation as configured).
    pub gain_at_one: f64,
    /// `√μ_max · dt` at `min_scale`.
    pub step_at_min: f64,
    /// Largest body speed `|ṙ|` the vehicles can follow, length/s (∞: no limit).
    pub max_body_speed: f64,
    /// `|dk/dt|·k` at most, 1/s: the adaptation rate at scale `k` is bounded by this over
    /// `k` (the lag bound goes as `1/k`); ∞ when nothing bounds it.
    pub scale_rate_times_k: f64,
    /// `|dk/dt|·max|p̄_i|` at most, length/s: the vehicles' speed budget less the body's
    /// speed (a tenth of the budget at least); without a budget (the paper's vehicle) the
    /// body's speed `v0`, so that the growth adds no more kinetic energy to V of (II.2)
    /// than cruising does.
    pub slot_speed: f64,
}

impl Envelope {
    /// The largest `|dk/dt|` at scale `scale`, 1/s (lag and speed bounds together).
    pub fn max_scale_rate(&self, scale: f64, radius_bar: f64) -> f64 {
        let lag = self.scale_rate_times_k / scale.max(f64::MIN_POSITIVE);
        let speed = if radius_bar > 0.0 {
            self.slot_speed / radius_bar
        } else {
            f64::INFINITY
        };
        lag.min(speed)
    }
}

/// The linearisation of a design at scale 1: Hessians of the inter-vehicle terms (whole
/// and off-diagonal) and of the leader terms, over the `dim` coordinates of each slot,
/// and the slot spring.
#[derive(Clone, Debug)]
pub struct Linearised {
    /// `H_I`, (dim·N)².
    pub inter: DMatrix<f64>,
    /// `‖O_I‖`: spectral radius of the off-diagonal blocks of `H_I`.
    pub coupling: f64,
    /// `H_L`, (dim·N)².
    pub leader: DMatrix<f64>,
    /// `κ_s` at scale 1, 1/s².
    pub slot: f64,
    /// Stiffness of the breathing mode at scale 1 (Rayleigh quotient of `H_I + H_L` on
    /// `x_i ∝ p̄_i`), 1/s²; its robust counterpart mixes in `κ_s`.
    pub breathing: (f64, f64),
    /// max |p̄_i|, length.
    pub radius: f64,
}

/// The force's slope `f'(x)` by a central difference (the force is C¹).
fn slope(p: &PairPotential, x: f64) -> f64 {
    let h = 1e-6 * p.d0;
    (p.force(x + h) - p.force(x - h)) / (2.0 * h)
}

/// The Hessian block `f'(d) ê êᵀ + f(d)/d (I − ê êᵀ)` of a pair term at offset `e` (from
/// the other point to this one), over the first `dim` coordinates; zero beyond the cut-off.
fn pair_block(p: &PairPotential, e: &Vec3, dim: usize) -> DMatrix<f64> {
    let d = e.norm();
    let mut b = DMatrix::zeros(dim, dim);
    if d <= 0.0 || d >= p.d1 {
        return b;
    }
    let u = e / d;
    let (fs, f) = (slope(p, d), p.force(d));
    for r in 0..dim {
        for c in 0..dim {
            let uu = u[r] * u[c];
            let id = if r == c { 1.0 } else { 0.0 };
            b[(r, c)] = fs * uu + f / d * (id - uu);
        }
    }
    b
}

/// Adds `b` to the block `(i, j)` of `m` (blocks of size `dim`), times `sign`.
fn add_block(m: &mut DMatrix<f64>, b: &DMatrix<f64>, i: usize, j: usize, dim: usize, sign: f64) {
    for r in 0..dim {
        for c in 0..dim {
            m[(i * dim + r, j * dim + c)] += sign * b[(r, c)];
        }
    }
}

/// The spectral radius of a symmetric matrix.
fn spectral_radius(m: &DMatrix<f64>) -> f64 {
    SymmetricEigen::new(m.clone())
        .eigenvalues
        .iter()
        .fold(0.0_f64, |a, v| a.max(v.abs()))
}

/// The linearisation of `design` at its equilibrium, scale 1 (module docs).
pub fn linearise(design: &FormationDesign, dim: usize) -> Linearised {
    let n = design.slots.len();
    let size = n * dim;
    let mut inter = DMatrix::zeros(size, size);
    let mut off = DMatrix::zeros(size, size);
    for i in 0..n {
        for j in 0..n {
            if i == j {
                continue;
            }
            let b = pair_block(&design.inter, &(design.slots[i] - design.slots[j]), dim);
            add_block(&mut inter, &b, i, i, dim, 1.0);
            add_block(&mut inter, &b, i, j, dim, -1.0);
            add_block(&mut off, &b, i, j, dim, -1.0);
        }
    }
    let mut leader = DMatrix::zeros(size, size);
    for i in 0..n {
        for b_l in &design.leaders {
            let b = pair_block(&design.leader, &(design.slots[i] - b_l), dim);
            add_block(&mut leader, &b, i, i, dim, 1.0);
        }
    }
    let slot = slot_stiffness(&design.leader);
    let mut breath = DMatrix::zeros(size, 1);
    for (i, p) in design.slots.iter().enumerate() {
        for r in 0..dim {
            breath[(i * dim + r, 0)] = p[r];
        }
    }
    let norm2 = breath.norm_squared();
    let quotient = |m: &DMatrix<f64>| {
        if norm2 > 0.0 {
            (breath.transpose() * m * &breath)[(0, 0)] / norm2
        } else {
            0.0
        }
    };
    let whole = &inter + &leader;
    let radius = design.slots.iter().fold(0.0_f64, |a, p| a.max(p.norm()));
    Linearised {
        coupling: spectral_radius(&off),
        breathing: (quotient(&whole), quotient(&leader)),
        inter,
        leader,
        slot,
        radius,
    }
}

/// Ages tried between `a_min` and `a_max` (both included).
const AGES: usize = 12;
/// Frequencies tried per age, log-spaced.
const FREQUENCIES: usize = 160;

/// The stiffness and coupling of the law at scale `k` for neighbours `age` s old: the
/// eigenvalues of `M`, `‖Q‖` and the prediction `c` (module docs).
fn law_at(lin: &Linearised, inputs: &EnvelopeInputs<'_>, k: f64, age: f64) -> (Vec<f64>, f64, f64) {
    let k2 = k * k;
    let (w, c, slot) = match inputs.law {
        EnvelopeLaw::Paper => (1.0, 0.0, 0.0),
        EnvelopeLaw::Robust { memory } => {
            let tau = memory
                .unwrap_or_else(|| derived_memory(&inputs.design.inter.scaled(k), inputs.damping));
            let w = fade(age, tau);
            let c =
                super::robust::relative_drift(&Vec3::x(), &Vec3::zeros(), age, inputs.damping).x;
            (w, c, (1.0 - w) * lin.slot)
        }
    };
    let size = lin.inter.nrows();
    let m = (&lin.inter * w + &lin.leader + DMatrix::identity(size, size) * slot) / k2;
    let mu = SymmetricEigen::new(m).eigenvalues.iter().copied().collect();
    (mu, w * lin.coupling / k2, c)
}

/// The loop gain `g` of the module docs at scale `k` (0 on ideal links).
pub fn loop_gain(lin: &Linearised, inputs: &EnvelopeInputs<'_>, k: f64) -> f64 {
    let Some((a_min, a_max)) = inputs.ages else {
        return 0.0;
    };
    let kd = inputs.damping;
    // Under the robust law a neighbour older than 30 memories weighs e^{-30}: nothing.
    let a_max = match inputs.law {
        EnvelopeLaw::Robust { memory } => {
            let tau = memory
                .unwrap_or_else(|| derived_memory(&inputs.design.inter.scaled(k), inputs.damping));
            a_max.min(a_min + 30.0 * tau)
        }
        EnvelopeLaw::Paper => a_max,
    };
    let mut worst = 0.0_f64;
    for ai in 0..AGES {
        let age = a_min + (a_max - a_min) * ai as f64 / (AGES - 1) as f64;
        if age <= 0.0 {
            continue;
        }
        let (mu, q, c) = law_at(lin, inputs, k, age);
        if q <= 0.0 {
            continue;
        }
        let top = mu.iter().fold(0.0_f64, |a, v| a.max(*v)).max(1e-12);
        let (lo, hi) = (1e-4 / age.max(1e-9), 10.0 * top.sqrt() + 10.0 / age);
        for fi in 0..FREQUENCIES {
            let omega = lo * (hi / lo).powf(fi as f64 / (FREQUENCIES - 1) as f64);
            let delayed =
                Complex::new(0.0, -omega * age).exp() * Complex::new(1.0, c * omega) - 1.0;
            let nearest = mu.iter().fold(f64::INFINITY, |a, m| {
                a.min(Complex::new(m - omega * omega, kd * omega).norm())
            });
            worst = worst.max(q * delayed.norm() / nearest);
        }
    }
    worst
}

/// `√μ_max · dt` at scale `k` (the stiffest mode with fresh neighbours).
pub fn step_at(lin: &Linearised, inputs: &EnvelopeInputs<'_>, k: f64) -> f64 {
    let (mu, _, _) = law_at(lin, inputs, k, 0.0);
    let top = mu.iter().fold(0.0_f64, |a, v| a.max(*v));
    top.max(0.0).sqrt() * inputs.dt
}

/// Scales tried, log-spaced from `max_scale` down to `max_scale`·10⁻³.
const SCALES: usize = 60;

/// The envelope of `inputs` (module docs). On ideal links only the time step limits the
/// scale.
pub fn envelope(inputs: &EnvelopeInputs<'_>) -> Envelope {
    let lin = linearise(inputs.design, inputs.dim);
    let held = |k: f64| -> Option<ScaleLimit> {
        if step_at(&lin, inputs, k) > STEP_LIMIT {
            return Some(ScaleLimit::Step);
        }
        (loop_gain(&lin, inputs, k) >= GAIN_LIMIT).then_some(ScaleLimit::Links)
    };
    let top = inputs.max_scale;
    let mut min_scale = top;
    let mut limit = ScaleLimit::None;
    let mut empty = false;
    let mut last_held = None;
    for i in 0..SCALES {
        let k = top * 1e-3_f64.powf(i as f64 / (SCALES - 1) as f64);
        match held(k) {
            None => last_held = Some(k),
            Some(why) => {
                limit = why;
                break;
            }
        }
    }
    match last_held {
        Some(k) => min_scale = k,
        None => empty = true,
    }
    if limit != ScaleLimit::None && !empty {
        // Refine between the last scale held and the first not held.
        let (mut good, mut bad) = (
            min_scale,
            min_scale * 1e-3_f64.powf(1.0 / (SCALES - 1) as f64),
        );
        for _ in 0..20 {
            let mid = (good * bad).sqrt();
            if held(mid).is_none() {
                good = mid;
            } else {
                bad = mid;
            }
        }
        min_scale = good;
    } else if limit == ScaleLimit::None {
        min_scale = top * 1e-3;
    }
    let kd = inputs.damping;
    let ages_max = inputs.ages.map_or(0.0, |a| a.1);
    let breathing = {
        let (whole, leader) = lin.breathing;
        match inputs.law {
            EnvelopeLaw::Paper => whole,
            EnvelopeLaw::Robust { .. } if ages_max > 0.0 => whole.min(leader + lin.slot),
            EnvelopeLaw::Robust { .. } => whole,
        }
    };
    // Lag K |k̇| R̄ / (μ_b/k²) ≤ LAG_SPACINGS · k d̄0  ⇒  |k̇| k ≤ LAG_SPACINGS d̄0 μ_b / (K R̄).
    let d0 = inputs.design.neighbour_spacing();
    let scale_rate_times_k = if kd > 0.0 && lin.radius > 0.0 {
        LAG_SPACINGS * d0 * breathing / (kd * lin.radius)
    } else {
        f64::INFINITY
    };
    let max_body_speed = inputs.speed_budget.unwrap_or(f64::INFINITY);
    // What the budget leaves for the slot's own motion once the body moves at v0 (a tenth
    // of the budget at least: the body slows when V grows, (IV.4)).
    let slot_speed = inputs
        .speed_budget
        .map_or(inputs.v0, |b| (b - inputs.v0).max(0.1 * b));
    Envelope {
        min_scale,
        limit,
        empty,
        gain_at_one: loop_gain(&lin, inputs, 1.0),
        step_at_min: step_at(&lin, inputs, min_scale),
        max_body_speed,
        scale_rate_times_k,
        slot_speed,
    }
}

#[cfg(test)]
mod tests;
