//! The shrinker: from a failing draw, simplifications tried one at a time; one is kept when
//! the simplified mission still validates and still fails the SAME criterion (the first
//! criterion the original failed, in [`crate::judge::CRITERIA`] order), and the loop runs
//! again until no simplification applies or the flight budget is spent.

use serde::{Deserialize, Serialize};

use crate::draw::Draw;

/// Most flights one shrink may make.
pub const MAX_SHRINK_FLIGHTS: usize = 60;

/// A shrunk failure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Shrunk {
    /// The simplest draw found that still fails `criterion`.
    pub draw: Draw,
    /// The criterion kept failing.
    pub criterion: String,
    /// The simplifications kept, in order.
    pub steps: Vec<String>,
    /// Flights made while shrinking.
    pub flights: usize,
}

/// The simplifications of `d` that apply, each named; each changes one thing.
pub fn simplifications(d: &Draw) -> Vec<(String, Draw)> {
    let mut out = Vec::new();
    let kills = |d: &Draw, n: usize| {
        d.faults
            .iter()
            .filter(|f| f.until.is_none() && (f.vehicle as usize) < n)
            .count()
    };
    let mut fewer = |label: String, n: usize| {
        if n < d.n && n > d.dim && n - kills(d, n) > d.dim {
            let mut s = d.clone();
            s.n = n;
            s.faults.retain(|f| (f.vehicle as usize) < n);
            out.push((label, s));
        }
    };
    fewer(format!("vehicles {} -> {}", d.n, d.n / 2), d.n / 2);
    fewer(
        format!("vehicles {} -> {}", d.n, d.n.saturating_sub(1)),
        d.n.saturating_sub(1),
    );
    let mut with = |label: &str, change: &dyn Fn(&mut Draw)| {
        let mut s = d.clone();
        change(&mut s);
        if s != *d {
            out.push((label.to_string(), s));
        }
    };
    for (j, f) in d.faults.iter().enumerate() {
        let label = format!(
            "drop fault {j} ({} of vehicle {} at {} s)",
            if f.until.is_some() { "rejoin" } else { "kill" },
            f.vehicle,
            f.at
        );
        with(&label, &|s: &mut Draw| {
            s.faults.remove(j);
        });
    }
    with("loss -> 0", &|s| {
        s.loss = 0.0;
        s.burst = None;
    });
    with("bursty -> Bernoulli", &|s| s.burst = None);
    with("jitter -> 0", &|s| s.jitter = 0.0);
    with("delay -> 0", &|s| {
        s.delay = 0.0;
        s.jitter = 0.0;
    });
    with("acoustic off", &|s| s.acoustic = None);
    with("Iridium off", &|s| s.iridium = None);
    with("surfacing off", &|s| {
        s.surfacing = None;
        s.iridium = None;
        s.acoustic = None;
    });
    with("current off", &|s| s.current = None);
    with("glider -> ideal", &|s| {
        s.glider = None;
        s.current = None;
    });
    with("adapt off", &|s| s.adapt = false);
    if d.delay > 0.05 {
        with("delay halved", &|s| {
            s.delay /= 2.0;
            s.jitter = s.jitter.min(s.delay);
        });
    }
    if d.noise_fraction > 0.01 {
        with("noise halved", &|s| {
            s.noise_fraction = (s.noise_fraction / 2.0).max(0.01)
        });
    }
    out
}

/// Shrinks `draw`, which failed `criterion`. `fails(d)` flies `d` and returns the criteria
/// it failed, or `None` when `d` is not a valid mission (or could not fly).
pub fn shrink(
    draw: &Draw,
    criterion: &str,
    fails: &mut dyn FnMut(&Draw) -> Option<Vec<String>>,
) -> Shrunk {
    let mut current = draw.clone();
    let mut steps = Vec::new();
    let mut flights = 0;
    'outer: loop {
        for (label, candidate) in simplifications(&current) {
            if flights >= MAX_SHRINK_FLIGHTS {
                break 'outer;
            }
            flights += 1;
            if fails(&candidate).is_some_and(|f| f.iter().any(|c| c == criterion)) {
                current = candidate;
                steps.push(label);
                continue 'outer;
            }
        }
        break;
    }
    Shrunk {
        draw: current,
        criterion: criterion.to_string(),
        steps,
        flights,
    }
}
