// The page: loads a run from the server, plays it with a time slider, and follows a running
// one over Server-Sent Events. `window.vbap` exposes the state (the browser tests read it).
"use strict";

const $ = (id) => document.getElementById(id);
const state = {
  meta: null, frames: [], panels: null, events: [], i: 0, playing: false, ready: false,
  lastTick: -1, lastUpdate: 0, charts: [], trail: 200,
};
window.vbap = state;
const map = new RunMap($("map"));
state.map = map;

// Mission time in the unit that suits the mission's length (the axes' unit), to 3 digits.
function fmtTime(t, span) {
  return VbapTicks.fmtTime(t, span || (state.meta ? state.meta.duration : t));
}

const MARKERS = {
  lost: "#d62728", rejoin: "#2ca02c", reconfigured: "#9467bd", stall_began: "#ff7f0e",
  stall_ended: "#ffbb78", surfaced: "#17becf", formation_broken: "#8c564b",
  formation_restored: "#c49c94", near_collision: "#e377c2", fault: "#000000",
  contact_lost: "#bcbd22", contact_regained: "#dbdb8d", converged: "#2ca02c",
};

// uPlot plugin: event markers (vertical lines; surfacings as short ticks at the bottom) and
// the current time.
function markersPlugin() {
  return {
    hooks: {
      draw: [(u) => {
        const cx = u.ctx, top = u.bbox.top, h = u.bbox.height, dpr = devicePixelRatio || 1;
        cx.save();
        for (const e of state.events) {
          const c = MARKERS[e.kind]; if (!c) continue;
          const x = Math.round(u.valToPos(e.t, "x", true));
          if (x < u.bbox.left || x > u.bbox.left + u.bbox.width) continue;
          cx.strokeStyle = c; cx.lineWidth = dpr;
          cx.beginPath();
          if (e.kind === "surfaced") { cx.moveTo(x, top + h); cx.lineTo(x, top + h - 6 * dpr); }
          else { cx.moveTo(x, top); cx.lineTo(x, top + h); }
          cx.stroke();
        }
        const f = state.frames[state.i];
        if (f) {
          const x = Math.round(u.valToPos(f.t, "x", true));
          cx.strokeStyle = "#000"; cx.lineWidth = 1.5 * dpr;
          cx.beginPath(); cx.moveTo(x, top); cx.lineTo(x, top + h); cx.stroke();
        }
        cx.restore();
      }],
    },
  };
}

// The panels: series [key, label, colour] and the unit of the values (`unit(meta)`).
const PANELS = [
  { title: "V / V_U of (II.2): true (from the true states) and seen", series: [["v_true", "true", "#d62728"], ["v_seen", "seen", "#1f77b4"]], log: true, one: true, unit: () => "V/V_U" },
  { title: "distance of the body to the optimum", series: [["dist", "distance", "#333"]], unit: (m) => lengthUnit(m) },
  { title: "gradient-estimate error |∇T_est − ∇T|", series: [["grad_err", "error", "#9467bd"]], unit: (m) => `${fieldUnit(m)}/${lengthUnit(m)}` },
  { title: "ṡ / v0", series: [["sdot", "ṡ/v0", "#2ca02c"]], unit: () => "ṡ/v0" },
];

// The mission's length unit, "L" when non-dimensional.
function lengthUnit(m) { return m.length_unit || "L"; }
// The field's unit from its label ("T (°C)" → "°C"), else its label ("T").
function fieldUnit(m) {
  const label = m.field_label || "T", u = /\(([^()]+)\)\s*$/.exec(label);
  return u ? u[1] : label;
}

// Tick labels of a logarithmic axis.
function logTicks(u, vals) {
  return vals.map((v) => (v == null ? "" : Math.abs(v) >= 0.01 && Math.abs(v) < 1e4 ? String(+v.toPrecision(2)) : v.toExponential(0)));
}

// uPlot axes whose ticks come from ticks.js: round time steps in the mission's unit ("6 h"),
// values with the decimals their step needs. The labels drawn last are kept on the chart
// (`chart.vbapLabels`, read by the browser tests).
function timeAxis() {
  let last = null;
  return {
    splits: (u, i, lo, hi) => {
      last = VbapTicks.time(lo, hi, Math.max(2, Math.round(u.bbox.width / (devicePixelRatio || 1) / 90)));
      return last.values;
    },
    values: (u, vals) => {
      const labels = vals.map((v, j) => (last && last.values[j] === v ? `${last.labels[j]} ${last.unit.symbol}` : fmtTime(v)));
      (u.vbapLabels = u.vbapLabels || {}).x = labels;
      return labels;
    },
  };
}
function valueAxis(unit) {
  let last = null;
  return {
    size: 60, label: unit, labelSize: 16, labelFont: "12px system-ui",
    splits: (u, i, lo, hi) => {
      last = VbapTicks.linear(lo, hi, Math.max(2, Math.round(u.bbox.height / (devicePixelRatio || 1) / 30)));
      return last.values;
    },
    values: (u, vals) => {
      const labels = vals.map((v, j) => (last && last.values[j] === v ? last.labels[j] : String(v)));
      (u.vbapLabels = u.vbapLabels || {}).y = labels;
      return labels;
    },
  };
}

function panelData(p, cfg) {
  return [p.t, ...cfg.series.map(([key]) => p[key].map((v) => (cfg.log && !(v > 0) ? null : v)))];
}

function buildPanels() {
  const box = $("panels");
  box.innerHTML = "";
  state.charts = PANELS.map((cfg) => {
    const div = document.createElement("div");
    const title = document.createElement("div");
    title.className = "title";
    title.innerHTML = cfg.title + " " + cfg.series.map(([, label, colour]) => `<span style="color:${colour}">■ ${label}</span>`).join(" ");
    box.appendChild(title); box.appendChild(div);
    const opts = {
      width: Math.max(300, box.clientWidth - 12), height: 125,
      scales: { x: { time: false }, y: cfg.log ? { distr: 3 } : {} },
      axes: [timeAxis(), cfg.log ? { size: 60, label: cfg.unit(state.meta), labelSize: 16, labelFont: "12px system-ui", values: logTicks } : valueAxis(cfg.unit(state.meta))],
      series: [{ label: "t", value: (u, v) => (v == null ? "" : fmtTime(v)) },
        ...cfg.series.map(([, label, colour]) => ({ label, stroke: colour, width: 1.2, spanGaps: false }))],
      legend: { show: false },
      plugins: [markersPlugin()],
    };
    return new uPlot(opts, panelData(state.panels, cfg), div);
  });
}

function legend() {
  $("legend").innerHTML = CONTACT_NAMES.slice(0, 6).map((n, i) =>
    `<span><i style="background:${CONTACT_COLOURS[i]}"></i>${n}</span>`).join("") +
    `<span><i style="background:#fff;border:2px solid rgba(120,0,160,.9)"></i>slot</span>` +
    `<span><i style="background:#fff;border:2px solid #fc0"></i>report delivered</span>` +
    `<span><i style="background:#1a9850"></i>Iridium session (red: failed)</span>` +
    `<span><i style="background:#fff;border:2px solid #6a3d9a"></i>acoustic frame sent</span>`;
}

function status() {
  const m = state.meta, f = state.frames[state.i];
  const what = state.disconnected ? "the server stopped (replay it with `vbap view DIR`)"
    : m.live && !m.finished ? "live" : m.finished ? (m.verdict || "finished") : "in progress";
  $("title").textContent = m.name;
  $("status").textContent = `${m.vehicles} vehicles · ${m.ticks} ticks · ${what} · ${m.link_drops} link drops`;
  $("time").textContent = f ? `t = ${fmtTime(f.t)} (tick ${f.k})` : "no tick yet";
}

function show(i) {
  state.i = Math.max(0, Math.min(state.frames.length - 1, i));
  $("slider").max = Math.max(0, state.frames.length - 1);
  $("slider").value = state.i;
  map.draw(state.frames, state.i, state.trail);
  for (const c of state.charts) c.redraw(false, false);
  status();
}

// Playback: `speed` frames a second, on animation frames.
let lastStep = 0;
function tick(now) {
  if (state.playing) {
    const fps = Number($("speed").value);
    if (now - lastStep >= 1000 / fps) {
      lastStep = now;
      if (state.i >= state.frames.length - 1) { if (!state.meta.live || state.meta.finished) setPlaying(false); }
      else show(state.i + 1);
    }
  }
  requestAnimationFrame(tick);
}
function setPlaying(p) { state.playing = p; $("play").textContent = p ? "❚❚" : "▶"; }

function hover(ev) {
  const r = map.canvas.getBoundingClientRect();
  const d = map.pick(ev.clientX - r.left, ev.clientY - r.top), tip = $("tip");
  if (!d) { tip.hidden = true; return; }
  const v = d.vehicle;
  tip.textContent = `vehicle ${v[0]} · ${CONTACT_NAMES[v[3]]}\nage of information ${v[4] == null ? "none yet" : fmtTime(v[4], v[4])}` +
    `\nslot error ${v[5] == null ? "n/a" : v[5].toFixed(3) + " spacing"}`;
  tip.style.left = d.px + 14 + "px"; tip.style.top = d.py + 8 + "px"; tip.hidden = false;
}

// Live: appends what the stream brings; follows the newest frame while "follow live" is on.
function follow() {
  const es = new EventSource(`/api/stream?from=${state.meta.ticks}&events=${state.events.length}`);
  state.stream = es;
  // The live server stops with its run: no reconnecting to it.
  es.onerror = () => {
    es.close();
    if (!state.meta.finished) { state.meta.live = false; state.disconnected = true; status(); }
  };
  es.addEventListener("update", (msg) => {
    const u = JSON.parse(msg.data);
    const atEnd = state.i >= state.frames.length - 1;
    Object.assign(state.meta, { ticks: u.ticks, finished: u.finished, verdict: u.verdict, link_drops: u.link_drops });
    if (u.frame && (!state.frames.length || u.frame.k > state.frames[state.frames.length - 1].k)) {
      state.frames.push(u.frame);
      growBounds(u.frame);
    }
    const p = state.panels;
    for (const key of Object.keys(p)) p[key].push(...u.panels[key]);
    state.events.push(...u.events);
    state.lastTick = state.frames.length ? state.frames[state.frames.length - 1].k : -1;
    state.lastUpdate = performance.now();
    state.charts.forEach((c, j) => c.setData(panelData(p, PANELS[j])));
    show($("follow").checked || atEnd ? state.frames.length - 1 : state.i);
    if (u.finished) es.close();
  });
}

function growBounds(f) {
  const b = map.bounds;
  let grown = false;
  for (const v of f.v) {
    if (v[1] < b[0] || v[1] > b[2] || v[2] < b[1] || v[2] > b[3]) grown = true;
  }
  if (grown) {
    const xs = f.v.map((v) => v[1]).concat([b[0], b[2]]), ys = f.v.map((v) => v[2]).concat([b[1], b[3]]);
    const m = 0.05 * Math.max(Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys));
    map.bounds = [Math.min(...xs) - m, Math.min(...ys) - m, Math.max(...xs) + m, Math.max(...ys) + m];
  }
}

async function load() {
  const get = (u) => fetch(u).then((r) => { if (!r.ok) throw new Error(u + ": " + r.status); return r.json(); });
  const [meta, field, frames, panels, events] = await Promise.all([
    get("/api/meta"), get("/api/field"), get("/api/frames"), get("/api/panels"), get("/api/events")]);
  Object.assign(state, { meta, frames: frames.frames, panels, events: events.events });
  map.bounds = meta.bounds;
  map.lengthUnit = meta.length_unit || "";
  map.fieldLabel = meta.field_label || "T";
  map.setField(field);
  legend();
  buildPanels();
  // A link may name the view and the time: ?view=fleet&t=SECONDS.
  const q = new URLSearchParams(location.search);
  if (q.get("view") === "fleet") { map.mode = "fleet"; $("viewmode").value = "fleet"; }
  let start = meta.finished ? 0 : state.frames.length - 1;
  if (q.has("t")) {
    const t = Number(q.get("t"));
    start = state.frames.findIndex((f) => f.t >= t);
    if (start < 0) start = state.frames.length - 1;
  }
  show(start);
  $("slider").addEventListener("input", (e) => show(Number(e.target.value)));
  $("play").addEventListener("click", () => setPlaying(!state.playing));
  document.addEventListener("keydown", (e) => { if (e.key === " ") { e.preventDefault(); setPlaying(!state.playing); } });
  map.canvas.addEventListener("mousemove", hover);
  map.canvas.addEventListener("mouseleave", () => ($("tip").hidden = true));
  $("viewmode").addEventListener("change", (e) => { map.mode = e.target.value; show(state.i); });
  map.canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    if (map.mode !== "whole") { map.mode = "whole"; $("viewmode").value = "whole"; }
    const r = map.canvas.getBoundingClientRect();
    map.zoom(e.deltaY > 0 ? 1.2 : 1 / 1.2, e.clientX - r.left, e.clientY - r.top);
    show(state.i);
  }, { passive: false });
  let drag = null;
  map.canvas.addEventListener("mousedown", (e) => (drag = [e.clientX, e.clientY]));
  window.addEventListener("mouseup", () => (drag = null));
  map.canvas.addEventListener("mousemove", (e) => {
    if (!drag || map.mode !== "whole") return;
    map.pan(e.clientX - drag[0], e.clientY - drag[1]);
    drag = [e.clientX, e.clientY];
    show(state.i);
  });
  map.canvas.addEventListener("dblclick", () => { map.userBounds = null; show(state.i); });
  window.addEventListener("resize", () => { buildPanels(); show(state.i); });
  $("follow").parentElement.hidden = meta.finished;
  state.lastTick = state.frames.length ? state.frames[state.frames.length - 1].k : -1;
  state.loadedMs = performance.now();
  state.ready = true;
  if (!meta.finished) follow();
  requestAnimationFrame(tick);
}

load().catch((e) => { $("status").textContent = "failed: " + e.message; state.error = String(e); });
