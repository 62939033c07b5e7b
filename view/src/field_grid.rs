//! The field on a regular grid, for the page's colour map and contours: sampled from the
//! mission's own field (`Mission::field`, the field the run was judged by) at the depth
//! z = 0, at one time when it does not change, else at several times over the mission.

use crate::model::Model;
use serde::Serialize;

/// Times the field is sampled at when it moves.
pub const MOVING_SAMPLES: usize = 9;

/// The field on a grid: `values[i][row * nx + col]` is T at time `times[i]` and
/// `(x0 + col (x1 − x0)/(nx − 1), y0 + row (y1 − y0)/(ny − 1))`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FieldGrid {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
    pub nx: usize,
    pub ny: usize,
    pub times: Vec<f64>,
    pub values: Vec<Vec<f32>>,
    /// Smallest and largest value over every grid.
    pub min: f32,
    pub max: f32,
}

/// The region the map shows at first: the field's own hint, every track and body position,
/// and the optimum, with a margin of 5 % ([x0, y0, x1, y1]).
pub fn bounds(model: &Model) -> [f64; 4] {
    let (lo, hi) = model.field.bounds_hint();
    let mut b = [lo.x, lo.y, hi.x, hi.y];
    let mut grow = |x: f64, y: f64| {
        if x.is_finite() && y.is_finite() {
            b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
    };
    for tick in model.ticks() {
        for v in &tick.vehicles {
            grow(v.x, v.y);
        }
        if let Some(body) = tick.body {
            grow(body.x, body.y);
        }
    }
    if let Some((x, y)) = model.optimum(0.0) {
        grow(x, y);
    }
    let m = 0.05 * (b[2] - b[0]).max(b[3] - b[1]).max(1e-9);
    [b[0] - m, b[1] - m, b[2] + m, b[3] + m]
}

/// The field over `bounds` on an `n` × `n` grid (n clamped to 8…400).
pub fn grid(model: &Model, bounds: [f64; 4], n: usize) -> FieldGrid {
    let n = n.clamp(8, 400);
    let [x0, y0, x1, y1] = bounds;
    let sample = |t: f64| -> Vec<f32> {
        let mut out = Vec::with_capacity(n * n);
        for row in 0..n {
            let y = y0 + (y1 - y0) * row as f64 / (n - 1) as f64;
            for col in 0..n {
                let x = x0 + (x1 - x0) * col as f64 / (n - 1) as f64;
                out.push(model.field.value(&vbap_math::Vec3::new(x, y, 0.0), t) as f32);
            }
        }
        out
    };
    let end = model.mission.mission.duration;
    let first = sample(0.0);
    let (times, values) = if sample(end) == first {
        (vec![0.0], vec![first])
    } else {
        let times: Vec<f64> = (0..MOVING_SAMPLES)
            .map(|i| end * i as f64 / (MOVING_SAMPLES - 1) as f64)
            .collect();
        let values = times.iter().map(|t| sample(*t)).collect();
        (times, values)
    };
    let finite = values.iter().flatten().filter(|v| v.is_finite());
    let min = finite.clone().fold(f32::INFINITY, |a, b| a.min(*b));
    let max = finite.fold(f32::NEG_INFINITY, |a, b| a.max(*b));
    FieldGrid {
        x0,
        y0,
        x1,
        y1,
        nx: n,
        ny: n,
        times,
        values,
        min,
        max,
    }
}
