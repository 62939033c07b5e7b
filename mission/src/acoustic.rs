//! Acoustic modems between the vehicles (`[acoustic]`, beyond the paper): every vehicle
//! broadcasts its state in one frame, once per `acoustic.interval`, and every other vehicle
//! hears it, or not, by the physics of a shared acoustic channel (docs/design/links.md,
//! "Acoustic modems").
//!
//! A frame sent at `T` by a vehicle at `x_s` (its true position at the tick of `T`) reaches
//! a receiver at `x_r` (its true position at the same tick) over `d = |x_s − x_r|` during
//! `[T + d/c, T + d/c + 8·bytes/bit_rate)` (c: `sound_speed`). The receiver decodes it when
//! - `d ≤ detection_range` (else `range`: it still interferes up to `interference_range`),
//! - the receiver was not transmitting during it (else `deaf`: modems are half-duplex),
//! - no other frame within `interference_range` of the receiver overlapped it there (else
//!   `collision`: both are lost),
//! - `d ≤ communication_range` (else `undecoded`: detected, not decoded),
//! - and a keyed draw is below `decode_probability` (else `noise`).
//!
//! Pure and seeded, as the vehicle ↔ coordinator link is (`crate::link`): transmission
//! times are a function of (seed, vehicle, transmission number), decoding draws of (seed,
//! sender, receiver, transmission number), and the verdicts of a receiver are a function of
//! the frames sent and of its own track. A receiver ([`Ear`]) decides a frame once it has
//! ended at the receiver, at the step of the first tick after it; every frame that may
//! overlap it was sent before that tick, so an agent holding every frame of the earlier
//! ticks decides exactly as the in-process simulator does.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use rand::Rng;
use vbap_math::rng::{keyed, Stream};
use vbap_math::Vec3;
use vbap_wire::compact::{acoustic_frame_len, Precision};

use crate::config::{AcousticSchedule, AcousticSection, Mission};
use crate::faults::FaultPlan;

/// The acoustic channel of a mission: its schedule, its frames' size and air time, and
/// who transmits when.
#[derive(Clone, Debug)]
pub struct AcousticModel {
    /// `[acoustic]`.
    pub config: AcousticSection,
    seed: u64,
    dt: f64,
    vehicles: usize,
    precision: Precision,
    bytes: u64,
    air: f64,
    /// Scheduled kills: (vehicle, first tick dead, last tick without a frame: the restart
    /// tick, or `u64::MAX`).
    silent: Vec<(u32, u64, u64)>,
}

/// One transmission of a vehicle's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// The sender.
    pub sender: u32,
    /// Its transmission number (the n-th of the mission).
    pub n: u64,
    /// The tick of the state it carries.
    pub tick: u64,
    /// When it starts, s.
    pub at: f64,
    /// Where the sender truly is at `tick` (the channel's geometry; not part of the frame's
    /// bytes), length unit.
    pub source: Vec3,
    /// What the sender believes its position is, as the frame carries it, length unit.
    pub position: Vec3,
    /// The sender's velocity, as the frame carries it, length unit/s.
    pub velocity: Vec3,
}

/// What became of one frame at one receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// Decoded, `latency` s after it was sent (propagation and air time).
    Heard {
        /// s.
        latency: f64,
    },
    /// Beyond `detection_range`.
    Range,
    /// The receiver was transmitting (half-duplex).
    Deaf,
    /// Another frame overlapped it at the receiver.
    Collision,
    /// Detected beyond `communication_range`, not decoded.
    Undecoded,
    /// Within range and alone, lost to the decoding draw.
    Noise,
}

impl Verdict {
    /// Name in the message records (`drop` reason) and the summary.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Heard { .. } => "heard",
            Verdict::Range => "range",
            Verdict::Deaf => "deaf",
            Verdict::Collision => "collision",
            Verdict::Undecoded => "undecoded",
            Verdict::Noise => "noise",
        }
    }

    /// Every loss, in the order the checks are made.
    pub const LOSSES: [Verdict; 5] = [
        Verdict::Range,
        Verdict::Deaf,
        Verdict::Collision,
        Verdict::Undecoded,
        Verdict::Noise,
    ];
}

/// The receptions of one or more receivers, by verdict: the summary's `acoustic` object
/// (`vbap_wire::rundir::AcousticTotals`), counted here.
pub use vbap_wire::rundir::AcousticTotals as AcousticCounts;

impl Verdict {
    /// Counts this verdict in `counts`.
    pub fn count(self, counts: &mut AcousticCounts) {
        *match self {
            Verdict::Heard { .. } => &mut counts.heard,
            Verdict::Range => &mut counts.range,
            Verdict::Deaf => &mut counts.deaf,
            Verdict::Collision => &mut counts.collision,
            Verdict::Undecoded => &mut counts.undecoded,
            Verdict::Noise => &mut counts.noise,
        } += 1;
    }
}

/// The newest state a receiver decoded from one sender.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heard {
    /// The sender.
    pub sender: u32,
    /// The tick of its state.
    pub tick: u64,
    /// Its believed position then, length unit.
    pub position: Vec3,
    /// Its velocity then, length unit/s.
    pub velocity: Vec3,
}

impl AcousticModel {
    /// The channel of `mission` (None without `[acoustic]`).
    pub fn new(mission: &Mission) -> Option<Arc<Self>> {
        let config = mission.acoustic.clone()?;
        let precision = Precision::of_quantum(mission.links.position_quantum);
        let bytes = acoustic_frame_len(precision) as u64;
        let silent = FaultPlan::new(mission)
            .kills
            .iter()
            .map(|k| (k.vehicle, k.tick, k.restart.unwrap_or(u64::MAX)))
            .collect();
        Some(Arc::new(Self {
            air: config.air_time(bytes),
            config,
            seed: mission.mission.seed,
            dt: mission.mission.dt,
            vehicles: mission.vehicles.count,
            precision,
            bytes,
            silent,
        }))
    }

    /// The size of a frame, bytes.
    pub fn frame_bytes(&self) -> u64 {
        self.bytes
    }

    /// The air time of a frame, s.
    pub fn air_time(&self) -> f64 {
        self.air
    }

    /// When transmission `n` of `vehicle` starts, s: `n·interval` plus the vehicle's TDMA
    /// slot, or a seeded offset in `[0, interval − air)` (so a vehicle's own frames never
    /// overlap).
    pub fn transmission_time(&self, vehicle: u32, n: u64) -> f64 {
        let i = self.config.interval;
        let offset = match self.config.schedule {
            AcousticSchedule::Tdma => vehicle as f64 * i / self.vehicles as f64,
            AcousticSchedule::Random => {
                let u: f64 = keyed(self.seed, Stream::Acoustic, 2 * vehicle as u64, n).random();
                u * (i - self.air)
            }
        };
        n as f64 * i + offset
    }

    /// The transmissions of `vehicle` that start during tick `k` (in `[k·dt, (k+1)·dt)`),
    /// as (number, start s).
    pub fn transmissions(&self, vehicle: u32, k: u64) -> impl Iterator<Item = (u64, f64)> + '_ {
        let (from, to) = (k as f64 * self.dt, (k + 1) as f64 * self.dt);
        let i = self.config.interval;
        let first = ((from / i).floor() as u64).saturating_sub(1);
        let last = (to / i).floor() as u64;
        (first..=last)
            .map(move |n| (n, self.transmission_time(vehicle, n)))
            .filter(move |&(_, at)| at >= from && at < to)
    }

    /// Whether `vehicle` may send the frames of its state at `tick`: not between a
    /// scheduled kill and its restart tick (inclusive: a restarted vehicle sends from the
    /// state after its first, as every vehicle does).
    pub fn sends(&self, vehicle: u32, tick: u64) -> bool {
        !self
            .silent
            .iter()
            .any(|&(v, from, to)| v == vehicle && tick >= from && tick <= to)
    }

    /// The frames `vehicle` sends during tick `k`, its state then being `source` (true
    /// position), `position` (believed) and `velocity`; none at or before its first tick
    /// `first` (the deployment, or its restart) or while a scheduled kill silences it.
    pub fn frames(
        &self,
        vehicle: u32,
        k: u64,
        first: u64,
        source: Vec3,
        position: Vec3,
        velocity: Vec3,
    ) -> Vec<Frame> {
        if k <= first || !self.sends(vehicle, k) {
            return Vec::new();
        }
        let position = self.carried(&position);
        let velocity = self.carried(&velocity);
        self.transmissions(vehicle, k)
            .map(|(n, at)| Frame {
                sender: vehicle,
                n,
                tick: k,
                at,
                source,
                position,
                velocity,
            })
            .collect()
    }

    /// Whether `vehicle` is alive at `tick` by the scheduled faults (not in `[kill,
    /// restart)`): a process that ran ahead of its kill decides nothing past it, as the
    /// simulator's vehicle, gone at the kill, does not.
    pub fn alive(&self, vehicle: u32, tick: u64) -> bool {
        !self
            .silent
            .iter()
            .any(|&(v, from, to)| v == vehicle && tick >= from && tick < to)
    }

    /// The tick `vehicle`'s process that is alive at tick `tick` started from: its last
    /// scheduled restart at or before `tick`, else 0 (the deployment).
    fn first_tick(&self, vehicle: u32, tick: u64) -> u64 {
        self.silent
            .iter()
            .filter(|&&(v, _, restart)| v == vehicle && restart <= tick)
            .map(|&(_, _, restart)| restart)
            .max()
            .unwrap_or(0)
    }

    /// The numbers of the transmissions `vehicle` makes during tick `tick` by the mission's
    /// schedule and its scheduled faults (none while silenced, none at its first tick).
    pub fn expected(&self, vehicle: u32, tick: u64) -> impl Iterator<Item = u64> + '_ {
        let sends = self.sends(vehicle, tick) && tick > self.first_tick(vehicle, tick);
        self.transmissions(vehicle, tick)
            .filter(move |_| sends)
            .map(|(n, _)| n)
    }

    /// When `vehicle`'s frames start in `[from, to)` (s), in order: its transmissions by
    /// [`AcousticModel::expected`] (the schedule and the scheduled faults).
    pub fn sent_between(&self, vehicle: u32, from: f64, to: f64) -> Vec<f64> {
        let (k0, k1) = (
            (from / self.dt).floor().max(0.0) as u64,
            (to / self.dt).ceil() as u64,
        );
        (k0..=k1)
            .flat_map(|k| self.expected(vehicle, k).collect::<Vec<_>>())
            .map(|n| self.transmission_time(vehicle, n))
            .filter(|&at| at >= from && at < to)
            .collect()
    }

    /// `v` as a frame carries it (`links.position_quantum`, absolute; kept exact when the
    /// quantum cannot hold it).
    fn carried(&self, v: &Vec3) -> Vec3 {
        let a = [v.x, v.y, v.z];
        let r = self.precision.round_trip(&a, &[0.0; 3]).unwrap_or(a);
        Vec3::new(r[0], r[1], r[2])
    }

    /// Whether a frame read over IPC is one this channel could have sent: a known sender,
    /// finite numbers, and its start and tick those of its number.
    pub fn is_plausible(&self, f: &Frame) -> bool {
        let finite = |v: &Vec3| v.iter().all(|x| x.is_finite());
        (f.sender as usize) < self.vehicles
            && finite(&f.source)
            && finite(&f.position)
            && finite(&f.velocity)
            && f.at.to_bits() == self.transmission_time(f.sender, f.n).to_bits()
            && f.at >= f.tick as f64 * self.dt
            && f.at < (f.tick + 1) as f64 * self.dt
    }

    /// Whether receiver `receiver` decodes transmission `n` of `sender` (the draw of a
    /// frame in range, alone on the channel).
    fn decodes(&self, sender: u32, receiver: u32, n: u64) -> bool {
        let id = 1 + 2 * (sender as u64 * 1024 + receiver as u64);
        let u: f64 = keyed(self.seed, Stream::Acoustic, id, n).random();
        u < self.config.decode_probability
    }

    /// Ticks of its own track a receiver keeps: a frame is decided within
    /// `air + max propagation` of its tick, plus a margin.
    fn track_ticks(&self) -> u64 {
        ((self.air + self.config.max_propagation()) / self.dt).ceil() as u64 + 4
    }
}

/// Where a frame is at one receiver.
#[derive(Clone, Copy, Debug)]
struct Arrival {
    range: f64,
    start: f64,
    end: f64,
}

#[derive(Clone, Debug)]
struct Pending {
    frame: Frame,
    arrival: Option<Arrival>,
    decided: bool,
}

/// One vehicle's acoustic receiver: the frames it has been sent, its own transmissions and
/// track, what it has decoded.
#[derive(Clone, Debug)]
pub struct Ear {
    model: Arc<AcousticModel>,
    me: u32,
    /// Frames sent before this time (s) are not for this receiver (not yet deployed or
    /// restarted).
    from: f64,
    pending: Vec<Pending>,
    /// Its own transmissions, [start, end) s.
    own: Vec<(f64, f64)>,
    /// Its true position by tick.
    track: VecDeque<(u64, Vec3)>,
    heard: BTreeMap<u32, Heard>,
    /// Verdicts so far.
    pub counts: AcousticCounts,
    /// Frames refused as implausible ([`AcousticModel::is_plausible`]).
    pub rejected: u64,
    /// Verdicts kept for the message records (sender, tick, verdict), when asked.
    verdicts: Option<Vec<(u32, u64, Verdict)>>,
    /// Per sender, the first tick whose frames have not all been seen yet
    /// ([`Ear::missing`]).
    complete_from: Vec<u64>,
    /// Per sender, frames of ticks before this one are no longer awaited nor taken
    /// ([`Ear::give_up`]).
    given_up: Vec<u64>,
    /// Per sender, given up and not heard since: its frames are not awaited until one
    /// comes (a process that died stays silent; a restarted one speaks again).
    silent: Vec<bool>,
}

impl Ear {
    /// The receiver of vehicle `me`, whose first state is that of tick `first`.
    pub fn new(model: Arc<AcousticModel>, me: u32, first: u64) -> Self {
        let (n, frame_b) = (model.vehicles, model.bytes);
        Self {
            from: first as f64 * model.dt,
            complete_from: vec![first; n],
            given_up: vec![0; n],
            silent: vec![false; n],
            model,
            me,
            pending: Vec::new(),
            own: Vec::new(),
            track: VecDeque::new(),
            heard: BTreeMap::new(),
            counts: AcousticCounts {
                frame_b,
                ..AcousticCounts::default()
            },
            rejected: 0,
            verdicts: None,
        }
    }

    /// This receiver keeping its verdicts for [`Ear::take_verdicts`].
    pub fn keeping_verdicts(mut self) -> Self {
        self.verdicts = Some(Vec::new());
        self
    }

    /// The channel.
    pub fn model(&self) -> &Arc<AcousticModel> {
        &self.model
    }

    /// The vehicle is truly at `position` at `tick` (every tick, in order).
    pub fn track(&mut self, tick: u64, position: Vec3) {
        if self.track.back().is_some_and(|&(k, _)| k >= tick) {
            return;
        }
        self.track.push_back((tick, position));
        let keep = self.model.track_ticks();
        while self.track.front().is_some_and(|&(k, _)| k + keep < tick) {
            self.track.pop_front();
        }
    }

    /// The vehicle transmits `frame` itself (it is deaf meanwhile).
    pub fn transmitted(&mut self, frame: &Frame) {
        self.own.push((frame.at, frame.at + self.model.air));
    }

    /// `frame` reaches this receiver's process (its own, early ones, those a scheduled
    /// kill silenced and duplicates are ignored; implausible ones are counted and refused).
    pub fn hear(&mut self, frame: Frame) {
        if frame.sender == self.me || frame.at < self.from {
            return;
        }
        if !self.model.is_plausible(&frame) {
            self.rejected += 1;
            return;
        }
        let i = frame.sender as usize;
        if self.silent[i] && frame.tick >= self.given_up[i] {
            // A given-up sender speaks again (a restarted process): awaited from this
            // frame on; the frames of its silence will never come.
            self.silent[i] = false;
            self.complete_from[i] = self.complete_from[i].max(frame.tick);
        }
        if !self.model.sends(frame.sender, frame.tick)
            || frame.tick < self.given_up[frame.sender as usize]
            || self
                .pending
                .iter()
                .any(|p| p.frame.sender == frame.sender && p.frame.n == frame.n)
        {
            return;
        }
        self.pending.push(Pending {
            frame,
            arrival: None,
            decided: false,
        });
    }

    /// A sender some of whose frames sent before tick `k` (by the schedule) have not reached
    /// this receiver yet (None: all in; the step from `k` may decide). Cheap: each sender's
    /// ticks are checked once.
    pub fn missing(&mut self, k: u64) -> Option<u32> {
        let model = self.model.clone();
        for sender in 0..model.vehicles as u32 {
            if sender == self.me || self.silent[sender as usize] {
                continue;
            }
            let from = &mut self.complete_from[sender as usize];
            while *from < k {
                let all_in = model.expected(sender, *from).all(|n| {
                    self.pending
                        .iter()
                        .any(|p| p.frame.sender == sender && p.frame.n == n)
                });
                if !all_in {
                    return Some(sender);
                }
                *from += 1;
            }
        }
        None
    }

    /// Stops waiting for `sender`'s frames before tick `k` (its process is gone without a
    /// scheduled fault saying so); those that come late are ignored, and its later frames
    /// are not awaited either until one of them comes ([`Ear::hear`]): a dead sender is
    /// given up once, not at every frame the schedule gives it.
    pub fn give_up(&mut self, sender: u32, k: u64) {
        let i = sender as usize;
        self.complete_from[i] = self.complete_from[i].max(k);
        self.given_up[i] = self.given_up[i].max(k);
        self.silent[i] = true;
    }

    fn position_at(&self, tick: u64) -> Option<Vec3> {
        self.track
            .iter()
            .rev()
            .find(|&&(k, _)| k == tick)
            .map(|&(_, p)| p)
    }

    /// Decides every frame that has ended here by tick `k` (the receiver's track must hold
    /// tick `k − 1`; every frame sent before tick `k` must have been heard).
    pub fn decide(&mut self, k: u64) {
        if !self.model.alive(self.me, k) {
            return;
        }
        let model = self.model.clone();
        let cfg = &model.config;
        let t = k as f64 * model.dt;
        for i in 0..self.pending.len() {
            let p = &self.pending[i];
            if p.arrival.is_some() || p.frame.tick >= k {
                continue;
            }
            let Some(x) = self.position_at(p.frame.tick) else {
                // Older than the track (a paced run's late frame): nothing to decide.
                self.pending[i].decided = true;
                self.pending[i].arrival = Some(Arrival {
                    range: f64::INFINITY,
                    start: f64::NEG_INFINITY,
                    end: f64::NEG_INFINITY,
                });
                continue;
            };
            let range = (p.frame.source - x).norm();
            let start = p.frame.at + range / cfg.sound_speed;
            self.pending[i].arrival = Some(Arrival {
                range,
                start,
                end: start + model.air,
            });
        }
        let mut order: Vec<usize> = (0..self.pending.len())
            .filter(|&i| {
                let p = &self.pending[i];
                !p.decided && p.arrival.is_some_and(|a| a.end <= t)
            })
            .collect();
        order.sort_by(|&a, &b| {
            let (fa, fb) = (&self.pending[a].frame, &self.pending[b].frame);
            (fa.at, fa.sender).partial_cmp(&(fb.at, fb.sender)).unwrap()
        });
        for i in order {
            let f = self.pending[i].frame;
            let a = self.pending[i]
                .arrival
                .expect("decided frames have arrived");
            let overlaps = |s: f64, e: f64| s < a.end && a.start < e;
            let verdict = if a.range > cfg.detection_range {
                Verdict::Range
            } else if self.own.iter().any(|&(s, e)| overlaps(s, e)) {
                Verdict::Deaf
            } else if self.pending.iter().enumerate().any(|(j, g)| {
                j != i
                    && g.arrival.is_some_and(|b| {
                        b.range <= cfg.interference_range && overlaps(b.start, b.end)
                    })
            }) {
                Verdict::Collision
            } else if a.range > cfg.communication_range {
                Verdict::Undecoded
            } else if model.decodes(f.sender, self.me, f.n) {
                Verdict::Heard {
                    latency: a.end - f.at,
                }
            } else {
                Verdict::Noise
            };
            self.pending[i].decided = true;
            verdict.count(&mut self.counts);
            if let Some(v) = &mut self.verdicts {
                v.push((f.sender, f.tick, verdict));
            }
            if matches!(verdict, Verdict::Heard { .. })
                && self.heard.get(&f.sender).is_none_or(|h| h.tick < f.tick)
            {
                self.heard.insert(
                    f.sender,
                    Heard {
                        sender: f.sender,
                        tick: f.tick,
                        position: f.position,
                        velocity: f.velocity,
                    },
                );
            }
        }
        // A vehicle a scheduled kill took is not where it was last heard (its hull drifts,
        // its restarted process starts over): its frames are forgotten.
        self.heard.retain(|&sender, _| model.alive(sender, k));
        // Kept while a frame not decided yet may overlap them.
        let horizon = t - model.air;
        self.pending.retain(|p| {
            !p.decided
                || p.arrival
                    .is_some_and(|a| a.end >= horizon && a.range <= cfg.interference_range)
        });
        self.own.retain(|&(_, e)| e >= horizon);
    }

    /// The newest state decoded from each sender (by sender id).
    pub fn heard(&self) -> impl Iterator<Item = &Heard> {
        self.heard.values()
    }

    /// Forgets what was heard from `sender` (a vehicle lost, or admitted back).
    pub fn forget(&mut self, sender: u32) {
        self.heard.remove(&sender);
    }

    /// The verdicts since the last call ([`Ear::keeping_verdicts`]).
    pub fn take_verdicts(&mut self) -> Vec<(u32, u64, Verdict)> {
        self.verdicts
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }
}

#[cfg(test)]
mod tests;
