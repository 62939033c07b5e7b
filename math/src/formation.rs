//! The formation designer (Sec. II, Figs. 3–4; docs/ARCHITECTURE.md §6): from a number of vehicles (or a
//! wanted shape) to virtual leaders `b̄_l` and potentials `V_I(d0, d1)`, `V_h(h0, h1)`
//! whose equilibrium of (II.1) is that shape.
//!
//! Two kinds of design:
//!
//! - **Central** ([`design_regular`] for one vehicle, 2-D polygons with `N ≥ 3`, and the
//!   tetrahedron, octahedron and icosahedron): one virtual leader at the body centre with
//!   `h0 = radius`, vehicles on the circle/sphere of that radius with every neighbour pair
//!   (an edge) at `d0` and every other pair beyond `d1`. Each active term of (II.2) is at
//!   its minimum, so the shape is an exact equilibrium and a local minimum of the potential
//!   energy; it keeps the rotational symmetry about the centre (Fig. 4(a)), as the paper
//!   does for regular formations. These frameworks (edges plus spokes to the centre) are
//!   infinitesimally rigid up to that rotation, so the minimum is non-degenerate.
//! - **Per-slot leaders** ([`design_for_shape`], and [`design_regular`] for the other
//!   cases): each slot gets its own `dim + 1` virtual leaders at distance `h0` on its outer
//!   side, out of reach (`h1`) of every other slot. This breaks all symmetry (Remark 5.3,
//!   Fig. 4(b)) and makes any shape with distinct slots an exact, strict local minimum.
//!
//! Why not central everywhere: around a single centre some frameworks are flexible to first
//! order, so their equilibrium is only quartically stable and converges slowly (seen in
//! simulation): two antipodal vehicles (collinear with the centre), three vehicles in 3-D
//! (coplanar with the centre), the cube (24 coordinates − 3 rotations = 21 > 12 edges + 8
//! spokes) and the dodecahedron (57 > 30 + 20).
//!
//! A 2-D ring of five or more vehicles about one centre is a local minimum but not the
//! only one: vehicles that fold into the empty interior put more pairs at `d0`, and (II.1),
//! which descends the energy, can settle there (most formation failures of random missions
//! on ideal links, docs/STRESS.md). Per-slot leaders remove that minimum but their basin
//! reaches only about 0.8 spacing from each slot (their `h1` must stop short of the
//! neighbours' slots), against four radii for the central leader, and a ring of them
//! cannot turn; measured, that trade lost more missions of some families than it saved
//! (docs/STRESS.md), so rings stay central.

use super::potential::{potential_energy, PairPotential};
use super::Vec3;

/// Why no formation could be designed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FormationError {
    /// A formation needs at least one vehicle.
    #[error("a formation needs at least one vehicle")]
    NoVehicles,
    /// The dimension must be 2 or 3.
    #[error("dimension must be 2 or 3, got {0}")]
    BadDimension(usize),
    /// A numeric parameter is non-finite or out of range.
    #[error("{name} = {value} is invalid: must be finite and > 0")]
    BadParameter {
        /// Which parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A slot has a non-finite coordinate.
    #[error("slot {0} has a non-finite coordinate")]
    NonFiniteSlot(usize),
    /// In a 2-D design every slot must have z = 0.
    #[error("slot {index} has z = {z} in a 2-D design")]
    NotPlanar {
        /// Which slot.
        index: usize,
        /// Its z coordinate.
        z: f64,
    },
    /// Two slots (nearly) coincide, so no spacing can be designed.
    #[error("slots {i} and {j} coincide")]
    CoincidentSlots {
        /// First slot.
        i: usize,
        /// Second slot.
        j: usize,
    },
    /// A single slot at the body centre gives no length scale to design with.
    #[error("a single slot at the body centre gives no length scale")]
    DegenerateShape,
}

/// A formation design at scale `k = 1` in the body frame (origin = virtual body centre `r`),
/// Sec. II; moved, rotated and scaled by the virtual body (III.3).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FormationDesign {
    /// 2 or 3.
    pub dim: usize,
    /// Virtual leaders `b̄_l` in the body frame, length.
    pub leaders: Vec<Vec3>,
    /// The `N` vehicle positions of the designed equilibrium, body frame, length. Prefixes
    /// `slots[..n]` are themselves equilibria with as many neighbour pairs as the design
    /// allows (used when vehicles are lost, see [`FormationDesign::equilibrium_energy`]).
    pub slots: Vec<Vec3>,
    /// Inter-vehicle potential `V_I` with `d̄0`, `d̄1`.
    pub inter: PairPotential,
    /// Vehicle–leader potential `V_h` with `h̄0`, `h̄1`.
    pub leader: PairPotential,
    /// Potential energy of (II.2) at the equilibrium (pairs beyond the cut-offs each add a
    /// plateau), energy per unit mass; subtracted so the Lyapunov function is 0 there.
    /// Invariant under scaling.
    pub v_eq: f64,
}

impl FormationDesign {
    /// A design of `slots` and `leaders` (body frame, length) with potentials `inter`
    /// (V_I) and `leader` (V_h), its equilibrium energy `v_eq` the potential part of (II.2)
    /// with every vehicle at its slot.
    fn at_equilibrium(
        dim: usize,
        leaders: Vec<Vec3>,
        slots: Vec<Vec3>,
        inter: PairPotential,
        leader: PairPotential,
    ) -> Self {
        let v_eq = potential_energy(&slots, &leaders, &inter, &leader);
        Self {
            dim,
            leaders,
            slots,
            inter,
            leader,
            v_eq,
        }
    }

    /// The design with the slots `holes` (indices into `slots`) left empty (beyond the
    /// paper): the same leaders and potentials, the other slots in their order, `v_eq`
    /// the potential energy of (II.2) with a vehicle in each slot kept.
    ///
    /// What a formation that lost vehicles flies under `control.law = "robust"`: in both
    /// kinds of design every active pair of the equilibrium sits at its `d0` (zero force)
    /// and every other beyond `d1`, so the vehicles left in their slots are still at an
    /// equilibrium of (II.1), with `V = 0`; a regular design for fewer vehicles would
    /// move every slot, and `V` at the switch with it. A vehicle that comes back flies
    /// to a hole, and the design gets its slot back.
    pub fn without_slots(&self, holes: &[usize]) -> Self {
        let slots = self
            .slots
            .iter()
            .enumerate()
            .filter(|(m, _)| !holes.contains(m))
            .map(|(_, p)| *p)
            .collect();
        Self::at_equilibrium(
            self.dim,
            self.leaders.clone(),
            slots,
            self.inter,
            self.leader,
        )
    }

    /// Number of vehicles `N` the design is for.
    pub fn n(&self) -> usize {
        self.slots.len()
    }

    /// `max_i |p̄_i|`, the largest distance of a slot from the body centre at `k = 1`
    /// (length); 0 without slots. A slot of the formation at scale `k` moves at
    /// `|k̇| · extent` at most when the scale changes.
    pub fn extent(&self) -> f64 {
        extent(&self.slots)
    }

    /// True when the design has one virtual leader at the body centre (one vehicle, the
    /// 2-D polygons, the tetrahedron, octahedron and icosahedron of [`design_regular`]):
    /// its energy does not change when the vehicles turn together about the centre
    /// (Fig. 4(a)).
    pub fn is_central(&self) -> bool {
        self.leaders.len() == 1 && self.leaders[0] == Vec3::zeros()
    }

    /// `d̄0`, the designed neighbour spacing at `k = 1` (length), as used by the resolution
    /// adaptation `dk/ds = −a(k d̄0 − Δd)` of Sec. V. It is the equilibrium distance of
    /// `V_I` and the smallest slot-to-slot distance.
    pub fn neighbour_spacing(&self) -> f64 {
        self.inter.d0
    }

    /// The potential energy (II.2) of an equilibrium of `n` vehicles, energy per unit mass,
    /// the constant the Lyapunov function subtracts (`lyapunov_terms`):
    ///
    /// - `n = N`: [`FormationDesign::v_eq`];
    /// - `n < N` (vehicles lost): the energy of the first `n` slots, themselves an
    ///   equilibrium (every active pair at its `d0`/`h0`); the slots are ordered so that
    ///   each prefix keeps as many neighbour pairs as possible;
    /// - `n > N` (vehicles joined, not yet redesigned): `v_eq` plus the extra vehicles
    ///   counted as far away (each pair and leader term at its plateau).
    pub fn equilibrium_energy(&self, n: usize) -> f64 {
        let big_n = self.n();
        if n == big_n {
            return self.v_eq;
        }
        if n < big_n {
            return potential_energy(&self.slots[..n], &self.leaders, &self.inter, &self.leader);
        }
        let extra = (n - big_n) as f64;
        let new_pairs = (n * (n - 1) / 2 - big_n * big_n.saturating_sub(1) / 2) as f64;
        self.v_eq
            + extra * self.leaders.len() as f64 * self.leader.plateau()
            + new_pairs * self.inter.plateau()
    }
}

fn check_positive(name: &'static str, value: f64) -> Result<(), FormationError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(FormationError::BadParameter { name, value })
    }
}

fn check_dim(dim: usize) -> Result<(), FormationError> {
    if dim == 2 || dim == 3 {
        Ok(())
    } else {
        Err(FormationError::BadDimension(dim))
    }
}

/// The largest norm of `slots` (length), 0 when empty.
fn extent(slots: &[Vec3]) -> f64 {
    slots.iter().map(|p| p.norm()).fold(0.0, f64::max)
}

/// A regular formation of `n` vehicles at distance `radius` (length) from the body centre
/// (Sec. II, Figs. 3–4), with potential strengths `alpha_inter` (`V_I`) and `alpha_leader`
/// (`V_h`), (length/s)². Always `d0` = the smallest slot distance (the edge) and
/// `d1 = min(1.5 d0, (d0 + d_next)/2)`, `d_next` the next larger slot distance, so that
/// only neighbours interact at equilibrium.
///
/// - `n = 1`: one slot at `(radius, 0, 0)`, central; `d0 = 2 radius` (where a second
///   vehicle would sit), `d1 = 1.5 d0`.
/// - `n = 2`: two antipodal slots on the x axis, `d0 = 2 radius`, per-slot leaders.
/// - 2-D, `n ≥ 3`: the regular `n`-gon of circumradius `radius` (vertex 0 on +x, ring
///   order), `d0` = side, central.
/// - 3-D, `n = 3`: the equilateral triangle in the plane z = 0, per-slot leaders.
/// - 3-D, `n ∈ {4, 6, 12}`: tetrahedron, octahedron, icosahedron inscribed in the sphere,
///   `d0` = edge, central.
/// - 3-D, `n ∈ {8, 20}`: cube, dodecahedron, `d0` = edge, per-slot leaders.
/// - 3-D, other `n`: `n` points spread evenly on the sphere (a Fibonacci lattice relaxed
///   for a fixed number of steps under Coulomb repulsion, deterministic), per-slot leaders,
///   so these points are the exact equilibrium; neighbour spacings are only roughly equal
///   (`d0` is the smallest).
///
/// Central designs: one leader at the centre, `h0 = radius`, `h1 = 4 radius` (a wide
/// basin). Per-slot designs: see [`design_for_shape`]. See the module docs for why.
/// Slots are ordered so that every prefix keeps as many neighbour pairs as possible.
pub fn design_regular(
    n: usize,
    dim: usize,
    radius: f64,
    alpha_inter: f64,
    alpha_leader: f64,
) -> Result<FormationDesign, FormationError> {
    check_dim(dim)?;
    if n == 0 {
        return Err(FormationError::NoVehicles);
    }
    check_positive("radius", radius)?;
    check_positive("alpha_inter", alpha_inter)?;
    check_positive("alpha_leader", alpha_leader)?;
    let per_slot = |unit: Vec<Vec3>| {
        let slots: Vec<Vec3> = unit.iter().map(|p| p * radius).collect();
        design_for_shape(&dense_order(slots), dim, alpha_inter, alpha_leader)
    };
    let unit: Vec<Vec3> = match (dim, n) {
        (_, 1) => vec![Vec3::x()],
        (_, 2) => return per_slot(vec![Vec3::x(), -Vec3::x()]),
        (2, _) => polygon(n),
        (3, 3) => return per_slot(polygon(3)),
        (3, 4 | 6 | 12) => platonic(n),
        (3, 8 | 20) => return per_slot(platonic(n)),
        _ => return per_slot(sphere_points(n)),
    };
    let slots = dense_order(unit.iter().map(|p| p * radius).collect());
    let (d0, d1) = if n == 1 {
        (2.0 * radius, 3.0 * radius)
    } else {
        spacing(&slots)
    };
    let inter = PairPotential {
        alpha: alpha_inter,
        d0,
        d1,
    };
    let leader = PairPotential {
        alpha: alpha_leader,
        d0: radius,
        d1: 4.0 * radius,
    };
    let leaders = vec![Vec3::zeros()];
    Ok(FormationDesign::at_equilibrium(
        dim, leaders, slots, inter, leader,
    ))
}

/// A design whose equilibrium of (II.1) is exactly the given shape (e.g. an anisotropic
/// optimal formation of (V.7)), Remark 5.3: `slots` in the body frame (length, z = 0 in
/// 2-D), potential strengths in (length/s)².
///
/// With `D` the smallest slot-to-slot distance (for a single slot, its distance to the
/// centre):
///
/// - `V_I` has `d0 = D` and `d1 = min(1.5 D, (D + d_next)/2)`, `d_next` the next larger
///   slot distance: nearest pairs sit at `d0`, all others beyond `d1`, and closer vehicles
///   repel (collision avoidance). Pair distances within 1e-6 relative of `D` count as
///   nearest pairs (slots from an optimiser are symmetric only to its tolerance); their
///   residual force is at most about `alpha_inter · 1e-6 / D`.
/// - each slot `p_i` gets `dim + 1` virtual leaders `p_i + h0 u_k` on its outer side: with
///   `o_i` the direction away from the other slots (their inverse-square repulsion; for a
///   single slot, away from the centre), `u_k` are `o_i` rotated by 0, ±60° (2-D), or `o_i`
///   and three directions at `arccos(1/3)` from it, 120° apart (3-D). The slot is the only
///   point at distance `h0` from all of them (the centre of their circumcircle/sphere), and
///   their energy has a strict minimum there with the isotropic Hessian
///   `V_h''(h0) (dim+1)/dim · I`.
/// - `h0` is the largest of `0.5 D, 0.4 D, 0.3 D, 0.25 D` for which
///   `h1 = min(3 h0, 0.9 c) ≥ 1.5 h0`, `c` the smallest distance from a leader to another
///   slot; `h0 = 0.25 D` always qualifies (`c ≥ 0.75 D`). So no leader reaches another
///   slot.
///
/// Every term of (II.2) is then at its minimum or on its plateau: the shape is an exact
/// equilibrium and a strict local minimum, with no remaining symmetry (the body's rotation
/// `R(s)` is followed). Limits: leaders sit `h0` from their slot (singular repulsion
/// there), so a vehicle must start clearly closer to its slot than `h0`, and it feels its
/// slot's leaders only within about `h0 + h1` of the slot; vehicles must start near
/// distinct slots. Vehicles are anonymous: which one takes which slot depends on where it
/// starts. Far from the shape the energy landscape may hold other minima (e.g. a vehicle
/// between two slots within reach of leaders of both).
pub fn design_for_shape(
    slots: &[Vec3],
    dim: usize,
    alpha_inter: f64,
    alpha_leader: f64,
) -> Result<FormationDesign, FormationError> {
    check_dim(dim)?;
    if slots.is_empty() {
        return Err(FormationError::NoVehicles);
    }
    check_positive("alpha_inter", alpha_inter)?;
    check_positive("alpha_leader", alpha_leader)?;
    for (i, p) in slots.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(FormationError::NonFiniteSlot(i));
        }
        if dim == 2 && p.z != 0.0 {
            return Err(FormationError::NotPlanar { index: i, z: p.z });
        }
    }
    let extent = extent(slots);
    let (d0, d1) = if slots.len() == 1 {
        if extent <= 0.0 {
            return Err(FormationError::DegenerateShape);
        }
        (extent, 1.5 * extent)
    } else {
        let (i, j, d) = closest_pair(slots);
        if d <= 1e-9 * extent.max(d) {
            return Err(FormationError::CoincidentSlots { i, j });
        }
        spacing(slots)
    };
    let inter = PairPotential {
        alpha: alpha_inter,
        d0,
        d1,
    };
    let dirs: Vec<Vec<Vec3>> = (0..slots.len())
        .map(|i| outer_directions(slots, i, dim))
        .collect();
    let place = |h0: f64| -> Vec<Vec3> {
        slots
            .iter()
            .zip(&dirs)
            .flat_map(|(p, us)| us.iter().map(move |u| p + u * h0))
            .collect()
    };
    let per_slot = dim + 1;
    let mut chosen = None;
    for frac in [0.5, 0.4, 0.3, 0.25] {
        let h0 = frac * d0;
        let leaders = place(h0);
        let mut clearance = f64::INFINITY;
        for (l, b) in leaders.iter().enumerate() {
            for (j, p) in slots.iter().enumerate() {
                if j != l / per_slot {
                    clearance = clearance.min((b - p).norm());
                }
            }
        }
        let h1 = (3.0 * h0).min(0.9 * clearance);
        if h1 >= 1.5 * h0 || frac == 0.25 {
            chosen = Some((
                leaders,
                PairPotential {
                    alpha: alpha_leader,
                    d0: h0,
                    d1: h1,
                },
            ));
            break;
        }
    }
    let (leaders, leader) = chosen.expect("the last fraction is always accepted");
    let slots = slots.to_vec();
    Ok(FormationDesign::at_equilibrium(
        dim, leaders, slots, inter, leader,
    ))
}

/// The `dim + 1` unit directions of slot `i`'s leaders, on the side away from the other
/// slots (see [`design_for_shape`]).
fn outer_directions(slots: &[Vec3], i: usize, dim: usize) -> Vec<Vec3> {
    let p = slots[i];
    let mut g = Vec3::zeros();
    for (j, q) in slots.iter().enumerate() {
        if j != i {
            let d = p - q;
            g += d / d.norm().powi(3);
        }
    }
    // Scale of g for a lone neighbour at distance D is 1/D²; below 1e-6 of that it is a
    // symmetric interior slot: fall back to the direction from the centre, then to x.
    let d_min = if slots.len() > 1 {
        closest_pair(slots).2
    } else {
        p.norm()
    };
    let o = if g.norm() * d_min * d_min > 1e-6 {
        g.normalize()
    } else if p.norm() > 1e-6 * d_min {
        p.normalize()
    } else {
        Vec3::x()
    };
    if dim == 2 {
        let perp = Vec3::new(-o.y, o.x, 0.0);
        let (s, c) = 60f64.to_radians().sin_cos();
        vec![o, c * o + s * perp, c * o - s * perp]
    } else {
        let a = if o.x.abs() < 0.9 {
            Vec3::x()
        } else {
            Vec3::y()
        };
        let e1 = (a - o * a.dot(&o)).normalize();
        let e2 = o.cross(&e1);
        let cos_t: f64 = 1.0 / 3.0;
        let sin_t = (1.0 - cos_t * cos_t).sqrt();
        let mut v = vec![o];
        for k in 0..3 {
            let (s, c) = (std::f64::consts::TAU * k as f64 / 3.0).sin_cos();
            v.push(cos_t * o + sin_t * (c * e1 + s * e2));
        }
        v
    }
}

/// The closest pair `(i, j, distance)`, first in index order on ties.
fn closest_pair(slots: &[Vec3]) -> (usize, usize, f64) {
    let mut best = (0, 0, f64::INFINITY);
    for i in 0..slots.len() {
        for j in i + 1..slots.len() {
            let d = (slots[i] - slots[j]).norm();
            if d < best.2 {
                best = (i, j, d);
            }
        }
    }
    best
}

/// `(d0, d1)`: `d0` the smallest pair distance, `d1 = min(1.5 d0, (d0 + d_next)/2)` with
/// `d_next` the smallest pair distance clearly above `d0` (relative gap > 1e-6). Needs ≥ 2
/// slots.
fn spacing(slots: &[Vec3]) -> (f64, f64) {
    let d0 = closest_pair(slots).2;
    let mut next = f64::INFINITY;
    for i in 0..slots.len() {
        for j in i + 1..slots.len() {
            let d = (slots[i] - slots[j]).norm();
            if d > d0 * (1.0 + 1e-6) && d < next {
                next = d;
            }
        }
    }
    (d0, (1.5 * d0).min(0.5 * (d0 + next)))
}

/// Reorders slots greedily so that every prefix has as many neighbour pairs (distance
/// within 1e-6 relative of the smallest) as the greedy choice allows: start at slot 0,
/// then repeatedly take the slot with most neighbours already taken (lowest index on ties).
/// For polygons this is the ring order.
fn dense_order(slots: Vec<Vec3>) -> Vec<Vec3> {
    let n = slots.len();
    if n < 3 {
        return slots;
    }
    let d0 = closest_pair(&slots).2;
    let adjacent = |i: usize, j: usize| (slots[i] - slots[j]).norm() <= d0 * (1.0 + 1e-6);
    // score[c]: neighbours of slot c already taken, kept up to date as slots are taken, so
    // the order costs O(n²) (recounting against the whole prefix cost O(n³): seconds per
    // process at N = 1024, every process computes the design).
    let mut score = vec![0usize; n];
    let mut order = Vec::with_capacity(n);
    let mut taken = vec![false; n];
    let mut next = 0usize;
    loop {
        taken[next] = true;
        order.push(next);
        if order.len() == n {
            break;
        }
        let mut best: Option<(usize, usize)> = None;
        for c in (0..n).filter(|&c| !taken[c]) {
            if adjacent(next, c) {
                score[c] += 1;
            }
            if best.is_none_or(|(_, s)| score[c] > s) {
                best = Some((c, score[c]));
            }
        }
        next = best.expect("an untaken slot remains").0;
    }
    order.into_iter().map(|i| slots[i]).collect()
}

/// Unit-circumradius regular polygon in the plane z = 0, vertex 0 on +x.
fn polygon(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            Vec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect()
}

/// Vertices of the Platonic solid with `n ∈ {4, 6, 8, 12, 20}` vertices, unit circumradius.
fn platonic(n: usize) -> Vec<Vec3> {
    let phi = 0.5 * (1.0 + 5.0f64.sqrt());
    let signs = [1.0, -1.0];
    let mut v: Vec<Vec3> = Vec::new();
    match n {
        4 => {
            v = vec![
                Vec3::new(1.0, 1.0, 1.0),
                Vec3::new(1.0, -1.0, -1.0),
                Vec3::new(-1.0, 1.0, -1.0),
                Vec3::new(-1.0, -1.0, 1.0),
            ]
        }
        6 => {
            for axis in 0..3 {
                for s in signs {
                    let mut p = Vec3::zeros();
                    p[axis] = s;
                    v.push(p);
                }
            }
        }
        8 => {
            for a in signs {
                for b in signs {
                    for c in signs {
                        v.push(Vec3::new(a, b, c));
                    }
                }
            }
        }
        12 => {
            // Cyclic permutations of (0, ±1, ±φ).
            for shift in 0..3 {
                for a in signs {
                    for b in signs {
                        v.push(cyclic(Vec3::new(0.0, a, b * phi), shift));
                    }
                }
            }
        }
        20 => {
            v = platonic(8);
            // Cyclic permutations of (0, ±1/φ, ±φ).
            for shift in 0..3 {
                for a in signs {
                    for b in signs {
                        v.push(cyclic(Vec3::new(0.0, a / phi, b * phi), shift));
                    }
                }
            }
        }
        _ => unreachable!("no Platonic solid with {n} vertices"),
    }
    v.into_iter().map(|p| p.normalize()).collect()
}

fn cyclic(p: Vec3, shift: usize) -> Vec3 {
    Vec3::new(p[shift % 3], p[(shift + 1) % 3], p[(shift + 2) % 3])
}

/// `n ≥ 3` points spread over the unit sphere: a Fibonacci lattice relaxed by 400 fixed
/// projected-gradient steps of the Coulomb energy `Σ 1/|p_i − p_j|` (Jacobi updates, so
/// the result does not depend on iteration order within a step).
fn sphere_points(n: usize) -> Vec<Vec3> {
    let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
    let mut pts: Vec<Vec3> = (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let rho = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            Vec3::new(rho * a.cos(), rho * a.sin(), z)
        })
        .collect();
    // Typical spacing ~ sqrt(4π/n); step so that a typical force moves a point ~5% of it.
    let spacing = (4.0 * std::f64::consts::PI / n as f64).sqrt();
    let eta = 0.05 * spacing.powi(3);
    for _ in 0..400 {
        let forces: Vec<Vec3> = (0..n)
            .map(|i| {
                let mut f = Vec3::zeros();
                for j in 0..n {
                    if j != i {
                        let d = pts[i] - pts[j];
                        let r = d.norm();
                        f += d / (r * r * r);
                    }
                }
                f - pts[i] * f.dot(&pts[i])
            })
            .collect();
        for (p, f) in pts.iter_mut().zip(&forces) {
            *p = (*p + f * eta).normalize();
        }
    }
    pts
}

#[cfg(test)]
mod tests;
