//! T, ∇T and ∇²T of the interpolant (tensor product of the axes' [`Stencil`]s; linear in
//! time between the two nearest time slices).

use super::axis::{linear, Stencil};
use super::values::{Rows, Values};
use super::GridField;
use crate::config::Goal;
use crate::field::ScalarField;
use vbap_math::{Mat3, Vec3};

/// The value, gradient and Hessian of one time slice at one point.
#[derive(Clone, Copy, Debug, Default)]
struct Jet {
    v: f64,
    g: [f64; 3],
    /// xx, yy, zz, xy, xz, yz.
    h: [f64; 6],
}

/// The single-node stencil of the missing z axis of a 2-D grid.
const FLAT: Stencil = Stencil {
    start: 0,
    w: [1.0, 0.0, 0.0, 0.0],
    d1: [0.0; 4],
    d2: [0.0; 4],
};

impl GridField {
    /// Offset of time slice `k` (the layout is canonical: see `build.rs`).
    fn slice(&self, k: usize) -> usize {
        k * self.layout.step[3] as usize
    }

    /// Offset of the first node of the stencil's x-row `k`, z-level `c` in slice `base`.
    #[inline]
    fn row_offset(&self, start: [usize; 3], k: usize, c: usize, base: usize) -> usize {
        let step = &self.layout.step;
        base + (start[2] + c) * step[2] as usize + (start[1] + k) * step[1] as usize + start[0]
    }

    /// The stencils of `p` along x, y and z (z: one node in 2-D) and the number of z nodes.
    fn stencils(&self, p: &Vec3) -> ([Stencil; 3], usize) {
        let z = self.z.as_ref().map(|a| a.stencil(p.z));
        (
            [self.x.stencil(p.x), self.y.stencil(p.y), z.unwrap_or(FLAT)],
            if z.is_some() { 4 } else { 1 },
        )
    }

    /// Value only (the hot path of a sensor reading): value weights only.
    #[inline]
    fn value_at(&self, w: &[(usize, [f64; 4]); 3], nz: usize, base: usize) -> f64 {
        let o = self.row_offset([w[0].0, w[1].0, w[2].0], 0, 0, base);
        let (sy, sz) = (self.layout.step[1] as usize, self.layout.step[2] as usize);
        match &self.data {
            Values::F64(d) => value_in(d.as_slice(), w, nz, o, [sy, sz]),
            Values::F32(d) => value_in(d.as_slice(), w, nz, o, [sy, sz]),
        }
    }

    /// Value, gradient and Hessian of one slice.
    fn jet_at(&self, st: &[Stencil; 3], nz: usize, base: usize) -> Jet {
        match &self.data {
            Values::F64(d) => self.jet_in(d.as_slice(), st, nz, base),
            Values::F32(d) => self.jet_in(d.as_slice(), st, nz, base),
        }
    }

    fn jet_in<R: Rows + ?Sized>(&self, data: &R, st: &[Stencil; 3], nz: usize, base: usize) -> Jet {
        let (sx, sy, sz) = (&st[0], &st[1], &st[2]);
        let start = [sx.start, sy.start, sz.start];
        let dot =
            |w: &[f64; 4], r: &[f64; 4]| w[0] * r[0] + w[1] * r[1] + w[2] * r[2] + w[3] * r[3];
        let mut j = Jet::default();
        for c in 0..nz {
            // A..F: sums over y of the x-row sums (see the module documentation).
            let [mut a, mut b, mut cc, mut d, mut e, mut f] = [0.0; 6];
            for k in 0..4 {
                let r = &data.row(self.row_offset(start, k, c, base));
                let (r0, r1, r2) = (dot(&sx.w, r), dot(&sx.d1, r), dot(&sx.d2, r));
                a += sy.w[k] * r0;
                b += sy.w[k] * r1;
                cc += sy.d1[k] * r0;
                d += sy.w[k] * r2;
                e += sy.d1[k] * r1;
                f += sy.d2[k] * r0;
            }
            let (wz, dz, d2z) = (sz.w[c], sz.d1[c], sz.d2[c]);
            j.v += wz * a;
            j.g[0] += wz * b;
            j.g[1] += wz * cc;
            j.g[2] += dz * a;
            j.h[0] += wz * d;
            j.h[1] += wz * f;
            j.h[2] += d2z * a;
            j.h[3] += wz * e;
            j.h[4] += dz * b;
            j.h[5] += dz * cc;
        }
        j
    }

    /// The jet at (p, t), linear in time between the two nearest slices.
    fn jet(&self, p: &Vec3, t: f64) -> Jet {
        let (st, nz) = self.stencils(p);
        let (k, tau) = linear(&self.times, t);
        let j0 = self.jet_at(&st, nz, self.slice(k));
        if tau == 0.0 {
            return j0;
        }
        let j1 = self.jet_at(&st, nz, self.slice(k + 1));
        let mix = |a: f64, b: f64| a + tau * (b - a);
        Jet {
            v: mix(j0.v, j1.v),
            g: [0, 1, 2].map(|i| mix(j0.g[i], j1.g[i])),
            h: [0, 1, 2, 3, 4, 5].map(|i| mix(j0.h[i], j1.h[i])),
        }
    }

    /// T(p, t) (the file's unit): the interpolant, constant beyond the grid's edges.
    pub fn value(&self, p: &Vec3, t: f64) -> f64 {
        let z = self.z.as_ref().map(|a| a.weights(p.z));
        let w = [
            self.x.weights(p.x),
            self.y.weights(p.y),
            z.unwrap_or((0, FLAT.w)),
        ];
        let nz = if z.is_some() { 4 } else { 1 };
        let (k, tau) = linear(&self.times, t);
        let v0 = self.value_at(&w, nz, self.slice(k));
        if tau == 0.0 {
            v0
        } else {
            v0 + tau * (self.value_at(&w, nz, self.slice(k + 1)) - v0)
        }
    }

    /// ∇T(p, t) of the interpolant (zero z component in 2-D; zero beyond the edges).
    pub fn gradient(&self, p: &Vec3, t: f64) -> Vec3 {
        let j = self.jet(p, t);
        Vec3::new(j.g[0], j.g[1], j.g[2])
    }

    /// ∇²T(p, t) of the interpolant, symmetric (zero z row and column in 2-D).
    pub fn hessian(&self, p: &Vec3, t: f64) -> Mat3 {
        let h = self.jet(p, t).h;
        Mat3::new(h[0], h[3], h[4], h[3], h[1], h[5], h[4], h[5], h[2])
    }

    /// The grid's box (length unit): x and y extents, z extent in 3-D.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (x0, x1) = self.x.range();
        let (y0, y1) = self.y.range();
        let (z0, z1) = self.z.as_ref().map_or((0.0, 0.0), |z| z.range());
        (Vec3::new(x0, y0, z0), Vec3::new(x1, y1, z1))
    }
}

/// Σ_c w_z[c] Σ_k w_y[k] (w_x · row(c, k)) from the offset `o` of the first node, `step` =
/// the y and z strides: the value weights of [`GridField::value`]. In 2-D (`nz` = 1, w_z = 1)
/// the z sum is skipped, which gives the same bits (1 · a = a).
#[inline(always)]
fn value_in<R: Rows + ?Sized>(
    data: &R,
    w: &[(usize, [f64; 4]); 3],
    nz: usize,
    o: usize,
    step: [usize; 2],
) -> f64 {
    let (wx, wy) = (&w[0].1, &w[1].1);
    let plane = |o: usize| {
        let mut a = 0.0;
        for (k, wk) in wy.iter().enumerate() {
            let r = data.row(o + k * step[0]);
            a += wk * (wx[0] * r[0] + wx[1] * r[1] + wx[2] * r[2] + wx[3] * r[3]);
        }
        a
    };
    if nz == 1 {
        return 0.0 + plane(o);
    }
    let mut v = 0.0;
    for c in 0..nz {
        v += w[2].1[c] * plane(o + c * step[1]);
    }
    v
}

impl ScalarField for GridField {
    fn dim(&self) -> usize {
        self.dim
    }
    fn value(&self, p: &Vec3, t: f64) -> f64 {
        GridField::value(self, p, t)
    }
    fn gradient(&self, p: &Vec3, t: f64) -> Vec3 {
        GridField::gradient(self, p, t)
    }
    fn hessian(&self, p: &Vec3, t: f64) -> Mat3 {
        GridField::hessian(self, p, t)
    }
    fn optimum(&self, t: f64, goal: Goal) -> Option<Vec3> {
        GridField::optimum(self, t, goal)
    }
    fn bounds_hint(&self) -> (Vec3, Vec3) {
        self.bounds()
    }
}
