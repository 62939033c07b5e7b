//! The client side of the field server's batched sensor reads (one request-response per
//! tick), with read-ahead: the states of later ticks already in (agents that ran ahead)
//! are read while the coordinator computes, so with lookahead a tick seldom waits for the
//! field server at all.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use anyhow::Result;
use iceoryx2::prelude::*;
use tracing::{info, warn};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_field::{SampleBatch, SensorRead};
use vbap_ipc::msg::field_to_coordinator::ReadingBatch;
use vbap_ipc::msg::{Header, MAX_VEHICLES};
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::topics;
use vbap_ipc::wait::Wake;

use super::liveness::Liveness;
use super::ports::Ports;

/// How long the coordinator waits for the readings of a tick before it wakes the field
/// server again (a lost wake-up must not stall the mission).
const RENOTIFY_AFTER: Duration = Duration::from_millis(500);
/// How long the coordinator waits for the readings of a tick before it sends the request
/// again (a field server restarted unseen: without a supervisor, or its start-up event
/// missed). A restart the supervisor reports is acted on at once.
const RESEND_AFTER: Duration = Duration::from_secs(1);
/// How long the coordinator waits for the readings of a tick before it gives up.
const SAMPLE_TIMEOUT: Duration = Duration::from_secs(10);
/// How long a paced tick waits for readings the field server has not answered yet: past
/// it the tick goes on without them (its states dropped, as states late at the deadline
/// are), and the next ticks do not wait at all until the field server answers again. A
/// field server that is stopped or restarting then holds up neither the mission's clock
/// nor the coordinator's liveness verdicts (a lockstep tick needs every reading and
/// waits; see docs/design/faults.md).
pub(super) const READINGS_GRACE: Duration = Duration::from_millis(100);

/// How a wait for readings ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Waited {
    /// The readings are in (or, paced, the tick goes on without those not in).
    Done,
    /// The supervisor reported agents' deaths (in `Liveness::agent_exits`): decide them,
    /// then wait again.
    Deaths,
}

/// The request-response types of the sensor reads.
type SampleResponse =
    iceoryx2::pending_response::PendingResponse<ipc::Service, SampleBatch, (), ReadingBatch, ()>;
type SampleClient = iceoryx2::port::client::Client<ipc::Service, SampleBatch, (), ReadingBatch, ()>;

/// The sensor reads of the states of a tick, by request-response to the field server.
pub(super) struct SensorReads {
    client: SampleClient,
    field: iceoryx2::port::notifier::Notifier<ipc::Service>,
    batch: Box<SampleBatch>,
    seq: u64,
    /// The request in flight and the (vehicle, tick) of its entries.
    pending: Option<(SampleResponse, Vec<(u32, u64)>)>,
    /// When the request in flight was sent.
    sent_at: Instant,
    /// Since when the field server owes an answer: the first request it has not answered
    /// (kept across requests sent again; None once an answer came).
    unanswered_since: Option<Instant>,
    /// Paced ticks that went on without some of their readings since the last answer.
    blind_ticks: u64,
    /// Readings received and not used yet.
    readings: Readings,
}

/// The key of a state's sensor read.
fn read_key(s: &VehicleState) -> (u32, u64) {
    (s.header.sender, s.header.tick)
}

/// The readings received and not used yet: (vehicle, tick) → reading (None: rejected).
/// The bookkeeping of [`SensorReads`], apart from its ports.
#[derive(Debug, Default)]
struct Readings(BTreeMap<(u32, u64), Option<f64>>);

impl Readings {
    /// True when the reading of `key` is in (good or rejected).
    fn has(&self, key: (u32, u64)) -> bool {
        self.0.contains_key(&key)
    }

    /// The first tick of vehicle `v` whose reading is not in yet, from `from` on: after the
    /// newest reading of `v` in (a vehicle's states come, and are read, in tick order).
    fn unread_from(&self, v: u32, from: u64) -> u64 {
        self.0
            .range((v, from)..=(v, u64::MAX))
            .next_back()
            .map_or(from, |(&(_, tick), _)| tick + 1)
    }

    /// Keeps the reading of `key` (None: rejected).
    fn insert(&mut self, key: (u32, u64), reading: Option<f64>) {
        self.0.insert(key, reading);
    }

    /// The reading of `key` (None: rejected, or not in), forgotten here.
    fn take(&mut self, key: (u32, u64)) -> Option<f64> {
        self.0.remove(&key).flatten()
    }

    /// Forgets the readings of ticks up to `k`.
    fn forget_through(&mut self, k: u64) {
        // Most ticks there is none: the readings in are of later ticks (read ahead).
        if self.0.keys().any(|&(_, tick)| tick <= k) {
            self.0.retain(|(_, tick), _| *tick > k);
        }
    }
}

impl SensorReads {
    /// The sensor reads through `client`, waking the field server with `field`; `batch` is
    /// the reused request buffer.
    pub fn new(
        client: SampleClient,
        field: iceoryx2::port::notifier::Notifier<ipc::Service>,
        batch: Box<SampleBatch>,
    ) -> Self {
        Self {
            client,
            field,
            batch,
            seq: 0,
            pending: None,
            sent_at: Instant::now(),
            unanswered_since: None,
            blind_ticks: 0,
            readings: Readings::default(),
        }
    }

    /// True when the readings of every state in `states` are in.
    pub fn has_all(&self, states: &[VehicleState]) -> bool {
        states.iter().all(|s| self.readings.has(read_key(s)))
    }

    /// True when no request is in flight: a read-ahead would be sent now.
    pub fn idle(&self) -> bool {
        self.pending.is_none()
    }

    /// The first tick of vehicle `v` whose reading is not in yet, from `from` on: after the
    /// newest reading of `v` in (a vehicle's states come, and are read, in tick order).
    pub fn unread_from(&self, v: u32, from: u64) -> u64 {
        self.readings.unread_from(v, from)
    }

    /// Asks for the readings of the states in `wanted` (in order) that are neither in
    /// nor asked for, unless a request is in flight (one at a time).
    pub fn request(&mut self, k: u64, dt: f64, wanted: &[VehicleState]) -> Result<()> {
        if self.pending.is_some() {
            return Ok(());
        }
        let mut keys = Vec::new();
        // Keys already in the batch: a set, not a scan of `keys` (O(n²): 0.5 M compares a
        // tick at N = 1024, and a read-ahead of 6 gliders × 48 ticks is 288 reads).
        let mut taken = std::collections::HashSet::with_capacity(wanted.len());
        for s in wanted {
            if keys.len() == MAX_VEHICLES {
                break;
            }
            let key = read_key(s);
            if self.readings.has(key) || !taken.insert(key) {
                continue;
            }
            self.batch.reads[keys.len()] = SensorRead {
                vehicle: s.header.sender,
                _pad: 0,
                tick: s.header.tick,
                t: s.header.t,
                position: s.position,
            };
            keys.push(key);
        }
        if keys.is_empty() {
            return Ok(());
        }
        self.seq += 1;
        self.batch.n = keys.len() as u32;
        self.batch.header = Header::new(Header::COORDINATOR, k, k as f64 * dt, self.seq);
        let pending = vbap_ipc::prefix::request(&self.client, &*self.batch)
            .map_err(|e| anyhow::anyhow!("sending the sensor reads of tick {k}: {e}"))?;
        self.notify_field()?;
        self.pending = Some((pending, keys));
        self.sent_at = Instant::now();
        self.unanswered_since.get_or_insert(self.sent_at);
        Ok(())
    }

    /// Wakes the field server.
    pub fn notify_field(&self) -> Result<()> {
        self.field
            .notify()
            .map_err(|e| anyhow::anyhow!("waking the field server: {e:?}"))?;
        Ok(())
    }

    /// Forgets the request in flight (its server died, or a new server started: a request
    /// reaches only the servers connected when it was sent); the next wait sends it again.
    pub fn forget_pending(&mut self, why: &str) {
        if let Some((_, keys)) = self.pending.take() {
            info!(
                reads = keys.len(),
                why, "sending the pending sensor request again"
            );
        }
    }

    /// Acts on the events of a wake-up: a (re)started field server gets the pending
    /// request again.
    pub fn note_events(&mut self, ids: &[usize]) {
        if ids.contains(&topics::EVENT_FIELD_UP.as_value()) {
            self.forget_pending("a field server started");
        }
    }

    /// Takes in the answer to the request in flight, if it has come.
    fn poll(&mut self, msgs: &mut MsgLog) -> Result<()> {
        let Some((pending, keys)) = &self.pending else {
            return Ok(());
        };
        let Some(reply) = pending
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving sensor readings: {e:?}"))?
        else {
            return Ok(());
        };
        let h = reply.header;
        msgs.recv_now("field_reply", &h, Header::COORDINATOR);
        let readings = reply.readings();
        anyhow::ensure!(
            h.sender == Header::FIELD_SERVER
                && reply.request_seq == self.seq
                && readings.len() == keys.len(),
            "the field server answered sensor reads out of turn (sender {}, request {} of {}, \
             {} readings for {})",
            h.sender,
            reply.request_seq,
            self.seq,
            readings.len(),
            keys.len()
        );
        for (r, key) in readings.iter().zip(keys) {
            let good = (r.vehicle, r.tick) == *key && r.rejected == 0 && r.value.is_finite();
            self.readings.insert(*key, good.then_some(r.value));
        }
        drop(reply);
        self.pending = None;
        self.unanswered_since = None;
        if self.blind_ticks > 0 {
            info!(
                ticks_without = std::mem::take(&mut self.blind_ticks),
                "sensor readings again from the field server"
            );
        }
        Ok(())
    }

    /// Blocks until the readings of every state in `needed` are in (asking for them when
    /// no request is in flight); `grace`: in a paced run, [`READINGS_GRACE`], how long the
    /// field server may owe an answer before the tick goes on without the readings not in
    /// (None in lockstep: every reading is waited for). Returns early, with
    /// [`Waited::Deaths`], when the supervisor reports an agent's death (kept in `live`):
    /// the caller decides it at once, not when the field server answers, then waits again.
    /// None on a termination signal. Vehicle events consumed meanwhile are harmless (every
    /// tick starts with a full drain).
    #[allow(clippy::too_many_arguments)]
    pub fn wait_for(
        &mut self,
        k: u64,
        dt: f64,
        needed: &[VehicleState],
        grace: Option<Duration>,
        ports: &Ports,
        msgs: &mut MsgLog,
        live: &mut Liveness,
    ) -> Result<Option<Waited>> {
        let started = Instant::now();
        loop {
            if live.hear()? {
                self.forget_pending("the field server died");
            }
            if !live.agent_exits.is_empty() {
                return Ok(Some(Waited::Deaths));
            }
            self.poll(msgs)?;
            if self.has_all(needed) {
                return Ok(Some(Waited::Done));
            }
            if self.pending.is_some() && self.sent_at.elapsed() >= RESEND_AFTER {
                self.forget_pending("no answer");
            }
            self.request(k, dt, needed)?;
            // A lockstep tick gives up after SAMPLE_TIMEOUT of its own wait; a paced one
            // after SAMPLE_TIMEOUT without any answer (its ticks meanwhile went on).
            let owed = match grace {
                None => started,
                Some(_) => self.unanswered_since.unwrap_or(started),
            };
            let left = SAMPLE_TIMEOUT.saturating_sub(owed.elapsed());
            anyhow::ensure!(
                !left.is_zero(),
                "no sensor readings from the field server within {SAMPLE_TIMEOUT:?} (tick {k})"
            );
            let renotify = left.min(RENOTIFY_AFTER);
            let mut wait = renotify;
            if let Some(grace) = grace {
                let Some(wait_left) = blind_wait(self.unanswered_since, grace) else {
                    if self.blind_ticks == 0 {
                        warn!(
                            tick = k,
                            waited_ms = owed.elapsed().as_secs_f64() * 1e3,
                            "no sensor readings: the paced ticks go on without them"
                        );
                    }
                    self.blind_ticks += 1;
                    return Ok(Some(Waited::Done));
                };
                wait = wait.min(wait_left);
            }
            let mut ids = Vec::new();
            match ports.wait(wait, &mut ids)? {
                Wake::Stop => return Ok(None),
                Wake::Timeout if wait == renotify => {
                    warn!(
                        tick = k,
                        "no sensor readings yet: waking the field server again"
                    );
                    self.notify_field()?;
                }
                Wake::Timeout => {}
                Wake::Events => self.note_events(&ids),
            }
        }
    }

    /// True when the reading of `s` is in (good or rejected).
    pub fn has(&self, s: &VehicleState) -> bool {
        self.readings.has(read_key(s))
    }

    /// The reading of state `s` (None: rejected, or never asked for), forgotten here.
    pub fn take(&mut self, s: &VehicleState) -> Option<f64> {
        self.readings.take(read_key(s))
    }

    /// Forgets the readings of ticks up to `k` that were never used (their vehicle was
    /// lost).
    pub fn forget_through(&mut self, k: u64) {
        self.readings.forget_through(k);
    }
}

/// How much longer a paced tick may wait for readings the field server has owed since
/// `owed_since` (None: it owes nothing), given `grace`; None when the tick goes on without
/// them now.
fn blind_wait(owed_since: Option<Instant>, grace: Duration) -> Option<Duration> {
    let owed = owed_since.map_or(Duration::ZERO, |t| t.elapsed());
    let left = grace.saturating_sub(owed);
    (!left.is_zero()).then_some(left)
}

#[cfg(test)]
mod tests {
    use super::{blind_wait, Readings};
    use std::time::{Duration, Instant};

    /// A paced tick waits for the field server's answer at most the grace counted from
    /// the first request it has not answered, not from this tick: after an outage began,
    /// no later tick waits at all.
    #[test]
    fn a_paced_tick_waits_for_readings_only_within_the_grace_of_the_first_unanswered_request() {
        let grace = Duration::from_millis(100);
        // Nothing owed: the whole grace.
        assert_eq!(blind_wait(None, grace), Some(grace));
        // Owed since just now: the grace less the time since.
        let now = Instant::now();
        let left = blind_wait(Some(now), grace).expect("within the grace");
        assert!(left <= grace && left + now.elapsed() >= grace, "{left:?}");
        // Owed longer than the grace: no wait.
        if let Some(long_ago) = Instant::now().checked_sub(Duration::from_secs(2)) {
            assert_eq!(blind_wait(Some(long_ago), grace), None);
        }
        // A zero grace never waits.
        assert_eq!(blind_wait(None, Duration::ZERO), None);
    }

    #[test]
    fn unread_from_starts_after_the_newest_reading_of_the_vehicle() {
        let mut r = Readings::default();
        // Nothing in: from `from` itself.
        assert_eq!(r.unread_from(3, 10), 10);
        // Vehicle 3 read through tick 14 (one rejected), vehicle 4 through 30.
        for tick in 10..=14 {
            r.insert((3, tick), (tick != 12).then_some(tick as f64));
        }
        r.insert((4, 30), Some(1.0));
        assert_eq!(r.unread_from(3, 10), 15);
        assert_eq!(r.unread_from(3, 14), 15);
        // Another vehicle's readings never count.
        assert_eq!(r.unread_from(2, 10), 10);
        assert_eq!(r.unread_from(4, 10), 31);
        // Readings before `from` are not "ahead".
        assert_eq!(r.unread_from(3, 15), 15);
        assert_eq!(r.unread_from(3, 20), 20);
        // The extremes of the key space.
        r.insert((u32::MAX, u64::MAX - 1), None);
        assert_eq!(r.unread_from(u32::MAX, 0), u64::MAX);
    }

    #[test]
    fn readings_are_taken_once_and_forgotten_through_a_tick() {
        let mut r = Readings::default();
        r.insert((0, 5), Some(2.5));
        r.insert((0, 6), None);
        r.insert((1, 7), Some(-1.0));
        assert!(r.has((0, 6)), "a rejected reading is in");
        assert_eq!(r.take((0, 6)), None);
        assert!(!r.has((0, 6)));
        assert_eq!(r.take((0, 5)), Some(2.5));
        assert_eq!(r.take((0, 5)), None, "taken once");
        r.insert((0, 5), Some(2.5));
        r.forget_through(6);
        assert!(!r.has((0, 5)));
        assert!(r.has((1, 7)));
        assert_eq!(r.unread_from(0, 0), 0, "forgotten: unread again");
        r.forget_through(6);
        assert_eq!(r.take((1, 7)), Some(-1.0));
    }
}
