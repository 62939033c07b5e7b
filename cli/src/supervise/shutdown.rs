//! SIGINT and SIGTERM, listened to for the whole run. A leaf: it uses no other module of
//! this crate.

use anyhow::{Context, Result};

/// SIGINT and SIGTERM, listened to from [`Shutdown::listen`] for as long as it lives.
///
/// One listener for the whole run, never one per wait: tokio drops a signal that arrives
/// while nobody listens to it (its handler is installed, so the process does not die
/// either), and a Ctrl-C between two waits, or while a restarted process starts, was lost.
pub struct Shutdown {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
    /// A signal came: every later [`Shutdown::requested`] resolves at once.
    seen: bool,
}

impl Shutdown {
    /// Installs the handlers and starts listening (inside a tokio runtime).
    pub fn listen() -> Result<Self> {
        use tokio::signal::unix::{signal, SignalKind};
        Ok(Self {
            term: signal(SignalKind::terminate()).context("installing the SIGTERM handler")?,
            int: signal(SignalKind::interrupt()).context("installing the SIGINT handler")?,
            seen: false,
        })
    }

    /// Resolves once SIGINT or SIGTERM has arrived since [`Shutdown::listen`] (at once when
    /// one already did). Cancel-safe: a signal is never lost to a wait that lost a race.
    pub async fn requested(&mut self) {
        if !self.seen {
            tokio::select! {
                _ = self.term.recv() => {},
                _ = self.int.recv() => {},
            }
            self.seen = true;
        }
    }
}
