//! Where a noise-free gradient climb from a point ends: the local optimum of a field whose
//! basin holds the point (beyond the paper, which climbs with estimates). The judge of a run
//! uses it to tell a body that found a local optimum of a field with several from one that
//! went astray: the paper's method is a local climb and may end at any of them.

use super::Vec3;

/// The local optimum reached from `from` (length unit) by climbing (`sign` = +1) or
/// descending (`sign` = −1) the field whose gradient at a point is `gradient` (field unit
/// per length unit): steps of `step` along the normalised gradient, halved each time the
/// gradient turns back (an overshoot of the optimum), until the step is below
/// `step`/1024, the gradient vanishes, or `max_steps` evaluations are spent. The optimum is
/// then known within about `step`/1024 (length unit). `from` itself when `step` is not
/// positive and finite.
pub fn local_optimum(
    gradient: impl Fn(&Vec3) -> Vec3,
    from: &Vec3,
    sign: f64,
    step: f64,
    max_steps: usize,
) -> Vec3 {
    if !(step.is_finite() && step > 0.0) {
        return *from;
    }
    let mut x = *from;
    let mut g = gradient(&x) * sign;
    let mut h = step;
    for _ in 0..max_steps {
        let n = g.norm();
        if !n.is_finite() || n <= 0.0 || h < step / 1024.0 {
            break;
        }
        let next = x + g * (h / n);
        let g_next = gradient(&next) * sign;
        if g_next.dot(&g) < 0.0 {
            h *= 0.5;
            continue;
        }
        x = next;
        g = g_next;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gradient of a sum of Gaussian bumps (amplitude, centre, width).
    fn bumps(list: &[(f64, Vec3, f64)]) -> impl Fn(&Vec3) -> Vec3 + '_ {
        move |x| {
            list.iter().fold(Vec3::zeros(), |acc, (a, c, w)| {
                let d = x - c;
                acc - d * (a / (w * w) * (-d.norm_squared() / (2.0 * w * w)).exp())
            })
        }
    }

    #[test]
    fn a_climb_ends_at_the_optimum_of_the_basin_it_starts_in() {
        let far = Vec3::new(10.0, 0.0, 0.0);
        let near = Vec3::new(-2.0, 1.0, 0.0);
        let list = [(10.0, far, 4.0), (2.0, near, 1.0)];
        let g = bumps(&list);
        // Next to the small bump: its top, moved a little by the big one's slope; the
        // gradient vanishes there.
        let top = local_optimum(&g, &Vec3::new(-1.5, 0.5, 0.0), 1.0, 0.05, 10_000);
        assert!((top - near).norm() < 0.1, "{top:?}");
        assert!(g(&top).norm() < 1e-3, "{:?}", g(&top));
        // On the big bump's slope: its top.
        let top = local_optimum(&g, &Vec3::new(6.0, 1.0, 0.0), 1.0, 0.05, 10_000);
        assert!((top - far).norm() < 1e-3, "{top:?}");
        // Descending a bowl (goal min): its bottom.
        let bowl = |x: &Vec3| 2.0 * (x - Vec3::new(1.0, 2.0, 3.0));
        let bottom = local_optimum(bowl, &Vec3::zeros(), -1.0, 0.05, 10_000);
        assert!((bottom - Vec3::new(1.0, 2.0, 3.0)).norm() < 1e-3);
        // No step, no climb.
        assert_eq!(local_optimum(bowl, &far, -1.0, 0.0, 10), far);
    }
}
