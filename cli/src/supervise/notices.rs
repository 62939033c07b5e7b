//! The supervisor's iceoryx2 side, on a thread of its own: process exits reported to the
//! coordinator, the body service read for the mission's final command. A leaf: it uses no
//! other module of this crate.

use std::time::Duration;

use anyhow::Result;
use tracing::warn;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::Header;
use vbap_ipc::ports;
use vbap_ipc::topics::{Domain, Limits};
use vbap_ipc::wait::Event;

/// How often the supervisor reads the body service while the mission runs (to see its
/// final command; a few reads a second cost nothing).
const BODY_READ_EVERY: Duration = Duration::from_millis(20);
/// What the supervisor tells, or asks, the mission over iceoryx2. One thread owns those
/// ports (they are not `Send`), so a process exit is reported the moment the child is
/// reaped, whatever the supervisor's main loop is doing (a restart's backoff, say).
pub enum Notice {
    /// A child was reaped: tell the coordinator (`<m>/supervisor/exits`) and wake it.
    Exit(ProcessExit),
    /// Has the coordinator published the mission's final command (`FINISHED`)?
    Finished(tokio::sync::oneshot::Sender<bool>),
    /// The run is over: drop the ports and the node.
    Stop,
}

/// The supervisor's iceoryx2 side: a node of the mission's domain, the exit publisher, a
/// notifier of the coordinator's wake service, a subscriber of the body service.
pub struct Notices {
    /// Where the notices go (to the thread).
    pub tx: std::sync::mpsc::Sender<Notice>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Notices {
    /// Starts the thread (after the domain was cleaned: its node is a live node of the
    /// mission) and returns once its ports exist, before any process of the set starts:
    /// the coordinator's body publisher then connects to the body subscriber when it is
    /// created, so the mission's final command is never missed (a subscriber made later
    /// could come after a fast mission's coordinator is gone, and every agent ending on
    /// FINISHED would look like a process to restart under policy `always`). Without its
    /// ports (an error, logged) the run goes on: the coordinator finds deaths by itself,
    /// only later.
    pub fn start(domain: &Domain, vehicles: usize) -> Self {
        let (tx, rx) = std::sync::mpsc::channel::<Notice>();
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<()>();
        let domain = domain.clone();
        let thread = std::thread::spawn(move || {
            let ports = (|| -> Result<_> {
                let limits = Limits::for_fleet(vehicles);
                let node = domain.supervisor_node()?;
                // Process exits, each waking the coordinator with `Event::Exit`.
                let exits = ports::Sender::new(
                    ports::publisher(&domain.exits_service(&node, &limits)?)?,
                    ports::notifier(&domain.coordinator_wake(&node, &limits)?, Event::Exit)?,
                    Event::Exit,
                );
                let body = ports::subscriber(&domain.body_service(&node, &limits)?)?;
                Ok((exits, body, node))
            })();
            if let Err(e) = &ports {
                warn!(error = %e, "no process-exit reports to the coordinator");
            }
            let _ = ready_tx.send(());
            let mut finished = false;
            let mut seq = 0;
            // The body subscriber is read while the mission runs (every BODY_READ_EVERY),
            // not only when asked: a subscriber connects to a publisher when it reads, and a
            // coordinator that exits right after its final command would otherwise be gone
            // before the first read, its FINISHED never seen.
            let read_body = |body: &iceoryx2::port::subscriber::Subscriber<
                iceoryx2::prelude::ipc::Service,
                BodyCommand,
                (),
            >,
                             finished: &mut bool| {
                while let Ok(Some(sample)) = body.receive() {
                    let h = sample.header;
                    *finished |=
                        h.sender == Header::COORDINATOR && h.flags & BodyCommand::FINISHED != 0;
                }
            };
            loop {
                let notice = match rx.recv_timeout(BODY_READ_EVERY) {
                    Ok(notice) => notice,
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                        if let Ok((_, body, _)) = &ports {
                            read_body(body, &mut finished);
                        }
                        continue;
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
                };
                match (notice, &ports) {
                    (Notice::Stop, _) => break,
                    (Notice::Exit(mut e), Ok((exits, _, _))) => {
                        seq += 1;
                        e.header = e.header.resent(seq);
                        let _ = exits.publish(e);
                        let _ = exits.notify();
                    }
                    (Notice::Finished(reply), Ok((_, body, _))) => {
                        read_body(body, &mut finished);
                        let _ = reply.send(finished);
                    }
                    (Notice::Finished(reply), Err(_)) => {
                        let _ = reply.send(false);
                    }
                    (Notice::Exit(_), Err(_)) => {}
                }
            }
        });
        // The thread answers as soon as its ports exist (or failed); a thread that died
        // first drops the sender and ends the wait too.
        let _ = ready_rx.recv();
        Self {
            tx,
            thread: Some(thread),
        }
    }

    /// True when the coordinator has published the mission's final command.
    pub async fn mission_finished(&self) -> bool {
        let (reply, answer) = tokio::sync::oneshot::channel();
        if self.tx.send(Notice::Finished(reply)).is_err() {
            return false;
        }
        answer.await.unwrap_or(false)
    }

    /// Ends the thread (its node leaves the domain).
    pub fn stop(&mut self) {
        let _ = self.tx.send(Notice::Stop);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
