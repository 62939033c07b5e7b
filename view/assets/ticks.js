// Axis ticks that read at a glance, by the rules of the report's pictures
// (report/src/plot/chart/ticks.rs, report/src/plot/style.rs; both are tested on the same
// cases, report/src/plot/chart/ticks_cases.json): steps of 1, 2, 2.5 or 5 × 10^k; a time
// axis in the unit that suits its range (s up to 15 min, min up to 3 h, h up to 4 days, d
// beyond) at steps of the clock (every 6 h, 15 min, ...); labels with as many decimals as
// the step needs, so two ticks never read the same. Used by the page (app.js, map.js) and
// by node in the tests (view/tests/ticks_js.rs).
"use strict";

(function (root) {
  // Time units: symbol, length (s), the longest span (s) an axis reads in it, its steps.
  const UNITS = [
    { symbol: "s", seconds: 1, upTo: 900, steps: [1, 2, 5, 10, 15, 20, 30, 60] },
    { symbol: "min", seconds: 60, upTo: 3 * 3600, steps: [1, 2, 5, 10, 15, 20, 30, 60] },
    { symbol: "h", seconds: 3600, upTo: 4 * 86400, steps: [1, 2, 3, 6, 12, 24] },
    { symbol: "d", seconds: 86400, upTo: Infinity, steps: [] },
  ];

  // The unit of a time axis spanning `spanS` seconds.
  function timeUnit(spanS) {
    const s = Math.abs(spanS);
    if (!Number.isFinite(s)) return UNITS[0];
    return UNITS.find((u) => s <= u.upTo);
  }

  // 10^k, exact (Math.pow(10, -5) is not 1e-5 in every engine; the parser's is).
  const pow10 = (k) => Number(`1e${k}`);

  // The smallest nice step (1, 2, 2.5, 5 or 10 × 10^k) not below `raw` (> 0).
  function niceStep(raw) {
    const mag = pow10(Math.floor(Math.log10(raw)));
    const f = raw / mag;
    const m = f <= 1 ? 1 : f <= 2 ? 2 : f <= 2.5 ? 2.5 : f <= 5 ? 5 : 10;
    return m * mag;
  }

  // A step of about span / target in `unit` (a time unit's own steps first), or 1-2-5.
  function stepFor(span, target, unit) {
    const raw = Math.abs(span) / Math.max(target, 1);
    if (!(Number.isFinite(raw) && raw > 0)) return 1;
    if (!unit) return niceStep(raw);
    const own = unit.steps.find((s) => s >= raw && raw >= 0.5);
    return own === undefined ? niceStep(raw) : own;
  }

  // Tick values from lo to hi (both included when on a step) `step` apart.
  function values(lo, hi, step) {
    const out = [];
    let v = Math.ceil(lo / step - 1e-9) * step;
    while (v <= hi + step * 1e-9) {
      out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
      v += step;
    }
    return out;
  }

  // 1 when `step` is 2.5 × 10^k (it needs one digit more than its power of ten).
  function quarter(step) {
    const m = step / pow10(Math.floor(Math.log10(step)));
    return Math.abs(m - 2.5) < 1e-6 ? 1 : 0;
  }

  // The label of tick `v` on an axis whose ticks are `step` apart: "0.25", "7.5", "200";
  // scientific outside [1e-4, 1e6) with the digits the step needs ("1.001e-5"); never "-0".
  function fmtTick(v, step) {
    if (v === 0) return "0";
    const a = Math.abs(v);
    if (!(a >= 1e-4 && a < 1e6)) {
      const apart = Math.max(0, Math.floor(Math.log10(a)) - Math.floor(Math.log10(Math.abs(step))));
      const digits = Math.min(15, Math.max(1, apart + quarter(Math.abs(step))));
      return v.toExponential(digits).replace("e+", "e").replace(".0e", "e");
    }
    let decimals;
    if (step >= 1) decimals = Math.abs(step % 1) > 1e-9 ? 1 : 0;
    else decimals = Math.max(0, Math.ceil(-Math.log10(step) - 1e-9)) + quarter(step);
    const s = v.toFixed(decimals);
    return s.startsWith("-") && s.replace(/[-0.]/g, "") === "" ? "0" : s;
  }

  // Ticks of a value axis over [lo, hi], about `target` of them: {values, step, labels}.
  function linear(lo, hi, target) {
    const step = stepFor(Math.max(hi - lo, Number.MIN_VALUE), target);
    const vs = values(lo, hi, step);
    return { values: vs, step, labels: vs.map((v) => fmtTick(v, step)) };
  }

  // Ticks of a time axis over [loS, hiS] seconds: {unit, values (s), step (in the unit),
  // labels (numbers in the unit, without its symbol)}.
  function time(loS, hiS, target) {
    const unit = timeUnit(hiS - loS);
    const lo = loS / unit.seconds, hi = hiS / unit.seconds;
    const step = stepFor(Math.max(hi - lo, Number.MIN_VALUE), target, unit);
    const vs = values(lo, hi, step);
    return { unit, values: vs.map((v) => v * unit.seconds), step, labels: vs.map((v) => fmtTick(v, step)) };
  }

  // A time `t` (s) in the unit of a span `spanS`, to 3 significant digits: "36 h", "12.4 s".
  function fmtTime(t, spanS) {
    const unit = timeUnit(spanS);
    const x = t / unit.seconds;
    const d = x === 0 ? 0 : Math.min(3, Math.max(0, 2 - Math.floor(Math.log10(Math.abs(x)))));
    return `${String(+x.toFixed(d))} ${unit.symbol}`;
  }

  // A length of about `target` (> 0) in `unit` ("m", or "" when non-dimensional) rounded
  // to 1, 2 or 5 × 10^k, for a scale bar: {length (in the unit), label ("2 km", "500 m", "0.5")}.
  function scaleBar(target, unit) {
    const mag = pow10(Math.floor(Math.log10(target)));
    const m = [5, 2, 1].find((k) => k * mag <= target) || 1;
    const length = m * mag;
    let label;
    if (unit === "m" && length >= 1000) label = `${fmtTick(length / 1000, length / 1000)} km`;
    else label = `${fmtTick(length, length)}${unit ? " " + unit : " L"}`;
    return { length, label };
  }

  const api = { UNITS, timeUnit, niceStep, fmtTick, linear, time, fmtTime, scaleBar };
  root.VbapTicks = api;
  if (typeof module !== "undefined" && module.exports) module.exports = api;
})(typeof window !== "undefined" ? window : globalThis);
