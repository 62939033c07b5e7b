//! The campaign's times: how long a run lasts after its actions, when an action is judged,
//! the earliest action, the shortest stop, how often and how long the campaign looks. A
//! leaf: it uses no other module of this crate.

use std::time::Duration;

/// Wall time a paced run lasts after the action window, s: room to detect, restart and
/// readmit the last action's target.
pub const TAIL: f64 = 5.0;
/// An action is judged when the mission went on at least this long after it (wall, s).
pub const MARGIN: f64 = 3.0;
/// Earliest action, s of wall time after the process set is up.
pub const FIRST_ACTION: f64 = 0.5;
/// Shortest SIGSTOP pause, s.
pub const MIN_STOP: f64 = 0.2;
/// How often the campaign looks at the process set.
pub const POLL: Duration = Duration::from_millis(2);
/// Longest wait for the process set to come up.
pub const UP_TIMEOUT: Duration = Duration::from_secs(120);
/// A compound fault's agent kill comes this long after the coordinator's or field
/// server's kill (inside its restart: the restart backoff is 0.2 s by default), s.
pub const COMPOUND_GAP: f64 = 0.03;
/// A compound fault's agent is killed this long after it was stopped, s.
pub const STOPPED_BEFORE_KILL: f64 = 0.3;
