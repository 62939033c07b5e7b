//! What a supervised process is ([`Role`]) and the report of its death to the coordinator.
//! A leaf: it uses no other module of this crate.

use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::Header;

/// What a supervised process is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    FieldServer,
    Coordinator,
    Agent(u32),
    /// The Zenoh bridge of a host of a mission spread over machines (`HostPlan`).
    Bridge,
}

impl Role {
    /// The process's name (its logs are named so).
    pub fn name(self) -> String {
        match self {
            Role::FieldServer => "field_server".into(),
            Role::Coordinator => "coordinator".into(),
            Role::Agent(id) => format!("vehicle_agent_{id}"),
            Role::Bridge => "vbap_bridge".into(),
        }
    }
}

impl Role {
    /// The `ProcessExit` role and vehicle of this process (None: a bridge, no process of
    /// the coordinator's).
    pub fn exit_role(self) -> Option<(u32, u32)> {
        match self {
            Role::FieldServer => Some((ProcessExit::FIELD_SERVER, 0)),
            Role::Coordinator => Some((ProcessExit::COORDINATOR, 0)),
            Role::Agent(id) => Some((ProcessExit::AGENT, id)),
            Role::Bridge => None,
        }
    }
}

/// The report of the death of process `pid` in `role`, reaped at `died_ns`.
pub fn exit_report(
    role: Role,
    pid: u32,
    status: &std::io::Result<std::process::ExitStatus>,
    died_ns: u64,
) -> ProcessExit {
    use std::os::unix::process::ExitStatusExt;
    // A bridge is never reported (see `ProcessSet::watch`).
    let (role, vehicle) = role.exit_role().unwrap_or((u32::MAX, 0));
    ProcessExit {
        header: Header::from_sender(Header::SUPERVISOR),
        role,
        vehicle,
        pid,
        signal: status.as_ref().ok().and_then(|s| s.signal()).unwrap_or(0) as u32,
        died_ns,
    }
}
