//! vbap-view: a browser map of a run. `vbap view RUN_DIR` replays a finished run with a
//! time slider; `vbap run MISSION --view` follows a running one, streamed over
//! Server-Sent Events. Everything shown is read from the run directory's files (by column
//! name): the processes of a run write them anyway, so watching adds no message, no
//! subscriber and no wait to the mission (docs/ARCHITECTURE.md §13).
//!
//! - [`model`]: the run as read so far (ticks, vehicles, contact, events);
//! - [`frames`]: map frames (design slots fitted as the judge fits them, pulses of
//!   delivered reports) and panel series, decimated on the server;
//! - [`field_grid`]: the mission's field on a grid for the colour map and contours;
//! - [`server`]: the page (bundled: no network needed), the JSON endpoints, the stream.

pub mod field_grid;
pub mod frames;
pub mod model;
pub mod server;
pub mod tail;

use std::net::SocketAddr;
use std::path::Path;
use std::sync::{Arc, RwLock};

use anyhow::{Context, Result};
use tokio::sync::{oneshot, watch};

/// The address served when none is given: loopback, any free port.
pub const DEFAULT_ADDR: &str = "127.0.0.1:0";

/// A viewer serving on its own thread (and its own runtime): nothing of the caller's
/// runtime or of the run's processes waits for it. Dropping it stops the server.
pub struct Viewer {
    addr: SocketAddr,
    stop: Option<oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Viewer {
    /// The address served.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's URL.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Binds `addr` (errors now: a port in use, an address not of this host) and starts the
/// viewer of the run directory `dir` on its own thread. `live`: the run is under way
/// (the page follows it); the files are followed in any case until `summary.json` is there.
pub fn spawn(dir: &Path, addr: &str, live: bool) -> Result<Viewer> {
    let listener = bind(addr)?;
    let addr = listener.local_addr()?;
    let app = shared(dir, live)?;
    let (stop, stopped) = oneshot::channel::<()>();
    let thread = std::thread::Builder::new()
        .name("vbap-view".into())
        .spawn(move || {
            let Ok(rt) = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
            else {
                return;
            };
            rt.block_on(async move {
                tokio::select! {
                    r = serve(listener, app) => {
                        if let Err(e) = r {
                            tracing::warn!(error = %e, "view: the server stopped");
                        }
                    }
                    _ = stopped => {}
                }
            });
        })?;
    Ok(Viewer {
        addr,
        stop: Some(stop),
        thread: Some(thread),
    })
}

/// `vbap view RUN_DIR --addr ADDR`: serves the run until Ctrl-C / SIGTERM, after printing
/// its URL (and how long reading the run took).
pub fn serve_until_stopped(dir: &Path, addr: &str) -> Result<()> {
    let started = std::time::Instant::now();
    let listener = bind(addr)?;
    let addr = listener.local_addr()?;
    let app = shared(dir, false)?;
    let ticks = app.model.read().map(|m| m.ticks().len()).unwrap_or(0);
    println!(
        "vbap view: {} ({ticks} ticks read in {:.2} s) at http://{addr}/  (Ctrl-C to stop)",
        dir.display(),
        started.elapsed().as_secs_f64()
    );
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    rt.block_on(async move {
        tokio::select! {
            r = serve(listener, app) => r,
            _ = tokio::signal::ctrl_c() => Ok(()),
        }
    })
}

fn bind(addr: &str) -> Result<std::net::TcpListener> {
    let listener =
        std::net::TcpListener::bind(addr).with_context(|| format!("cannot listen on {addr}"))?;
    listener.set_nonblocking(true)?;
    Ok(listener)
}

fn shared(dir: &Path, live: bool) -> Result<Arc<server::Shared>> {
    let model = model::Model::open(dir)?;
    let (version, _) = watch::channel(model.version());
    Ok(Arc::new(server::Shared {
        model: RwLock::new(model),
        version,
        live,
    }))
}

/// Serves `app` on `listener`, following the run's files meanwhile.
async fn serve(listener: std::net::TcpListener, app: Arc<server::Shared>) -> Result<()> {
    let listener = tokio::net::TcpListener::from_std(listener)?;
    tokio::spawn(server::follow(app.clone()));
    axum::serve(listener, server::router(app)).await?;
    Ok(())
}
