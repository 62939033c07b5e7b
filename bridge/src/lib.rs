//! `vbap-bridge`: one process per host that forwards, between this host's iceoryx2 domain
//! and Zenoh, exactly the services that cross hosts (docs/ARCHITECTURE.md §14).
//!
//! | stream | Zenoh key | direction | iceoryx2 side |
//! |---|---|---|---|
//! | vehicle states (joins are flagged states), a frame per pass of a host's bridge | `vbap/<m>/states/<host>` | glider host → shore | `<m>/vehicle/<id>/state` + `Event::Vehicle(id)` on `<m>/coordinator/wake`, per state |
//! | body commands with the snapshot | `vbap/<m>/body` | shore → glider hosts | `<m>/body` + `Event::Body` on every local `<m>/vehicle/<id>/wake` |
//! | acknowledgement of the mission's final command | `vbap/<m>/final_ack/<host>` | glider host → shore | none (the shore's bridge ends once every glider host's is in: `run`'s doc) |
//! | process exits of a host's supervisor | `vbap/<m>/exits/<host>` | glider host → shore | `<m>/supervisor/exits` + `Event::Exit` |
//! | liveliness of a host's bridge | `vbap/<m>/host/<host>/<bridge pid>` (token) | every host | proxy nodes `vehicle_agent_<id>`; `ProcessExit::UNREACHABLE` when gone |
//!
//! A forwarded message wakes its reader exactly as a local one does: the bridge publishes
//! on the same service and notifies the same wake service with the same event. On the
//! sending host the bridge is woken as the absent reader would be (it listens on the
//! coordinator's wake service on a glider host, on the remote vehicles' wake services on
//! the shore). Sensor requests stay on the shore (the field server runs beside the
//! coordinator: the hosts file says so).
//!
//! Quality of service: every stream is a reliable, blocking (`CongestionControl::Block`),
//! express publication over the link, mutual TLS (plain TCP only with the hosts file's
//! `insecure = true`; the acknowledgements too) — lockstep needs every state and every command
//! (a dropped one would stall or desynchronise the tick), and the link model that drops
//! messages lives in the application, not here. Zenoh's reliability ends with a link, so
//! what goes unanswered is put again and a copy is dropped where it was not lost
//! (`run/repeat.rs`). States and commands go at
//! `Priority::RealTime`, exits at `Priority::InteractiveHigh`.

pub mod keys;
pub mod ping;
pub mod relay;
pub mod run;
pub mod wire;

pub use run::{publisher, run, Counts};
