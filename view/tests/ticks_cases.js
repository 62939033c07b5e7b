// The viewer's ticks (view/assets/ticks.js) on the cases the report is tested on
// (report/src/plot/chart/ticks_cases.json), and its scale bar and time labels.
// Run by view/tests/ticks_js.rs: `node view/tests/ticks_cases.js`; exits 1 naming each failure.
"use strict";
const fs = require("fs");
const path = require("path");
const T = require("../assets/ticks.js");

const root = path.join(__dirname, "..", "..");
const { cases } = JSON.parse(fs.readFileSync(path.join(root, "report/src/plot/chart/ticks_cases.json"), "utf8"));
const failures = [];
const same = (what, got, want) => {
  if (JSON.stringify(got) !== JSON.stringify(want)) failures.push(`${what}: got ${JSON.stringify(got)}, want ${JSON.stringify(want)}`);
};

for (const c of cases) {
  const what = `ticks of ${JSON.stringify({ lo: c.lo, hi: c.hi, target: c.target, time: c.time })}`;
  const t = c.time ? T.time(c.lo, c.hi, c.target) : T.linear(c.lo, c.hi, c.target);
  same(what, t.labels, c.labels);
  if (c.time) same(`${what} unit`, t.unit.symbol, c.unit);
  if (new Set(t.labels).size !== t.labels.length) failures.push(`${what}: two ticks read the same: ${t.labels}`);
}
if (cases.length < 10) failures.push(`only ${cases.length} cases`);

// A glider run of 11.11 h: ticks every 2 h, at whole hours in seconds.
const g = T.time(0, 40000, 6);
same("11.11 h in seconds", g.values, [0, 7200, 14400, 21600, 28800, 36000]);
same("time labels", [T.fmtTime(20000, 40000), T.fmtTime(259200, 259200), T.fmtTime(12.5, 20)], ["5.56 h", "72 h", "12.5 s"]);
same("scale bars", [T.scaleBar(2600, "m").label, T.scaleBar(480, "m").label, T.scaleBar(0.7, "").label],
  ["2 km", "200 m", "0.5 L"]);

if (failures.length) {
  console.error(failures.join("\n"));
  process.exit(1);
}
console.log(`ticks.js: ${cases.length} shared cases and the scale bar pass`);
