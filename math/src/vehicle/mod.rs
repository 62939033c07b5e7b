//! The motion of a real vehicle (beyond the paper): the paper's vehicle is the double
//! integrator ẍ_i = u_i of (II.1) with no limit; a real glider flies through the water at
//! a limited speed, turns and accelerates at limited rates, is carried by the current it
//! swims in and, under water, knows its position only by dead reckoning.
//!
//! [`VehicleModel`] maps the control u_i of the law to the vehicle's velocity through the
//! water; [`advance`] moves the true position with water velocity + current and the
//! vehicle's belief with the water velocity alone (the current is unknown to it);
//! [`land`] keeps vehicles and the body centre out of land.
//!
//! With [`VehicleModel::Ideal`], no current and no land, [`advance`] is the semi-implicit
//! Euler step of [`crate::control::integrate`] bit for bit.

pub mod dive;
pub mod land;
#[cfg(test)]
mod tests;

use crate::Vec3;

/// Limits of a glider's motion through the water.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GliderLimits {
    /// Largest speed through the water, length unit/s (> 0).
    pub max_speed: f64,
    /// Largest change of the water velocity, length unit/s² (> 0).
    pub max_accel: f64,
    /// Largest turn rate of the heading through the water, rad/s (> 0).
    pub max_turn_rate: f64,
}

/// How fast the virtual body may change its velocity so that gliders can follow it
/// (beyond the paper, whose vehicles accelerate and turn without limit).
///
/// A glider turns its heading at most `Ω = max_turn_rate`: a body that sets off from rest
/// at full speed, or turns sharply, leaves its gliders looping behind it for `π/Ω`
/// seconds (2.5 s at 1.26 rad/s, a body at 0.9 L/s is then 2 L away: a formation broken
/// at the start of random missions, the failures concentrated at the lowest turn rates).
/// The body therefore turns at most at half the gliders' rate and accelerates at most at
/// `min(max_accel/4, v0 Ω/π)`: from rest to `v0` in no less than a glider's half turn,
/// leaving each glider three quarters of its acceleration for its own slot.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BodyLimits {
    /// Largest acceleration of the body centre, length unit/s² (> 0).
    pub max_accel: f64,
    /// Largest turn rate of the body's velocity, rad/s (> 0).
    pub max_turn_rate: f64,
}

impl BodyLimits {
    /// The limits for gliders of `limits` flying a body of nominal speed `v0` (length
    /// unit/s); None when a limit is not positive and finite.
    pub fn for_gliders(limits: &GliderLimits, v0: f64) -> Option<Self> {
        let omega = limits.max_turn_rate;
        let accel = (0.25 * limits.max_accel).min(v0 * omega / std::f64::consts::PI);
        let ok = |x: f64| x.is_finite() && x > 0.0;
        (ok(accel) && ok(omega)).then_some(Self {
            max_accel: accel,
            max_turn_rate: 0.5 * omega,
        })
    }

    /// The rate `wanted` of the body (any norm) turned from the direction of the body's
    /// previous velocity `previous` by at most `max_turn_rate · dt` (`dt` in s), at the
    /// norm of `wanted`'s projection on the heading reached (none when `wanted` points
    /// behind it: the body slows while it turns round, and stops rather than orbit an
    /// optimum it overshot at full speed, as gliders do, `VehicleModel::water_velocity`);
    /// `wanted` as it is when the body was (almost) at rest, when either is zero, or when
    /// it turns less.
    pub fn turn(&self, previous: &Vec3, wanted: &Vec3, dt: f64) -> Vec3 {
        if previous.norm() <= 1e-9 || wanted.norm() == 0.0 {
            return *wanted;
        }
        nearest_on_heading(
            wanted,
            &turn_towards(previous, wanted, self.max_turn_rate * dt),
        )
    }

    /// The largest speed (length unit/s) after a step of `dt` s from the speed `previous`.
    pub fn speed_after(&self, previous: f64, dt: f64) -> f64 {
        previous + self.max_accel * dt
    }
}

/// How the control u_i of the law moves the vehicle through the water.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VehicleModel {
    /// The paper's double integrator (II.1): w' = w + u dt, no limit.
    Ideal,
    /// A glider: u_i applied to the water velocity, then saturated by [`GliderLimits`].
    Glider(GliderLimits),
}

impl VehicleModel {
    /// The water velocity after a step of `dt` s from water velocity `w` (length unit/s)
    /// under control `u` (length unit/s²).
    ///
    /// Ideal: w + u dt, the velocity update of (II.1) integrated by semi-implicit Euler.
    /// Glider (beyond the paper), in this order: the change u dt is clipped to
    /// `max_accel`·dt; the heading turns from that of `w` by at most `max_turn_rate`·dt
    /// (not checked below 1 % of `max_speed`, where a heading means little), and when the
    /// turn falls short the velocity is the wanted one's projection on the new heading
    /// (`nearest_on_heading`: slower while turning, stopped rather than flying away); the
    /// speed is capped at `max_speed`. The result never exceeds `max_speed`.
    pub fn water_velocity(&self, w: &Vec3, u: &Vec3, dt: f64) -> Vec3 {
        match self {
            VehicleModel::Ideal => w + u * dt,
            VehicleModel::Glider(l) => {
                let mut change = u * dt;
                let most = l.max_accel * dt;
                if change.norm() > most {
                    change *= most / change.norm();
                }
                let wanted = w + change;
                let turned = if w.norm() > 0.01 * l.max_speed {
                    nearest_on_heading(&wanted, &turn_towards(w, &wanted, l.max_turn_rate * dt))
                } else {
                    wanted
                };
                cap_speed(&turned, l.max_speed)
            }
        }
    }

    /// Where the control law is evaluated for a vehicle at `position` (length unit) moving
    /// at `relative` (length unit/s) relative to where it is held (its slot, over the
    /// ground): the ideal vehicle at `position`; a glider at its braking point
    /// `position + v|v|/(2 a)`, where it would come to rest if it braked now at its largest
    /// acceleration `a = max_accel` (beyond the paper).
    ///
    /// Why: a glider's acceleration is clipped ([`VehicleModel::water_velocity`]). Near a
    /// stiff slot (formation modes of √μ rad/s, stiffness μ = α/h0² of (II.1)) the law
    /// asks for `μ e`, far beyond `a`, all the way to the slot: the glider arrives at
    /// speed, cannot stop within a tick and swings through to the other side, for ever
    /// (seen in random missions: gliders 0.07 spacing about their slots at 1.1 L/s, V at
    /// 8 V_U, two of them 0.085 spacing apart; `docs/ENVELOPE.md`). Anticipating the stop
    /// brakes in time, the way a pilot brakes for the point it aims at. The shift is
    /// quadratic in the speed, so the law's linearisation about its equilibrium, and the
    /// envelope computed from it, are unchanged.
    ///
    /// The shift is at most `reach` (length unit): a glider crossing the formation at
    /// speed (assembling from a bunched start, 1.6 L/s braked at 4.7 L/s²: 0.27 L) would
    /// otherwise be steered by the forces at a point past a per-slot leader, where the
    /// singular repulsion points the wrong way.
    pub fn braking_point(&self, position: &Vec3, relative: &Vec3, reach: f64) -> Vec3 {
        match self {
            VehicleModel::Ideal => *position,
            VehicleModel::Glider(l) => {
                let speed = relative.norm();
                let shift = (speed * speed / (2.0 * l.max_accel)).min(reach.max(0.0));
                if shift > 0.0 {
                    position + relative * (shift / speed)
                } else {
                    *position
                }
            }
        }
    }
}

/// `v` scaled down to a norm of at most `max` (length unit/s); returned as is when slower.
pub fn cap_speed(v: &Vec3, max: f64) -> Vec3 {
    let n = v.norm();
    if n <= max {
        return *v;
    }
    let mut out = v * (max / n);
    // Rounding may leave the norm an ulp above: shrink until it is not.
    while out.norm() > max {
        out *= 1.0 - f64::EPSILON;
    }
    out
}

/// The velocity along `heading`'s direction nearest to `wanted` (length unit/s): `wanted`
/// projected on that direction, and zero when it points behind it; `wanted` itself when
/// `heading` is `wanted` (the turn was within reach). A pilot whose turn is limited flies
/// slower while it is still turning towards where it is asked to go, and stops turning
/// round rather than carrying its speed the wrong way.
fn nearest_on_heading(wanted: &Vec3, heading: &Vec3) -> Vec3 {
    let n = heading.norm();
    if heading == wanted || n == 0.0 {
        return *heading;
    }
    let h = heading / n;
    h * wanted.dot(&h).max(0.0)
}

/// `to` with its direction turned from that of `from` by at most `angle` rad, keeping the
/// norm of `to`. When the two are opposite the turn is made about z (in the plane of a
/// 2-D mission) or about the axis nearest to perpendicular.
fn turn_towards(from: &Vec3, to: &Vec3, angle: f64) -> Vec3 {
    let speed = to.norm();
    if speed == 0.0 {
        return *to;
    }
    let a = from / from.norm();
    let b = to / speed;
    let cos = a.dot(&b).clamp(-1.0, 1.0);
    if cos.acos() <= angle {
        return *to;
    }
    let perp = b - a * cos;
    let e = if perp.norm() > 1e-12 {
        perp / perp.norm()
    } else {
        let z = Vec3::new(0.0, 0.0, 1.0);
        let c = a.cross(&z);
        if c.norm() > 1e-6 {
            // In the xy plane: a quarter turn of a about z.
            Vec3::new(-a.y, a.x, 0.0) / a.xy().norm()
        } else {
            a.cross(&Vec3::new(1.0, 0.0, 0.0)).normalize()
        }
    };
    (a * angle.cos() + e * angle.sin()) * speed
}

/// One vehicle's state of motion: where it truly is, where it believes it is, and how it
/// moves through the water.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// True position, length unit.
    pub position: Vec3,
    /// Believed position (dead reckoning since the last fix), length unit.
    pub belief: Vec3,
    /// Velocity through the water, length unit/s.
    pub water: Vec3,
    /// True velocity over the ground, length unit/s: water velocity + current, or the
    /// displacement ÷ dt when land stopped or deflected the step.
    pub ground: Vec3,
}

/// One step of `dt` s under control `u` (length unit/s²) with the current `current`
/// (length unit/s, at the true position, unknown to the vehicle):
/// w' = [`VehicleModel::water_velocity`], x' = x + (w' + c) dt (the true position,
/// advected; its ground velocity w' + c), b' = b + w' dt (the belief: dead reckoning with the water velocity). The true
/// position is then passed through `keep` (land: [`land::slide`]); pass the identity
/// when there is no land. In 2-D (`dim` = 2) z stays 0.
pub fn advance(
    model: &VehicleModel,
    m: &Motion,
    u: &Vec3,
    current: &Vec3,
    dt: f64,
    dim: usize,
    keep: impl Fn(&Vec3, &Vec3) -> Vec3,
) -> Motion {
    let mut water = model.water_velocity(&m.water, u, dt);
    let mut ground = water + current;
    if dim == 2 {
        water.z = 0.0;
        ground.z = 0.0;
    }
    let free = m.position + ground * dt;
    let mut position = keep(&m.position, &free);
    if position != free {
        ground = (position - m.position) / dt;
    }
    let mut belief = m.belief + water * dt;
    if dim == 2 {
        position.z = 0.0;
        belief.z = 0.0;
    }
    Motion {
        position,
        belief,
        water,
        ground,
    }
}
