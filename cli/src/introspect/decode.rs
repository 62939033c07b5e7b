//! The payloads of `wire/src/msg.rs` as JSON (what `vbap echo` prints): every field by its
//! name, arrays cut to their used length.

use serde_json::{json, Value};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::Header;

fn header(h: &Header) -> Value {
    json!({"sender": h.sender, "flags": h.flags, "tick": h.tick, "t": h.t, "seq": h.seq,
           "sent_ns": h.sent_ns})
}

/// A vehicle's state.
pub fn state(s: &VehicleState) -> Value {
    json!({"type": "VehicleState", "header": header(&s.header), "pid": s.pid,
           "position": s.position, "velocity": s.velocity, "commands_read": s.commands_read})
}

/// A body command: the used leaders, snapshot entries and plan segments only.
pub fn body(b: &BodyCommand) -> Value {
    let n_l = (b.n_leaders as usize).min(b.leaders.len());
    let n_p = (b.n_plan as usize).min(b.plan.len());
    json!({"type": "BodyCommand", "header": header(&b.header), "s": b.s, "sdot": b.sdot,
           "r": b.r, "scale": b.scale, "inter": b.inter, "leader": b.leader,
           "damping": b.damping, "velocity": b.velocity, "n_leaders": b.n_leaders,
           "n_vehicles": b.n_vehicles, "leaders": &b.leaders[..n_l],
           "snapshot": b.snapshot_entries(), "plan_start": b.plan_start,
           "plan_ticks": b.plan_ticks, "n_plan": b.n_plan, "plan": &b.plan[..n_p]})
}

/// A process exit told by the supervisor.
pub fn exit(e: &ProcessExit) -> Value {
    json!({"type": "ProcessExit", "header": header(&e.header), "role": e.role,
           "vehicle": e.vehicle, "pid": e.pid, "signal": e.signal, "died_ns": e.died_ns})
}

/// The payload kind of a service, from its name (`<m>/vehicle/<id>/state`, `<m>/body`,
/// `<m>/supervisor/exits`); `None`: not a publish-subscribe service of vbap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    State,
    Body,
    Exit,
}

impl Kind {
    /// The kind of service `name` of mission `mission`.
    pub fn of(mission: &str, name: &str) -> Option<Kind> {
        let rest = name.strip_prefix(mission)?.strip_prefix('/')?;
        match rest.split('/').collect::<Vec<_>>().as_slice() {
            ["vehicle", id, "state"] if id.parse::<u32>().is_ok() => Some(Kind::State),
            ["body"] => Some(Kind::Body),
            ["supervisor", "exits"] => Some(Kind::Exit),
            _ => None,
        }
    }
}
