//! The exit codes of every vbap process and command: what a process tells its supervisor
//! (and a shell) when it ends.

/// Exit code: success.
pub const EXIT_OK: i32 = 0;
/// Exit code: runtime failure.
pub const EXIT_FAILURE: i32 = 1;
/// Exit code: invalid input (config, arguments).
pub const EXIT_INVALID: i32 = 2;
