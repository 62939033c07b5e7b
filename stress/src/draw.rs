//! One sampled mission ([`Draw`]): the parameters drawn from the [`Space`], a pure function of
//! (campaign seed, mission index, attempt), and its text as a mission file ([`Draw::toml`]).
//!
//! The shrinker edits a `Draw` (fewer vehicles, a fault dropped, an impairment set benign)
//! and renders it again, so an original and its shrunk mission differ only where a
//! simplification applied.

use std::fmt::Write;
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::grid::{GRID_AMPLITUDE, GRID_BUMP, GRID_WIDTH};
use crate::space::{Range, Space};

/// The size of the acoustic frame the space's missions send, bytes (exact positions:
/// `vbap_wire::compact::acoustic_frame_len`).
const ACOUSTIC_FRAME_BYTES: f64 = 54.0;

/// Radius of the paper's optimal square (Table I, N = 4), L: the formation radius of N
/// vehicles is this × (N/4)^(1/dim), so the neighbour spacing stays about the paper's.
pub const PAPER_RADIUS: f64 = 1.229;

/// A scheduled fault of a draw.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FaultDraw {
    /// The vehicle killed.
    pub vehicle: u32,
    /// When, s.
    pub at: f64,
    /// When it is restarted (a rejoin), s; none: a permanent kill.
    pub until: Option<f64>,
}

/// The field of a draw, as the `[field]` keys say it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldDraw {
    /// `field.kind`.
    pub kind: String,
    /// `field.center` (L), empty when unused.
    pub center: Vec<f64>,
    /// `field.amplitude` (F).
    pub amplitude: f64,
    /// `field.width` (L).
    pub width: f64,
    /// `field.hessian` (F/L²), empty when unused.
    pub hessian: Vec<Vec<f64>>,
    /// `field.velocity` (L/s), empty when unused.
    pub velocity: Vec<f64>,
    /// `field.normal`, empty when unused.
    pub normal: Vec<f64>,
    /// `field.offset` (F for a quadratic, L for a front).
    pub offset: f64,
    /// `[[field.bumps]]`: centre (L), amplitude (F), width (L).
    pub bumps: Vec<(Vec<f64>, f64, f64)>,
    /// `mission.goal`: "max" or "min".
    pub goal: String,
    /// The field's range over the mission area, F (noise is a fraction of it).
    pub range: f64,
    /// |curvature| at the optimum, F/L² (the Hessian guess).
    pub curvature: f64,
    /// The gradient scale, F/L (grad_saturation and kalman_b follow it).
    pub gradient: f64,
}

/// Everything drawn for one mission. Units: L, s, F.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Draw {
    /// Mission index in the campaign.
    pub index: u64,
    /// `mission.seed` (noise, links, start positions).
    pub seed: u64,
    /// Vehicles N.
    pub n: usize,
    /// 2 or 3.
    pub dim: usize,
    /// `vehicles.start`, L.
    pub start: Vec<f64>,
    /// Distance from the start to the optimum (or the front), L.
    pub distance: f64,
    /// The field.
    pub field: FieldDraw,
    /// σ_M ÷ the field's range.
    pub noise_fraction: f64,
    /// `links.delay`, s.
    pub delay: f64,
    /// `links.jitter`, s.
    pub jitter: f64,
    /// `links.loss`.
    pub loss: f64,
    /// Gilbert–Elliott (`burst_enter`, `burst_exit`, `burst_loss`); none: Bernoulli loss.
    pub burst: Option<(f64, f64, f64)>,
    /// Surfacing (`surfacing_period`, `surfacing_window`), s; none: always in contact.
    pub surfacing: Option<(f64, f64)>,
    /// Iridium sessions on a surfacing link (`session_interval`, `session_failure`,
    /// `latency_short`), s; none: store and forward.
    pub iridium: Option<(f64, f64, f64)>,
    /// Acoustic modems (`[acoustic]`); none in plans written before they were drawn.
    #[serde(default)]
    pub acoustic: Option<AcousticDraw>,
    /// `[[faults]]`: kills and rejoins.
    pub faults: Vec<FaultDraw>,
    /// `formation.adapt`.
    pub adapt: bool,
    /// `formation.min_scale`.
    pub min_scale: f64,
    /// `formation.radius` ÷ the spacing-preserving radius ([`Draw::radius`]); 1 in plans
    /// written before it was drawn.
    #[serde(default = "one")]
    pub radius_factor: f64,
    /// `formation.alpha`, L²/s².
    pub alpha: f64,
    /// `vehicles.damping`, 1/s.
    pub damping: f64,
    /// `body.v0`, L/s.
    pub v0: f64,
    /// Glider limits (`max_speed` L/s, `max_accel` L/s², `max_turn_rate` rad/s); none: the
    /// ideal vehicle.
    pub glider: Option<(f64, f64, f64)>,
    /// Uniform current, L/s; none: still water.
    pub current: Option<Vec<f64>>,
    /// `mission.duration`, s.
    pub duration: f64,
}

/// The `[acoustic]` of a mission. Units: L, s.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AcousticDraw {
    /// `interval`, s.
    pub interval: f64,
    /// `schedule = "tdma"` (else `"random"`).
    pub tdma: bool,
    /// `communication_range`, L (detection 1.3 ×, interference 1.6 × it).
    pub range: f64,
    /// `bit_rate`, bit/s (a 54-byte frame, exact positions).
    pub bit_rate: f64,
    /// `sound_speed`, L/s.
    pub sound_speed: f64,
    /// `decode_probability`.
    pub decode_probability: f64,
}

/// SplitMix64 finaliser.
const fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The ChaCha8 stream of mission `index`, attempt `attempt`, of campaign `seed`: keyed by
/// the three (as `vbap_math::rng` keys a mission's draws), never by the order of drawing.
pub fn stream(seed: u64, index: u64, attempt: u64) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    let mut h = mix64(seed ^ 0x5354_5245_5353_0000); // "STRESS"
    for (i, part) in [index, attempt, 0x7374_7265_7373, 1]
        .into_iter()
        .enumerate()
    {
        h = mix64(h ^ part.wrapping_add(0x9e37_79b9_7f4a_7c15u64.wrapping_mul(i as u64 + 1)));
        key[i * 8..i * 8 + 8].copy_from_slice(&h.to_le_bytes());
    }
    ChaCha8Rng::from_seed(key)
}

fn draw(rng: &mut ChaCha8Rng, r: &Range) -> f64 {
    r.at(rng.random::<f64>())
}

fn unit_vector(rng: &mut ChaCha8Rng, dim: usize) -> Vec<f64> {
    loop {
        let v: Vec<f64> = (0..dim).map(|_| rng.random::<f64>() * 2.0 - 1.0).collect();
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.1 && n <= 1.0 {
            return v.iter().map(|x| x / n).collect();
        }
    }
}

fn scaled(v: &[f64], k: f64) -> Vec<f64> {
    v.iter().map(|x| x * k).collect()
}

/// A random rotation R (dim × dim, rows) by Gram–Schmidt of random unit vectors.
fn rotation(rng: &mut ChaCha8Rng, dim: usize) -> Vec<Vec<f64>> {
    let mut rows: Vec<Vec<f64>> = Vec::new();
    while rows.len() < dim {
        let mut v = unit_vector(rng, dim);
        for r in &rows {
            let d: f64 = v.iter().zip(r).map(|(a, b)| a * b).sum();
            for (x, y) in v.iter_mut().zip(r) {
                *x -= d * y;
            }
        }
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.3 {
            rows.push(scaled(&v, 1.0 / n));
        }
    }
    rows
}

impl Draw {
    /// Draws mission `index` of campaign `seed` at `attempt` (0 first; a redraw after an
    /// invalid mission takes the next attempt): a pure function of the three.
    pub fn sample(space: &Space, seed: u64, index: u64, attempt: u64) -> Draw {
        let mut rng = stream(seed, index, attempt);
        let rng = &mut rng;
        let n = rng.random_range(space.vehicles.0..=space.vehicles.1);
        let dim = space.dims[rng.random_range(0..space.dims.len())];
        let v0 = draw(rng, &space.v0);
        let distance = draw(rng, &space.distance);
        let mut kind = space.field_kinds[rng.random_range(0..space.field_kinds.len())];
        if kind == "grid" && dim != 2 {
            kind = "gaussian";
        }
        let dir = unit_vector(rng, dim);
        let (field, start) = Self::field(space, rng, kind, dim, distance, &dir, v0);
        let noise_fraction = draw(rng, &space.noise_fraction);
        let (delay, jitter) = if rng.random::<f64>() < space.p_no_delay {
            (0.0, 0.0)
        } else {
            let d = draw(rng, &space.delay);
            let j = if rng.random::<f64>() < space.p_jitter {
                d * rng.random::<f64>()
            } else {
                0.0
            };
            (d, j)
        };
        let (loss, burst) = if rng.random::<f64>() < space.p_no_loss {
            (0.0, None)
        } else {
            let l = draw(rng, &space.loss);
            let b = (rng.random::<f64>() < space.p_bursty).then(|| {
                (
                    draw(rng, &space.burst_enter),
                    draw(rng, &space.burst_exit),
                    draw(rng, &space.burst_loss),
                )
            });
            (l, b)
        };
        let surfacing = (rng.random::<f64>() < space.p_surfacing).then(|| {
            let p = draw(rng, &space.surfacing_period);
            (p, p * draw(rng, &space.surfacing_window_fraction))
        });
        let duration = space.duration_margin * distance / v0 + space.duration_extra;
        let duration = (duration / space.dt).round() * space.dt;
        let faults = Self::faults(space, rng, n, dim, duration);
        let adapt = rng.random::<f64>() < space.p_adapt;
        let alpha = draw(rng, &space.alpha);
        let damping = draw(rng, &space.damping);
        let glider = (rng.random::<f64>() < space.p_glider).then(|| {
            (
                v0 * draw(rng, &space.glider_max_speed),
                draw(rng, &space.glider_max_accel),
                draw(rng, &space.glider_max_turn_rate),
            )
        });
        let current = (glider.is_some() && rng.random::<f64>() < space.p_current).then(|| {
            let speed = v0 * draw(rng, &space.current_speed);
            scaled(&unit_vector(rng, dim), speed)
        });
        // A TOML integer holds at most 2⁶³ − 1.
        let seed_of_mission = rng.random::<u64>() >> 1;
        let min_scale = draw(rng, &space.min_scale);
        let radius_factor = draw(rng, &space.radius_factor);
        // Drawn last: a mission without it draws what it drew before Iridium was in the
        // space.
        let iridium = surfacing.and_then(|(_, window)| {
            (rng.random::<f64>() < space.p_iridium).then(|| {
                (
                    window / draw(rng, &space.sessions_per_window),
                    draw(rng, &space.session_failure),
                    window * draw(rng, &space.session_latency_fraction),
                )
            })
        });
        // Drawn after Iridium, for the same reason.
        let acoustic = (surfacing.is_some()
            && n <= vbap_mission::config::MAX_ACOUSTIC_VEHICLES
            && rng.random::<f64>() < space.p_acoustic)
            .then(|| {
                let interval =
                    space.dt * draw(rng, &space.acoustic_interval_ticks).round().max(1.0);
                let tdma = rng.random::<f64>() < space.p_tdma;
                let share = if tdma {
                    interval / n as f64
                } else {
                    interval / 2.0
                };
                let air = share * draw(rng, &space.acoustic_air);
                let propagation = share * draw(rng, &space.acoustic_air);
                let radius = radius_factor * PAPER_RADIUS * (n as f64 / 4.0).powf(1.0 / dim as f64);
                let range = radius * draw(rng, &space.acoustic_range);
                AcousticDraw {
                    interval,
                    tdma,
                    range,
                    bit_rate: 8.0 * ACOUSTIC_FRAME_BYTES / air,
                    sound_speed: 1.6 * range / propagation,
                    decode_probability: draw(rng, &space.decode_probability),
                }
            });
        Draw {
            index,
            seed: seed_of_mission,
            acoustic,
            n,
            dim,
            start,
            distance,
            field,
            noise_fraction,
            delay,
            jitter,
            loss,
            burst,
            surfacing,
            iridium,
            faults,
            adapt,
            alpha,
            damping,
            v0,
            glider,
            current,
            duration,
            min_scale,
            radius_factor,
        }
    }

    /// The field of kind `kind` with its optimum (or front) `distance` L from the start
    /// along `dir`; returns it and the start.
    fn field(
        space: &Space,
        rng: &mut ChaCha8Rng,
        kind: &str,
        dim: usize,
        distance: f64,
        dir: &[f64],
        v0: f64,
    ) -> (FieldDraw, Vec<f64>) {
        let mut f = FieldDraw {
            kind: kind.to_string(),
            center: Vec::new(),
            amplitude: 0.0,
            width: 0.0,
            hessian: Vec::new(),
            velocity: Vec::new(),
            normal: Vec::new(),
            offset: 0.0,
            bumps: Vec::new(),
            goal: "max".into(),
            range: 1.0,
            curvature: 1.0,
            gradient: 1.0,
        };
        let origin = vec![0.0; dim];
        let gaussian = |f: &mut FieldDraw, rng: &mut ChaCha8Rng| {
            f.center = scaled(dir, distance);
            f.amplitude = draw(rng, &space.amplitude);
            f.width = distance * draw(rng, &space.width_over_distance);
            f.range = f.amplitude;
            f.curvature = f.amplitude / (f.width * f.width);
            // The largest slope of a Gaussian, at one width from its centre.
            f.gradient = f.amplitude / f.width * (-0.5f64).exp();
        };
        match kind {
            "quadratic" => {
                f.center = scaled(dir, distance);
                f.goal = "min".into();
                let eig: Vec<f64> = (0..dim)
                    .map(|_| draw(rng, &space.hessian_eigenvalue))
                    .collect();
                let r = rotation(rng, dim);
                // H = Rᵀ diag(eig) R; the upper triangle is computed and mirrored, so H is
                // symmetric to the bit (the validator checks it).
                let entry = |i: usize, j: usize| -> f64 {
                    let (a, b) = (i.min(j), i.max(j));
                    (0..dim).map(|k| r[k][a] * eig[k] * r[k][b]).sum()
                };
                f.hessian = (0..dim)
                    .map(|i| (0..dim).map(|j| entry(i, j)).collect())
                    .collect();
                let mean = eig.iter().sum::<f64>() / dim as f64;
                let max = eig.iter().cloned().fold(0.0, f64::max);
                f.range = 0.5 * mean * distance * distance;
                f.curvature = mean;
                // The slope at 1 L from the bottom: the body slows inside about 1 L.
                f.gradient = max;
            }
            "eddy" => {
                gaussian(&mut f, rng);
                let drift = v0 * draw(rng, &space.eddy_drift);
                f.velocity = scaled(&unit_vector(rng, dim), drift);
            }
            "front" => {
                f.normal = dir.to_vec();
                f.amplitude = draw(rng, &space.amplitude);
                f.width = draw(rng, &space.front_width);
                f.offset = distance;
                f.range = 2.0 * f.amplitude;
                f.curvature = 0.77 * f.amplitude / (f.width * f.width);
                f.gradient = f.amplitude / f.width;
            }
            "gaussian_sum" => {
                gaussian(&mut f, rng);
                let main = (f.center.clone(), f.amplitude, f.width);
                let extra = rng.random_range(1..=2);
                let mut bumps = vec![main];
                for _ in 0..extra {
                    let c = scaled(&unit_vector(rng, dim), distance * rng.random::<f64>());
                    let a = f.amplitude * Range::uniform(0.2, 0.5).at(rng.random());
                    let w = f.width * Range::uniform(0.2, 0.4).at(rng.random());
                    bumps.push((c, a, w));
                }
                f.curvature = curvature_at_optimum(&bumps, dim).unwrap_or(f.curvature);
                f.bumps = bumps;
                f.center = Vec::new();
            }
            "grid" => {
                // The campaign's grid: its peak at (0, 0); the start is `distance` away.
                f.range = GRID_AMPLITUDE;
                f.curvature = GRID_AMPLITUDE / (GRID_WIDTH * GRID_WIDTH);
                f.gradient = GRID_AMPLITUDE / GRID_WIDTH * (-0.5f64).exp();
                let _ = GRID_BUMP;
                return (f, scaled(dir, -distance));
            }
            _ => gaussian(&mut f, rng),
        }
        (f, origin)
    }

    /// 0–3 faults: permanent kills (leaving at least dim + 2 vehicles) and rejoins, on
    /// distinct vehicles.
    fn faults(
        space: &Space,
        rng: &mut ChaCha8Rng,
        n: usize,
        dim: usize,
        duration: f64,
    ) -> Vec<FaultDraw> {
        let u: f64 = rng.random();
        let mut count = 0;
        let mut acc = 0.0;
        for (c, p) in space.fault_counts.iter().enumerate() {
            acc += p;
            if u >= acc {
                count = c + 1;
            }
        }
        let count = count.min(3).min(n);
        let mut faults: Vec<FaultDraw> = Vec::new();
        let mut kills = 0;
        for _ in 0..count {
            let vehicle = rng.random_range(0..n as u32);
            let rejoin = rng.random::<f64>() < space.p_rejoin;
            let at = (duration * draw(rng, &space.fault_at) * 100.0).round() / 100.0;
            let outage = duration * draw(rng, &space.rejoin_outage);
            if faults.iter().any(|f| f.vehicle == vehicle) {
                continue;
            }
            if !rejoin && n - kills <= dim + 2 {
                continue;
            }
            if !rejoin {
                kills += 1;
            }
            let until = rejoin.then(|| (((at + outage) * 100.0).round() / 100.0).min(duration));
            faults.push(FaultDraw { vehicle, at, until });
        }
        faults
    }

    /// The formation radius, L: the neighbour-spacing-preserving radius of N vehicles
    /// times the drawn `radius_factor`.
    pub fn radius(&self) -> f64 {
        self.radius_factor * PAPER_RADIUS * (self.n as f64 / 4.0).powf(1.0 / self.dim as f64)
    }

    /// The mission file of this draw flying `law`; `grid`: the campaign's grid file
    /// (absolute, for `field.kind = "grid"`).
    pub fn toml(&self, law: &str, grid: &Path) -> String {
        let mut s = String::new();
        self.write_mission(&mut s, law);
        self.write_field(&mut s, grid);
        self.write_vehicles(&mut s);
        self.write_formation(&mut s);
        self.write_body_and_estimator(&mut s);
        self.write_links(&mut s);
        self.write_control_and_faults(&mut s, law);
        s
    }

    /// The header comment and the `[mission]` section.
    fn write_mission(&self, s: &mut String, law: &str) {
        let f = &self.field;
        let _ = writeln!(
            s,
            "# vbap stress: mission {} ({} field, N = {}, dim {}), law {law}",
            self.index, f.kind, self.n, self.dim
        );
        let _ = writeln!(s, "[mission]");
        let _ = writeln!(s, "name = \"stress_{}\"", self.index);
        let _ = writeln!(s, "seed = {}", self.seed);
        let _ = writeln!(s, "duration = {:?}", self.duration);
        let _ = writeln!(s, "dt = 0.05");
        let _ = writeln!(s, "goal = \"{}\"", f.goal);
        let _ = writeln!(s, "dim = {}", self.dim);
        let _ = writeln!(s, "tolerance = 1.0");
    }

    /// The `[field]` section and its bumps; `grid`: the campaign's grid file.
    fn write_field(&self, s: &mut String, grid: &Path) {
        let f = &self.field;
        let noise = self.noise_fraction * f.range;
        let _ = writeln!(s, "\n[field]");
        let _ = writeln!(s, "kind = \"{}\"", f.kind);
        if f.kind == "grid" {
            let _ = writeln!(s, "file = {:?}", grid.display().to_string());
            let _ = writeln!(s, "variable = \"value\"");
        }
        if !f.center.is_empty() {
            let _ = writeln!(s, "center = {}", toml_vector(&f.center));
        }
        if f.kind != "grid" && f.kind != "gaussian_sum" && f.kind != "quadratic" {
            let _ = writeln!(s, "amplitude = {:?}", f.amplitude);
            let _ = writeln!(s, "width = {:?}", f.width);
        }
        if !f.hessian.is_empty() {
            let _ = writeln!(s, "hessian = {}", toml_matrix(&f.hessian));
        }
        if !f.velocity.is_empty() {
            let _ = writeln!(s, "velocity = {}", toml_vector(&f.velocity));
        }
        if !f.normal.is_empty() {
            let _ = writeln!(s, "normal = {}", toml_vector(&f.normal));
            let _ = writeln!(s, "offset = {:?}", f.offset);
        }
        let _ = writeln!(s, "noise_std = {noise:?}");
        for (c, a, w) in &f.bumps {
            let _ = writeln!(s, "[[field.bumps]]");
            let _ = writeln!(
                s,
                "center = {}\namplitude = {a:?}\nwidth = {w:?}",
                toml_vector(c)
            );
        }
    }

    /// The `[vehicles]` section.
    fn write_vehicles(&self, s: &mut String) {
        let _ = writeln!(s, "\n[vehicles]");
        let _ = writeln!(s, "count = {}", self.n);
        let _ = writeln!(s, "start = {}", toml_vector(&self.start));
        let _ = writeln!(s, "start_spread = 0.2");
        let _ = writeln!(s, "damping = {:?}", self.damping);
        if let Some((speed, accel, turn)) = self.glider {
            let _ = writeln!(s, "model = \"glider\"");
            let _ = writeln!(s, "max_speed = {speed:?}");
            let _ = writeln!(s, "max_accel = {accel:?}");
            let _ = writeln!(s, "max_turn_rate = {turn:?}");
            if self.current.is_some() {
                let _ = writeln!(s, "current_estimate = true");
            }
        }
    }

    /// The `[formation]` section (its Hessian guess: the field's curvature on the diagonal).
    fn write_formation(&self, s: &mut String) {
        let radius = self.radius();
        let _ = writeln!(s, "\n[formation]");
        let _ = writeln!(s, "radius = {radius:?}");
        let _ = writeln!(s, "adapt = {}", self.adapt);
        let _ = writeln!(s, "adapt_gain = 0.5");
        let _ = writeln!(s, "alpha = {:?}", self.alpha);
        let _ = writeln!(s, "min_scale = {}", self.min_scale);
        let _ = writeln!(s, "max_scale = 3.0");
        let _ = writeln!(s, "sigma_h = 1.0");
        let c = self.field.curvature;
        let guess: Vec<Vec<f64>> = (0..self.dim)
            .map(|i| {
                (0..self.dim)
                    .map(|j| if i == j { c } else { 0.0 })
                    .collect()
            })
            .collect();
        let _ = writeln!(s, "hessian_guess = {}", toml_matrix(&guess));
    }

    /// The `[body]` and `[estimator]` sections.
    fn write_body_and_estimator(&self, s: &mut String) {
        let f = &self.field;
        // V of (II.2) sums a potential over every pair: V_U per pair as the paper's (10 at
        // N = 4, α = 60), plus the cruise's kinetic energy. Theorem 4.1 needs V(0) ≤ V_U; α/6
        // alone put V(0) up to 3.8 V_U at N ≥ 13 (start_spread 0.2 L).
        let pairs = (self.n * (self.n - 1)) as f64 / 2.0;
        let v_u = self.alpha / 6.0 * pairs / 6.0 + self.n as f64 * self.v0 * self.v0;
        let _ = writeln!(s, "\n[body]");
        let _ = writeln!(s, "v0 = {:?}", self.v0);
        let _ = writeln!(s, "v_u = {v_u:?}");
        let _ = writeln!(s, "delta = 0.01");
        let _ = writeln!(s, "grad_saturation = {:?}", 0.3 * f.gradient);
        let _ = writeln!(s, "\n[estimator]");
        let _ = writeln!(s, "kalman_b = {:?}", 0.05 * f.gradient);
    }

    /// The `[links]` section.
    fn write_links(&self, s: &mut String) {
        let _ = writeln!(s, "\n[links]");
        let _ = writeln!(s, "delay = {:?}", self.delay);
        let _ = writeln!(s, "jitter = {:?}", self.jitter);
        let _ = writeln!(s, "loss = {:?}", self.loss);
        if let Some((enter, exit, bl)) = self.burst {
            let _ = writeln!(
                s,
                "burst_enter = {enter:?}\nburst_exit = {exit:?}\nburst_loss = {bl:?}"
            );
        }
        if let Some((period, window)) = self.surfacing {
            let _ = writeln!(
                s,
                "surfacing_period = {period:?}\nsurfacing_window = {window:?}"
            );
        }
        if let Some(a) = &self.acoustic {
            let _ = writeln!(
                s,
                "\n[acoustic]\nframe_bytes = 64\ninterval = {:?}\nschedule = \"{}\"\nbit_rate = {:?}\nsound_speed = {:?}\ncommunication_range = {:?}\ndetection_range = {:?}\ninterference_range = {:?}\ndecode_probability = {:?}",
                a.interval,
                if a.tdma { "tdma" } else { "random" },
                a.bit_rate,
                a.sound_speed,
                a.range,
                1.3 * a.range,
                1.6 * a.range,
                a.decode_probability
            );
        }
        if let Some((interval, failure, latency)) = self.iridium {
            let _ = writeln!(
                s,
                "\n[links.iridium]\nsession_interval = {interval:?}\nsession_failure = {failure:?}\nlatency_short = {latency:?}\nlatency_full = {:?}",
                4.0 * latency
            );
        }
    }

    /// The `[control]` section (flying `law`), the `[current]`, and the faults with the
    /// `[restart]` their rejoins need.
    fn write_control_and_faults(&self, s: &mut String, law: &str) {
        let _ = writeln!(s, "\n[control]\nlaw = \"{law}\"");
        if let Some(c) = &self.current {
            let _ = writeln!(
                s,
                "\n[current]\nkind = \"uniform\"\nvelocity = {}",
                toml_vector(c)
            );
        }
        if self.faults.iter().any(|f| f.until.is_some()) {
            let _ = writeln!(s, "\n[restart]\nvehicles = \"on-failure\"");
        }
        for fault in &self.faults {
            let _ = writeln!(
                s,
                "\n[[faults]]\nkind = \"kill\"\nvehicle = {}\nat = {:?}",
                fault.vehicle, fault.at
            );
            if let Some(u) = fault.until {
                let _ = writeln!(s, "until = {u:?}");
            }
        }
    }
}

/// `x` as a TOML array, each number in Rust's shortest round-trip form (`{:?}`).
/// The mean |eigenvalue| of the Hessian of the sum of `bumps` (centre, amplitude, width) at
/// its maximum, F/L²: the declared Hessian guess, `|curvature at the optimum|`. The main
/// bump's own curvature, A/w², misses the narrower side bumps whose peak often holds the
/// optimum (up to 12 times as curved). None when the sum has no maximum.
fn curvature_at_optimum(bumps: &[(Vec<f64>, f64, f64)], dim: usize) -> Option<f64> {
    use vbap_mission::config::{BumpConfig, FieldConfig, FieldKind, Goal};
    use vbap_mission::field::Field;
    let config = FieldConfig {
        kind: FieldKind::GaussianSum,
        background: 0.0,
        bumps: bumps
            .iter()
            .map(|(center, amplitude, width)| BumpConfig {
                center: center.clone(),
                amplitude: *amplitude,
                width: *width,
            })
            .collect(),
        ..FieldConfig::default()
    };
    let field = Field::from_config(&config, dim);
    let top = field.optimum(0.0, Goal::Max)?;
    let eig = field.hessian(&top, 0.0).symmetric_eigenvalues();
    let mean = eig.iter().map(|e| e.abs()).sum::<f64>() / dim as f64;
    (mean.is_finite() && mean > 0.0).then_some(mean)
}

fn toml_vector(x: &[f64]) -> String {
    let items: Vec<String> = x.iter().map(|a| format!("{a:?}")).collect();
    format!("[{}]", items.join(", "))
}

/// The rows of `x` as a TOML array of arrays ([`toml_vector`]).
fn toml_matrix(x: &[Vec<f64>]) -> String {
    let rows: Vec<String> = x.iter().map(|r| toml_vector(r)).collect();
    format!("[{}]", rows.join(", "))
}

/// The serde default of `radius_factor` (here and in the result lines).
pub(crate) fn one() -> f64 {
    1.0
}
