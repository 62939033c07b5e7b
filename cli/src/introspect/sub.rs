//! A subscriber to one of the mission's publish-subscribe services, whatever its payload.

use anyhow::{anyhow, Result};
use iceoryx2::node::Node;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ipc, ServiceName};
use serde_json::Value;
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;

use super::decode::{self, Kind};

/// A subscriber of a state, body or exits service.
pub enum Sub {
    State(Subscriber<ipc::Service, VehicleState, ()>),
    Body(Subscriber<ipc::Service, BodyCommand, ()>),
    Exit(Subscriber<ipc::Service, ProcessExit, ()>),
}

macro_rules! subscribe {
    ($node:expr, $name:expr, $ty:ty, $variant:ident) => {{
        let service = $node
            .service_builder($name)
            .publish_subscribe::<$ty>()
            .open()
            .map_err(|e| anyhow!("opening {}: {e:?}", $name))?;
        let sub = service
            .subscriber_builder()
            .create()
            .map_err(|e| anyhow!("subscribing to {}: {e:?}", $name))?;
        Sub::$variant(sub)
    }};
}

macro_rules! drain {
    ($sub:expr, $decode:expr, $out:expr, $f:path) => {{
        let mut n = 0;
        while let Some(sample) = $sub.receive().map_err(|e| anyhow!("receiving: {e:?}"))? {
            n += 1;
            if $decode {
                $out($f(sample.payload()));
            }
        }
        n
    }};
}

impl Sub {
    /// Subscribes to the existing service `name` of payload `kind` (never creates it).
    pub fn open(node: &Node<ipc::Service>, kind: Kind, name: &str) -> Result<Sub> {
        let name = &ServiceName::new(name).map_err(|e| anyhow!("service name {name:?}: {e:?}"))?;
        Ok(match kind {
            Kind::State => subscribe!(node, name, VehicleState, State),
            Kind::Body => subscribe!(node, name, BodyCommand, Body),
            Kind::Exit => subscribe!(node, name, ProcessExit, Exit),
        })
    }

    /// Takes every sample waiting; `out` gets each decoded when `decode`. Returns how many.
    pub fn drain(&self, decode: bool, out: &mut dyn FnMut(Value)) -> Result<usize> {
        Ok(match self {
            Sub::State(s) => drain!(s, decode, out, decode::state),
            Sub::Body(s) => drain!(s, decode, out, decode::body),
            Sub::Exit(s) => drain!(s, decode, out, decode::exit),
        })
    }
}
