//! What the page draws, built from the [`Model`]: frames of the map (a tick's vehicles,
//! body, design slots, optimum, and which vehicles' reports reached the coordinator since
//! the frame before), the panels' series, decimated on the server so that a long run's
//! replay stays small.

use std::collections::HashMap;

use nalgebra::Rotation3;
use serde::Serialize;
use vbap_math::body::VirtualBody;
use vbap_math::fit::fit_slots;
use vbap_math::Vec3;

use crate::model::{Model, Tick};

/// A vehicle in a frame, as a JSON array: `[id, x, y, contact, age_s, slot_error, pulse,
/// links]` (`contact`: a code of [`crate::model::CONTACTS`]; `age_s` and `slot_error` null
/// when unknown; `pulse` 1 when a report of it reached the coordinator since the frame
/// before; `links`: what its links did since the frame before, bits [`LINK_SESSION`],
/// [`LINK_SESSION_FAILED`], [`LINK_ACOUSTIC`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameVehicle(
    pub u32,
    pub f32,
    pub f32,
    pub u8,
    pub Option<f32>,
    pub Option<f32>,
    pub u8,
    pub u8,
);

/// `links` bit: the vehicle opened an Iridium session (`[links.iridium]`).
pub const LINK_SESSION: u8 = 1;
/// `links` bit: an Iridium session of the vehicle failed.
pub const LINK_SESSION_FAILED: u8 = 2;
/// `links` bit: the vehicle sent an acoustic frame (`[acoustic]`).
pub const LINK_ACOUSTIC: u8 = 4;

/// One frame of the map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Frame {
    /// Tick and its mission time (s).
    pub k: u64,
    pub t: f64,
    /// Body centre and scale `[x, y, k]`.
    pub b: Option<[f32; 3]>,
    /// The vehicles.
    pub v: Vec<FrameVehicle>,
    /// The design slots, as fitted to the true positions (`vbap_math::fit`): `[[x, y], …]`.
    pub s: Vec<[f32; 2]>,
    /// The field's optimum `[x, y]`.
    pub o: Option<[f32; 2]>,
}

/// What a sequence of frames remembers of the frame before (for the pulses).
#[derive(Clone, Debug, Default)]
pub struct FrameCursor {
    /// Per vehicle: (t, age of information) of the last frame built.
    last: HashMap<u32, (f64, Option<f64>)>,
}

impl FrameCursor {
    /// The frame of tick `k` of `model` (which must be ready); the cursor moves to it.
    pub fn frame(&mut self, model: &Model, k: usize) -> Frame {
        let tick = &model.ticks()[k];
        let v = tick
            .vehicles
            .iter()
            .map(|q| {
                let pulse = match (self.last.get(&q.id), q.age) {
                    // Without news the age grows by the time passed; less: a report came.
                    (Some((t0, Some(a0))), Some(a)) => a < a0 + (tick.t - t0) - 1e-6,
                    (Some((_, None)), Some(_)) => true,
                    _ => false,
                };
                // Since the frame before (the first frame: nothing).
                let since = self.last.get(&q.id).map_or(tick.t, |&(t0, _)| t0);
                self.last.insert(q.id, (tick.t, q.age));
                let links = model.links_between(q.id, since, tick.t);
                FrameVehicle(
                    q.id,
                    q.x as f32,
                    q.y as f32,
                    q.contact,
                    q.age.map(|a| a as f32),
                    q.slot_error.map(|e| e as f32),
                    pulse as u8,
                    links,
                )
            })
            .collect();
        Frame {
            k: k as u64,
            t: tick.t,
            b: tick.body.map(|b| [b.x as f32, b.y as f32, b.scale as f32]),
            v,
            s: slots(model, tick),
            o: model.optimum(tick.t).map(|(x, y)| [x as f32, y as f32]),
        }
    }
}

/// The slots of the tick's design fitted to its live vehicles' true positions, as the
/// judge of `formation.csv` fits them (the body's orientation is not recorded: the
/// identity, which the fit rotates for central designs).
fn slots(model: &Model, tick: &Tick) -> Vec<[f32; 2]> {
    let Some(body) = tick.body else {
        return Vec::new();
    };
    let Some(design) = model.design(body.n_vehicles) else {
        return Vec::new();
    };
    let dead = crate::model::contact_code("dead");
    let positions: Vec<Vec3> = tick
        .vehicles
        .iter()
        .filter(|v| v.contact != dead)
        .map(|v| Vec3::new(v.x, v.y, 0.0))
        .collect();
    let vb = VirtualBody {
        s: 0.0,
        r: Vec3::new(body.x, body.y, 0.0),
        rotation: Rotation3::identity(),
        scale: body.scale,
    };
    let fit = fit_slots(&positions, design, &vb, 2.min(model.mission.mission.dim));
    design
        .slots
        .iter()
        .map(|p| {
            let q = fit.rotation * (body.scale * p) + vb.r;
            [q.x as f32, q.y as f32]
        })
        .collect()
}

/// At most `max` (≥ 2) evenly spaced ticks of `from..n`, the last one included.
pub fn stride(from: usize, n: usize, max: usize) -> Vec<usize> {
    if from >= n {
        return Vec::new();
    }
    let count = n - from;
    let max = max.max(2);
    if count <= max {
        return (from..n).collect();
    }
    let step = (count - 1) as f64 / (max - 1) as f64;
    let mut ks: Vec<usize> = (0..max)
        .map(|i| from + (i as f64 * step).round() as usize)
        .collect();
    ks.dedup();
    ks
}

/// The frames of ticks `from..ready`, at most `max` of them, evenly spaced (the pulses
/// of a frame cover every tick since the one before, skipped ones included).
pub fn frames(model: &Model, from: usize, max: usize) -> Vec<Frame> {
    let mut cursor = FrameCursor::default();
    stride(from, model.ticks().len(), max)
        .into_iter()
        .map(|k| cursor.frame(model, k))
        .collect()
}

/// The panels' series over mission time (`t`, s): V/V_U of (II.2) true and seen, the
/// body's distance to the optimum (length unit), the gradient-estimate error, ṡ ÷ v0.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Panels {
    pub t: Vec<f64>,
    pub v_true: Vec<Option<f32>>,
    pub v_seen: Vec<Option<f32>>,
    pub dist: Vec<Option<f32>>,
    pub grad_err: Vec<Option<f32>>,
    pub sdot: Vec<Option<f32>>,
}

/// The five values of a tick.
fn values(model: &Model, tick: &Tick) -> [Option<f64>; 5] {
    let truth = tick.truth.unwrap_or_default();
    let dist = tick.body.and_then(|b| {
        model
            .optimum(tick.t)
            .map(|(x, y)| ((b.x - x).powi(2) + (b.y - y).powi(2)).sqrt())
    });
    [
        truth.v_true,
        truth.v_seen,
        dist,
        tick.body.and_then(|b| b.grad_error),
        truth.sdot,
    ]
}

/// The panels of ticks `from..ready`: every tick when they are at most `max`, else
/// `max / 2` buckets of two points each, where each series takes its minimum and maximum
/// over the bucket (in the order they occur), so no spike is lost.
pub fn panels(model: &Model, from: usize, max: usize) -> Panels {
    let ticks = model.ticks();
    let mut p = Panels::default();
    if from >= ticks.len() {
        return p;
    }
    let span = &ticks[from..];
    let buckets = (max / 2).max(1);
    if span.len() <= max {
        for tick in span {
            push(
                &mut p,
                tick.t,
                values(model, tick).map(|v| v.map(|x| x as f32)),
            );
        }
        return p;
    }
    let per = span.len().div_ceil(buckets);
    for chunk in span.chunks(per) {
        let rows: Vec<[Option<f64>; 5]> = chunk.iter().map(|t| values(model, t)).collect();
        let mut first = [None; 5];
        let mut second = [None; 5];
        for s in 0..5 {
            let mut lo: Option<(usize, f64)> = None;
            let mut hi: Option<(usize, f64)> = None;
            for (i, r) in rows.iter().enumerate() {
                if let Some(x) = r[s].filter(|x| x.is_finite()) {
                    if lo.is_none_or(|(_, m)| x < m) {
                        lo = Some((i, x));
                    }
                    if hi.is_none_or(|(_, m)| x > m) {
                        hi = Some((i, x));
                    }
                }
            }
            if let (Some(lo), Some(hi)) = (lo, hi) {
                let (a, b) = if lo.0 <= hi.0 { (lo, hi) } else { (hi, lo) };
                first[s] = Some(a.1 as f32);
                second[s] = Some(b.1 as f32);
            }
        }
        push(&mut p, chunk[0].t, first);
        if chunk.len() > 1 {
            push(&mut p, chunk[chunk.len() - 1].t, second);
        }
    }
    p
}

fn push(p: &mut Panels, t: f64, v: [Option<f32>; 5]) {
    p.t.push(t);
    p.v_true.push(v[0]);
    p.v_seen.push(v[1]);
    p.dist.push(v[2]);
    p.grad_err.push(v[3]);
    p.sdot.push(v[4]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stride_keeps_both_ends_and_its_bound() {
        assert_eq!(stride(0, 5, 10), vec![0, 1, 2, 3, 4]);
        let s = stride(0, 1000, 11);
        assert_eq!(s.len(), 11);
        assert_eq!((s[0], s[10]), (0, 999));
        assert!(stride(7, 7, 3).is_empty());
        assert_eq!(stride(3, 1000, 2), vec![3, 999]);
    }
}
