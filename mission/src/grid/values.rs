//! The grid's node values: f64 while the grid is built (land filled, optimum found), then
//! kept as f32 when that loses nothing — every value is exactly an f32, as when the file
//! stores floats — halving the memory a reading walks through (4 MB instead of 8 MB for a
//! 1000 × 1000 grid). An f32 widens to the same f64 exactly, so every reading is bit for bit
//! what the f64 store gives.

/// Node values in the canonical layout (see `build.rs`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Values {
    /// Double precision (packed or double files, or filled values that are not floats).
    F64(Vec<f64>),
    /// Single precision: every value was exactly an f32.
    F32(Vec<f32>),
}

/// Four x-adjacent node values as f64: the one memory access of a stencil row.
pub(crate) trait Rows {
    /// The values at `o..o + 4`.
    fn row(&self, o: usize) -> [f64; 4];
}

impl Rows for [f64] {
    #[inline(always)]
    fn row(&self, o: usize) -> [f64; 4] {
        let r: &[f64; 4] = self[o..o + 4].try_into().expect("four values");
        *r
    }
}

impl Rows for [f32] {
    #[inline(always)]
    fn row(&self, o: usize) -> [f64; 4] {
        let r: &[f32; 4] = self[o..o + 4].try_into().expect("four values");
        r.map(f64::from)
    }
}

impl Values {
    /// Number of values.
    pub(crate) fn len(&self) -> usize {
        match self {
            Values::F64(v) => v.len(),
            Values::F32(v) => v.len(),
        }
    }

    /// Value `i`.
    #[inline]
    pub(crate) fn get(&self, i: usize) -> f64 {
        match self {
            Values::F64(v) => v[i],
            Values::F32(v) => f64::from(v[i]),
        }
    }

    /// The values for editing while the grid is built (they are f64 until [`Values::compact`]).
    pub(crate) fn build_mut(&mut self) -> &mut Vec<f64> {
        match self {
            Values::F64(v) => v,
            Values::F32(_) => unreachable!("a grid's values are edited only while built (f64)"),
        }
    }

    /// Every value, as f64.
    pub(crate) fn iter(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    /// Stores the values as f32 when each one is exactly an f32 (NaN aside: there are none
    /// once land is filled), else leaves them f64.
    pub(crate) fn compact(&mut self) {
        let Values::F64(v) = self else { return };
        if v.iter().all(|x| f64::from(*x as f32) == *x) {
            *self = Values::F32(v.iter().map(|x| *x as f32).collect());
        }
    }

    /// Bytes of value storage.
    pub(crate) fn bytes(&self) -> usize {
        match self {
            Values::F64(v) => v.len() * 8,
            Values::F32(v) => v.len() * 4,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compact_keeps_exact_floats_only() {
        let mut a = Values::F64(vec![1.5, -0.25, 3.0e7, f64::from(0.1f32)]);
        a.compact();
        assert!(matches!(a, Values::F32(_)));
        assert_eq!(a.get(3), f64::from(0.1f32));
        assert_eq!(a.bytes(), 16);
        let mut b = Values::F64(vec![1.5, 0.1]);
        b.compact();
        assert!(matches!(b, Values::F64(_)), "0.1 is not an f32");
        let f: &[f32] = &[1.0, 2.0, 3.0, 4.5, 5.0];
        assert_eq!(f.row(1), [2.0, 3.0, 4.5, 5.0]);
    }

    /// A file of floats (3-D, two times) is held as f32 and reads bit for bit what the f64
    /// store reads: value, gradient and Hessian, inside and beyond the grid.
    #[test]
    fn an_f32_store_reads_the_same_bits_as_the_f64_store() {
        use crate::grid::{GridField, GridSpec};
        use vbap_formats::write::{write_netcdf, NcData, NcVar};
        use vbap_math::Vec3;
        let dir = tempfile::tempdir().unwrap();
        let (xs, ys, zs): (Vec<f64>, Vec<f64>, Vec<f64>) = (
            (0..9).map(|j| f64::from(j) * 10.0).collect(),
            (0..7).map(|j| f64::from(j * j) * 3.0).collect(),
            vec![0.0, 5.0, 15.0, 30.0, 50.0],
        );
        let mut data = Vec::new();
        for t in 0..2 {
            for z in &zs {
                for y in &ys {
                    for x in &xs {
                        let v = (0.05 * x).sin() * (0.03 * y).cos() + 0.01 * z + f64::from(t);
                        data.push(v as f32);
                    }
                }
            }
        }
        let path = dir.path().join("f.nc");
        let axis =
            |n: &str, v: &[f64]| NcVar::new(n, &[n], NcData::F64(v.to_vec()), &[("units", "m")]);
        let time = NcVar::new(
            "time",
            &["time"],
            NcData::F64(vec![0.0, 60.0]),
            &[("units", "s")],
        );
        let dims = [("time", 2), ("depth", 5), ("y", 7), ("x", 9)];
        let var = NcVar::new("temp", &["time", "depth", "y", "x"], NcData::F32(data), &[]);
        let vars = [
            time,
            axis("depth", &zs),
            axis("y", &ys),
            axis("x", &xs),
            var,
        ];
        write_netcdf(&path, false, &dims, &vars, "f32").unwrap();
        let spec = GridSpec {
            file: path,
            dim: 3,
            ..GridSpec::default()
        };
        let g = GridField::load(&spec).unwrap();
        let wide = g.with_f64_values();
        assert_eq!(
            (g.value_precision(), wide.value_precision()),
            ("f32", "f64")
        );
        assert_eq!(2 * g.value_bytes(), wide.value_bytes());
        for k in 0..400 {
            let a = f64::from(k) * 0.618_033_988_7;
            let p = Vec3::new(
                -5.0 + 90.0 * a.fract(),
                -3.0 + 115.0 * (a * 1.7).fract(),
                55.0 * (a * 2.3).fract() - 2.0,
            );
            let t = 70.0 * (a * 3.1).fract() - 5.0;
            assert_eq!(
                g.value(&p, t).to_bits(),
                wide.value(&p, t).to_bits(),
                "{p:?} {t}"
            );
            assert_eq!(g.gradient(&p, t), wide.gradient(&p, t), "{p:?} {t}");
            assert_eq!(g.hessian(&p, t), wide.hessian(&p, t), "{p:?} {t}");
        }
    }
}
