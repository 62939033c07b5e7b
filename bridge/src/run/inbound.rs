//! Zenoh → this host's iceoryx2 services, published and notified exactly as the local
//! writer would (same service, same wake event); the hosts' liveliness.
//!
//! On the shore: remote vehicles' states (a frame per glider host's pass, each state
//! checked alone and published on `<m>/vehicle/<id>/state`, waking the coordinator with
//! `Event::Vehicle(id)`), the glider hosts' process exits and acknowledgements of the
//! final command (see `super`'s doc: the end), and for
//! every remote vehicle whose host is up a *proxy node* `vehicle_agent_<id>` in this
//! domain (the coordinator's node-list scan finds the vehicle alive while its host is).
//! When a glider host's token vanishes, its vehicles are reported
//! [`ProcessExit::UNREACHABLE`] on `<m>/supervisor/exits` (the coordinator loses them at
//! once and redesigns; the process may live on, so its next state is a join request) and
//! their proxy nodes end. On a glider host: the body commands (publisher of `<m>/body`,
//! `Event::Body` on every local vehicle's wake service), the final one acknowledged.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::Ordering;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use iceoryx2::node::Node;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::ipc;
use iceoryx2::service::port_factory::PortFactory as _;
use tracing::{info, warn};
use vbap_ipc::ports::{self, Sender};
use vbap_ipc::topics;
use vbap_ipc::wait::Event;
use vbap_wire::msg::agent_to_coordinator::VehicleState;
use vbap_wire::msg::coordinator_to_agent::BodyCommand;
use vbap_wire::msg::supervisor_to_coordinator::ProcessExit;
use vbap_wire::msg::{wall_ns, Header};
use zenoh::qos::Priority;
use zenoh::Wait;

use super::repeat::{Identity, Peers};
use super::{liveliness_event, Counts, In, Place, Stop, HOST_GONE_GRACE, POLL, RESEND};
use crate::keys::Keys;
use crate::wire::{self, Headed, RawBody, RawBytes, RawExit, RawState};

/// The Zenoh subscribers of this host (kept alive by the caller): their callbacks send to
/// `tx`.
pub(crate) fn subscribe(
    session: &zenoh::Session,
    place: &Place<'_>,
    tx: &mpsc::Sender<In>,
) -> Result<Vec<zenoh::pubsub::Subscriber<()>>> {
    let keys = &place.keys;
    let wanted = if place.is_shore() {
        vec![keys.all_states(), keys.all_exits(), keys.final_acks()]
    } else {
        vec![keys.body()]
    };
    let mut subs = Vec::new();
    for key in wanted {
        let tx = tx.clone();
        subs.push(
            session
                .declare_subscriber(key.clone())
                .callback(move |s| {
                    let _ = tx.send(In::Frame {
                        key: s.key_expr().as_str().to_string(),
                        bytes: s.payload().to_bytes().into_owned(),
                        again: s.attachment().is_some(),
                    });
                })
                .wait()
                .map_err(|e| anyhow!("subscribing to {key}: {e}"))?,
        );
    }
    let tx = tx.clone();
    subs.push(
        session
            .liveliness()
            .declare_subscriber(keys.hosts())
            .history(true)
            .callback(move |s| liveliness_event(&tx, &s))
            .wait()
            .map_err(|e| anyhow!("subscribing to the hosts' liveliness: {e}"))?,
    );
    Ok(subs)
}

/// The shore's inbound ports.
struct Shore {
    node: Node<ipc::Service>,
    states: BTreeMap<u32, Sender<RawState>>,
    exits: Sender<RawExit>,
    /// Proxy nodes of the remote vehicles whose host is up.
    proxies: BTreeMap<u32, Node<ipc::Service>>,
    /// The pid of each remote vehicle's process, from its last state.
    pids: BTreeMap<u32, u32>,
    /// This bridge started while the coordinator already ran (it is a restarted bridge:
    /// the coordinator lost the remote vehicles when the old one's proxy nodes died).
    restarted: bool,
    /// The remote vehicles whose first state through this bridge has been forwarded.
    heard: BTreeSet<u32>,
    /// The last state published for each remote vehicle (a frame put again is dropped).
    last: BTreeMap<u32, Identity>,
    /// The body commands' key, for putting the final command again.
    body_out: zenoh::pubsub::Publisher<'static>,
    /// The mission's final command once forwarded, until every glider host has it.
    held: Option<Held>,
}

/// The mission's final command kept on the shore for the glider hosts that have not
/// acknowledged it.
struct Held {
    frame: Vec<u8>,
    since: Instant,
    last_put: Instant,
    pending: BTreeSet<String>,
    /// A pending host's token is back: put the command again at once.
    now: bool,
}

/// A glider host's inbound ports.
struct Glider {
    body: Publisher<ipc::Service, RawBody, ()>,
    wakes: Vec<Notifier<ipc::Service>>,
    /// Acknowledges the mission's final command to the shore.
    ack: zenoh::pubsub::Publisher<'static>,
    /// When the final command was published here (None: not yet).
    finished: Option<Instant>,
    /// The last body command published here (a frame put again is dropped).
    last: Option<Identity>,
    /// The node of the ports (dropped after them).
    _node: Node<ipc::Service>,
}

/// The inbound loop: opens the ports, declares this host's token when it may, calls
/// `ready` when this host may start its processes, forwards until `stop`.
pub(crate) fn run(
    session: &zenoh::Session,
    place: &Place<'_>,
    rx: &mpsc::Receiver<In>,
    stop: &Stop,
    counts: &Counts,
    peers: &Peers,
    ready: impl FnOnce(),
) -> Result<()> {
    let (domain, limits) = (&place.domain, &place.limits);
    let node = domain.node("vbap_bridge_in")?;
    // The coordinator is up once the body service has its publisher.
    let body_service = domain.body_service_as::<RawBody>(&node, limits)?;
    let coordinator_publishes = || body_service.dynamic_config().number_of_publishers() > 0;
    let mut inbound = Inbound::open(session, place, node, coordinator_publishes())?;
    let liveliness = session.liveliness();
    let declare = || {
        liveliness
            .declare_token(place.keys.host(place.host, std::process::id()))
            .wait()
            .map_err(|e| anyhow!("declaring this host's liveliness token: {e}"))
    };
    // A glider host is up as soon as its ports are; the shore once its coordinator is.
    let mut token = if place.is_shore() {
        None
    } else {
        Some(declare()?)
    };
    let mut ready = Some(ready);
    let final_wait = Duration::from_secs_f64(place.hosts.final_wait);
    while !stop.is_set() {
        match rx.recv_timeout(POLL) {
            Ok(message) => {
                if inbound.take(place, message, counts, peers)? {
                    stop.set();
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
        inbound.gone_for_good(place, peers)?;
        if inbound.final_wait_over(final_wait, counts)? {
            stop.set();
        }
        if inbound.may_start(place) {
            if let Some(r) = ready.take() {
                info!("every host this one waits for is up: ready");
                r();
            }
        }
        if token.is_none() && ready.is_none() && coordinator_publishes() {
            info!("the coordinator publishes: this host's token declared");
            token = Some(declare()?);
        }
    }
    drop(token);
    Ok(())
}

/// What the inbound loop holds: this host's ports (the shore's or a glider host's) and
/// which hosts are up.
struct Inbound {
    shore: Option<Shore>,
    glider: Option<Glider>,
    /// Each host heard of: up (its token is there) or gone.
    up: BTreeMap<String, bool>,
    /// The bridge process whose token each host shows (or showed last).
    bridge: BTreeMap<String, u32>,
    /// Hosts whose token vanished, and when: gone for good (their vehicles reported
    /// unreachable) once [`HOST_GONE_GRACE`] passes without the same bridge's token coming
    /// back, or at once when another bridge's token comes (the host's bridge restarted).
    vanished: BTreeMap<String, Instant>,
}

impl Inbound {
    /// Opens the ports of this host's side on `node`; `coordinator_up`: the coordinator
    /// already publishes (the shore's bridge was restarted).
    fn open(
        session: &zenoh::Session,
        place: &Place<'_>,
        node: Node<ipc::Service>,
        coordinator_up: bool,
    ) -> Result<Self> {
        let (shore, glider) = if place.is_shore() {
            (
                Some(Shore::open(session, place, node, coordinator_up)?),
                None,
            )
        } else {
            (None, Some(Glider::open(session, place, node)?))
        };
        Ok(Self {
            shore,
            glider,
            up: BTreeMap::new(),
            bridge: BTreeMap::new(),
            vanished: BTreeMap::new(),
        })
    }

    /// Takes one message of the Zenoh callbacks or the outbound thread; true when the
    /// bridge is done (the final command delivered, or the shore gone after it).
    fn take(
        &mut self,
        place: &Place<'_>,
        message: In,
        counts: &Counts,
        peers: &Peers,
    ) -> Result<bool> {
        match message {
            In::Frame { key, bytes, again } => match (&mut self.shore, &mut self.glider) {
                // On the shore: true on the last acknowledgement of the final command.
                (Some(s), _) => s.frame(place, &key, &bytes, again, counts, peers),
                (_, Some(g)) => g
                    .frame(&key, &bytes, again, counts, || {
                        peers.heard(&place.hosts.shore)
                    })
                    .map(|()| false),
                _ => Ok(false),
            },
            In::Up(h, pid) => {
                let same = self.bridge.insert(h.clone(), pid) == Some(pid);
                if let Some(at) = self.vanished.remove(&h) {
                    if same {
                        info!(
                            host = %h,
                            away_ms = at.elapsed().as_secs_f64() * 1e3,
                            "host back within the grace: its link was reopened (what it lost is put again)"
                        );
                        return Ok(false);
                    }
                    // Another bridge: the one that vanished is gone for good.
                    self.gone(place, &h, peers)?;
                }
                info!(host = %h, bridge_pid = pid, "host up");
                self.up.insert(h.clone(), true);
                peers.set_up(&h, true);
                if let Some(s) = &mut self.shore {
                    s.host_up(place, &h)?;
                    if let Some(held) = s.held.as_mut().filter(|d| d.pending.contains(&h)) {
                        held.now = true;
                    }
                }
                Ok(false)
            }
            In::Down(h, pid) => {
                if self.bridge.get(&h) != Some(&pid) {
                    return Ok(false); // a bridge already replaced
                }
                let finished = self.glider.as_ref().is_some_and(|g| g.finished.is_some());
                if finished && h == place.hosts.shore {
                    info!("the shore is gone after the final command: bridge ends");
                    return Ok(true);
                }
                if self.up.get(&h) == Some(&true) {
                    info!(
                        host = %h,
                        grace_ms = HOST_GONE_GRACE.as_millis() as u64,
                        "host token vanished: gone unless back within the grace"
                    );
                    self.vanished.entry(h).or_insert_with(Instant::now);
                }
                Ok(false)
            }
            In::Final(frame) => Ok(self.shore.as_mut().is_some_and(|s| s.hold(place, frame))),
        }
    }

    /// The hosts whose token vanished [`HOST_GONE_GRACE`] ago and did not come back are
    /// gone: on the shore, their vehicles are reported unreachable.
    fn gone_for_good(&mut self, place: &Place<'_>, peers: &Peers) -> Result<()> {
        let gone: Vec<String> = self
            .vanished
            .iter()
            .filter(|(_, at)| at.elapsed() >= HOST_GONE_GRACE)
            .map(|(h, _)| h.clone())
            .collect();
        for h in gone {
            self.vanished.remove(&h);
            self.gone(place, &h, peers)?;
        }
        Ok(())
    }

    /// Host `h` is gone: on the shore, its vehicles are reported unreachable.
    fn gone(&mut self, place: &Place<'_>, h: &str, peers: &Peers) -> Result<()> {
        warn!(host = %h, "host gone");
        self.up.insert(h.to_string(), false);
        peers.set_up(h, false);
        if let Some(s) = &mut self.shore {
            s.host_down(place, h)?;
        }
        Ok(())
    }

    /// The final command's deadlines: the shore puts it again to the glider hosts that
    /// have not acknowledged it; true when the bridge is done waiting (every host has it,
    /// or `final_wait` is over on either side).
    fn final_wait_over(&mut self, final_wait: Duration, counts: &Counts) -> Result<bool> {
        if let Some(s) = &mut self.shore {
            if s.resend(final_wait, counts)? {
                return Ok(true);
            }
        }
        if let Some(at) = self.glider.as_ref().and_then(|g| g.finished) {
            if at.elapsed() > final_wait {
                warn!(
                    final_wait_s = final_wait.as_secs_f64(),
                    "the shore still there final_wait after the final command: bridge ends"
                );
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Whether every host this one waits for is up: the glider hosts for the shore, the
    /// shore for a glider host.
    fn may_start(&self, place: &Place<'_>) -> bool {
        let all_up = |names: &[String]| names.iter().all(|n| self.up.get(n) == Some(&true));
        if place.is_shore() {
            all_up(&place.glider_hosts())
        } else {
            all_up(std::slice::from_ref(&place.hosts.shore))
        }
    }
}

impl Shore {
    /// The shore's inbound ports on `node`: a state publisher per remote vehicle, the exits
    /// publisher, the body commands' Zenoh key. `restarted`: the coordinator already runs.
    fn open(
        session: &zenoh::Session,
        place: &Place<'_>,
        node: Node<ipc::Service>,
        restarted: bool,
    ) -> Result<Self> {
        let (domain, limits) = (&place.domain, &place.limits);
        let mut states = BTreeMap::new();
        for id in place.remote_vehicles() {
            let publisher = ports::publisher(&domain.state_like_service_as::<RawState>(
                &node,
                &format!("vehicle/{id}/state"),
                limits,
            )?)?;
            let wake = ports::notifier(&domain.coordinator_wake(&node, limits)?, Event::Data)?;
            states.insert(id, Sender::new(publisher, wake, Event::Vehicle(id)));
        }
        let exits = Sender::new(
            ports::publisher(&domain.exits_service_as::<RawExit>(&node, limits)?)?,
            ports::notifier(&domain.coordinator_wake(&node, limits)?, Event::Exit)?,
            Event::Exit,
        );
        let shore = Shore {
            node,
            states,
            exits,
            proxies: BTreeMap::new(),
            pids: BTreeMap::new(),
            restarted,
            heard: Default::default(),
            last: BTreeMap::new(),
            body_out: super::publisher(session, place.keys.body(), Priority::RealTime)?,
            held: None,
        };
        if restarted {
            info!("the coordinator already runs: a restarted bridge (remote vehicles rejoin)");
        }
        Ok(shore)
    }

    /// A frame from a glider host (`again`: put again): its vehicles' states (`peers` hears
    /// of the host when one is published), its exits, or its acknowledgement of the final
    /// command; true when that was the last acknowledgement awaited.
    fn frame(
        &mut self,
        place: &Place<'_>,
        key: &str,
        bytes: &[u8],
        again: bool,
        counts: &Counts,
        peers: &Peers,
    ) -> Result<bool> {
        let last = Keys::last(key);
        if key.contains("/states/") {
            let entries = match wire::decode_all::<RawState>(bytes) {
                Ok(e) => e,
                Err(e) => {
                    counts.refuse(key, &e);
                    return Ok(false);
                }
            };
            for entry in entries {
                match entry {
                    Ok(raw) => self.state(place, key, raw, again, counts, peers)?,
                    Err(e) => counts.refuse(key, &e),
                }
            }
            return Ok(false);
        }
        if key.contains("/final_ack/") {
            return Ok(self.acknowledged(last));
        }
        let raw = match wire::decode::<RawExit>(bytes) {
            Ok(r) => r,
            Err(e) => {
                counts.refuse(key, &e);
                return Ok(false);
            }
        };
        let role = wire::u32_at(raw.bytes(), std::mem::offset_of!(ProcessExit, role));
        let vehicle = wire::u32_at(raw.bytes(), std::mem::offset_of!(ProcessExit, vehicle));
        let theirs = place
            .hosts
            .hosts
            .get(last)
            .is_some_and(|h| h.vehicles.contains(&vehicle));
        if role != ProcessExit::AGENT || !theirs {
            counts.refuse(
                key,
                &format!("an exit of role {role}, vehicle {vehicle} from host {last}"),
            );
            return Ok(false);
        }
        self.exits.send(raw)?;
        counts.inbound.fetch_add(1, Ordering::Relaxed);
        Ok(false)
    }

    /// One state of the frame of glider host `key`'s last chunk: published on its vehicle's
    /// service when the vehicle is one of that host's, unless it came `again` and is the
    /// one last published for it (dropped), else refused alone. `peers` hears of the
    /// host before the state is published: the outbound thread's note of what it heard when
    /// it put the answer must already count it.
    fn state(
        &mut self,
        place: &Place<'_>,
        key: &str,
        raw: RawState,
        again: bool,
        counts: &Counts,
        peers: &Peers,
    ) -> Result<()> {
        let host = Keys::last(key);
        let header = raw.header();
        let id = header.sender;
        let theirs = place
            .hosts
            .hosts
            .get(host)
            .is_some_and(|h| h.vehicles.contains(&id));
        if !theirs || !self.states.contains_key(&id) {
            counts.refuse(
                key,
                &format!("a state of sender {id}, not a remote vehicle of host {host}"),
            );
            return Ok(());
        }
        let identity = Identity::of(&header);
        if self.last.insert(id, identity) == Some(identity) && again {
            counts.duplicates.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
        peers.heard(host);
        let pid = wire::u32_at(raw.bytes(), std::mem::offset_of!(VehicleState, pid));
        self.pids.insert(id, pid);
        if self.restarted && self.heard.insert(id) {
            // The coordinator lost this vehicle with the old bridge's proxy node (it saw a
            // dead node) and takes its process's states as last words: report it
            // unreachable, so its next state is a join request and it rejoins.
            self.exits.send(unreachable(id, pid))?;
            info!(
                vehicle = id,
                pid, "first state through a restarted bridge: rejoins"
            );
        }
        self.states[&id].send(raw)?;
        counts.inbound.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    /// The outbound thread forwarded the mission's final command `frame`: kept until every
    /// glider host acknowledges it; true when there is none to wait for.
    fn hold(&mut self, place: &Place<'_>, frame: Vec<u8>) -> bool {
        let pending: BTreeSet<String> = place.glider_hosts().into_iter().collect();
        info!(
            hosts = ?pending,
            final_wait_s = place.hosts.final_wait,
            "the mission's final command is forwarded: kept until every glider host acknowledges it"
        );
        let now = Instant::now();
        let none = pending.is_empty();
        self.held = Some(Held {
            frame,
            since: now,
            last_put: now,
            pending,
            now: false,
        });
        none
    }

    /// Glider host `host` acknowledged the final command; true when it was the last.
    fn acknowledged(&mut self, host: &str) -> bool {
        let Some(held) = &mut self.held else {
            return false;
        };
        if held.pending.remove(host) {
            info!(
                host,
                after_ms = held.since.elapsed().as_secs_f64() * 1e3,
                "final command acknowledged"
            );
        }
        if held.pending.is_empty() {
            info!("every glider host has the final command: bridge ends");
            return true;
        }
        false
    }

    /// While the final command is held: puts it again every [`RESEND`] or at once when a
    /// pending host's token is back; true when `final_wait` has run out (the hosts that
    /// never acknowledged are logged).
    fn resend(&mut self, final_wait: Duration, counts: &Counts) -> Result<bool> {
        let Some(held) = &mut self.held else {
            return Ok(false);
        };
        if held.pending.is_empty() {
            return Ok(false);
        }
        if held.since.elapsed() > final_wait {
            warn!(
                never = ?held.pending,
                final_wait_s = final_wait.as_secs_f64(),
                "final command not acknowledged by every glider host within final_wait: bridge ends"
            );
            return Ok(true);
        }
        if held.last_put.elapsed() >= RESEND || held.now {
            held.now = false;
            self.body_out
                .put(held.frame.as_slice())
                .wait()
                .map_err(|e| anyhow!("putting the final command again: {e}"))?;
            counts.frames_out.fetch_add(1, Ordering::Relaxed);
            held.last_put = Instant::now();
        }
        Ok(false)
    }

    /// Host `host` is up: proxy nodes for its vehicles.
    fn host_up(&mut self, place: &Place<'_>, host: &str) -> Result<()> {
        let _ = &self.node;
        for &id in place
            .hosts
            .hosts
            .get(host)
            .map(|h| h.vehicles.as_slice())
            .unwrap_or(&[])
        {
            if let std::collections::btree_map::Entry::Vacant(slot) = self.proxies.entry(id) {
                slot.insert(place.domain.agent_node(&topics::agent_node_name(id))?);
            }
        }
        Ok(())
    }

    /// Host `host` is gone: its vehicles are reported unreachable, their proxies end.
    fn host_down(&mut self, place: &Place<'_>, host: &str) -> Result<()> {
        for &id in place
            .hosts
            .hosts
            .get(host)
            .map(|h| h.vehicles.as_slice())
            .unwrap_or(&[])
        {
            if self.proxies.remove(&id).is_some() {
                let pid = self.pids.get(&id).copied().unwrap_or(0);
                self.exits.send(unreachable(id, pid))?;
                warn!(
                    vehicle = id,
                    pid, host, "vehicle unreachable: reported to the coordinator"
                );
            }
        }
        Ok(())
    }
}

impl Glider {
    /// A glider host's inbound ports on `node`: the body publisher, every local vehicle's
    /// wake notifier, the acknowledgement key of the final command.
    fn open(session: &zenoh::Session, place: &Place<'_>, node: Node<ipc::Service>) -> Result<Self> {
        let (domain, limits) = (&place.domain, &place.limits);
        let mut wakes = Vec::new();
        for id in place.local_vehicles() {
            wakes.push(ports::notifier(
                &domain.vehicle_wake(&node, id, limits)?,
                Event::Body,
            )?);
        }
        Ok(Glider {
            body: ports::publisher(&domain.body_service_as::<RawBody>(&node, limits)?)?,
            wakes,
            ack: super::publisher(
                session,
                place.keys.final_ack(place.host),
                Priority::RealTime,
            )?,
            finished: None,
            last: None,
            _node: node,
        })
    }

    /// A body command from the shore: published here, every local agent woken, unless it
    /// came `again` and is the one last published (dropped); the mission's final one
    /// acknowledged (every time it comes: the shore puts it again until it hears us), and
    /// once it is published nothing more is. `news` is called before a command is
    /// published (the outbound thread's note of what it heard when it put the agents'
    /// answer must already count it).
    fn frame(
        &mut self,
        key: &str,
        bytes: &[u8],
        again: bool,
        counts: &Counts,
        news: impl FnOnce(),
    ) -> Result<()> {
        let raw = match wire::decode::<RawBody>(bytes) {
            Ok(r) => r,
            Err(e) => {
                counts.refuse(key, &e);
                return Ok(());
            }
        };
        let header = raw.header();
        let (sender, flags) = (header.sender, header.flags);
        if sender != Header::COORDINATOR {
            counts.refuse(key, &format!("a body command of sender {sender}"));
            return Ok(());
        }
        let last = flags & BodyCommand::FINISHED != 0;
        let identity = Identity::of(&header);
        let again = again && self.last == Some(identity);
        let published = self.finished.is_none() && !again;
        if again && self.finished.is_none() {
            counts.duplicates.fetch_add(1, Ordering::Relaxed);
        }
        if published {
            self.last = Some(identity);
            news();
            self.body
                .send_copy(raw)
                .map_err(|e| anyhow!("publishing the body: {e:?}"))?;
            for w in &self.wakes {
                let _ = w.notify();
            }
            counts.inbound.fetch_add(1, Ordering::Relaxed);
            if last {
                info!("the mission's final command is published here: acknowledged, waiting for the shore to end");
                self.finished = Some(Instant::now());
            }
        }
        if last {
            self.ack
                .put(&[][..])
                .wait()
                .map_err(|e| anyhow!("acknowledging the final command: {e}"))?;
            counts.frames_out.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    }
}

/// The report that vehicle `vehicle` (process `pid`, 0: unknown) is unreachable, written
/// field by field into the bytes of a [`ProcessExit`].
fn unreachable(vehicle: u32, pid: u32) -> RawExit {
    use std::mem::offset_of;
    let mut b = [0u8; std::mem::size_of::<ProcessExit>()];
    let mut put = |at: usize, v: &[u8]| b[at..at + v.len()].copy_from_slice(v);
    let h = offset_of!(ProcessExit, header);
    put(
        h + offset_of!(Header, sender),
        &Header::SUPERVISOR.to_ne_bytes(),
    );
    put(
        offset_of!(ProcessExit, role),
        &ProcessExit::UNREACHABLE.to_ne_bytes(),
    );
    put(offset_of!(ProcessExit, vehicle), &vehicle.to_ne_bytes());
    put(offset_of!(ProcessExit, pid), &pid.to_ne_bytes());
    put(offset_of!(ProcessExit, died_ns), &wall_ns().to_ne_bytes());
    RawExit { bytes: b }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unreachable_report_reads_back_as_a_process_exit() {
        let raw = unreachable(7, 4242);
        let b = raw.bytes();
        assert_eq!(
            wire::u32_at(b, std::mem::offset_of!(ProcessExit, role)),
            ProcessExit::UNREACHABLE
        );
        assert_eq!(
            wire::u32_at(b, std::mem::offset_of!(ProcessExit, vehicle)),
            7
        );
        assert_eq!(
            wire::u32_at(b, std::mem::offset_of!(ProcessExit, pid)),
            4242
        );
        assert_eq!(wire::u32_at(b, 0), Header::SUPERVISOR);
        assert!(wire::u64_at(b, std::mem::offset_of!(ProcessExit, died_ns)) > 0);
    }
}
