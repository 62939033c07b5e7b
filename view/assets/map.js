// The map of a run on a canvas: the field (colour map and contours, its colour bar), trails,
// the virtual body, the design slots and the formation outline, the vehicles by contact
// state, comms pulses, the optimum, a scale bar. Hand-written, no library (ticks.js for
// round numbers).
"use strict";

const CONTACT_COLOURS = ["#2ca02c", "#17becf", "#1f4e9c", "#ff7f0e", "#777777", "#d62728", "#000000"];
const CONTACT_NAMES = ["in contact", "surfaced", "submerged", "link down", "dead", "rejoining", "unknown"];

// A light sequential colour scale (white to mid grey-beige), t in [0, 1]: the vehicles'
// colours stay readable on any part of the field.
function fieldColour(t) {
  const stops = [[255, 255, 255], [240, 237, 228], [222, 215, 198], [196, 186, 164], [160, 150, 128]];
  t = Math.min(1, Math.max(0, t)) * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(t)), f = t - i;
  return stops[i].map((c, j) => Math.round(c + f * (stops[i + 1][j] - c)));
}

// Contour segments of a grid at a level (marching squares), in grid coordinates.
function contourSegments(v, nx, ny, level) {
  const segs = [];
  const lerp = (a, b) => (level - a) / (b - a);
  for (let r = 0; r < ny - 1; r++) {
    for (let c = 0; c < nx - 1; c++) {
      const a = v[r * nx + c], b = v[r * nx + c + 1], d = v[(r + 1) * nx + c], e = v[(r + 1) * nx + c + 1];
      const pts = [];
      if ((a < level) !== (b < level)) pts.push([c + lerp(a, b), r]);
      if ((b < level) !== (e < level)) pts.push([c + 1, r + lerp(b, e)]);
      if ((d < level) !== (e < level)) pts.push([c + lerp(d, e), r + 1]);
      if ((a < level) !== (d < level)) pts.push([c, r + lerp(a, d)]);
      if (pts.length >= 2) segs.push([pts[0], pts[1]]);
      if (pts.length === 4) segs.push([pts[2], pts[3]]);
    }
  }
  return segs;
}

// Convex hull (monotone chain) of [x, y] points.
function hull(points) {
  const p = points.slice().sort((a, b) => a[0] - b[0] || a[1] - b[1]);
  if (p.length < 3) return p;
  const cross = (o, a, b) => (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
  const lower = [], upper = [];
  for (const q of p) {
    while (lower.length >= 2 && cross(lower[lower.length - 2], lower[lower.length - 1], q) <= 0) lower.pop();
    lower.push(q);
  }
  for (const q of p.slice().reverse()) {
    while (upper.length >= 2 && cross(upper[upper.length - 2], upper[upper.length - 1], q) <= 0) upper.pop();
    upper.push(q);
  }
  return lower.slice(0, -1).concat(upper.slice(0, -1));
}

class RunMap {
  constructor(canvas) {
    this.canvas = canvas;
    this.bounds = [0, 0, 1, 1];
    this.field = null;      // the /api/field grid
    this.fieldImages = [];  // one offscreen canvas per field time
    this.drawn = [];        // [{id, px, py, vehicle}] of the last draw (hover, tests)
    this.mode = "whole";    // "whole": the map (zoom with the wheel, drag to pan); "fleet": follow the fleet
    this.userBounds = null; // the map zoomed or panned by the user
    this.lengthUnit = "";   // the mission's length unit ("m"; "" non-dimensional)
    this.fieldLabel = "T";  // the field's label with its unit ("T (°C)")
    this.overlay = {};      // what the scale bar and colour bar said in the last draw (tests)
  }

  // The region shown for frame f.
  viewBounds(f) {
    if (this.mode === "fleet" && f) {
      const pts = f.v.map((v) => [v[1], v[2]]).concat(f.s);
      if (f.b) pts.push([f.b[0], f.b[1]]);
      const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
      const x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
      const r = 0.7 * Math.max(x1 - x0, y1 - y0, 1e-9), cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
      return [cx - r, cy - r, cx + r, cy + r];
    }
    return this.userBounds || this.bounds;
  }

  // Zooms by `factor` (< 1: in) about canvas pixel (px, py).
  zoom(factor, px, py) {
    const [x0, y0, x1, y1] = this.shown, x = this.wx(px), y = this.wy(py);
    this.userBounds = [x + (x0 - x) * factor, y + (y0 - y) * factor, x + (x1 - x) * factor, y + (y1 - y) * factor];
  }

  // Moves the map by (dx, dy) canvas pixels.
  pan(dx, dy) {
    const [x0, y0, x1, y1] = this.shown, s = this.scale;
    this.userBounds = [x0 - dx / s, y0 + dy / s, x1 - dx / s, y1 + dy / s];
  }

  setField(grid) {
    this.field = grid;
    this.fieldImages = grid.values.map((vals) => {
      const img = document.createElement("canvas");
      img.width = grid.nx; img.height = grid.ny;
      const cx = img.getContext("2d");
      const data = cx.createImageData(grid.nx, grid.ny);
      const span = grid.max - grid.min || 1;
      for (let r = 0; r < grid.ny; r++) {
        for (let c = 0; c < grid.nx; c++) {
          const [R, G, B] = fieldColour((vals[r * grid.nx + c] - grid.min) / span);
          const o = ((grid.ny - 1 - r) * grid.nx + c) * 4;  // row 0 is the bottom
          data.data[o] = R; data.data[o + 1] = G; data.data[o + 2] = B; data.data[o + 3] = 255;
        }
      }
      cx.putImageData(data, 0, 0);
      const levels = [];
      for (let i = 1; i < 12; i++) levels.push(grid.min + span * i / 12);
      return { img, contours: levels.map((l) => contourSegments(vals, grid.nx, grid.ny, l)) };
    });
  }

  // World (x, y) to canvas pixels, equal scales, y up.
  layout(bounds) {
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight, dpr = window.devicePixelRatio || 1;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr); this.canvas.height = Math.round(h * dpr);
    }
    const [x0, y0, x1, y1] = bounds;
    const s = Math.min(w / (x1 - x0), h / (y1 - y0));
    const ox = (w - s * (x1 - x0)) / 2, oy = (h - s * (y1 - y0)) / 2;
    this.px = (x) => ox + s * (x - x0);
    this.py = (y) => h - oy - s * (y - y0);
    this.wx = (px) => x0 + (px - ox) / s;
    this.wy = (py) => y0 + (h - oy - py) / s;
    this.scale = s;
    this.shown = [x0 - ox / s, y0 - oy / s, x0 + (w - ox) / s, y0 + (h - oy) / s];
    return dpr;
  }

  drawField(cx, t) {
    const g = this.field;
    if (!g || !this.fieldImages.length) return;
    let i = 0;
    for (let j = 0; j < g.times.length; j++) if (Math.abs(g.times[j] - t) < Math.abs(g.times[i] - t)) i = j;
    const { img, contours } = this.fieldImages[i];
    const X0 = this.px(g.x0), Y1 = this.py(g.y1), W = this.px(g.x1) - X0, H = this.py(g.y0) - Y1;
    cx.imageSmoothingEnabled = true;
    cx.drawImage(img, X0, Y1, W, H);
    const gx = (c) => this.px(g.x0 + (g.x1 - g.x0) * c / (g.nx - 1));
    const gy = (r) => this.py(g.y0 + (g.y1 - g.y0) * r / (g.ny - 1));
    cx.strokeStyle = "rgba(0,0,0,0.25)"; cx.lineWidth = 1;
    cx.beginPath();
    for (const segs of contours) for (const [a, b] of segs) { cx.moveTo(gx(a[0]), gy(a[1])); cx.lineTo(gx(b[0]), gy(b[1])); }
    cx.stroke();
  }

  // Draws frame `i` of `frames` with trails of `trail` frames.
  draw(frames, i, trail) {
    const dpr = this.layout(this.viewBounds(frames[i]));
    const cx = this.canvas.getContext("2d");
    cx.setTransform(dpr, 0, 0, dpr, 0, 0);
    cx.fillStyle = "#fff"; cx.fillRect(0, 0, this.canvas.width, this.canvas.height);
    const f = frames[i];
    this.drawn = [];
    if (!f) return;
    this.drawField(cx, f.t);
    const from = Math.max(0, i - trail);
    // The body's path so far, and the vehicles' trails.
    cx.strokeStyle = "rgba(0,0,0,0.6)"; cx.lineWidth = 1.5; cx.setLineDash([4, 3]);
    cx.beginPath();
    let started = false;
    for (let j = 0; j <= i; j++) {
      const b = frames[j].b; if (!b) continue;
      if (!started) { cx.moveTo(this.px(b[0]), this.py(b[1])); started = true; } else cx.lineTo(this.px(b[0]), this.py(b[1]));
    }
    cx.stroke(); cx.setLineDash([]);
    const trails = new Map();
    for (let j = from; j <= i; j++) for (const v of frames[j].v) {
      if (!trails.has(v[0])) trails.set(v[0], []);
      trails.get(v[0]).push([this.px(v[1]), this.py(v[2])]);
    }
    cx.lineWidth = 1.2;
    for (const [id, pts] of trails) {
      cx.strokeStyle = `hsla(${(id * 137.5) % 360}, 60%, 35%, 0.55)`;
      cx.beginPath(); pts.forEach((p, k) => (k ? cx.lineTo(p[0], p[1]) : cx.moveTo(p[0], p[1]))); cx.stroke();
    }
    // The formation outline through the design slots, and the slots.
    if (f.s.length >= 2) {
      const h = hull(f.s);
      cx.strokeStyle = "rgba(120,0,160,0.7)"; cx.lineWidth = 1; cx.setLineDash([2, 2]);
      cx.beginPath(); h.forEach((p, k) => (k ? cx.lineTo(this.px(p[0]), this.py(p[1])) : cx.moveTo(this.px(p[0]), this.py(p[1]))));
      cx.closePath(); cx.stroke(); cx.setLineDash([]);
    }
    cx.strokeStyle = "rgba(120,0,160,0.9)";
    for (const s of f.s) { cx.beginPath(); cx.arc(this.px(s[0]), this.py(s[1]), 6, 0, 2 * Math.PI); cx.stroke(); }
    // The optimum.
    if (f.o) {
      const x = this.px(f.o[0]), y = this.py(f.o[1]);
      cx.strokeStyle = "#c00"; cx.lineWidth = 2;
      cx.beginPath(); cx.moveTo(x - 7, y); cx.lineTo(x + 7, y); cx.moveTo(x, y - 7); cx.lineTo(x, y + 7); cx.stroke();
      cx.beginPath(); cx.arc(x, y, 9, 0, 2 * Math.PI); cx.stroke();
    }
    // The virtual body.
    if (f.b) {
      cx.fillStyle = "#000";
      cx.beginPath(); cx.arc(this.px(f.b[0]), this.py(f.b[1]), 4, 0, 2 * Math.PI); cx.fill();
    }
    // Comms pulses: rings on vehicles whose report reached the coordinator in the last frames.
    for (let j = Math.max(0, i - 3); j <= i; j++) {
      const age = i - j;
      for (const v of frames[j].v) if (v[6]) {
        cx.strokeStyle = `rgba(255,200,0,${0.9 - 0.2 * age})`; cx.lineWidth = 2;
        cx.beginPath(); cx.arc(this.px(v[1]), this.py(v[2]), 9 + 5 * age, 0, 2 * Math.PI); cx.stroke();
      }
    }
    // What the links did (bits of v[7], frames.rs): an acoustic frame sent (a purple ring
    // fading over the next frames), an Iridium session opened (green) or failed (red) as a
    // short bar above the vehicle.
    for (let j = Math.max(0, i - 3); j <= i; j++) {
      const age = i - j;
      for (const v of frames[j].v) if ((v[7] || 0) & 4) {
        cx.strokeStyle = `rgba(106,61,154,${0.8 - 0.2 * age})`; cx.lineWidth = 1.5;
        cx.beginPath(); cx.arc(this.px(v[1]), this.py(v[2]), 12 + 6 * age, 0, 2 * Math.PI); cx.stroke();
      }
    }
    for (const v of f.v) {
      const bits = v[7] || 0;
      if (bits & 3) {
        cx.fillStyle = bits & 1 ? "#1a9850" : "#d73027";
        cx.fillRect(this.px(v[1]) - 6, this.py(v[2]) - 14, 12, 3);
      }
    }
    // The vehicles.
    for (const v of f.v) {
      const x = this.px(v[1]), y = this.py(v[2]), c = CONTACT_COLOURS[v[3]] || "#000";
      if (v[3] === 4) {
        cx.strokeStyle = c; cx.lineWidth = 2.5;
        cx.beginPath(); cx.moveTo(x - 5, y - 5); cx.lineTo(x + 5, y + 5); cx.moveTo(x + 5, y - 5); cx.lineTo(x - 5, y + 5); cx.stroke();
      } else {
        cx.fillStyle = c; cx.strokeStyle = "#fff"; cx.lineWidth = 1.5;
        cx.beginPath(); cx.arc(x, y, 6, 0, 2 * Math.PI); cx.fill(); cx.stroke();
      }
      cx.fillStyle = "#000"; cx.font = "11px system-ui"; cx.fillText(String(v[0]), x + 8, y - 6);
      this.drawn.push({ id: v[0], px: x, py: y, vehicle: v });
    }
    this.drawScaleBar(cx);
    this.drawColourBar(cx);
  }

  // A scale bar in the bottom-left corner: a round length (1, 2 or 5 × 10^k) about a fifth
  // of the map's width, labelled with its unit ("2 km").
  drawScaleBar(cx) {
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight;
    const bar = VbapTicks.scaleBar((this.shown[2] - this.shown[0]) / 5, this.lengthUnit);
    const px = bar.length * this.scale, x = 14, y = h - 16;
    if (!(px > 0 && px < w)) return;
    cx.fillStyle = "rgba(255,255,255,0.85)";
    cx.fillRect(x - 6, y - 24, px + 12, 32);
    cx.strokeStyle = "#000"; cx.lineWidth = 2;
    cx.beginPath(); cx.moveTo(x, y - 5); cx.lineTo(x, y); cx.lineTo(x + px, y); cx.lineTo(x + px, y - 5); cx.stroke();
    cx.fillStyle = "#000"; cx.font = "12px system-ui"; cx.textAlign = "center";
    cx.fillText(bar.label, x + px / 2, y - 9);
    cx.textAlign = "start";
    this.overlay.scaleBar = { label: bar.label, px };
  }

  // The field's colour bar in the top-right corner: the colour scale of the map from the
  // field's smallest to its largest value, ticks at round values, the field's label.
  drawColourBar(cx) {
    const g = this.field;
    if (!g || !(g.max > g.min)) return;
    const w = this.canvas.clientWidth, bw = 14, bh = Math.min(160, this.canvas.clientHeight / 3);
    const x = w - 70, y = 30;
    const ticks = VbapTicks.linear(g.min, g.max, 4);
    cx.fillStyle = "rgba(255,255,255,0.85)";
    cx.fillRect(x - 10, y - 24, 78, bh + 34);
    for (let i = 0; i < bh; i++) {
      const [R, G, B] = fieldColour(1 - i / (bh - 1));
      cx.fillStyle = `rgb(${R},${G},${B})`;
      cx.fillRect(x, y + i, bw, 1);
    }
    cx.strokeStyle = "#000"; cx.lineWidth = 1; cx.strokeRect(x, y, bw, bh);
    cx.fillStyle = "#000"; cx.font = "11px system-ui";
    for (let j = 0; j < ticks.values.length; j++) {
      const ty = y + bh * (1 - (ticks.values[j] - g.min) / (g.max - g.min));
      cx.beginPath(); cx.moveTo(x + bw, ty); cx.lineTo(x + bw + 4, ty); cx.stroke();
      cx.fillText(ticks.labels[j], x + bw + 6, ty + 4);
    }
    cx.font = "12px system-ui";
    cx.fillText(this.fieldLabel, x - 6, y - 9);
    this.overlay.colourBar = { label: this.fieldLabel, ticks: ticks.labels };
  }

  // The vehicle drawn nearest to (x, y) canvas pixels, within 12 px.
  pick(x, y) {
    let best = null, bd = 144;
    for (const d of this.drawn) {
      const e = (d.px - x) ** 2 + (d.py - y) ** 2;
      if (e < bd) { bd = e; best = d; }
    }
    return best;
  }
}

window.RunMap = RunMap;
window.CONTACT_COLOURS = CONTACT_COLOURS;
window.CONTACT_NAMES = CONTACT_NAMES;
