//! The box around the interesting part of a [`Field`], for plots.

use vbap_math::Vec3;

use super::Field;

impl Field {
    /// A box (lower corner, upper corner; length unit) around the interesting part of the field
    /// at t = 0, for plots: ±3 widths around every bump; ±10 length units around a quadratic's
    /// centre (a quadratic has no length scale); ±5 widths around a front's mid-point without a
    /// bump. z is 0 in 2-D. Plots should union it with the tracks.
    pub fn bounds_hint(&self) -> (Vec3, Vec3) {
        let boxed = |c: &Vec3, half: f64| (c - Vec3::repeat(half), c + Vec3::repeat(half));
        let (mut lo, mut hi) = match self {
            Field::Quadratic { center, .. } => boxed(center, 10.0),
            Field::GaussianSum { bumps, .. } => {
                let mut it = bumps.iter().map(|b| boxed(&b.center, 3.0 * b.width));
                match it.next() {
                    Some(first) => it.fold(first, |(lo, hi), (l, h)| (lo.inf(&l), hi.sup(&h))),
                    None => boxed(&Vec3::zeros(), 10.0),
                }
            }
            Field::DriftingEddy { bump, .. } => boxed(&bump.center, 3.0 * bump.width),
            Field::MovingFront {
                normal,
                offset,
                width,
                bump,
                ..
            } => match bump {
                Some(b) => boxed(&b.center, 3.0 * b.width),
                None => boxed(&(normal * *offset), 5.0 * width),
            },
            Field::Grid(g) => g.bounds(),
        };
        if self.dim() == 2 {
            lo.z = 0.0;
            hi.z = 0.0;
        }
        (lo, hi)
    }
}
