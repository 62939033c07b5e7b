//! The virtual body (Sec. III): its configuration `(s, r, R, k) ∈ ℝ × SE(3) × ℝ` and the
//! virtual leaders and distance parameters it induces (III.3).

use nalgebra::Rotation3;

use super::formation::FormationDesign;
use super::potential::PairPotential;
use super::Vec3;

/// Configuration of the virtual body at path parameter `s` (III.3).
///
/// In 2-D missions `r.z = 0` and `rotation` is about the z axis only.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VirtualBody {
    /// Path parameter `s` (dimensionless; `ṡ` of (IV.4) is in 1/s).
    pub s: f64,
    /// Centre `r(s)` of the virtual body, length.
    pub r: Vec3,
    /// Orientation `R(s)` of the body frame relative to the inertial frame.
    pub rotation: Rotation3<f64>,
    /// Scale `k(s)` (III.3), dimensionless, > 0; `k = 1` is the design size.
    pub scale: f64,
}

/// Direction of the virtual-body motion per unit `s` (Sec. III-D): `dr/ds`, `dR/ds`,
/// `dk/ds`. The time derivatives are these times `ṡ`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BodyRates {
    /// `dr/ds`, length per unit `s`.
    pub dr_ds: Vec3,
    /// Angular rate `ω` per unit `s`, rad: `dR/ds = [ω]× R` (inertial-frame angular
    /// velocity). In 2-D only the z component may be non-zero.
    pub omega_ds: Vec3,
    /// `dk/ds`, per unit `s`.
    pub dk_ds: f64,
}

impl BodyRates {
    /// No motion at all.
    pub fn zero() -> Self {
        Self {
            dr_ds: Vec3::zeros(),
            omega_ds: Vec3::zeros(),
            dk_ds: 0.0,
        }
    }

    /// Pure translation with `dr/ds = dir`.
    pub fn translation(dir: Vec3) -> Self {
        Self {
            dr_ds: dir,
            ..Self::zero()
        }
    }
}

impl VirtualBody {
    /// The body at `s = 0` centred on `r`, unrotated, at the design scale `k = 1`.
    pub fn at(r: Vec3) -> Self {
        Self {
            s: 0.0,
            r,
            rotation: Rotation3::identity(),
            scale: 1.0,
        }
    }

    /// `k R p + r` for a point `p` of the body frame (III.3), length.
    pub fn to_inertial(&self, p: &Vec3) -> Vec3 {
        self.scale * (self.rotation * p) + self.r
    }

    /// Virtual leaders `b_l(s) = k(s) R(s) b̄_l + r(s)` (III.3), length.
    pub fn leader_positions(&self, design: &FormationDesign) -> Vec<Vec3> {
        design.leaders.iter().map(|b| self.to_inertial(b)).collect()
    }

    /// The designed equilibrium slots moved with the body, `k R p̄_i + r`, length.
    pub fn slot_positions(&self, design: &FormationDesign) -> Vec<Vec3> {
        design.slots.iter().map(|p| self.to_inertial(p)).collect()
    }

    /// `V_I` with `d_i(s) = k(s) d̄_i` (III.3).
    pub fn scaled_inter(&self, design: &FormationDesign) -> PairPotential {
        design.inter.scaled(self.scale)
    }

    /// `V_h` with `h_i(s) = k(s) h̄_i` (III.3).
    pub fn scaled_leader(&self, design: &FormationDesign) -> PairPotential {
        design.leader.scaled(self.scale)
    }

    /// The body after a step `ds` along `rates` (explicit Euler in `s`):
    /// `s + ds`, `r + dr/ds ds`, `exp([ω ds]×) R` (exponential map, re-orthonormalised),
    /// `k + dk/ds ds`. The caller keeps `k > 0` (see [`VirtualBody::is_valid`]).
    pub fn advance(&self, rates: &BodyRates, ds: f64) -> VirtualBody {
        let rotation = if rates.omega_ds == Vec3::zeros() {
            self.rotation
        } else {
            orthonormalised(Rotation3::new(rates.omega_ds * ds) * self.rotation)
        };
        VirtualBody {
            s: self.s + ds,
            r: self.r + rates.dr_ds * ds,
            rotation,
            scale: self.scale + rates.dk_ds * ds,
        }
    }

    /// All numbers finite and `k > 0`.
    pub fn is_valid(&self) -> bool {
        self.s.is_finite()
            && self.r.iter().all(|c| c.is_finite())
            && self.rotation.matrix().iter().all(|c| c.is_finite())
            && self.scale.is_finite()
            && self.scale > 0.0
    }
}

/// Gram–Schmidt on the columns (deterministic, closed form) to stop rounding drift.
fn orthonormalised(rot: Rotation3<f64>) -> Rotation3<f64> {
    let m = rot.matrix();
    let c0 = m.column(0).normalize();
    let c1 = m.column(1) - c0 * c0.dot(&m.column(1));
    let c1 = c1.normalize();
    let c2 = c0.cross(&c1);
    Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[c0, c1, c2]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formation::design_regular;
    use approx::assert_relative_eq;

    #[test]
    fn leaders_and_parameters_follow_iii3() {
        let design = design_regular(4, 2, 1.5, 1.0, 1.0).unwrap();
        let body = VirtualBody {
            s: 0.3,
            r: Vec3::new(1.0, 2.0, 0.0),
            rotation: Rotation3::from_axis_angle(&Vec3::z_axis(), 0.5),
            scale: 2.0,
        };
        let slots = body.slot_positions(&design);
        for (p, bar) in slots.iter().zip(&design.slots) {
            assert_relative_eq!((p - body.r).norm(), 2.0 * bar.norm(), max_relative = 1e-14);
            assert!(p.z.abs() < 1e-15);
        }
        assert_eq!(body.leader_positions(&design), vec![body.r]);
        assert_eq!(body.scaled_inter(&design).d0, 2.0 * design.inter.d0);
        assert_eq!(body.scaled_leader(&design).d1, 2.0 * design.leader.d1);
        assert_eq!(body.scaled_leader(&design).alpha, design.leader.alpha);
    }

    #[test]
    fn advance_is_euler_with_exponential_map() {
        let body = VirtualBody::at(Vec3::new(0.0, 0.0, 0.0));
        let rates = BodyRates {
            dr_ds: Vec3::new(1.0, 0.0, 0.0),
            omega_ds: Vec3::new(0.0, 0.0, 0.25),
            dk_ds: -0.05,
        };
        let mut b = body;
        for _ in 0..1000 {
            b = b.advance(&rates, 0.01);
        }
        assert_relative_eq!(b.s, 10.0, max_relative = 1e-12);
        assert_relative_eq!(b.r, Vec3::new(10.0, 0.0, 0.0), max_relative = 1e-12);
        assert_relative_eq!(b.scale, 0.5, max_relative = 1e-12);
        assert!(b.is_valid());
        assert!(!b.advance(&rates, 20.0).is_valid());
        assert_relative_eq!(b.rotation.angle(), 2.5, max_relative = 1e-12);
        let m = b.rotation.matrix();
        assert_relative_eq!(
            m.transpose() * m,
            nalgebra::Matrix3::identity(),
            epsilon = 1e-14
        );
        assert!(body.is_valid());
        assert_eq!(
            body.advance(&BodyRates::zero(), 1.0).rotation,
            body.rotation
        );
    }
}
