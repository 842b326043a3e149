// SpectraTac live page: rolling force/torque plots against the reference F/T, the sensor
// face with the decoded region, raw counts and link health, and the Snake game.
// Data arrive over /ws (see spectratac/apps/live/messages.py for the message format).
"use strict";

const AXES = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"];
const KEEP_S = 65;  // seconds of data kept for the longest plot window
const ARROWS = { up: "\u2191", down: "\u2193", left: "\u2190", right: "\u2192" };
const TORQUE_COLOURS = ["#1f5fbf", "#e08a00", "#2e7d32"];
// written into the page by the server: control (saves, latency reports, Snake) needs it
const TOKEN = document.querySelector('meta[name="spectratac-token"]').content;
const css = getComputedStyle(document.documentElement);
const PRED = css.getPropertyValue("--pred").trim();
const REF = css.getPropertyValue("--ref").trim();

const stac = {  // the page's state; window.stac for tests and for a look from the console
  meta: null, received: 0, paused: false, windowS: 20, autoscale: true,
  xs: [], seqs: [], pred: AXES.map(() => []), ref: AXES.map(() => []),
  latency: [], latencyBatch: [], arrivals: [], raw: {}, last: null, snake: null,
  snakeSteps: 0, litRegion: null, plots: {}, dirty: false, refsReceived: 0,
  stats: null, yRanges: {}, duplicates: 0, refused: [],
};
window.stac = stac;

const $ = (id) => document.getElementById(id);
const fmt = (v, d) => (v === null || v === undefined || Number.isNaN(v) ? "—" : v.toFixed(d));

// ---------------------------------------------------------------- tabs and controls
for (const tab of document.querySelectorAll(".tab")) {
  tab.addEventListener("click", () => showTab(tab.dataset.tab));
}
function showTab(name) {
  for (const t of document.querySelectorAll(".tab")) t.classList.toggle("active", t.dataset.tab === name);
  for (const p of document.querySelectorAll(".page")) p.classList.toggle("active", p.id === "page-" + name);
  if (name === "live") resizePlots();
  history.replaceState(null, "", "#" + name);
}
$("pause").addEventListener("click", () => {
  stac.paused = !stac.paused;
  $("pause").textContent = stac.paused ? "Resume" : "Pause";
  $("pause").classList.toggle("on", stac.paused);
  stac.dirty = true;
});
$("rescale").addEventListener("click", () => { stac.yRanges = {}; fitY(true); });
$("autoscale").addEventListener("change", (e) => { stac.autoscale = e.target.checked; stac.dirty = true; });
$("window").addEventListener("change", (e) => { stac.windowS = Number(e.target.value); stac.dirty = true; });
$("save").addEventListener("click", async () => {
  const body = { seconds: Number($("save-seconds").value), format: $("save-format").value };
  $("save").disabled = true;  // one save at a time from this page
  $("save-result").textContent = "saving…";
  try {
    const r = await fetch("/api/save", {
      method: "POST", body: JSON.stringify(body),
      headers: { "Content-Type": "application/json", "X-SpectraTac-Token": TOKEN },
    });
    const j = await r.json();
    $("save-result").textContent = r.ok ? `saved ${j.path}` : `not saved: ${j.error}`;
  } catch (err) {
    $("save-result").textContent = `not saved: ${err}`;
  } finally {
    $("save").disabled = false;
  }
});
$("snake-restart").addEventListener("click", () => send({ type: "snake_restart" }));
$("tare").addEventListener("click", () => send({ type: "tare" }));

// ---------------------------------------------------------------- plots (uPlot)
function plotOpts(key, series, height, legend) {
  return {
    width: 600, height, legend: { show: legend, live: false },
    cursor: { sync: { key: "forces" }, drag: { x: false, y: false } },
    scales: { x: { time: false }, y: { auto: false, range: () => stac.yRanges[key] || [-1, 1] } },
    axes: [{ size: 30 }, { size: 64, label: key === "T" ? "torque (N·m)" : `${key} (N)`, labelSize: 18 }],
    series: [{ label: "t (s)" }, ...series],
  };
}
function forceSeries(axis) {
  return [
    { label: axis, stroke: PRED, width: 1.6, spanGaps: false },
    { label: "reference", stroke: REF, width: 1.6, dash: [6, 4], spanGaps: false },
  ];
}
function torqueSeries() {
  const pred = AXES.slice(3).map((a, i) => ({ label: a, stroke: TORQUE_COLOURS[i], width: 1.6 }));
  const ref = AXES.slice(3).map((a, i) => ({ label: a + " ref", stroke: TORQUE_COLOURS[i], width: 1.4, dash: [6, 4] }));
  return [...pred, ...ref];
}
function makePlots() {
  for (const a of ["Fx", "Fy", "Fz"]) {
    stac.plots[a] = new uPlot(plotOpts(a, forceSeries(a), 140, false), [[], [], []], $("plot-" + a));
  }
  stac.plots.T = new uPlot(plotOpts("T", torqueSeries(), 180, true), [[], [], [], [], [], [], []], $("plot-T"));
  resizePlots();
}
function resizePlots() {
  for (const [k, p] of Object.entries(stac.plots)) {
    const el = $("plot-" + k);
    if (el.clientWidth > 0) p.setSize({ width: el.clientWidth, height: p.height });
  }
}
window.addEventListener("resize", resizePlots);

function visible(values) {  // finite values on screen
  const t1 = stac.xs.length ? stac.xs[stac.xs.length - 1] : 0;
  const out = [];
  for (let i = stac.xs.length - 1; i >= 0 && stac.xs[i] >= t1 - stac.windowS; i--) {
    for (const v of values) { const y = v[i]; if (y !== null && Number.isFinite(y)) out.push(y); }
  }
  return out;
}
function rangeOf(ys, minSpan) {
  if (!ys.length) return [-minSpan, minSpan];
  let lo = Math.min(...ys), hi = Math.max(...ys);
  const pad = Math.max((hi - lo) * 0.1, minSpan / 2);
  return [lo - pad, hi + pad];
}
function plotValues(key) {
  if (key === "T") return [3, 4, 5].flatMap((i) => [stac.pred[i], stac.ref[i]]);
  const i = AXES.indexOf(key);
  return [stac.pred[i], stac.ref[i]];
}
function fitY(force) {
  for (const key of Object.keys(stac.plots)) {
    if (force || stac.autoscale || !stac.yRanges[key]) {
      stac.yRanges[key] = rangeOf(visible(plotValues(key)), key === "T" ? 0.004 : 0.5);
    }
  }
  stac.dirty = true;
}
function redraw() {
  if (stac.dirty && !stac.paused && stac.xs.length) {
    stac.dirty = false;
    fitY(false);
    const t1 = stac.xs[stac.xs.length - 1];
    // copies: a paused view (and a resize while paused) keeps showing what it showed
    const xs = stac.xs.slice(), pred = stac.pred.map((a) => a.slice()), ref = stac.ref.map((a) => a.slice());
    const scale = { min: Math.max(t1 - stac.windowS, stac.xs[0]), max: Math.max(t1, stac.xs[0] + 1) };
    for (const a of ["Fx", "Fy", "Fz"]) {
      const i = AXES.indexOf(a);
      const p = stac.plots[a];
      p.batch(() => {
        p.setData([xs, pred[i], ref[i]], false);
        p.setScale("x", scale);
        p.setScale("y", { min: stac.yRanges[a][0], max: stac.yRanges[a][1] });
      });
    }
    const T = stac.plots.T;
    T.batch(() => {
      T.setData([xs, pred[3], pred[4], pred[5], ref[3], ref[4], ref[5]], false);
      T.setScale("x", scale);
      T.setScale("y", { min: stac.yRanges.T[0], max: stac.yRanges.T[1] });
    });
  }
  requestAnimationFrame(redraw);
}

// ---------------------------------------------------------------- the sensor face
const SVG = "http://www.w3.org/2000/svg";
function svgEl(tag, attrs, parent) {
  const el = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  parent.appendChild(el);
  return el;
}
function polar(r, deg) { const a = (deg * Math.PI) / 180; return [r * Math.cos(a), -r * Math.sin(a)]; }
function buildFace(g) {
  const face = $("face");
  face.innerHTML = "";
  svgEl("circle", { cx: 0, cy: 0, r: g.disc_mm, class: "rim" }, face);
  const ri = g.centre_mm, ro = g.active_mm;
  for (const [region, centre] of Object.entries(g.sectors_deg)) {
    const [x0, y0] = polar(ro, centre - 22.5), [x1, y1] = polar(ro, centre + 22.5);
    const [x2, y2] = polar(ri, centre + 22.5), [x3, y3] = polar(ri, centre - 22.5);
    const d = `M${x0},${y0} A${ro},${ro} 0 0 0 ${x1},${y1} L${x2},${y2} A${ri},${ri} 0 0 1 ${x3},${y3} Z`;
    svgEl("path", { d, class: "region", "data-region": region }, face);
    const [tx, ty] = polar(ri + 0.33 * (ro - ri), centre);  // inside the sensors and LEDs
    svgEl("text", { x: tx, y: ty, "data-label": region }, face).textContent = region;
  }
  svgEl("circle", { cx: 0, cy: 0, r: ri, class: "region", "data-region": "5" }, face);
  svgEl("text", { x: 0, y: 0, "data-label": "5" }, face).textContent = "5";
  for (const [i, a] of g.sensors_deg.entries()) {
    const [x, y] = polar(g.ring_mm, a);
    svgEl("rect", { x: x - 0.35, y: y - 0.35, width: 0.7, height: 0.7, class: "sensor" }, face)
      .appendChild(document.createElementNS(SVG, "title")).textContent = `colour sensor ${i}`;
  }
  for (const [i, a] of g.leds_deg.entries()) {
    const [x, y] = polar(g.ring_mm, a);
    svgEl("circle", { cx: x, cy: y, r: 0.36, class: "led" }, face)
      .appendChild(document.createElementNS(SVG, "title")).textContent = `RGB LED ${i}`;
  }
}
function showRegion(msg) {
  const lit = msg.contact && !msg.invalid && msg.region > 0 ? msg.region : null;
  if (lit !== stac.litRegion) {
    for (const el of document.querySelectorAll("#face .region")) el.classList.remove("lit");
    for (const el of document.querySelectorAll("#face text")) el.classList.remove("on");
    if (lit) {
      document.querySelector(`#face .region[data-region="${lit}"]`).classList.add("lit");
      document.querySelector(`#face text[data-label="${lit}"]`).classList.add("on");
    }
    stac.litRegion = lit;
  }
  if (lit) document.querySelector(`#face .region[data-region="${lit}"]`).style.fillOpacity = 0.3 + 0.7 * (msg.p || 0);
  $("region-label").textContent = lit ? `region ${lit} · ${Math.round(100 * (msg.p || 0))} %` : "no contact";
  $("flag-contact").classList.toggle("on", msg.contact);
  $("flag-ood").classList.toggle("on", msg.ood);
  $("flag-invalid").classList.toggle("on", msg.invalid);
  $("flag-no-rest").classList.toggle("on", !!msg.no_rest);
  const f = msg.force;
  $("readout").textContent = `Fx ${fmt(f[0], 2)}  Fy ${fmt(f[1], 2)}  Fz ${fmt(f[2], 2)} N`;
}

// ---------------------------------------------------------------- raw counts and link
const CHANNELS = ["R", "G", "B", "C"];
const STATUS_BITS = [[1, "saturated"], [2, "bus fault"], [4, "stale"], [8, "absent"]];
function showRaw(msg) {
  stac.raw[msg.step] = msg;
  const steps = Object.keys(stac.raw).map(Number).sort((a, b) => a - b);
  const head = $("raw").tHead, body = $("raw").tBodies[0];
  if (head.rows.length === 0 || head.rows[0].cells.length !== steps.length + 1) {
    head.innerHTML = "<tr><th></th>" + steps.map((s) => `<th>step ${s}</th>`).join("") + "</tr>";
    body.innerHTML = "";
    for (let k = 0; k < 12; k++) {
      const tr = body.insertRow();
      tr.innerHTML = `<th>S${Math.floor(k / 4)} ${CHANNELS[k % 4]}</th>` + steps.map(() => "<td></td>").join("");
    }
  }
  const warnings = [];
  for (const [j, s] of steps.entries()) {
    const m = stac.raw[s];
    for (let k = 0; k < 12; k++) {
      const td = body.rows[k].cells[j + 1];
      td.textContent = m.counts[k];
      td.className = m.saturated[k] ? "sat" : (k % 4 === 3 && m.dark[Math.floor(k / 4)] ? "dark" : "");
    }
    m.saturated.forEach((sat, k) => { if (sat) warnings.push(`sensor ${Math.floor(k / 4)} ${CHANNELS[k % 4]} saturated (65535) at step ${s}`); });
    m.dark.forEach((dark, i) => { if (dark) warnings.push(`sensor ${i} dark (Clear < 20 counts) at step ${s}`); });
    m.status.forEach((bits, i) => {
      for (const [bit, name] of STATUS_BITS) if (bits & bit && bit !== 1) warnings.push(`sensor ${i}: ${name}`);
    });
  }
  const text = [...new Set(warnings)].map((w) => `<li>${w}</li>`).join("");
  if ($("warnings").innerHTML !== text) $("warnings").innerHTML = text;
}
function percentile(values, q) {
  if (!values.length) return null;
  const s = [...values].sort((a, b) => a - b);
  return s[Math.min(s.length - 1, Math.floor(q * s.length))];
}
function showLink() {
  const now = performance.now();
  stac.arrivals = stac.arrivals.filter((t) => t > now - 2000);
  const s = stac.stats || {}, link = s.link || {}, echo = s.echo || {};
  const rows = [
    ["rate", `${(stac.arrivals.length / 2).toFixed(1)} /s`],
    ["samples", link.samples ?? "—"],
    ["lost", link.lost ?? "—", link.lost > 0],
    ["frame errors", link.errors ?? "—", link.errors > 0],
    ["buffer overflows", link.overflows ?? "—", link.overflows > 0],
    ["reconnects", link.reconnects ?? "—", link.reconnects > 0],
  ];
  if (s.ft) rows.push(["F/T samples", s.ft.received], ["F/T lost", s.ft.lost, s.ft.lost > 0]);
  const lat = stac.latency;
  rows.push(["to browser p50 / p99", `${fmt(percentile(lat, 0.5), 1)} / ${fmt(percentile(lat, 0.99), 1)} ms`]);
  rows.push(["WebSocket echo p50 / p99", `${fmt(echo.p50_ms, 1)} / ${fmt(echo.p99_ms, 1)} ms`]);
  if (s.error) rows.push(["error", s.error, true]);
  $("link").innerHTML = rows.map(([k, v, bad]) => `<dt>${k}</dt><dd class="${bad ? "bad" : ""}">${v}</dd>`).join("");
}
setInterval(showLink, 500);

// ---------------------------------------------------------------- Snake
function buildKeypad(meta) {
  const map = meta.snake.mapping;
  $("keypad").innerHTML = [1, 2, 3, 4, 5, 6, 7, 8, 9].map((r) => {
    const d = map[String(r)];
    return `<div data-region="${r}"><b>${ARROWS[d] || "\u00b7"}</b><small>${r} ${d === "none" ? "neutral" : d}</small></div>`;
  }).join("");
  $("snake-help").textContent = `A command fires when the normal force exceeds ${meta.threshold_n.toFixed(1)} N ` +
    `(re-armed below ${meta.release_n.toFixed(1)} N): one press, one command.`;
}
function showSnakeInput(msg) {
  const normal = msg.force[2] === null ? 0 : -msg.force[2];
  const thr = stac.meta.threshold_n, full = 4 * thr;
  $("forcebar-fill").style.width = `${Math.max(0, Math.min(1, normal / full)) * 100}%`;
  $("forcebar-fill").classList.toggle("over", normal > thr);
  $("forcebar-threshold").style.left = `${(thr / full) * 100}%`;
  $("snake-force").textContent = `normal force ${fmt(normal, 2)} N · region ${msg.region > 0 ? msg.region : "—"}`;
  for (const el of document.querySelectorAll("#keypad div")) {
    el.classList.toggle("lit", msg.contact && normal > thr && Number(el.dataset.region) === msg.region);
  }
}
function showSnake(state, commands) {
  stac.snake = state;
  stac.snakeSteps = state.steps;
  const cv = $("snake-board"), ctx = cv.getContext("2d");
  const cell = Math.floor(Math.min(cv.width / state.width, cv.height / state.height));
  const ox = (cv.width - cell * state.width) / 2, oy = (cv.height - cell * state.height) / 2;
  ctx.fillStyle = "#10161f"; ctx.fillRect(0, 0, cv.width, cv.height);
  ctx.strokeStyle = "#1c2533";
  for (let x = 0; x <= state.width; x++) { ctx.beginPath(); ctx.moveTo(ox + x * cell, oy); ctx.lineTo(ox + x * cell, oy + cell * state.height); ctx.stroke(); }
  for (let y = 0; y <= state.height; y++) { ctx.beginPath(); ctx.moveTo(ox, oy + y * cell); ctx.lineTo(ox + cell * state.width, oy + y * cell); ctx.stroke(); }
  ctx.fillStyle = "#e5484d";
  ctx.beginPath(); ctx.arc(ox + (state.food[0] + 0.5) * cell, oy + (state.food[1] + 0.5) * cell, cell * 0.35, 0, 2 * Math.PI); ctx.fill();
  state.body.forEach(([x, y], i) => {
    ctx.fillStyle = i === 0 ? "#7ee787" : "#2ea043";
    ctx.fillRect(ox + x * cell + 2, oy + y * cell + 2, cell - 4, cell - 4);
  });
  if (!state.alive) {
    ctx.fillStyle = "rgba(0,0,0,.6)"; ctx.fillRect(0, 0, cv.width, cv.height);
    ctx.fillStyle = "#fff"; ctx.font = "bold 36px system-ui"; ctx.textAlign = "center";
    ctx.fillText("Game over", cv.width / 2, cv.height / 2);
  }
  $("snake-status").textContent = `score ${state.score} · length ${state.body.length} · heading ${ARROWS[state.direction]}` +
    (!state.alive ? " · game over: press a direction to play again" : state.started === false ? " · press a direction to start" : "");
  if (state.commands) {
    $("snake-commands").innerHTML = [...state.commands].reverse().map((c) =>
      `<li>${c.direction ? ARROWS[c.direction] + " " + c.direction : "neutral"} · region ${c.region} · ${c.force_n.toFixed(2)} N · t ${c.time.toFixed(2)} s</li>`).join("");
  }
}

// ---------------------------------------------------------------- messages
// Index of `key` in the increasing `seqs`, or -1: sequence numbers may have gaps (a page
// that joined late, messages dropped for a slow page), so search rather than subtract.
function indexOfSeq(seqs, key) {
  let lo = 0, hi = seqs.length - 1;
  while (lo <= hi) {
    const mid = (lo + hi) >> 1;
    if (seqs[mid] === key) return mid;
    if (seqs[mid] < key) lo = mid + 1; else hi = mid - 1;
  }
  return -1;
}
stac.indexOfSeq = indexOfSeq;
function onEstimate(msg) {
  // an estimate seen already (or older than the newest) would break the increasing order
  if (stac.seqs.length && msg.seq <= stac.seqs[stac.seqs.length - 1]) { stac.duplicates += 1; return; }
  const arrived = performance.timeOrigin + performance.now();
  const lat = arrived - msg.arrival_ms;
  stac.latency.push(lat); stac.latencyBatch.push(lat);
  if (stac.latency.length > 2000) stac.latency.splice(0, stac.latency.length - 2000);
  stac.arrivals.push(performance.now());
  stac.received += 1;
  stac.last = msg;
  stac.xs.push(msg.t);
  stac.seqs.push(msg.seq);
  const values = [...msg.force, ...msg.torque];
  AXES.forEach((_, i) => { stac.pred[i].push(values[i]); stac.ref[i].push(null); });
  for (const [key, , ...wrench] of msg.refs || []) {
    const idx = indexOfSeq(stac.seqs, key);
    if (idx >= 0) {
      wrench.forEach((v, i) => { stac.ref[i][idx] = v; });
      stac.refsReceived += 1;
    }
  }
  while (stac.xs.length > 2 && stac.xs[0] < msg.t - KEEP_S) {
    stac.xs.shift(); stac.seqs.shift();
    for (const a of stac.pred) a.shift();
    for (const a of stac.ref) a.shift();
  }
  if (msg.mae) {
    $("mae").textContent = "running MAE  " + AXES.map((a, i) =>
      `${a} ${fmt(msg.mae[a], i < 3 ? 3 : 4)}`).join("  ") + "  (N, N·m)";
  }
  stac.dirty = true;
  showRegion(msg);
  showRaw(msg);
  showSnakeInput(msg);
  if (msg.snake) showSnake(msg.snake);
}
stac.onEstimate = onEstimate;  // for tests: replay a message
function onMeta(meta) {
  stac.meta = meta;
  const m = meta.model;
  $("source").textContent = `${meta.url}${meta.ft_url ? "  +  F/T " + meta.ft_url : ""}  ·  model ${m.path || ""} (${m.targets.join(", ")})`;
  buildFace(meta.geometry);
  buildKeypad(meta);
  showSnake(meta.snake);
}

let socket = null;
function send(obj) { if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(obj)); }
function connect() {
  socket = new WebSocket(`ws://${location.host}/ws?token=${encodeURIComponent(TOKEN)}`);
  socket.onopen = () => { $("conn").textContent = "live"; $("conn").className = "badge on"; };
  socket.onclose = () => { $("conn").textContent = "offline"; $("conn").className = "badge off"; setTimeout(connect, 1000); };
  socket.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    switch (msg.type) {
      case "estimate": onEstimate(msg); break;
      case "ping": send({ type: "pong", id: msg.id }); break;
      case "stats": stac.stats = msg; break;
      case "meta": onMeta(msg); break;
      case "snake": showSnake(msg.snake); break;
      case "refused": stac.refused.push(msg); console.warn("server refused a message:", msg.message); break;
      case "error": stac.stats = { ...(stac.stats || {}), error: msg.message }; break;
    }
  };
}
setInterval(() => {
  if (stac.latencyBatch.length) { send({ type: "latency", values: stac.latencyBatch }); stac.latencyBatch = []; }
}, 1000);

makePlots();
connect();
requestAnimationFrame(redraw);
if (location.hash === "#snake") showTab("snake");
