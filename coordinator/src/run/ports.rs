//! The coordinator's iceoryx2 ports: every vehicle's state subscriber and wake notifier,
//! the body publisher, the field server's request-response client, the supervisor's
//! process exits, and the wake listener with its WaitSet (the one place the coordinator
//! blocks).

use std::time::Duration;

use anyhow::Result;
use iceoryx2::prelude::*;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::coordinator_to_field::SampleBatch;
use vbap_ipc::msg::field_to_coordinator::ReadingBatch;
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::wall_ns;
use vbap_ipc::topics::{self, Domain, Limits};
use vbap_ipc::wait::{spin_then_wait, Waiter, Wake, WakeListener, COORDINATOR_SPIN};
use vbap_mission::config::Mission;

use super::inbox::StateSubscriber;

/// The ports the tick loop uses without changing them.
pub(super) struct Ports {
    pub domain: Domain,
    /// Vehicle `id`'s states, at index `id`.
    pub subscribers: Vec<StateSubscriber>,
    /// Vehicle `id`'s wake-up, at index `id`.
    notifiers: Vec<iceoryx2::port::notifier::Notifier<ipc::Service>>,
    body: iceoryx2::port::publisher::Publisher<ipc::Service, BodyCommand, ()>,
    wake: WakeListener,
    /// Dropped last: every port above belongs to it.
    _node: Node<ipc::Service>,
}

/// The field server's request-response client.
pub(super) type SampleClient =
    iceoryx2::port::client::Client<ipc::Service, SampleBatch, (), ReadingBatch, ()>;
/// The supervisor's process exits.
pub(super) type ExitSubscriber =
    iceoryx2::port::subscriber::Subscriber<ipc::Service, ProcessExit, ()>;

/// Every port of the coordinator: the fixed ones, and those its sensor reads
/// (`SensorReads`) and its liveness watch (`Liveness`) own.
pub(super) struct Opened {
    pub ports: Ports,
    /// The field server's client and wake-up notifier.
    pub sample: (
        SampleClient,
        iceoryx2::port::notifier::Notifier<ipc::Service>,
    ),
    pub exits: ExitSubscriber,
}

/// Wraps an iceoryx2 port error with what was being created.
fn port_err<E: std::fmt::Debug>(what: impl std::fmt::Display) -> impl FnOnce(E) -> anyhow::Error {
    move |e| anyhow::anyhow!("{what}: {e:?}")
}

impl Ports {
    /// Opens every port of the coordinator of `mission`.
    pub fn open(mission: &Mission) -> Result<Opened> {
        let n = mission.vehicles.count;
        let domain = Domain::new(&mission.mission.name)?;
        let limits = Limits::for_fleet(n);
        let node = domain.node(topics::COORDINATOR_NODE)?;
        let mut subscribers = Vec::with_capacity(n);
        let mut notifiers = Vec::with_capacity(n);
        for id in 0..n as u32 {
            subscribers.push(
                domain
                    .state_service(&node, id, &limits)?
                    .subscriber_builder()
                    .create()
                    .map_err(port_err(format_args!(
                        "subscribing to {}",
                        domain.state_name(id)
                    )))?,
            );
            notifiers.push(
                domain
                    .vehicle_wake(&node, id, &limits)?
                    .notifier_builder()
                    .default_event_id(topics::EVENT_BODY)
                    .create()
                    .map_err(port_err(format_args!("notifier of vehicle {id}")))?,
            );
        }
        let body = domain
            .body_service(&node, &limits)?
            .publisher_builder()
            .create()
            .map_err(port_err(
                "publishing the body (is another coordinator running?)",
            ))?;
        let sample = (
            domain
                .sample_service(&node, &limits)?
                .client_builder()
                .create()
                .map_err(port_err("creating the sensor-read client"))?,
            domain
                .field_wake(&node, &limits)?
                .notifier_builder()
                .default_event_id(topics::EVENT_DATA)
                .create()
                .map_err(port_err("field notifier"))?,
        );
        let exits = domain
            .exits_service(&node, &limits)?
            .subscriber_builder()
            .create()
            .map_err(port_err("subscribing to the supervisor's process exits"))?;
        let wake = WakeListener::new(&domain.coordinator_wake(&node, &limits)?)?;
        let ports = Ports {
            domain,
            subscribers,
            notifiers,
            body,
            wake,
            _node: node,
        };
        Ok(Opened {
            ports,
            sample,
            exits,
        })
    }

    /// Attaches the wake listener to its WaitSet (for as long as the waiter lives).
    pub fn attach(&self) -> Result<Waiter<'_>> {
        Ok(self.wake.attach()?)
    }

    /// Waits at most `timeout` for a wake-up; the ids of the events that arrived go into
    /// `ids`.
    pub fn wait(&self, timeout: Duration, ids: &mut Vec<usize>) -> Result<Wake> {
        Ok(spin_then_wait(
            self.wake.waitset(),
            self.wake.listener(),
            timeout,
            COORDINATOR_SPIN,
            |id| ids.push(id),
        )?)
    }

    /// Publishes `body` (its entries in use copied into the subscribers' shared memory), its
    /// `sent_ns` stamped now.
    pub fn publish(&self, body: &mut BodyCommand) -> Result<()> {
        body.header.sent_ns = wall_ns();
        vbap_ipc::prefix::publish(&self.body, body)
            .map_err(|e| anyhow::anyhow!("publishing the body: {e}"))?;
        Ok(())
    }

    /// Wakes every agent (best effort: an agent that is gone has no listener).
    pub fn wake_agents(&self) {
        self.wake_agents_where(|_| true);
    }

    /// Wakes the agents of the vehicles `wake` says (best effort, as [`Ports::wake_agents`]).
    pub fn wake_agents_where(&self, wake: impl Fn(u32) -> bool) {
        for (id, notifier) in self.notifiers.iter().enumerate() {
            if wake(id as u32) {
                let _ = notifier.notify();
            }
        }
    }
}
