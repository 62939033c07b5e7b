//! The one wait of every vbap process: typed wake-up events and the WaitSet loop.
//!
//! Every process sleeps in the same way: a WaitSet with one event listener attached (its
//! wake service), woken by a notification, a timeout or SIGINT/SIGTERM. [`WakeListener`]
//! owns that listener and its WaitSet; [`WakeListener::attach`] gives the [`Waiter`] whose
//! [`Waiter::wait`] is the loop. What arrived is told as [`Event`]s, not raw event ids.
//!
//! ```no_run
//! use std::time::Duration;
//! use vbap_ipc::topics::{Domain, Limits};
//! use vbap_ipc::wait::{Event, Wake, WakeListener};
//!
//! # fn main() -> Result<(), vbap_ipc::topics::TopicError> {
//! let domain = Domain::new("example")?;
//! let limits = Limits::for_fleet(4);
//! let node = domain.node("coordinator")?;
//! // The coordinator's wake service: agents notify with `Event::Vehicle(id)`, the field
//! // server with `Event::Sample` / `Event::FieldUp`, the supervisor with `Event::Exit`.
//! let wake = WakeListener::new(&domain.coordinator_wake(&node, &limits)?)?;
//! let waiter = wake.attach()?;
//! let mut events = Vec::new();
//! loop {
//!     events.clear();
//!     match waiter.wait(Duration::from_millis(100), |e| events.push(e))? {
//!         Wake::Stop => break, // SIGINT or SIGTERM: flush and exit cleanly
//!         Wake::Timeout => {}  // nothing for 100 ms: poll the ports once anyway
//!         Wake::Events => {
//!             for e in &events {
//!                 if let Event::Vehicle(id) = e {
//!                     // read vehicle `id`'s state subscriber
//!                     let _ = id;
//!                 }
//!             }
//!         }
//!     }
//! }
//! # Ok(())
//! # }
//! ```

use std::time::{Duration, Instant};

use iceoryx2::port::event_id::EventId;
use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::{ipc, CallbackProgression, SignalHandlingMode, WaitSetBuilder};
use iceoryx2::service::port_factory::{event, PortFactory};
use iceoryx2::waitset::{WaitSet, WaitSetGuard, WaitSetRunResult};

use crate::topics::{
    TopicError, EVENT_BODY, EVENT_DATA, EVENT_EXIT, EVENT_FIELD_UP, EVENT_NOTIFIER_DEAD,
    EVENT_SAMPLE, EVENT_VEHICLE_BASE,
};

/// What ended a wait.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wake {
    /// At least one event arrived (all pending events were drained).
    Events,
    /// The timeout passed with no event.
    Timeout,
    /// SIGINT or SIGTERM: flush and exit cleanly.
    Stop,
}

/// A wake-up event of a vbap wake service: what happened, instead of a raw event id.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Event {
    /// A new body command was published (coordinator → agent).
    Body,
    /// The readings of a sample batch are ready (field server → coordinator).
    Sample,
    /// A vehicle state was published / a request was sent.
    Data,
    /// A notifier of the service died (iceoryx2's dead-notifier event).
    NotifierDead,
    /// The supervisor reaped a process (`<m>/supervisor/exits`).
    Exit,
    /// A field server (re)started and serves requests.
    FieldUp,
    /// Vehicle `id` published a state (on the coordinator's wake service).
    Vehicle(u32),
    /// An id none of the above has (a newer peer, a tool): the raw value.
    Other(usize),
}

impl Event {
    /// The iceoryx2 event id of this event (the numbering of `vbap_ipc::topics`).
    pub fn id(self) -> EventId {
        EventId::new(self.value())
    }

    /// The raw value of [`Event::id`].
    pub fn value(self) -> usize {
        match self {
            Event::Body => EVENT_BODY.as_value(),
            Event::Sample => EVENT_SAMPLE.as_value(),
            Event::Data => EVENT_DATA.as_value(),
            Event::NotifierDead => EVENT_NOTIFIER_DEAD.as_value(),
            Event::Exit => EVENT_EXIT.as_value(),
            Event::FieldUp => EVENT_FIELD_UP.as_value(),
            Event::Vehicle(id) => EVENT_VEHICLE_BASE + id as usize,
            Event::Other(v) => v,
        }
    }

    /// The event of a raw id (the inverse of [`Event::value`]).
    pub fn from_value(v: usize) -> Self {
        const BODY: usize = EVENT_BODY.as_value();
        const SAMPLE: usize = EVENT_SAMPLE.as_value();
        const DATA: usize = EVENT_DATA.as_value();
        const DEAD: usize = EVENT_NOTIFIER_DEAD.as_value();
        const EXIT: usize = EVENT_EXIT.as_value();
        const FIELD_UP: usize = EVENT_FIELD_UP.as_value();
        match v {
            BODY => Event::Body,
            SAMPLE => Event::Sample,
            DATA => Event::Data,
            DEAD => Event::NotifierDead,
            EXIT => Event::Exit,
            FIELD_UP => Event::FieldUp,
            v if v >= EVENT_VEHICLE_BASE && v - EVENT_VEHICLE_BASE <= u32::MAX as usize => {
                Event::Vehicle((v - EVENT_VEHICLE_BASE) as u32)
            }
            v => Event::Other(v),
        }
    }
}

fn waitset_err(what: &str, e: impl std::fmt::Debug) -> TopicError {
    TopicError::Service {
        service: what.into(),
        reason: format!("{e:?}"),
    }
}

/// The one wait: blocks in `waitset` (which has `listener` attached) until an event, the
/// timeout or a termination signal, then drains the listener (so the next wait blocks
/// again), calling `on_id` with the raw id of every event drained.
///
/// A stop is a termination request, or an interrupt while iceoryx2's handler has seen
/// SIGINT/SIGTERM; any other signal (a debugger or `strace -p` attaching) interrupts the
/// wait without being a stop, and is reported as [`Wake::Events`]: callers look and wait
/// again (a timeout would make a paced agent hold station before its time).
pub fn wait_once(
    waitset: &WaitSet<ipc::Service>,
    listener: &Listener<ipc::Service>,
    timeout: Duration,
    mut on_id: impl FnMut(usize),
) -> Result<Wake, TopicError> {
    let mut woke = false;
    let result = waitset
        .wait_and_process_once_with_timeout(
            |_| {
                woke = true;
                CallbackProgression::Continue
            },
            timeout,
        )
        .map_err(|e| waitset_err("waitset", e))?;
    let spurious = match result {
        WaitSetRunResult::TerminationRequest => return Ok(Wake::Stop),
        WaitSetRunResult::Interrupt => {
            if iceoryx2_bb_posix::signal::SignalHandler::termination_requested() {
                return Ok(Wake::Stop);
            }
            true
        }
        _ => false,
    };
    let drained = listener
        .try_wait(|a| on_id(a.id.as_value()))
        .map_err(|e| waitset_err("listener", e))?;
    Ok(if woke || drained > 0 || spurious {
        Wake::Events
    } else {
        Wake::Timeout
    })
}

/// How long the coordinator polls for a message before it sleeps ([`spin_then_wait`]).
/// It waits, once or a few times a tick, for the field server's readings and for the
/// states of the tick, which mostly come within tens of µs; sleeping instead costs the
/// wake-up of an idle CPU on the way back. `vbap bench` on a quiet 2-CPU VM, without and
/// with it: lockstep ticks per second +26 / +31 / +23 / +15 % at N = 4 / 16 / 64 / 256, the
/// 6-glider mission +10 %, the N = 4 state hop p50 12.4 → 10.2 µs. At most 100 µs of CPU a
/// wait. Agents and the field server do not spin: they are many, or wait long (the field
/// server spinning as well made the glider run 2× slower while other work ran).
pub const COORDINATOR_SPIN: Duration = Duration::from_micros(100);

/// [`wait_once`] after polling the listener for up to `spin` first: an event that comes
/// within `spin` is taken without the process going to sleep, so without the wake-up of an
/// idle CPU (tens of µs on a VM: `vbap bench` section 1, raw ping-pong with the CPUs idle
/// vs kept awake). Each poll is one non-blocking read of the listener's socket; a
/// termination request ends the spin as it ends the wait. `spin` zero: [`wait_once`].
pub fn spin_then_wait(
    waitset: &WaitSet<ipc::Service>,
    listener: &Listener<ipc::Service>,
    timeout: Duration,
    spin: Duration,
    mut on_id: impl FnMut(usize),
) -> Result<Wake, TopicError> {
    let started = Instant::now();
    let spin = spin.min(timeout);
    while started.elapsed() < spin {
        let drained = listener
            .try_wait(|a| on_id(a.id.as_value()))
            .map_err(|e| waitset_err("listener", e))?;
        if drained > 0 {
            return Ok(Wake::Events);
        }
        if iceoryx2_bb_posix::signal::SignalHandler::termination_requested() {
            return Ok(Wake::Stop);
        }
        std::hint::spin_loop();
    }
    wait_once(
        waitset,
        listener,
        timeout.saturating_sub(started.elapsed()),
        on_id,
    )
}

/// The listener of one wake service and the WaitSet it wakes (stops on SIGINT/SIGTERM).
#[derive(Debug)]
pub struct WakeListener {
    listener: Listener<ipc::Service>,
    waitset: WaitSet<ipc::Service>,
}

impl WakeListener {
    /// A listener on the wake service `service` (e.g. [`crate::topics::Domain::vehicle_wake`])
    /// and a WaitSet that ends its waits on SIGINT/SIGTERM.
    pub fn new(service: &event::PortFactory<ipc::Service>) -> Result<Self, TopicError> {
        let listener = service
            .listener_builder()
            .create()
            .map_err(|e| waitset_err(&format!("listener of {}", service.name()), e))?;
        let waitset = WaitSetBuilder::new()
            .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
            .create::<ipc::Service>()
            .map_err(|e| waitset_err("waitset", e))?;
        Ok(Self { listener, waitset })
    }

    /// Attaches the listener to the WaitSet: the returned [`Waiter`] waits (detached when
    /// it is dropped).
    pub fn attach(&self) -> Result<Waiter<'_>, TopicError> {
        let guard = self
            .waitset
            .attach_notification(&self.listener)
            .map_err(|e| waitset_err("attaching the wake listener", e))?;
        Ok(Waiter {
            wake: self,
            _guard: guard,
        })
    }

    /// The listener (for a caller that drives its own WaitSet).
    pub fn listener(&self) -> &Listener<ipc::Service> {
        &self.listener
    }

    /// The WaitSet (to attach more, e.g. an interval).
    pub fn waitset(&self) -> &WaitSet<ipc::Service> {
        &self.waitset
    }
}

/// A [`WakeListener`] attached to its WaitSet: the wait loop of a process.
pub struct Waiter<'a> {
    wake: &'a WakeListener,
    _guard: WaitSetGuard<'a, 'a, ipc::Service>,
}

impl Waiter<'_> {
    /// One wait ([`wait_once`]): `on_event` gets every event drained.
    pub fn wait(
        &self,
        timeout: Duration,
        mut on_event: impl FnMut(Event),
    ) -> Result<Wake, TopicError> {
        wait_once(&self.wake.waitset, &self.wake.listener, timeout, |v| {
            on_event(Event::from_value(v))
        })
    }

    /// One wait after polling for up to `spin` ([`spin_then_wait`]).
    pub fn spin_then_wait(
        &self,
        timeout: Duration,
        spin: Duration,
        mut on_event: impl FnMut(Event),
    ) -> Result<Wake, TopicError> {
        spin_then_wait(
            &self.wake.waitset,
            &self.wake.listener,
            timeout,
            spin,
            |v| on_event(Event::from_value(v)),
        )
    }

    /// Waits until at least one event is drained, the timeout passes or a stop: a wake-up
    /// that finds no event (its events drained by an earlier wait, or another signal) waits
    /// again for the time left.
    pub fn wait_for_event(
        &self,
        timeout: Duration,
        mut on_event: impl FnMut(Event),
    ) -> Result<Wake, TopicError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(Wake::Timeout);
            }
            let mut got = 0usize;
            let wake = self.wait(left, |e| {
                got += 1;
                on_event(e)
            })?;
            match wake {
                Wake::Stop => return Ok(Wake::Stop),
                _ if got > 0 => return Ok(Wake::Events),
                _ => {}
            }
        }
    }
}

/// Calls `each` every `period` (a WaitSet interval: the thread sleeps between) while
/// `keep_going` says so, checked before every wait. Signals are left to the process (the
/// WaitSet handles none): for a helper thread such as a progress display.
pub fn every(
    period: Duration,
    keep_going: impl Fn() -> bool,
    mut each: impl FnMut(),
) -> Result<(), TopicError> {
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| waitset_err("waitset", e))?;
    let _tick = waitset
        .attach_interval(period)
        .map_err(|e| waitset_err("attaching an interval", e))?;
    while keep_going() {
        let _ = waitset.wait_and_process_once(|_| CallbackProgression::Continue);
        each();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pending event ends the spin at once; with none, the wait ends at its timeout
    /// (the spin is part of it, not added to it).
    #[test]
    fn spin_then_wait_takes_a_pending_event_and_keeps_its_timeout() {
        use crate::topics::{Domain, Limits};
        let domain = Domain::new(&format!("spinwait_{}", std::process::id())).unwrap();
        let limits = Limits::for_fleet(1);
        let node = domain.node("spin_test").unwrap();
        let service = domain.coordinator_wake(&node, &limits).unwrap();
        let wake = WakeListener::new(&service).unwrap();
        let notifier = service.notifier_builder().create().unwrap();
        let spin = Duration::from_millis(5);
        {
            let waiter = wake.attach().unwrap();
            notifier
                .notify_with_custom_event_id(Event::Vehicle(0).id())
                .unwrap();
            let mut got = Vec::new();
            let woke = waiter
                .spin_then_wait(Duration::from_secs(5), spin, |e| got.push(e))
                .unwrap();
            assert_eq!((woke, got), (Wake::Events, vec![Event::Vehicle(0)]));
            let started = Instant::now();
            let timeout = Duration::from_millis(30);
            let woke = waiter.spin_then_wait(timeout, spin, |_| {}).unwrap();
            assert_eq!(woke, Wake::Timeout);
            assert!(started.elapsed() >= timeout, "{:?}", started.elapsed());
        }
        drop((notifier, wake, service, node));
        domain.remove_files();
        assert!(domain.files().is_empty());
    }

    #[test]
    fn every_event_survives_its_id() {
        let events = [
            Event::Body,
            Event::Sample,
            Event::Data,
            Event::NotifierDead,
            Event::Exit,
            Event::FieldUp,
            Event::Vehicle(0),
            Event::Vehicle(7),
            Event::Vehicle(crate::msg::MAX_VEHICLES as u32 - 1),
            Event::Other(0),
            Event::Other(9),
        ];
        for e in events {
            assert_eq!(Event::from_value(e.value()), e, "{e:?}");
            assert_eq!(e.id().as_value(), e.value());
        }
    }

    #[test]
    fn ids_are_those_of_the_wire() {
        assert_eq!(Event::Body.id(), EVENT_BODY);
        assert_eq!(Event::FieldUp.id(), EVENT_FIELD_UP);
        assert_eq!(Event::Vehicle(3).id(), crate::topics::vehicle_event(3));
        // Below the vehicle base and not a named id: not mistaken for a vehicle.
        assert_eq!(Event::from_value(EVENT_VEHICLE_BASE - 1), Event::Other(15));
    }
}
