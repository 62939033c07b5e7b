//! The one tracing setup of every vbap process.
//!
//! JSON lines, one object per event, to `--log FILE` when given (the supervisor points each
//! process at `RUN_DIR/logs/<process>.jsonl`), else to stderr. `RUST_LOG` overrides the
//! built-in default filter. iceoryx2's own messages arrive through its `tracing` logger
//! feature under the target `iceoryx2_bb_loggers::tracing`.
//!
//! Level meanings: `error` the process cannot go on; `warn` something was lost or rejected;
//! `info` lifecycle and mission events; `debug` details; `trace` inner loops.
//!
//! Per-message records (latency analysis) are not tracing events: they go to
//! `<process>.msgs.csv` beside the log file, through [`crate::msglog`], a cheaper format.
//! The log level does not switch them (`RUST_LOG=info` keeps them): their own switch is the
//! environment variable `VBAP_MSG_RECORDS` (`on` by default, `off`). Logs of earlier versions
//! carry them as JSON lines of that target (fields `hop`, `sender`, `tick`, `seq`,
//! `sent_ns`, `recv_ns`, …); `vbap analyze` reads both.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::{Arc, Mutex};

use tracing_subscriber::fmt::writer::BoxMakeWriter;
use tracing_subscriber::fmt::MakeWriter;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::EnvFilter;

/// Target of per-message records in the JSON logs of earlier versions (the records now have
/// their own file and switch, [`crate::msglog`]).
pub use vbap_wire::msglog::MSG_TARGET;

/// Default filter: info everywhere, message records included, iceoryx2 warnings only.
pub const DEFAULT_FILTER: &str = "info,vbap::msg=debug,iceoryx2_bb_loggers=warn";

/// A buffered log file shared by the subscriber; flushed by [`LogGuard`] on drop.
#[derive(Clone)]
struct SharedFile(Arc<Mutex<BufWriter<File>>>);

struct SharedFileWriter(Arc<Mutex<BufWriter<File>>>);

impl Write for SharedFileWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0
            .lock()
            .map_err(|_| std::io::Error::other("log lock poisoned"))?
            .write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0
            .lock()
            .map_err(|_| std::io::Error::other("log lock poisoned"))?
            .flush()
    }
}

/// Every event is flushed to the file as soon as it is written: the tracing log holds the
/// lifecycle lines only (message records go to their own file, `crate::msglog`), few
/// enough for a write each, and a user tailing a running process's log sees them at once.
impl Drop for SharedFileWriter {
    fn drop(&mut self) {
        if let Ok(mut f) = self.0.lock() {
            let _ = f.flush();
        }
    }
}

impl<'a> MakeWriter<'a> for SharedFile {
    type Writer = SharedFileWriter;
    fn make_writer(&'a self) -> Self::Writer {
        SharedFileWriter(self.0.clone())
    }
}

/// Keeps the log file open; flushes it when dropped. Hold it in `main` until exit.
pub struct LogGuard(Option<Arc<Mutex<BufWriter<File>>>>);

impl LogGuard {
    /// Flushes buffered log lines now (call before a deliberate exit).
    pub fn flush(&self) {
        if let Some(file) = &self.0 {
            if let Ok(mut f) = file.lock() {
                let _ = f.flush();
            }
        }
    }
}

impl Drop for LogGuard {
    fn drop(&mut self) {
        self.flush();
    }
}

/// Installs the global subscriber for process `process` (recorded as a field of every
/// line through the span-less `process` target name). Returns the guard that flushes.
pub fn init(process: &str, log_file: Option<&Path>) -> std::io::Result<LogGuard> {
    init_with(process, log_file, DEFAULT_FILTER)
}

/// [`init`] with another built-in default filter (the `vbap` front door logs warnings only
/// to the terminal).
pub fn init_with(
    process: &str,
    log_file: Option<&Path>,
    default_filter: &str,
) -> std::io::Result<LogGuard> {
    init_watching(process, log_file, default_filter, "off", |_| {})
}

/// A watcher of the events its own filter lets through, called with each.
struct Watch<F>(F);

impl<S: tracing::Subscriber, F: Fn(&tracing::Event<'_>) + Send + Sync + 'static>
    tracing_subscriber::Layer<S> for Watch<F>
{
    fn on_event(&self, event: &tracing::Event<'_>, _: tracing_subscriber::layer::Context<'_, S>) {
        (self.0)(event)
    }
}

/// [`init_with`], and `watch` is called with every event that `watch_filter` (an
/// `EnvFilter` directive string, e.g. `"zenoh_link_tls=warn"`) lets through, whether or
/// not the log's own filter writes it: the bridge counts the TLS handshakes its Zenoh
/// refused (warnings) and the messages its access control denied (Zenoh logs those only
/// at `trace`, which the log file never holds).
pub fn init_watching(
    process: &str,
    log_file: Option<&Path>,
    default_filter: &str,
    watch_filter: &str,
    watch: impl Fn(&tracing::Event<'_>) + Send + Sync + 'static,
) -> std::io::Result<LogGuard> {
    use tracing_subscriber::Layer;
    let filter =
        EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default_filter));
    let (writer, guard) = match log_file {
        Some(path) => {
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)?;
            }
            let file = Arc::new(Mutex::new(BufWriter::with_capacity(
                1 << 16,
                std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(path)?,
            )));
            (
                BoxMakeWriter::new(SharedFile(file.clone())),
                LogGuard(Some(file)),
            )
        }
        None => (BoxMakeWriter::new(std::io::stderr), LogGuard(None)),
    };
    let log = tracing_subscriber::fmt::layer()
        .json()
        .with_current_span(false)
        .with_span_list(false)
        .with_thread_ids(false)
        .with_target(true)
        .with_writer(writer)
        .with_filter(filter);
    let _ = tracing_subscriber::registry()
        .with(log)
        .with(Watch(watch).with_filter(EnvFilter::new(watch_filter)))
        .try_init();
    tracing::info!(process, pid = std::process::id(), "started");
    Ok(guard)
}

#[cfg(test)]
mod tests {
    use super::DEFAULT_FILTER;
    use crate::msglog::MsgLog;

    #[test]
    fn beside_ignores_the_tracing_filter() {
        let dir =
            std::env::temp_dir().join(format!("vbap-telemetry-{}-beside", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let jsonl = dir.join("logs/coordinator.jsonl");
        let csv = dir.join("logs/coordinator.msgs.csv");
        let with_filter = |filter: &str| {
            let sub = tracing_subscriber::fmt()
                .with_env_filter(tracing_subscriber::EnvFilter::new(filter))
                .with_writer(std::io::sink)
                .finish();
            tracing::subscriber::with_default(sub, || MsgLog::beside(Some(&jsonl)).unwrap())
        };
        // RUST_LOG=info (or even error) keeps the records.
        for filter in ["info", "error"] {
            let log = with_filter(filter);
            assert!(log.is_enabled(), "{filter}");
        }
        let mut on = with_filter(DEFAULT_FILTER);
        assert!(on.is_enabled());
        on.recv("state", 0, u32::MAX - 1, 0, 0, 1, 2);
        drop(on);
        assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
