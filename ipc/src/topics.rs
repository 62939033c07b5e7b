//! Every iceoryx2 service name and limit of vbap, and the only place they are spelled.
//!
//! One *domain* per mission: the iceoryx2 prefix `vbap_<mission>.` keeps two missions on one
//! host (and two tests) apart, and every service name also starts with the mission name.
//! The `.` ends the mission name: a name holds only letters, digits and `_`, so no domain's
//! prefix is the beginning of another's (`vbap_pfx.` is not a prefix of `vbap_pfx_2.`),
//! whatever the names. The creator of a service fixes its limits for the service's life, so every
//! process opens every service with the same [`Limits`], sized from the fleet.
//!
//! Topology (a star through the coordinator, O(N) connections):
//!
//! | service | pattern | who writes | who reads |
//! |---|---|---|---|
//! | `<m>/vehicle/<id>/state` | pub-sub `VehicleState` | agent `id` (the only publisher: the lock against two agents with one id) | coordinator (+1 spare) |
//! | `<m>/body` | pub-sub `BodyCommand` (history 1) | coordinator | every agent, in place |
//! | `<m>/field/sample` | request-response `SampleBatch` → `ReadingBatch`: every sensor read of a tick at once | coordinator (client) | field server |
//! | `<m>/vehicle/<id>/wake` | event | coordinator | agent `id` |
//! | `<m>/coordinator/wake` | event | agents (event id per vehicle), field server | coordinator |
//! | `<m>/field/wake` | event | coordinator | field server |
//! | `<m>/supervisor/exits` | pub-sub `ProcessExit` (history 16) | supervisor: every child it reaps | coordinator |

use iceoryx2::config::Config;
use iceoryx2::node::{Node, NodeBuilder, NodeState};
use iceoryx2::port::event_id::EventId;
use iceoryx2::prelude::{
    ipc, CallbackProgression, FileName, NodeName, SemanticString, ServiceName,
};
use iceoryx2::service::port_factory::{event, publish_subscribe, request_response};

use iceoryx2::signal_handling_mode::SignalHandlingMode;

use crate::msg::agent_to_agent::AcousticFrame;
use crate::msg::agent_to_coordinator::VehicleState;
use crate::msg::coordinator_to_agent::BodyCommand;
use crate::msg::coordinator_to_field::SampleBatch;
use crate::msg::field_to_coordinator::ReadingBatch;
use crate::msg::supervisor_to_coordinator::ProcessExit;

/// Event id: a new body command was published.
pub const EVENT_BODY: EventId = EventId::new(1);
/// Event id: the readings of a sample batch are ready.
pub const EVENT_SAMPLE: EventId = EventId::new(2);
/// Event id: a vehicle state was published / a request was sent.
pub const EVENT_DATA: EventId = EventId::new(3);
/// Event id: a notifier of the service died (iceoryx2 dead-notifier event).
pub const EVENT_NOTIFIER_DEAD: EventId = EventId::new(4);
/// Event id (coordinator wake): the supervisor reaped a process (`<m>/supervisor/exits`).
pub const EVENT_EXIT: EventId = EventId::new(5);
/// Event id (coordinator wake): a field server (re)started and serves requests.
pub const EVENT_FIELD_UP: EventId = EventId::new(6);
/// Largest event id of the shared event ids above.
pub const EVENT_ID_MAX: usize = 8;
/// A vehicle's event on the coordinator's and the field server's wake services is
/// `EVENT_VEHICLE_BASE + id`, so they poll only the ports that have something.
pub const EVENT_VEHICLE_BASE: usize = 16;

/// The event id by which vehicle `id` wakes the coordinator.
pub fn vehicle_event(id: u32) -> EventId {
    EventId::new(EVENT_VEHICLE_BASE + id as usize)
}

/// Errors opening a service or a node; the service name is always in the message.
#[derive(Debug, thiserror::Error)]
pub enum TopicError {
    /// A service or node name was refused by iceoryx2.
    #[error("invalid name {name:?}: {reason}")]
    Name { name: String, reason: String },
    /// Opening or creating a service failed.
    #[error("opening service {service:?}: {reason}")]
    Service { service: String, reason: String },
    /// Creating the node failed.
    #[error("creating node {node:?}: {reason}")]
    Node { node: String, reason: String },
}

/// Service limits of a mission, sized from the fleet. Everyone uses the same values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Fleet size N.
    pub vehicles: usize,
}

impl Limits {
    /// Limits for a fleet of `vehicles`.
    pub fn for_fleet(vehicles: usize) -> Self {
        Self { vehicles }
    }
    /// Nodes that may use a shared service: every agent, coordinator, field server, the
    /// supervisor, restarted processes not yet cleaned, tools and tests.
    pub fn max_nodes(&self) -> usize {
        2 * self.vehicles + 8
    }
    /// Subscribers of the body service, clients of the field service.
    pub fn fleet_ports(&self) -> usize {
        self.vehicles + 4
    }
    /// Notifiers of a vehicle's wake service: the coordinator, its restarts, the bridge,
    /// tools; and on a fleet that may have acoustic modems (≤ `MAX_ACOUSTIC_VEHICLES`)
    /// every other agent, whose frames wake it.
    pub fn vehicle_wake_notifiers(&self) -> usize {
        6 + if self.vehicles <= crate::msg::MAX_ACOUSTIC_VEHICLES {
            self.vehicles
        } else {
            0
        }
    }
    /// Buffer of an acoustic subscriber: 4 frames per vehicle and 8 more. A vehicle sends
    /// one frame an `acoustic.interval` (≥ dt: rarely two in a tick), and an agent drains
    /// at every wake-up and steps at most a tick past the newest command on an acoustic
    /// mission, so it finds at most a few ticks of frames; an overflow would show as a gap
    /// in a sender's sequence numbers (counted and logged by the agent).
    pub fn acoustic_buffer(&self) -> usize {
        (4 * self.vehicles + 8).max(Self::ACOUSTIC_HISTORY)
    }
    /// Frames of each agent a subscriber that comes late (a restarted agent) is handed:
    /// those of the ticks the others may have run ahead of its admission.
    pub const ACOUSTIC_HISTORY: usize = Self::LOOKAHEAD_TICKS as usize;
    /// Buffer of a vehicle-state subscriber: enough for a burst of stored-and-forwarded states.
    pub const STATE_BUFFER: usize = 64;
    /// Buffer of a body subscriber (commands an agent has not read yet): as many as fit
    /// [`Limits::BODY_SEGMENT_BUDGET`] for this fleet, between [`Limits::BODY_BUFFER_MIN`]
    /// and [`Limits::BODY_BUFFER_MAX`]. In lockstep a submerged glider that runs ahead is
    /// woken once every `body_buffer() − 2` commands (coordinator `Inbox::needs_wake`),
    /// so a deeper buffer means fewer wake-ups (32 up to N = 11: one every 30 ticks; 24 at
    /// N = 16; 4 from N ≈ 93 on, where the command, 203 KiB with its neighbour lists, is
    /// read in place by many).
    pub fn body_buffer(&self) -> usize {
        let per_command = (self.fleet_ports() * std::mem::size_of::<BodyCommand>()).max(1);
        (Self::BODY_SEGMENT_BUDGET / per_command)
            .clamp(Self::BODY_BUFFER_MIN, Self::BODY_BUFFER_MAX)
    }
    /// Shared memory the body service's subscriber buffers may reserve, bytes (virtual:
    /// iceoryx2 sizes the publisher's segment for every subscriber holding a full buffer
    /// of distinct commands): 96 MiB (64 MiB until the command grew its neighbour lists,
    /// 135 → 203 KiB: the budget grew with it, to keep 24 commands at N = 16).
    pub const BODY_SEGMENT_BUDGET: usize = 96 << 20;
    /// Smallest body buffer (lockstep flow control needs room for 2 unread commands).
    pub const BODY_BUFFER_MIN: usize = 4;
    /// Largest body buffer.
    pub const BODY_BUFFER_MAX: usize = 32;
    /// Ticks a lockstep agent may run ahead of the newest command it has received (the
    /// conservative lookahead of `vehicle_agent::Vehicle::ready_to_step`): its states must
    /// fit the coordinator's state buffer between two of its drains.
    pub const LOOKAHEAD_TICKS: u64 = 48;
    /// Process exits kept by the supervisor's exit service (history and buffer).
    pub const EXIT_HISTORY: usize = 16;
}

/// One listing of a domain's nodes ([`Domain::node_listing`]).
#[derive(Debug, Clone, Default)]
pub struct NodeListing {
    /// Every node named in the listing: true when alive, false when dead.
    pub states: std::collections::BTreeMap<String, bool>,
    /// True when no node was left out (see [`Domain::node_listing`]).
    pub complete: bool,
}

/// True when the process that owns the dead-listed node `view` still runs (not a zombie):
/// the node is being dropped, not left behind by a death.
fn owner_lives(view: &iceoryx2::node::DeadNodeView<ipc::Service>) -> bool {
    use iceoryx2::node::NodeView;
    view.id()
        .pid::<ipc::Service>()
        .is_ok_and(|pid| u32::try_from(pid.value()).is_ok_and(crate::process::process_alive))
}

/// The iceoryx2 domain of one mission.
#[derive(Clone, Debug)]
pub struct Domain {
    /// Mission name (letters, digits, `_`).
    pub mission: String,
    config: Config,
}

impl Domain {
    /// The domain of mission `mission`: iceoryx2 prefix `vbap_<mission>.` (see
    /// [`Domain::shm_prefix`]).
    pub fn new(mission: &str) -> Result<Self, TopicError> {
        let mut config = Config::default();
        // Expired connections a port keeps (those of a publisher, client or server that
        // left while it still held samples). iceoryx2's default, 128, costs every subscriber
        // a ~460 KiB slot map on the heap: 118 MiB of the coordinator's 136 MiB at N = 256
        // (one state subscriber per vehicle). Our services have one or two writers, and a
        // restarted writer is drained at the next tick: 4 is plenty (≥ the 2 borrowed samples
        // iceoryx2 requires).
        config
            .defaults
            .publish_subscribe
            .subscriber_expired_connection_buffer = Self::EXPIRED_CONNECTIONS;
        config
            .defaults
            .request_response
            .client_expired_connection_buffer = Self::EXPIRED_CONNECTIONS;
        config
            .defaults
            .request_response
            .server_expired_connection_buffer = Self::EXPIRED_CONNECTIONS;
        // iceoryx2 keeps a file per service, per node and per port of a node (`*.service`,
        // `*.service_tag`, `*.port_tag`, node details) under its root folder, /tmp/iceoryx2 by
        // default: a disk file system here. Creating a file on an ext4 without a journal scans
        // every inode deleted in the last ~30 s (`recently_deleted`), and a fleet creates and
        // removes thousands: start-up grew as N² (the coordinator took 3 s to open its ports
        // at N = 128, 0.17 s on tmpfs; BENCHMARKS.md, start-up). These files live as long as
        // the processes that own them, so a memory file system is the right home.
        config.global.set_root_path(&Self::root_path());
        let prefix = domain_prefix(mission);
        config.global.prefix = FileName::new(prefix.as_bytes()).map_err(|e| TopicError::Name {
            name: prefix.clone(),
            reason: format!("{e:?}"),
        })?;
        Ok(Self {
            mission: mission.to_string(),
            config,
        })
    }

    /// Expired connections each port keeps (iceoryx2's `*_expired_connection_buffer`).
    pub const EXPIRED_CONNECTIONS: usize = 4;

    /// iceoryx2's root folder for every domain of vbap: [`Domain::ROOT`], on tmpfs.
    fn root_path() -> iceoryx2::prelude::Path {
        iceoryx2::prelude::Path::new(Self::ROOT.as_bytes())
            .expect("Domain::ROOT is an absolute path iceoryx2 accepts")
    }

    /// iceoryx2's root folder (its `nodes/` and `services/` files): on tmpfs beside the
    /// shared memory, not iceoryx2's default /tmp/iceoryx2 (see [`Domain::new`]).
    pub const ROOT: &'static str = "/dev/shm/iceoryx2/";

    /// The iceoryx2 configuration of this domain.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The file prefix of this domain (files `/dev/shm/<prefix>*` and under iceoryx2's
    /// root folder): `vbap_<mission>.`. The `.`, which a mission name cannot hold (iceoryx2's
    /// `FileName` accepts it), ends the name, so the files of this domain and no other's
    /// start with it.
    pub fn shm_prefix(&self) -> String {
        domain_prefix(&self.mission)
    }

    /// Creates a node named `name` in this domain; signals are left to iceoryx2's waits
    /// (SIGINT/SIGTERM end a wait with an interrupt: exit cleanly).
    pub fn node(&self, name: &str) -> Result<Node<ipc::Service>, TopicError> {
        self.node_with_config(name, &self.config)
    }

    /// [`Domain::node`] for a vehicle agent: it does not scan the domain for dead nodes when
    /// it is created or dropped, nor the nodes of a shared service when it opens one (the
    /// supervisor cleans up after a death before it restarts the process, and the
    /// coordinator when it notices one), so N agents start in O(N), not O(N²): each open of
    /// `<m>/body` or `<m>/coordinator/wake` read the files of every node registered there
    /// (4 per node; ~340 opens per agent at N = 64).
    pub fn agent_node(&self, name: &str) -> Result<Node<ipc::Service>, TopicError> {
        let mut config = self.config.clone();
        config.global.node.cleanup_dead_nodes_on_creation = false;
        config.global.node.cleanup_dead_nodes_on_destruction = false;
        config.global.service.cleanup_dead_nodes_on_open = false;
        self.node_with_config(name, &config)
    }

    /// The supervisor's node: installs no signal handler (the supervisor handles SIGINT
    /// and SIGTERM itself).
    pub fn supervisor_node(&self) -> Result<Node<ipc::Service>, TopicError> {
        let node_name = NodeName::new(SUPERVISOR_NODE).map_err(|e| TopicError::Name {
            name: SUPERVISOR_NODE.to_string(),
            reason: format!("{e:?}"),
        })?;
        let node = NodeBuilder::new()
            .name(&node_name)
            .config(&self.config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| TopicError::Node {
                node: SUPERVISOR_NODE.to_string(),
                reason: format!("{e:?}"),
            })?;
        self.restrict_to_owner();
        Ok(node)
    }

    /// Takes group and others' permissions off every file of this domain this user owns
    /// (see [`Domain::files`]); returns how many it changed. iceoryx2 0.10 makes its
    /// shared memory and node files owner-only, except the node counter it shares between
    /// the nodes of a domain (`*.global_mgmt`), which it creates readable and writable by
    /// every local user: the supervisor narrows it once its first node made it (the
    /// processes of the mission are all this user's). Another user can then neither read
    /// nor attach to anything of the mission (tests/tests/hygiene.rs).
    pub fn restrict_to_owner(&self) -> usize {
        use std::os::unix::fs::{MetadataExt, PermissionsExt};
        // This process's effective user: the owner of its /proc entry.
        let Ok(me) = std::fs::metadata("/proc/self").map(|m| m.uid()) else {
            return 0;
        };
        let mut changed = 0;
        for path in self.files() {
            let Ok(meta) = std::fs::symlink_metadata(&path) else {
                continue;
            };
            let mode = meta.mode() & 0o7777;
            if !meta.is_file() || meta.uid() != me || mode & 0o077 == 0 {
                continue;
            }
            let owner_only = std::fs::Permissions::from_mode(mode & 0o700);
            if std::fs::set_permissions(&path, owner_only).is_ok() {
                changed += 1;
            }
        }
        changed
    }

    fn node_with_config(
        &self,
        name: &str,
        config: &Config,
    ) -> Result<Node<ipc::Service>, TopicError> {
        let node_name = NodeName::new(name).map_err(|e| TopicError::Name {
            name: name.to_string(),
            reason: format!("{e:?}"),
        })?;
        NodeBuilder::new()
            .name(&node_name)
            .config(config)
            .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
            .create::<ipc::Service>()
            .map_err(|e| TopicError::Node {
                node: name.to_string(),
                reason: format!("{e:?}"),
            })
    }

    /// The folders iceoryx2 keeps this domain's files in: /dev/shm (shared memory and, under
    /// [`Domain::ROOT`], its root folder) and /tmp/iceoryx2 (the root folder of earlier
    /// versions, so their leftovers are still found and removed).
    pub const FILE_ROOTS: [&'static str; 2] = ["/dev/shm", "/tmp/iceoryx2"];

    /// Files of this domain still present under [`Domain::FILE_ROOTS`] (exactly those whose
    /// name starts with [`Domain::shm_prefix`]).
    pub fn files(&self) -> Vec<std::path::PathBuf> {
        let mut out = Vec::new();
        for root in Self::FILE_ROOTS {
            walk_prefixed(std::path::Path::new(root), &self.shm_prefix(), &mut |p| {
                out.push(p.to_path_buf())
            });
        }
        out
    }

    /// Removes every file of this domain (see [`Domain::files`]), and the folders of its
    /// nodes (`nodes/<id>/`) left empty by that; returns how many files were removed. Call
    /// only when no process of the domain is alive.
    pub fn remove_files(&self) -> usize {
        let mut removed = 0;
        let mut dirs = std::collections::BTreeSet::new();
        for path in self.files() {
            if std::fs::remove_file(&path).is_ok() {
                removed += 1;
                if let Some(parent) = path.parent() {
                    dirs.insert(parent.to_path_buf());
                }
            }
        }
        for dir in dirs {
            // A node's own folder, emptied: remove_dir fails on anything not empty.
            if dir.parent().and_then(|p| p.file_name()) == Some(std::ffi::OsStr::new("nodes")) {
                let _ = std::fs::remove_dir(&dir);
            }
        }
        removed
    }

    /// Removes the stale resources of every dead node of this domain; returns how many
    /// dead nodes were found.
    pub fn cleanup_dead_nodes(&self) -> usize {
        let mut dead = 0;
        let _ = Node::<ipc::Service>::list(&self.config, |state| {
            if let NodeState::Dead(view) = state {
                dead += 1;
                let _ = view.try_remove_stale_resources();
            }
            CallbackProgression::Continue
        });
        dead
    }

    /// Every node of this domain by name: true when alive, false when dead (its process is
    /// gone but its resources are not cleaned yet). One `Node::list`; see
    /// [`Domain::node_listing`] for whether a node missing from it is really gone.
    pub fn node_states(&self) -> std::collections::BTreeMap<String, bool> {
        self.node_listing().states
    }

    /// [`Domain::node_states`], and whether the listing is complete: `Node::list` ended
    /// without an error and every node in it could be named and judged. A node being
    /// created, one whose details cannot be read at this instant, or an interrupted
    /// listing leaves names out, so a name missing from an incomplete listing says nothing.
    pub fn node_listing(&self) -> NodeListing {
        use iceoryx2::node::NodeView;
        let mut states = std::collections::BTreeMap::new();
        let mut complete = true;
        let listed = Node::<ipc::Service>::list(&self.config, |state| {
            let (details, alive) = match &state {
                NodeState::Alive(view) => (view.details(), true),
                // A node its live owner is dropping reads as dead for an instant (the bridge
                // removing a remote vehicle's proxy as its host goes out of reach): left
                // out, it is "gone", a death only when gone at two scans.
                NodeState::Dead(view) if owner_lives(view) => return CallbackProgression::Continue,
                NodeState::Dead(view) => (view.details(), false),
                NodeState::Inaccessible(_) | NodeState::Undefined(_) => (&None, false),
            };
            match details {
                Some(d) if alive => {
                    states.insert(d.name().to_string(), true);
                }
                Some(d) => {
                    states.entry(d.name().to_string()).or_insert(false);
                }
                None => complete = false,
            }
            CallbackProgression::Continue
        });
        NodeListing {
            states,
            complete: complete && listed.is_ok(),
        }
    }

    /// Names of the live nodes of this domain (one `Node::list`: ~0.2 ms per few nodes, scan
    /// at most about once a second with large fleets).
    pub fn alive_node_names(&self) -> Vec<String> {
        self.alive_nodes_where(|_| true)
    }

    /// Names of the live nodes of this domain owned by processes other than this one.
    pub fn alive_node_names_of_others(&self) -> Vec<String> {
        let me = std::process::id();
        self.alive_nodes_where(|pid| pid != Some(me))
    }

    /// Names of the live nodes whose owner's pid (None: unknown) passes `keep`.
    fn alive_nodes_where(&self, keep: impl Fn(Option<u32>) -> bool) -> Vec<String> {
        use iceoryx2::node::NodeView;
        let mut names = Vec::new();
        let _ = Node::<ipc::Service>::list(&self.config, |state| {
            if let NodeState::Alive(view) = state {
                let pid = view.id().pid::<ipc::Service>().ok();
                let pid = pid.and_then(|p| u32::try_from(p.value()).ok());
                if keep(pid) {
                    if let Some(details) = view.details() {
                        names.push(details.name().to_string());
                    }
                }
            }
            CallbackProgression::Continue
        });
        names
    }

    /// The domain's membership file, `/dev/shm/<prefix>members`: each process of the
    /// mission holds a shared `flock(2)` on it for its life, so the last one out of an
    /// orphaned mission knows it is the last (see `vbap_ipc::process::join_domain`). Its
    /// name starts with the prefix: [`Domain::remove_files`] removes it with the rest.
    pub fn members_file(&self) -> std::path::PathBuf {
        std::path::Path::new("/dev/shm").join(format!("{}members", self.shm_prefix()))
    }

    /// The service name `<mission>/<path>`.
    pub(crate) fn service_name(&self, path: &str) -> Result<ServiceName, TopicError> {
        let full = format!("{}/{}", self.mission, path);
        ServiceName::new(&full).map_err(|e| TopicError::Name {
            name: full,
            reason: format!("{e:?}"),
        })
    }

    /// Service name of vehicle `id`'s state.
    pub fn state_name(&self, id: u32) -> String {
        format!("{}/vehicle/{id}/state", self.mission)
    }

    /// `<m>/vehicle/<id>/state`.
    pub fn state_service(
        &self,
        node: &Node<ipc::Service>,
        id: u32,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, VehicleState, ()>, TopicError> {
        self.state_like_service(node, &format!("vehicle/{id}/state"), limits)
    }

    /// `<m>/body`.
    pub fn body_service(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, BodyCommand, ()>, TopicError> {
        self.body_service_as::<BodyCommand>(node, limits)
    }

    /// [`Domain::body_service`] with payload type `T`: a type of the same name, size and
    /// alignment as [`BodyCommand`] (the bridge copies its bytes; iceoryx2 refuses any other).
    pub fn body_service_as<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend>(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, T, ()>, TopicError> {
        let name = self.service_name("body")?;
        node.service_builder(&name)
            .publish_subscribe::<T>()
            .max_publishers(2)
            .max_subscribers(limits.fleet_ports())
            .max_nodes(limits.max_nodes())
            .history_size(1)
            .subscriber_max_buffer_size(limits.body_buffer())
            .enable_safe_overflow(true)
            .open_or_create()
            .map_err(|e| service_err(&name, e))
    }

    /// `<m>/acoustic`: every agent's acoustic frames, to every agent (`[acoustic]`).
    /// Between two drains an agent may find every vehicle's frames of a few ticks:
    /// [`Limits::acoustic_buffer`].
    pub fn acoustic_service(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, AcousticFrame, ()>, TopicError> {
        let name = self.service_name("acoustic")?;
        node.service_builder(&name)
            .publish_subscribe::<AcousticFrame>()
            .max_publishers(limits.fleet_ports())
            .max_subscribers(limits.fleet_ports())
            .max_nodes(limits.max_nodes())
            .history_size(Limits::ACOUSTIC_HISTORY)
            .subscriber_max_buffer_size(limits.acoustic_buffer())
            .enable_safe_overflow(true)
            .open_or_create()
            .map_err(|e| service_err(&name, e))
    }

    /// `<m>/field/sample`: the sensor reads of a tick, one batch per tick (coordinator →
    /// field server). One client and one server: a reply scans one connection.
    pub fn sample_service(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<
        request_response::PortFactory<ipc::Service, SampleBatch, (), ReadingBatch, ()>,
        TopicError,
    > {
        let name = self.service_name("field/sample")?;
        node.service_builder(&name)
            .request_response::<SampleBatch, ReadingBatch>()
            .max_servers(2)
            .max_clients(2)
            .max_nodes(limits.max_nodes())
            .max_active_requests_per_client(2)
            .max_response_buffer_size(2)
            .enable_safe_overflow_for_requests(true)
            .enable_safe_overflow_for_responses(true)
            .open_or_create()
            .map_err(|e| service_err(&name, e))
    }

    /// `<m>/supervisor/exits`: the supervisor tells the coordinator of every process it
    /// reaped. History: a restarted coordinator hears of deaths while it was down (it
    /// ignores those of processes it no longer knows, by pid).
    pub fn exits_service(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, ProcessExit, ()>, TopicError> {
        self.exits_service_as::<ProcessExit>(node, limits)
    }

    /// [`Domain::exits_service`] with payload type `T` (same name, size and alignment as
    /// [`ProcessExit`]: see [`Domain::body_service_as`]).
    pub fn exits_service_as<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend>(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, T, ()>, TopicError> {
        let name = self.service_name("supervisor/exits")?;
        node.service_builder(&name)
            .publish_subscribe::<T>()
            .max_publishers(2)
            .max_subscribers(4)
            .max_nodes(limits.max_nodes())
            .history_size(Limits::EXIT_HISTORY)
            .subscriber_max_buffer_size(Limits::EXIT_HISTORY)
            .enable_safe_overflow(true)
            .open_or_create()
            .map_err(|e| service_err(&name, e))
    }

    fn event_service(
        &self,
        node: &Node<ipc::Service>,
        path: &str,
        listeners: usize,
        notifiers: usize,
        limits: &Limits,
        max_event_id: usize,
    ) -> Result<event::PortFactory<ipc::Service>, TopicError> {
        let name = self.service_name(path)?;
        node.service_builder(&name)
            .event()
            .max_listeners(listeners)
            .max_notifiers(notifiers)
            .max_nodes(limits.max_nodes())
            .event_id_max_value(max_event_id)
            .notifier_dead_event(EVENT_NOTIFIER_DEAD)
            .open_or_create()
            .map_err(|e| service_err(&name, e))
    }

    /// `<m>/vehicle/<id>/wake`: the agent listens, the coordinator (and on an acoustic
    /// mission every other agent) notifies.
    pub fn vehicle_wake(
        &self,
        node: &Node<ipc::Service>,
        id: u32,
        limits: &Limits,
    ) -> Result<event::PortFactory<ipc::Service>, TopicError> {
        self.event_service(
            node,
            &format!("vehicle/{id}/wake"),
            2,
            limits.vehicle_wake_notifiers(),
            limits,
            EVENT_ID_MAX,
        )
    }

    /// `<m>/coordinator/wake`: the coordinator listens, agents and the field server notify.
    pub fn coordinator_wake(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<event::PortFactory<ipc::Service>, TopicError> {
        self.event_service(
            node,
            "coordinator/wake",
            2,
            limits.fleet_ports() + 4,
            limits,
            EVENT_VEHICLE_BASE + crate::msg::MAX_VEHICLES,
        )
    }

    /// `<m>/field/wake`: the field server listens, the coordinator notifies.
    pub fn field_wake(
        &self,
        node: &Node<ipc::Service>,
        limits: &Limits,
    ) -> Result<event::PortFactory<ipc::Service>, TopicError> {
        self.event_service(node, "field/wake", 2, 4, limits, EVENT_ID_MAX)
    }
}

/// Calls `found` for every file under `dir` (recursively) whose name starts with `prefix`.
fn walk_prefixed(dir: &std::path::Path, prefix: &str, found: &mut dyn FnMut(&std::path::Path)) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            walk_prefixed(&path, prefix, found);
        } else if entry.file_name().to_string_lossy().starts_with(prefix) {
            found(&path);
        }
    }
}

/// The iceoryx2 file prefix of mission `mission`'s domain: `vbap_<mission>.`.
pub fn domain_prefix(mission: &str) -> String {
    format!("vbap_{mission}.")
}

fn service_err(name: &ServiceName, e: impl std::fmt::Debug) -> TopicError {
    TopicError::Service {
        service: name.to_string(),
        reason: format!("{e:?}"),
    }
}

/// Node name of vehicle agent `id`.
pub fn agent_node_name(id: u32) -> String {
    format!("vehicle_agent_{id}")
}
/// Node name of the coordinator.
pub const COORDINATOR_NODE: &str = "coordinator";
/// Node name of the field server.
pub const FIELD_SERVER_NODE: &str = "field_server";
/// Node name of the supervisor (`vbap run`).
pub const SUPERVISOR_NODE: &str = "supervisor";

#[cfg(test)]
mod prefix_tests {
    use super::*;

    #[test]
    fn no_domain_prefix_begins_another_whatever_the_names() {
        let names = [
            "pfx",
            "pfx_2",
            "pfx_",
            "p",
            "glider",
            "glider_surfacing",
            "a_b",
            "a",
        ];
        for a in names {
            let domain = Domain::new(a).expect("iceoryx2 accepts the prefix as a file name");
            assert_eq!(domain.shm_prefix(), domain_prefix(a));
            for b in names {
                if a != b {
                    // A file of b's domain (its prefix, then anything) never starts with a's.
                    let file_of_b = format!("{}node.details", domain_prefix(b));
                    assert!(!file_of_b.starts_with(&domain_prefix(a)), "{a} vs {b}");
                }
            }
        }
    }
}

#[cfg(test)]
mod body_buffer_tests {
    use super::Limits;
    use crate::msg::coordinator_to_agent::BodyCommand;

    /// Deep for a few vehicles, never below the flow control's minimum, never deeper for a
    /// larger fleet, and within the budget whenever above the minimum.
    #[test]
    fn the_body_buffer_fits_its_budget_and_shrinks_with_the_fleet() {
        assert_eq!(Limits::for_fleet(6).body_buffer(), Limits::BODY_BUFFER_MAX);
        assert_eq!(
            Limits::for_fleet(1024).body_buffer(),
            Limits::BODY_BUFFER_MIN
        );
        let mut last = usize::MAX;
        for n in 1..=1024 {
            let limits = Limits::for_fleet(n);
            let b = limits.body_buffer();
            assert!((Limits::BODY_BUFFER_MIN..=Limits::BODY_BUFFER_MAX).contains(&b));
            assert!(b <= last, "N = {n}: {b} > {last}");
            if b > Limits::BODY_BUFFER_MIN {
                let bytes = b * limits.fleet_ports() * std::mem::size_of::<BodyCommand>();
                assert!(bytes <= Limits::BODY_SEGMENT_BUDGET, "N = {n}: {bytes} B");
            }
            last = b;
        }
    }
}

#[cfg(test)]
mod versioned_tests {
    use super::{Domain, Limits};
    use crate::msg::agent_to_coordinator::{RawVehicleState, VehicleState};
    use crate::msg::coordinator_to_agent::{BodyCommand, RawBodyCommand};
    use crate::msg::supervisor_to_coordinator::{ProcessExit, RawProcessExit};
    use crate::versioned::Versioned;
    use iceoryx2::prelude::{ipc, PortFactory as _, ZeroCopySend};
    use iceoryx2::service::port_factory::publish_subscribe::PortFactory;

    /// The type name iceoryx2 records for the payload of `service`.
    fn recorded<T: std::fmt::Debug + ZeroCopySend>(
        service: &PortFactory<ipc::Service, T, ()>,
    ) -> String {
        let details = service.static_config().message_type_details();
        details.payload.type_name().to_string()
    }

    #[test]
    fn each_raw_twin_opens_its_payloads_service_under_the_payloads_name() {
        let domain = Domain::new(&format!("versioned_{}", std::process::id())).unwrap();
        let limits = Limits::for_fleet(2);
        let node = domain.node("versioned_test").unwrap();
        let state = domain.state_service(&node, 1, &limits).unwrap();
        assert_eq!(recorded(&state), VehicleState::TYPE_NAME);
        domain
            .state_like_service_as::<RawVehicleState>(&node, "vehicle/1/state", &limits)
            .expect("the raw state opens the state service");
        let body = domain.body_service(&node, &limits).unwrap();
        assert_eq!(recorded(&body), BodyCommand::TYPE_NAME);
        domain
            .body_service_as::<RawBodyCommand>(&node, &limits)
            .expect("the raw body opens the body service");
        let exits = domain.exits_service(&node, &limits).unwrap();
        assert_eq!(recorded(&exits), ProcessExit::TYPE_NAME);
        domain
            .exits_service_as::<RawProcessExit>(&node, &limits)
            .expect("the raw exit opens the exits service");
        drop((state, body, exits, node));
        domain.remove_files();
        assert!(domain.files().is_empty());
    }
}
