//! The emulated glider link (docs/ARCHITECTURE.md §7): delay and jitter, Bernoulli or bursty
//! (Gilbert–Elliott) loss, link-down faults and surfacing windows with store-and-forward;
//! or Iridium SBD sessions (`[links.iridium]`): messages cross only in the sessions a
//! vehicle opens at the surface, the shore keeps the newest command for a vehicle, reports
//! go up packed into messages of a byte limit, and a message takes longer the more bytes
//! it has.
//!
//! A message's fate is drawn in two steps: [`LinkModel::fate`] by the schedule alone (which
//! session, lost or not: known before the message's content, so a vehicle can tell whether
//! a command it has not read yet could already be due), then [`LinkModel::carry`] by its
//! size (the transfer time, a split or a refusal over the limit). Without Iridium the
//! second step changes nothing.
//!
//! Pure and seeded: the fate of a message is drawn from `rng::keyed(seed, Link, link, tick)`
//! where `link` names the vehicle and the direction and `tick` the message, never from a
//! shared RNG consumed in arrival order; the receiver of every vehicle ↔ coordinator
//! message applies it (the in-process simulator and the processes alike), so a lockstep
//! run with impaired links is still reproducible bit for bit.

use rand::Rng;

use crate::config::{FaultKind, IridiumSection, Mission, Oversize, SurfacingPhase};
use vbap_math::rng::{keyed, Stream};

/// Direction of a message on a vehicle's link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Vehicle → coordinator (state and measurement).
    Uplink = 0,
    /// Coordinator → vehicle (virtual body and swarm snapshot).
    Downlink = 1,
}

/// Why a message was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DropReason {
    /// Bernoulli loss (or the good state of the burst model).
    Loss,
    /// Loss in the bad state of the Gilbert–Elliott model.
    Burst,
    /// A scheduled `link_down` fault.
    LinkDown,
    /// Iridium: a newer command reached the shore before the vehicle's next session (the
    /// shore keeps the newest only). Not a loss: what it said, the newer one says again.
    Superseded,
    /// Iridium: a command over `links.iridium.down_limit` with `oversize = "refuse"`.
    Oversize,
    /// Iridium: no session succeeded in the next million (session_failure near 1).
    NoSession,
}

impl DropReason {
    /// Name in logs and events.
    pub fn as_str(self) -> &'static str {
        match self {
            DropReason::Loss => "loss",
            DropReason::Burst => "burst",
            DropReason::LinkDown => "link_down",
            DropReason::Superseded => "superseded",
            DropReason::Oversize => "oversize",
            DropReason::NoSession => "no_session",
        }
    }
}

/// What happens to one message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fate {
    /// Delivered at mission time `at` (s), `injected` s after it was sent.
    Deliver { at: f64, injected: f64 },
    /// Lost.
    Drop(DropReason),
}

/// A vehicle's scheduled contact state ([`LinkModel::contact`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Contact {
    /// No surfacing schedule and no `link_down` fault active: in contact.
    Contact,
    /// In a surfacing window: can talk.
    Surfaced,
    /// Between surfacing windows: cannot talk.
    Submerged,
    /// A scheduled `link_down` fault is active.
    LinkDown,
}

impl Contact {
    /// Name in `formation.csv` and events.
    pub fn as_str(self) -> &'static str {
        match self {
            Contact::Contact => "contact",
            Contact::Surfaced => "surfaced",
            Contact::Submerged => "submerged",
            Contact::LinkDown => "link_down",
        }
    }
    /// True when messages can cross (subject to loss and delay).
    pub fn can_talk(self) -> bool {
        matches!(self, Contact::Contact | Contact::Surfaced)
    }
}

/// Per-link state of the burst model (one per vehicle and direction).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct LinkState {
    /// In the bad state of the Gilbert–Elliott chain.
    pub bad: bool,
    /// Last tick the chain was advanced to.
    pub tick: Option<u64>,
}

/// The link model of a mission.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LinkModel {
    seed: u64,
    vehicles: usize,
    delay: f64,
    jitter: f64,
    loss: f64,
    period: f64,
    window: f64,
    phase: SurfacingPhase,
    burst_enter: f64,
    burst_exit: f64,
    burst_loss: f64,
    downlink: bool,
    /// (vehicle, from, until) of every link_down fault, s.
    link_down: Vec<(u32, f64, f64)>,
    /// Tick length, s: commands and reports are sent once a tick.
    dt: f64,
    /// `[links.iridium]`, when the link is Iridium SBD sessions.
    iridium: Option<IridiumSection>,
}

/// One Iridium session of a vehicle ([`LinkModel::sessions`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Session {
    /// When it opens, mission time, s.
    pub at: f64,
    /// False when it failed (nothing crossed).
    pub ok: bool,
}

/// Largest number of sessions looked at for one that succeeds (with `session_failure`
/// below 1 they all failing is practically impossible; past it the message is dropped,
/// reason `no_session`).
const SESSION_SEARCH: u32 = 1_000_000;

impl LinkModel {
    /// The link model of `mission` (its `[links]` and its `link_down` faults).
    pub fn new(mission: &Mission) -> Self {
        let l = &mission.links;
        Self {
            seed: mission.mission.seed,
            vehicles: mission.vehicles.count.max(1),
            delay: l.delay,
            jitter: l.jitter,
            loss: l.loss,
            period: l.surfacing_period,
            window: l.surfacing_window,
            phase: l.surfacing_phase,
            burst_enter: l.burst_enter,
            burst_exit: l.burst_exit,
            burst_loss: l.burst_loss,
            downlink: l.downlink,
            link_down: mission
                .faults
                .iter()
                .filter(|f| f.kind == FaultKind::LinkDown)
                .map(|f| (f.vehicle, f.at, f.until.unwrap_or(f64::INFINITY)))
                .collect(),
            dt: mission.mission.dt,
            iridium: l.iridium.clone(),
        }
    }

    /// `[links.iridium]`, when the link is Iridium SBD sessions.
    pub fn iridium(&self) -> Option<&IridiumSection> {
        self.iridium.as_ref()
    }

    /// True when no message is ever delayed or lost.
    pub fn is_ideal(&self) -> bool {
        self.delay == 0.0
            && self.jitter == 0.0
            && self.loss == 0.0
            && self.period == 0.0
            && self.burst_enter == 0.0
            && self.link_down.is_empty()
            && self.iridium.is_none()
    }

    /// True when the model applies to messages in `dir`.
    pub fn applies(&self, dir: Direction) -> bool {
        dir == Direction::Uplink || self.downlink
    }

    /// Start of vehicle `vehicle`'s surfacing window within each period, s.
    pub fn phase_of(&self, vehicle: u32) -> f64 {
        match self.phase {
            SurfacingPhase::Together => 0.0,
            SurfacingPhase::Staggered => self.period * f64::from(vehicle) / self.vehicles as f64,
        }
    }

    /// True when vehicle `vehicle` is at the surface (in contact) at mission time `t`.
    pub fn at_surface(&self, vehicle: u32, t: f64) -> bool {
        if self.period <= 0.0 {
            return true;
        }
        (t - self.phase_of(vehicle)).rem_euclid(self.period) < self.window
    }

    /// The earliest time ≥ `t` at which vehicle `vehicle` is at the surface.
    pub fn next_surface(&self, vehicle: u32, t: f64) -> f64 {
        if self.at_surface(vehicle, t) {
            return t;
        }
        let phase = self.phase_of(vehicle);
        let n = ((t - phase) / self.period).floor() + 1.0;
        let mut start = phase + n * self.period;
        // Rounding may put the start an ulp before the window: step up to it.
        while !self.at_surface(vehicle, start) {
            start = start.next_up();
        }
        start
    }

    /// The contact state of vehicle `vehicle` at mission time `t` by the schedule alone
    /// (surfacing windows, `link_down` faults; random loss and delay are not a state):
    /// a `link_down` fault wins over the surfacing schedule.
    pub fn contact(&self, vehicle: u32, t: f64) -> Contact {
        if self.link_down_at(vehicle, t) {
            Contact::LinkDown
        } else if self.period <= 0.0 {
            Contact::Contact
        } else if self.at_surface(vehicle, t) {
            Contact::Surfaced
        } else {
            Contact::Submerged
        }
    }

    /// True when a `link_down` fault of vehicle `vehicle` is active at `t` s.
    fn link_down_at(&self, vehicle: u32, t: f64) -> bool {
        self.link_down
            .iter()
            .any(|&(v, from, until)| v == vehicle && t >= from && t < until)
    }

    fn link_id(vehicle: u32, dir: Direction) -> u64 {
        u64::from(vehicle) * 2 + dir as u64
    }

    /// Advances the burst chain of a link to `tick` (one step per tick, keyed draws).
    fn advance(&self, state: &mut LinkState, link: u64, tick: u64) {
        if self.burst_enter <= 0.0 {
            return;
        }
        let start = state.tick.map_or(0, |t| t + 1);
        for k in start..=tick {
            let u: f64 = keyed(self.seed, Stream::Link, link * 4 + 2, k).random();
            state.bad = if state.bad {
                u >= self.burst_exit
            } else {
                u < self.burst_enter
            };
        }
        state.tick = Some(state.tick.map_or(tick, |t| t.max(tick)));
    }

    /// The fate of the message of tick `tick` sent at mission time `sent` (s) on vehicle
    /// `vehicle`'s link in direction `dir`. `state` is that link's burst state.
    pub fn fate(
        &self,
        state: &mut LinkState,
        vehicle: u32,
        dir: Direction,
        tick: u64,
        sent: f64,
    ) -> Fate {
        if !self.applies(dir) {
            return Fate::Deliver {
                at: sent,
                injected: 0.0,
            };
        }
        if self.link_down_at(vehicle, sent) {
            return Fate::Drop(DropReason::LinkDown);
        }
        let link = Self::link_id(vehicle, dir);
        self.advance(state, link, tick);
        let session = match &self.iridium {
            Some(_) => match self.carrying_session(vehicle, dir, sent) {
                Ok(at) => Some(at),
                Err(reason) => return Fate::Drop(reason),
            },
            None => None,
        };
        let (p_loss, reason) = if state.bad {
            (self.burst_loss, DropReason::Burst)
        } else {
            (self.loss, DropReason::Loss)
        };
        if p_loss > 0.0 {
            let u: f64 = keyed(self.seed, Stream::Link, link * 4, tick).random();
            if u < p_loss {
                return Fate::Drop(reason);
            }
        }
        let mut delay = self.delay;
        if self.jitter > 0.0 {
            let u: f64 = keyed(self.seed, Stream::Link, link * 4 + 1, tick).random();
            delay += self.jitter * (2.0 * u - 1.0);
        }
        let at = match (session, &self.iridium) {
            // Iridium: the session, then the shore's delay, then the transfer of a message
            // of no bytes ([`LinkModel::carry`] adds the size's part).
            (Some(opens), Some(i)) => opens + delay.max(0.0) + i.latency_short,
            // Store and forward: nothing crosses while the vehicle is under water.
            _ => self.next_surface(vehicle, sent + delay.max(0.0)),
        };
        Fate::Deliver {
            at,
            injected: at - sent,
        }
    }

    /// The fate of a message of `bytes` bytes whose fate by the schedule is `fate`
    /// ([`LinkModel::fate`] of the message of tick `tick` sent at `sent` s on vehicle
    /// `vehicle`'s link in direction `dir`): Iridium adds the transfer time of its bytes
    /// (a report: of the message it is packed into with the reports of the same session,
    /// after the full messages before it), splits a command over the limit into messages
    /// sent one after another or refuses it. Without Iridium: `fate` as it is.
    pub fn carry(
        &self,
        fate: Fate,
        vehicle: u32,
        dir: Direction,
        tick: u64,
        sent: f64,
        bytes: u64,
    ) -> Fate {
        let (Some(i), Fate::Deliver { at, injected }) = (&self.iridium, fate) else {
            return fate;
        };
        if !self.applies(dir) {
            return fate;
        }
        let extra = match dir {
            Direction::Downlink => {
                if bytes > i.down_limit && i.oversize == Oversize::Refuse {
                    return Fate::Drop(DropReason::Oversize);
                }
                transfer_time(i, bytes, i.down_limit)
            }
            Direction::Uplink => self.bundled_time(i, vehicle, tick, sent, bytes),
        } - i.latency_short;
        Fate::Deliver {
            at: at + extra,
            injected: injected + extra,
        }
    }

    /// Time from the session's start until the report of tick `tick` (sent at `sent`, s,
    /// `bytes` bytes) has reached the shore: the reports of the ticks since the vehicle's
    /// previous successful session go up in this one, packed into messages of at most
    /// `up_limit` bytes, sent one after another.
    fn bundled_time(
        &self,
        i: &IridiumSection,
        vehicle: u32,
        tick: u64,
        sent: f64,
        bytes: u64,
    ) -> f64 {
        let bytes = bytes.max(1);
        let Some((index, opens)) = self.next_open_session(vehicle, sent) else {
            return transfer_time(i, bytes, i.up_limit);
        };
        let previous = self.previous_open_session(vehicle, index);
        // The ticks whose reports this session carries: sent in (previous, opens].
        let first = previous.map_or(0, |p| self.first_tick_after(p));
        let last = self.last_tick_at_or_before(opens).max(first);
        let count = last - first + 1;
        let place = tick.clamp(first, last) - first;
        let per_message = (i.up_limit / bytes).max(1);
        let message = place / per_message;
        let in_it = per_message.min(count - message * per_message);
        message as f64 * message_time(i, per_message * bytes, i.up_limit)
            + message_time(i, in_it * bytes, i.up_limit)
    }

    /// Number of messages a command of `bytes` bytes takes under Iridium (1 without it;
    /// more than 1: it is split).
    pub fn down_messages(&self, bytes: u64) -> u64 {
        self.iridium
            .as_ref()
            .map_or(1, |i| bytes.div_ceil(i.down_limit).max(1))
    }

    /// True when the command of tick `tick` to vehicle `vehicle` is carried to it: without
    /// Iridium, when the vehicle can talk at its sending time; with it, when it is the
    /// newest command at the shore as a successful session opens (refusals and losses on
    /// the way are not looked at: its bytes were sent).
    pub fn carries_command(&self, vehicle: u32, tick: u64) -> bool {
        let sent = tick as f64 * self.dt;
        if self.iridium.is_none() {
            return self.contact(vehicle, sent).can_talk();
        }
        if !self.applies(Direction::Downlink) || self.link_down_at(vehicle, sent) {
            return false;
        }
        self.carrying_session(vehicle, Direction::Downlink, sent)
            .is_ok()
    }

    /// Iridium: the opening time of the session that carries the message sent at `sent` s
    /// on vehicle `vehicle`'s link in direction `dir`: the vehicle's first successful one
    /// from then on, unless none comes (`NoSession`) or, for a command, the next one (sent
    /// a tick later) reaches the shore before it opens and replaces it (`Superseded`: the
    /// shore keeps the newest).
    fn carrying_session(&self, vehicle: u32, dir: Direction, sent: f64) -> Result<f64, DropReason> {
        match self.next_open_session(vehicle, sent) {
            None => Err(DropReason::NoSession),
            Some((_, at)) if dir == Direction::Downlink && sent + self.dt <= at => {
                Err(DropReason::Superseded)
            }
            Some((_, at)) => Ok(at),
        }
    }

    /// The first tick whose sending time is after `t` s.
    fn first_tick_after(&self, t: f64) -> u64 {
        let mut k = (t / self.dt).floor().max(0.0) as u64;
        while (k as f64 * self.dt) <= t {
            k += 1;
        }
        while k > 0 && ((k - 1) as f64 * self.dt) > t {
            k -= 1;
        }
        k
    }

    /// The last tick whose sending time is at or before `t` ≥ 0 s.
    fn last_tick_at_or_before(&self, t: f64) -> u64 {
        self.first_tick_after(t).saturating_sub(1)
    }

    /// Sessions per surfacing window (None: no surfacing schedule, sessions all along).
    fn windows(&self, i: &IridiumSection) -> Option<u64> {
        (self.period > 0.0).then(|| ((self.window / i.session_interval).ceil() as u64).max(1))
    }

    /// Opening time of vehicle `vehicle`'s session number `index` (any integer; numbered
    /// in time order).
    fn session_time(&self, i: &IridiumSection, vehicle: u32, index: i64) -> f64 {
        match self.windows(i) {
            Some(per) => {
                let per = per as i64;
                let (m, j) = (index.div_euclid(per), index.rem_euclid(per));
                self.phase_of(vehicle) + m as f64 * self.period + j as f64 * i.session_interval
            }
            None => self.session_phase(i, vehicle) + index as f64 * i.session_interval,
        }
    }

    /// Without a surfacing schedule: vehicle `vehicle`'s first session, s (staggered:
    /// vehicle i at i·interval/N).
    fn session_phase(&self, i: &IridiumSection, vehicle: u32) -> f64 {
        match self.phase {
            SurfacingPhase::Together => 0.0,
            SurfacingPhase::Staggered => {
                i.session_interval * f64::from(vehicle) / self.vehicles as f64
            }
        }
    }

    /// The number of vehicle `vehicle`'s first session opening at or after `t` s.
    fn session_at_or_after(&self, i: &IridiumSection, vehicle: u32, t: f64) -> i64 {
        let guess = match self.windows(i) {
            Some(per) => {
                let phase = self.phase_of(vehicle);
                let m = ((t - phase) / self.period).floor();
                let offset = t - phase - m * self.period;
                let j = (offset / i.session_interval).ceil().max(0.0) as i64;
                m as i64 * per as i64 + j.min(per as i64)
            }
            None => ((t - self.session_phase(i, vehicle)) / i.session_interval).ceil() as i64,
        };
        // Rounding: step to the first session at or after t.
        let mut index = guess;
        while self.session_time(i, vehicle, index) < t {
            index += 1;
        }
        while self.session_time(i, vehicle, index - 1) >= t {
            index -= 1;
        }
        index
    }

    /// True when vehicle `vehicle`'s session `index` succeeds (a keyed draw per session,
    /// shared by both directions).
    fn session_ok(&self, i: &IridiumSection, vehicle: u32, index: i64) -> bool {
        if i.session_failure <= 0.0 {
            return true;
        }
        let link = Self::link_id(vehicle, Direction::Uplink);
        let u: f64 = keyed(self.seed, Stream::Link, link * 4 + 3, index as u64).random();
        u >= i.session_failure
    }

    /// Vehicle `vehicle`'s first successful session opening at or after `t` s: its
    /// number and opening time.
    pub fn next_open_session(&self, vehicle: u32, t: f64) -> Option<(i64, f64)> {
        let i = self.iridium.as_ref()?;
        let first = self.session_at_or_after(i, vehicle, t.max(0.0));
        (first..first + i64::from(SESSION_SEARCH))
            .find(|&n| self.session_ok(i, vehicle, n))
            .map(|n| (n, self.session_time(i, vehicle, n)))
    }

    /// The opening time of vehicle `vehicle`'s last successful session before session
    /// `index` (None: none since the mission began).
    fn previous_open_session(&self, vehicle: u32, index: i64) -> Option<f64> {
        let i = self.iridium.as_ref()?;
        (index - i64::from(SESSION_SEARCH)..index)
            .rev()
            .map(|n| (n, self.session_time(i, vehicle, n)))
            .take_while(|&(_, at)| at >= 0.0)
            .find(|&(n, _)| self.session_ok(i, vehicle, n))
            .map(|(_, at)| at)
    }

    /// Vehicle `vehicle`'s Iridium sessions opening in [`from`, `until`) s (none without
    /// Iridium).
    pub fn sessions(&self, vehicle: u32, from: f64, until: f64) -> Vec<Session> {
        let Some(i) = &self.iridium else {
            return Vec::new();
        };
        let mut n = self.session_at_or_after(i, vehicle, from.max(0.0));
        let mut out = Vec::new();
        loop {
            let at = self.session_time(i, vehicle, n);
            if at >= until {
                return out;
            }
            out.push(Session {
                at,
                ok: self.session_ok(i, vehicle, n),
            });
            n += 1;
        }
    }
}

/// Time to send one message of `bytes` ≤ `limit` bytes, s.
fn message_time(i: &IridiumSection, bytes: u64, limit: u64) -> f64 {
    let share = bytes.min(limit) as f64 / limit.max(1) as f64;
    i.latency_short + (i.latency_full - i.latency_short) * share
}

/// Time to send `bytes` bytes as messages of at most `limit` bytes one after another, s.
fn transfer_time(i: &IridiumSection, bytes: u64, limit: u64) -> f64 {
    let messages = bytes.div_ceil(limit.max(1)).max(1);
    (messages - 1) as f64 * i.latency_full + message_time(i, bytes - (messages - 1) * limit, limit)
}

/// Messages held until their delivery time; released in delivery-time order (ties in
/// the order they were held).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DelayQueue<T> {
    held: Vec<(f64, u64, T)>,
    next: u64,
}

impl<T> Default for DelayQueue<T> {
    fn default() -> Self {
        Self {
            held: Vec::new(),
            next: 0,
        }
    }
}

impl<T> DelayQueue<T> {
    /// Holds `item` until mission time `at`.
    pub fn push(&mut self, at: f64, item: T) {
        self.held.push((at, self.next, item));
        self.next += 1;
    }

    /// Removes and returns every item due at or before `now`, in delivery order.
    ///
    /// The items kept stay where they are (moved down in place): the coordinator's queue
    /// holds every vehicle's reports, hundreds per submerged glider, and one surfaced
    /// glider's report falls due nearly every tick. Splitting the whole queue into two new
    /// vectors each time was a fifth of `vbap sim`'s time on the glider mission.
    pub fn pop_due(&mut self, now: f64) -> Vec<T> {
        if !self.held.iter().any(|(at, _, _)| *at <= now) {
            return Vec::new();
        }
        let mut due: Vec<_> = self.held.extract_if(.., |(at, _, _)| *at <= now).collect();
        due.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        due.into_iter().map(|(_, _, item)| item).collect()
    }

    /// The sequence number the next held item gets (items are numbered 0, 1, … as held).
    pub fn next_seq(&self) -> u64 {
        self.next
    }

    /// The held items as (delivery time, sequence number, item), in the order they were
    /// held.
    pub fn held(&self) -> &[(f64, u64, T)] {
        &self.held
    }

    /// A queue holding `held` (in the order they were held), numbering from `next` on.
    pub fn from_parts(next: u64, held: Vec<(f64, u64, T)>) -> Self {
        Self { held, next }
    }

    /// Drops every held item for which `keep` is false.
    pub fn retain(&mut self, mut keep: impl FnMut(&T) -> bool) {
        self.held.retain(|(_, _, item)| keep(item));
    }

    /// Number of held items.
    pub fn len(&self) -> usize {
        self.held.len()
    }

    /// True when nothing is held.
    pub fn is_empty(&self) -> bool {
        self.held.is_empty()
    }
}

#[cfg(test)]
mod tests;
