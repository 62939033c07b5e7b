//! The ports of a vbap process, in the pairs they are used in.
//!
//! A message always travels with a wake-up: a [`Sender`] is a publisher and the notifier
//! that wakes its readers with one [`Event`]; a [`Receiver`] is a subscriber and the
//! [`WakeListener`] its writers wake. The services themselves (names, limits) are those of
//! [`crate::topics::Domain`]; the builders here open them for one role.
//!
//! ```no_run
//! use std::time::Duration;
//! use vbap_ipc::msg::agent_to_coordinator::VehicleState;
//! use vbap_ipc::msg::Header;
//! use vbap_ipc::topics::{Domain, Limits};
//! use vbap_ipc::wait::Wake;
//!
//! # fn main() -> Result<(), vbap_ipc::topics::TopicError> {
//! let domain = Domain::new("example")?;
//! let limits = Limits::for_fleet(4);
//! let node = domain.agent_node("vehicle_agent_2")?;
//! // Vehicle 2: publishes its state and wakes the coordinator with `Event::Vehicle(2)`;
//! // reads the body command when its own wake service says so.
//! let state = domain.state_sender(&node, 2, &limits)?;
//! let body = domain.body_receiver(&node, 2, &limits)?;
//! let waiter = body.wake().attach()?;
//! state.send(VehicleState {
//!     header: Header::new(2, 0, 0.0, 1),
//!     ..VehicleState::default()
//! })?;
//! while waiter.wait(Duration::from_secs(1), |_| {})? != Wake::Stop {
//!     while let Some(command) = body.receive()? {
//!         let _ = command.header.tick;
//!     }
//! }
//! # Ok(())
//! # }
//! ```

use std::fmt::Debug;

use iceoryx2::node::Node;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ipc, ZeroCopySend};
use iceoryx2::sample::Sample;
use iceoryx2::service::port_factory::{event, publish_subscribe, PortFactory};

use crate::msg::agent_to_coordinator::VehicleState;
use crate::msg::coordinator_to_agent::BodyCommand;
use crate::topics::{Domain, Limits, TopicError};
use crate::wait::{Event, WakeListener};

fn port_err(what: impl std::fmt::Display, e: impl Debug) -> TopicError {
    TopicError::Service {
        service: what.to_string(),
        reason: format!("{e:?}"),
    }
}

/// A publisher of `service` (the error names the service).
pub fn publisher<T: Debug + ZeroCopySend + 'static>(
    service: &publish_subscribe::PortFactory<ipc::Service, T, ()>,
) -> Result<Publisher<ipc::Service, T, ()>, TopicError> {
    service
        .publisher_builder()
        .create()
        .map_err(|e| port_err(format!("publisher of {}", service.name()), e))
}

/// A subscriber of `service` (the error names the service).
pub fn subscriber<T: Debug + ZeroCopySend + 'static>(
    service: &publish_subscribe::PortFactory<ipc::Service, T, ()>,
) -> Result<Subscriber<ipc::Service, T, ()>, TopicError> {
    service
        .subscriber_builder()
        .create()
        .map_err(|e| port_err(format!("subscriber of {}", service.name()), e))
}

/// A notifier of the wake service `service` whose plain `notify()` sends `event`.
pub fn notifier(
    service: &event::PortFactory<ipc::Service>,
    event: Event,
) -> Result<Notifier<ipc::Service>, TopicError> {
    service
        .notifier_builder()
        .default_event_id(event.id())
        .create()
        .map_err(|e| port_err(format!("notifier of {}", service.name()), e))
}

/// A listener of the wake service `service`.
pub fn listener(
    service: &event::PortFactory<ipc::Service>,
) -> Result<Listener<ipc::Service>, TopicError> {
    service
        .listener_builder()
        .create()
        .map_err(|e| port_err(format!("listener of {}", service.name()), e))
}

/// A publisher and the notifier that wakes its readers: every [`Sender::send`] publishes,
/// then notifies with the sender's [`Event`].
#[derive(Debug)]
pub struct Sender<T: Debug + ZeroCopySend + 'static> {
    publisher: Publisher<ipc::Service, T, ()>,
    notifier: Notifier<ipc::Service>,
    event: Event,
}

impl<T: Debug + ZeroCopySend + 'static> Sender<T> {
    /// A sender publishing with `publisher`, waking with `event` on `notifier`.
    pub fn new(
        publisher: Publisher<ipc::Service, T, ()>,
        notifier: Notifier<ipc::Service>,
        event: Event,
    ) -> Self {
        Self {
            publisher,
            notifier,
            event,
        }
    }

    /// Publishes `value` (a copy into shared memory), then wakes the readers.
    pub fn send(&self, value: T) -> Result<(), TopicError> {
        self.publish(value)?;
        self.notify()
    }

    /// Publishes `value` without waking anyone (readers that poll).
    pub fn publish(&self, value: T) -> Result<(), TopicError> {
        self.publisher
            .send_copy(value)
            .map(|_| ())
            .map_err(|e| port_err("publishing", e))
    }

    /// Wakes the readers with this sender's event.
    pub fn notify(&self) -> Result<(), TopicError> {
        self.notifier
            .notify_with_custom_event_id(self.event.id())
            .map(|_| ())
            .map_err(|e| port_err("notifying", e))
    }
}

/// A subscriber and the wake listener its writers notify.
#[derive(Debug)]
pub struct Receiver<T: Debug + ZeroCopySend + 'static> {
    subscriber: Subscriber<ipc::Service, T, ()>,
    wake: WakeListener,
}

impl<T: Debug + ZeroCopySend + 'static> Receiver<T> {
    /// A receiver reading `subscriber`, woken through `wake`.
    pub fn new(subscriber: Subscriber<ipc::Service, T, ()>, wake: WakeListener) -> Self {
        Self { subscriber, wake }
    }

    /// The next sample, read in place; `None` when there is none.
    pub fn receive(&self) -> Result<Option<Sample<ipc::Service, T, ()>>, TopicError> {
        self.subscriber
            .receive()
            .map_err(|e| port_err("receiving", e))
    }

    /// The wake listener (attach it to wait: [`WakeListener::attach`]).
    pub fn wake(&self) -> &WakeListener {
        &self.wake
    }
}

impl Domain {
    /// A pub-sub service of [`VehicleState`] with the settings of the state service
    /// (`<m>/vehicle/<id>/state`: one publisher, history 1, a buffer of
    /// [`Limits::STATE_BUFFER`], safe overflow) at `<m>/<path>`.
    pub fn state_like_service(
        &self,
        node: &Node<ipc::Service>,
        path: &str,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, VehicleState, ()>, TopicError> {
        self.state_like_service_as::<VehicleState>(node, path, limits)
    }

    /// [`Domain::state_like_service`] with payload type `T` (same name, size and alignment
    /// as [`VehicleState`]: see [`Domain::body_service_as`]).
    pub fn state_like_service_as<T: Debug + ZeroCopySend>(
        &self,
        node: &Node<ipc::Service>,
        path: &str,
        limits: &Limits,
    ) -> Result<publish_subscribe::PortFactory<ipc::Service, T, ()>, TopicError> {
        let name = self.service_name(path)?;
        node.service_builder(&name)
            .publish_subscribe::<T>()
            .max_publishers(1)
            .max_subscribers(3)
            .max_nodes(limits.max_nodes())
            .history_size(1)
            .subscriber_max_buffer_size(Limits::STATE_BUFFER)
            .enable_safe_overflow(true)
            .open_or_create()
            .map_err(|e| port_err(name, e))
    }

    /// Vehicle `id`'s state sender: the only publisher of `<m>/vehicle/<id>/state` (a second
    /// agent with the same id is refused here) and a notifier of the coordinator's wake
    /// service sending [`Event::Vehicle`]`(id)`.
    pub fn state_sender(
        &self,
        node: &Node<ipc::Service>,
        id: u32,
        limits: &Limits,
    ) -> Result<Sender<VehicleState>, TopicError> {
        let publisher = self
            .state_service(node, id, limits)?
            .publisher_builder()
            .create()
            .map_err(|e| TopicError::Service {
                service: self.state_name(id),
                reason: format!("{e:?} (is another agent running with this id?)"),
            })?;
        let wake = notifier(&self.coordinator_wake(node, limits)?, Event::Data)?;
        Ok(Sender::new(publisher, wake, Event::Vehicle(id)))
    }

    /// Vehicle `id`'s body receiver: a subscriber of `<m>/body` and the listener of
    /// `<m>/vehicle/<id>/wake`.
    pub fn body_receiver(
        &self,
        node: &Node<ipc::Service>,
        id: u32,
        limits: &Limits,
    ) -> Result<Receiver<BodyCommand>, TopicError> {
        let body = subscriber(&self.body_service(node, limits)?)?;
        let wake = WakeListener::new(&self.vehicle_wake(node, id, limits)?)?;
        Ok(Receiver::new(body, wake))
    }
}
