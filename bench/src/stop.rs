//! Stopping the bench: SIGINT/SIGTERM caught once for the whole bench, read between and
//! inside the phases. A leaf: it uses no other module of this crate.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Result;
use iceoryx2::node::{Node, NodeWaitFailure};
use iceoryx2::prelude::ipc;
use vbap_ipc::domain::clean_domain;
use vbap_ipc::topics::Domain;

/// The bench was stopped by a signal.
#[derive(Debug, thiserror::Error)]
#[error("interrupted")]
pub struct Interrupted;

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Catches SIGINT/SIGTERM for the whole bench: an iceoryx2 node with
/// `HandleTerminationRequests` turns them into a flag that [`StopFlag::check`] reads between
/// and inside the phases, so an interrupted bench still reaps its children and removes its
/// shared-memory files.
pub struct StopFlag {
    node: Node<ipc::Service>,
    domain: Domain,
}

impl StopFlag {
    /// Catches the signals from now on; `domain`: the bench's own, cleaned by [`StopFlag::close`].
    pub fn new(domain: Domain) -> Result<Self> {
        let node = domain.node("bench_signals")?;
        let flag = Self { node, domain };
        let _ = flag.requested(); // installs iceoryx2's signal capture now
        Ok(flag)
    }

    /// True once SIGINT or SIGTERM has arrived (sticky).
    pub fn requested(&self) -> bool {
        if !INTERRUPTED.load(Ordering::SeqCst) {
            if let Err(NodeWaitFailure::Interrupt | NodeWaitFailure::TerminationRequest) =
                self.node.wait(Duration::ZERO)
            {
                INTERRUPTED.store(true, Ordering::SeqCst);
            }
        }
        INTERRUPTED.load(Ordering::SeqCst)
    }

    /// Records a signal seen by some other iceoryx2 wait.
    pub fn set() {
        INTERRUPTED.store(true, Ordering::SeqCst);
    }

    /// `Err(Interrupted)` once a signal has arrived.
    pub fn check(&self) -> Result<()> {
        if self.requested() {
            Err(Interrupted.into())
        } else {
            Ok(())
        }
    }

    /// Drops the signal node and cleans the bench's own domain.
    pub fn close(self) {
        let Self { node, domain } = self;
        drop(node);
        let _ = clean_domain(&domain);
    }
}
