//! The emulated glider link (docs/ARCHITECTURE.md §7): delay and jitter, Bernoulli or bursty
//! (Gilbert–Elliott) loss, link-down faults and surfacing windows with store-and-forward.
//!
//! Pure and seeded: the fate of a message is drawn from `rng::keyed(seed, Link, link, tick)`
//! where `link` names the vehicle and the direction and `tick` the message, never from a
//! shared RNG consumed in arrival order; the receiver of every vehicle ↔ coordinator
//! message applies it (the in-process simulator and the processes alike), so a lockstep
//! run with impaired links is still reproducible bit for bit.

use rand::Rng;

use crate::config::{FaultKind, Mission, SurfacingPhase};
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
}

impl DropReason {
    /// Name in logs and events.
    pub fn as_str(self) -> &'static str {
        match self {
            DropReason::Loss => "loss",
            DropReason::Burst => "burst",
            DropReason::LinkDown => "link_down",
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
}

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
        }
    }

    /// True when no message is ever delayed or lost.
    pub fn is_ideal(&self) -> bool {
        self.delay == 0.0
            && self.jitter == 0.0
            && self.loss == 0.0
            && self.period == 0.0
            && self.burst_enter == 0.0
            && self.link_down.is_empty()
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
        if self
            .link_down
            .iter()
            .any(|&(v, from, until)| v == vehicle && t >= from && t < until)
        {
            Contact::LinkDown
        } else if self.period <= 0.0 {
            Contact::Contact
        } else if self.at_surface(vehicle, t) {
            Contact::Surfaced
        } else {
            Contact::Submerged
        }
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
        if self
            .link_down
            .iter()
            .any(|&(v, from, until)| v == vehicle && sent >= from && sent < until)
        {
            return Fate::Drop(DropReason::LinkDown);
        }
        let link = Self::link_id(vehicle, dir);
        self.advance(state, link, tick);
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
        // Store and forward: nothing crosses while the vehicle is under water.
        let at = self.next_surface(vehicle, sent + delay.max(0.0));
        Fate::Deliver {
            at,
            injected: at - sent,
        }
    }
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
mod tests {
    use super::*;
    use crate::config::Mission;

    fn mission(links: &str) -> Mission {
        Mission::from_toml_str(
            &format!("[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[links]\n{links}"),
            "<test>",
        )
        .unwrap()
    }

    #[test]
    fn contact_states_follow_the_schedule() {
        let m = LinkModel::new(&mission(
            "surfacing_period = 100.0\nsurfacing_window = 10.0\nsurfacing_phase = \"staggered\"",
        ));
        // Vehicle 1 of 4 surfaces at 25 s of every 100 s.
        assert_eq!(m.contact(1, 24.9), Contact::Submerged);
        assert_eq!(m.contact(1, 25.0), Contact::Surfaced);
        assert_eq!(m.contact(1, 134.0), Contact::Surfaced);
        assert_eq!(m.contact(1, 135.0), Contact::Submerged);
        let down = Mission::from_toml_str(
            "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[[faults]]\nkind = \"link_down\"\nvehicle = 2\nat = 5.0\nuntil = 8.0",
            "<test>",
        )
        .unwrap();
        let m = LinkModel::new(&down);
        assert_eq!(m.contact(2, 4.9), Contact::Contact);
        assert_eq!(m.contact(2, 5.0), Contact::LinkDown);
        assert_eq!(m.contact(2, 8.0), Contact::Contact);
        assert_eq!(m.contact(1, 6.0), Contact::Contact);
        assert!(!Contact::LinkDown.can_talk() && Contact::Surfaced.can_talk());
    }

    #[test]
    fn ideal_links_deliver_at_once() {
        let m = LinkModel::new(&mission(""));
        assert!(m.is_ideal());
        let mut s = LinkState::default();
        assert_eq!(
            m.fate(&mut s, 1, Direction::Uplink, 5, 2.5),
            Fate::Deliver {
                at: 2.5,
                injected: 0.0
            }
        );
    }

    #[test]
    fn delay_and_jitter_are_within_bounds_and_centred() {
        let m = LinkModel::new(&mission("delay = 2.0\njitter = 0.5"));
        let mut s = LinkState::default();
        let mut sum = 0.0;
        let n = 20_000;
        for k in 0..n {
            match m.fate(&mut s, 0, Direction::Uplink, k, k as f64) {
                Fate::Deliver { injected, .. } => {
                    assert!((1.5..=2.5).contains(&injected), "{injected}");
                    sum += injected;
                }
                Fate::Drop(_) => panic!("no loss configured"),
            }
        }
        // Uniform on [1.5, 2.5]: mean 2, standard error 0.29/sqrt(n).
        assert!((sum / n as f64 - 2.0).abs() < 5.0 * 0.2887 / (n as f64).sqrt());
    }

    #[test]
    fn bernoulli_loss_rate_matches() {
        let m = LinkModel::new(&mission("loss = 0.2"));
        let mut s = LinkState::default();
        let n = 50_000u64;
        let lost = (0..n)
            .filter(|&k| matches!(m.fate(&mut s, 2, Direction::Uplink, k, 0.0), Fate::Drop(_)))
            .count();
        let rate = lost as f64 / n as f64;
        let se = (0.2 * 0.8 / n as f64).sqrt();
        assert!((rate - 0.2).abs() < 5.0 * se, "{rate}");
    }

    #[test]
    fn gilbert_elliott_loss_is_bursty_with_the_stationary_rate() {
        // Stationary probability of bad: enter / (enter + exit) = 0.05 / 0.25 = 0.2;
        // loss = 0.2·0.9 + 0.8·0.01 = 0.188.
        let m = LinkModel::new(&mission(
            "loss = 0.01\nburst_enter = 0.05\nburst_exit = 0.2\nburst_loss = 0.9",
        ));
        let mut s = LinkState::default();
        let n = 200_000u64;
        let drops: Vec<bool> = (0..n)
            .map(|k| {
                matches!(
                    m.fate(&mut s, 1, Direction::Downlink, k, 0.0),
                    Fate::Drop(_)
                )
            })
            .collect();
        let rate = drops.iter().filter(|d| **d).count() as f64 / n as f64;
        assert!((rate - 0.188).abs() < 0.01, "{rate}");
        // Bursty: a loss is much more likely right after a loss than on average.
        let after_loss = drops.windows(2).filter(|w| w[0]).count() as f64;
        let loss_loss = drops.windows(2).filter(|w| w[0] && w[1]).count() as f64;
        assert!(
            loss_loss / after_loss > 2.0 * rate,
            "{}",
            loss_loss / after_loss
        );
    }

    #[test]
    fn nothing_is_delivered_outside_a_surfacing_window() {
        let m = LinkModel::new(&mission(
            "delay = 5.0\njitter = 4.0\nsurfacing_period = 7200.0\nsurfacing_window = 600.0",
        ));
        let mut s = LinkState::default();
        for vehicle in 0..4u32 {
            for k in 0..2000u64 {
                let sent = k as f64 * 17.0;
                if let Fate::Deliver { at, .. } =
                    m.fate(&mut s, vehicle, Direction::Uplink, k, sent)
                {
                    assert!(
                        m.at_surface(vehicle, at),
                        "vehicle {vehicle} message at {at}"
                    );
                    assert!(at >= sent + 1.0 - 1e-9);
                }
            }
        }
        // Staggered phases: vehicle i surfaces at i·period/N.
        assert!(m.at_surface(1, 1800.0) && !m.at_surface(0, 1800.0));
        assert_eq!(m.next_surface(0, 700.0), 7200.0);
    }

    #[test]
    fn link_down_drops_inside_its_interval_only() {
        let text = "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[[faults]]\nkind = \"link_down\"\nvehicle = 1\nat = 10.0\nuntil = 20.0\n";
        let m = LinkModel::new(&Mission::from_toml_str(text, "<test>").unwrap());
        let mut s = LinkState::default();
        assert_eq!(
            m.fate(&mut s, 1, Direction::Uplink, 1, 15.0),
            Fate::Drop(DropReason::LinkDown)
        );
        assert!(matches!(
            m.fate(&mut s, 1, Direction::Uplink, 2, 20.0),
            Fate::Deliver { .. }
        ));
        assert!(matches!(
            m.fate(&mut s, 2, Direction::Uplink, 3, 15.0),
            Fate::Deliver { .. }
        ));
    }

    #[test]
    fn fates_do_not_depend_on_the_order_links_are_asked() {
        let m = LinkModel::new(&mission(
            "loss = 0.3\njitter = 0.5\ndelay = 1.0\nburst_enter = 0.1",
        ));
        let run = |order: &[u32]| {
            let mut states = [LinkState::default(); 4];
            let mut out = Vec::new();
            for k in 0..200u64 {
                for &v in order {
                    out.push((
                        v,
                        k,
                        m.fate(&mut states[v as usize], v, Direction::Uplink, k, k as f64),
                    ));
                }
            }
            out.sort_by_key(|a| (a.0, a.1));
            out
        };
        assert_eq!(run(&[0, 1, 2, 3]), run(&[3, 1, 0, 2]));
    }

    #[test]
    fn delay_queue_releases_in_delivery_order() {
        let mut q = DelayQueue::default();
        q.push(3.0, "c");
        q.push(1.0, "a");
        q.push(3.0, "d");
        q.push(2.0, "b");
        assert!(q.pop_due(0.5).is_empty());
        assert_eq!(q.pop_due(2.0), vec!["a", "b"]);
        assert_eq!(q.pop_due(10.0), vec!["c", "d"]);
        assert!(q.is_empty());
    }
}
