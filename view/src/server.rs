//! The HTTP side: the page (bundled into the binary), the JSON of a run, and the stream
//! of a running one (Server-Sent Events).
//!
//! Watching never slows the run: the run's processes only write their files; this server
//! reads them on its own thread ([`crate::spawn`]) every [`POLL`]. Each browser
//! connection is a task that, when the files have grown, sends the newest frame only
//! (latest frame wins: a slow browser skips frames, nothing queues for it) and the panel
//! points and events since its last message, at most [`STREAM_POINTS`] points a message.

use std::convert::Infallible;
use std::sync::{Arc, RwLock};
use std::time::Duration;

use axum::extract::{Query, State};
use axum::http::{header, StatusCode};
use axum::response::sse::{Event as SseEvent, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use futures_util::stream::Stream;
use serde::{Deserialize, Serialize};
use tokio::sync::watch;

use crate::field_grid::{bounds, grid, FieldGrid};
use crate::frames::{frames, panels, Frame, FrameCursor, Panels};
use crate::model::{Event, Model, CONTACTS};

/// How often a running run's files are looked at.
pub const POLL: Duration = Duration::from_millis(100);
/// Most panel points one stream message carries (older ones are decimated into them).
pub const STREAM_POINTS: usize = 400;
/// Frames a replay sends at most by default (`/api/frames?max=`).
pub const DEFAULT_FRAMES: usize = 2000;
/// Panel points a replay sends at most by default (`/api/panels?max=`).
pub const DEFAULT_POINTS: usize = 4000;

/// What every request handler shares.
pub struct Shared {
    pub model: RwLock<Model>,
    /// The model's version after each poll that read something.
    pub version: watch::Sender<u64>,
    /// Started to follow a running mission (`vbap run --view`).
    pub live: bool,
}

type App = Arc<Shared>;

/// The page's files, bundled into the binary.
const ASSETS: &[(&str, &str, &[u8])] = &[
    (
        "/",
        "text/html; charset=utf-8",
        include_bytes!("../assets/index.html"),
    ),
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../assets/app.js"),
    ),
    (
        "/ticks.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../assets/ticks.js"),
    ),
    (
        "/map.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../assets/map.js"),
    ),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_bytes!("../assets/style.css"),
    ),
    (
        "/vendor/uPlot.iife.min.js",
        "text/javascript; charset=utf-8",
        include_bytes!("../assets/vendor/uPlot.iife.min.js"),
    ),
    (
        "/vendor/uPlot.min.css",
        "text/css; charset=utf-8",
        include_bytes!("../assets/vendor/uPlot.min.css"),
    ),
];

/// The router of the viewer over `shared`.
pub fn router(shared: App) -> Router {
    let mut r = Router::new();
    for (path, mime, body) in ASSETS {
        r = r.route(
            path,
            get(move || async move { ([(header::CONTENT_TYPE, *mime)], *body) }),
        );
    }
    r.route("/api/meta", get(meta))
        .route("/api/field", get(field))
        .route("/api/frames", get(get_frames))
        .route("/api/panels", get(get_panels))
        .route("/api/events", get(get_events))
        .route("/api/stream", get(stream))
        .fallback(not_found)
        .with_state(shared)
}

/// `/api/meta`: the mission and how far the run is.
#[derive(Debug, Serialize, Deserialize, PartialEq)]
pub struct Meta {
    pub name: String,
    pub dim: usize,
    pub dt: f64,
    pub duration: f64,
    pub goal: String,
    /// Ticks whose rows are all in.
    pub ticks: usize,
    /// Vehicles started (the largest id + 1 seen).
    pub vehicles: usize,
    pub finished: bool,
    pub live: bool,
    pub verdict: Option<String>,
    /// [x0, y0, x1, y1] of the map.
    pub bounds: [f64; 4],
    pub link_drops: u64,
    /// Contact states by their code.
    pub contacts: Vec<String>,
    /// The mission's length unit ("m"; "" when non-dimensional), for axes and the scale bar.
    #[serde(default)]
    pub length_unit: String,
    /// The field's label with its unit ("T (°C)"), for the colour bar and the axes.
    #[serde(default)]
    pub field_label: String,
}

fn read(app: &App) -> std::sync::RwLockReadGuard<'_, Model> {
    app.model.read().unwrap_or_else(|p| p.into_inner())
}

/// The meta of `model`.
pub fn meta_of(model: &Model, live: bool) -> Meta {
    let vehicles = model
        .ticks()
        .iter()
        .flat_map(|t| t.vehicles.iter().map(|v| v.id as usize + 1))
        .max()
        .unwrap_or(model.mission.vehicles.count);
    Meta {
        name: model.mission.mission.name.clone(),
        dim: model.mission.mission.dim,
        dt: model.mission.mission.dt,
        duration: model.mission.mission.duration,
        goal: format!("{:?}", model.mission.mission.goal).to_lowercase(),
        ticks: model.ticks().len(),
        vehicles,
        finished: model.finished(),
        live,
        verdict: model.verdict().map(str::to_owned),
        bounds: bounds(model),
        link_drops: model.link_drops(),
        contacts: CONTACTS.iter().map(|s| s.to_string()).collect(),
        length_unit: model.mission.mission.length_unit.clone(),
        field_label: model.mission.mission.field_label.clone(),
    }
}

async fn meta(State(app): State<App>) -> Json<Meta> {
    Json(meta_of(&read(&app), app.live))
}

/// Query of the range endpoints.
#[derive(Debug, Default, Deserialize)]
pub struct Range {
    /// First tick (default 0).
    pub from: Option<usize>,
    /// Most items returned.
    pub max: Option<usize>,
    /// Grid points per side (`/api/field`).
    pub n: Option<usize>,
    /// Events the page already has (`/api/stream`; default: all there are now).
    pub events: Option<usize>,
}

async fn field(State(app): State<App>, Query(q): Query<Range>) -> Json<FieldGrid> {
    let model = read(&app);
    Json(grid(&model, bounds(&model), q.n.unwrap_or(120)))
}

/// `/api/frames`.
#[derive(Debug, Serialize)]
pub struct FramesOut {
    pub frames: Vec<Frame>,
}

async fn get_frames(State(app): State<App>, Query(q): Query<Range>) -> Json<FramesOut> {
    let model = read(&app);
    let max = q.max.unwrap_or(DEFAULT_FRAMES);
    Json(FramesOut {
        frames: frames(&model, q.from.unwrap_or(0), max),
    })
}

async fn get_panels(State(app): State<App>, Query(q): Query<Range>) -> Json<Panels> {
    let model = read(&app);
    Json(panels(
        &model,
        q.from.unwrap_or(0),
        q.max.unwrap_or(DEFAULT_POINTS),
    ))
}

/// `/api/events`.
#[derive(Debug, Serialize)]
pub struct EventsOut {
    pub events: Vec<Event>,
    pub link_drops: u64,
}

async fn get_events(State(app): State<App>) -> Json<EventsOut> {
    let model = read(&app);
    Json(EventsOut {
        events: model.events().to_vec(),
        link_drops: model.link_drops(),
    })
}

/// One message of `/api/stream` (SSE event `update`).
#[derive(Debug, Serialize)]
pub struct Update {
    /// Ticks whose rows are all in.
    pub ticks: usize,
    pub finished: bool,
    pub verdict: Option<String>,
    pub link_drops: u64,
    /// The newest frame.
    pub frame: Option<Frame>,
    /// Panel points since the last message (decimated to [`STREAM_POINTS`]).
    pub panels: Panels,
    /// Events since the last message.
    pub events: Vec<Event>,
}

/// A connection's place in the run.
struct Follower {
    app: App,
    rx: watch::Receiver<u64>,
    /// Version last sent (`None`: nothing sent yet).
    sent: Option<u64>,
    /// Next tick of the panels to send, next event.
    tick: usize,
    event: usize,
    frames: FrameCursor,
}

impl Follower {
    /// The message of what is new since the last one.
    fn update(&mut self) -> Update {
        let model = read(&self.app);
        let ready = model.ticks().len();
        self.tick = self.tick.min(ready);
        self.event = self.event.min(model.events().len());
        let frame = (ready > 0).then(|| self.frames.frame(&model, ready - 1));
        let update = Update {
            ticks: ready,
            finished: model.finished(),
            verdict: model.verdict().map(str::to_owned),
            link_drops: model.link_drops(),
            frame,
            panels: panels(&model, self.tick, STREAM_POINTS),
            events: model.events()[self.event..].to_vec(),
        };
        self.tick = ready;
        self.event = model.events().len();
        update
    }
}

async fn stream(
    State(app): State<App>,
    Query(q): Query<Range>,
) -> Sse<impl Stream<Item = Result<SseEvent, Infallible>>> {
    let rx = app.version.subscribe();
    let event = q.events.unwrap_or_else(|| read(&app).events().len());
    let follower = Follower {
        app,
        rx,
        sent: None,
        tick: q.from.unwrap_or(0),
        event,
        frames: FrameCursor::default(),
    };
    let s = futures_util::stream::unfold(follower, |mut f| async move {
        loop {
            let v = *f.rx.borrow_and_update();
            if f.sent != Some(v) {
                f.sent = Some(v);
                let data = serde_json::to_string(&f.update()).unwrap_or_default();
                return Some((Ok(SseEvent::default().event("update").data(data)), f));
            }
            if f.rx.changed().await.is_err() {
                return None;
            }
        }
    });
    Sse::new(s).keep_alive(KeepAlive::default())
}

/// Polls the model every [`POLL`] until the run is finished, telling the followers.
pub async fn follow(app: App) {
    let mut every = tokio::time::interval(POLL);
    every.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        every.tick().await;
        let (changed, finished, version) = {
            let mut m = app.model.write().unwrap_or_else(|p| p.into_inner());
            match m.poll() {
                Ok(c) => (c, m.finished(), m.version()),
                Err(e) => {
                    tracing::warn!(error = %e, "view: reading the run directory");
                    (false, false, m.version())
                }
            }
        };
        if changed {
            app.version.send_replace(version);
        }
        if finished {
            return;
        }
    }
}

/// A 404 for anything else.
pub async fn not_found() -> Response {
    (StatusCode::NOT_FOUND, "not found").into_response()
}
