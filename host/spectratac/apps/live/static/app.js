// SpectraTac live page: rolling force/torque plots against the reference F/T, raw counts per
// sensor and channel, the sensor face with the decoded region, link health, and the Snake game.
// Every plot zooms (drag, wheel), pans (shift+drag) and reads out values at the cursor in its
// legend; "Follow live" (or a double-click) returns to the newest data. Without a model the
// page shows raw counts and the reference only. Data arrive over /ws (see
// spectratac/apps/live/messages.py for the message format; thresholds come in the meta).
"use strict";

const AXES = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"];
const KEEP_S = 65;  // seconds of data kept for the longest plot window
const ARROWS = { up: "\u2191", down: "\u2193", left: "\u2190", right: "\u2192" };
const TORQUE_COLOURS = ["#1f5fbf", "#e08a00", "#2e7d32"];
const CHANNEL_COLOURS = { R: "#d0342c", G: "#2e7d32", B: "#1f5fbf", C: "#6b7483", IR: "#8e44ad" };
// written into the page by the server: control (saves, Tare, Snake) needs it
const TOKEN = document.querySelector('meta[name="spectratac-token"]').content;
const css = getComputedStyle(document.documentElement);
const PRED = css.getPropertyValue("--pred").trim();
const REF = css.getPropertyValue("--ref").trim();

const stac = {  // the page's state; window.stac for tests and for a look from the console
  meta: null, received: 0, paused: false, windowS: 20, autoscale: true, follow: true, view: null, countsFit: false,
  xs: [], seqs: [], steps: [], pred: AXES.map(() => []), ref: AXES.map(() => []), counts: [],
  rawStep: null, rawSteps: [], latency: [], latencyBatch: [], bare: [], bareBatch: [], handleBatch: [], redrawBatch: [], pending: [], lastSeq: -1, batches: 0, arrivals: [], raw: {}, last: null,
  snake: null, snakeSteps: 0, litRegion: null, plots: {}, dirty: false, refsReceived: 0,
  stats: null, yRanges: {}, duplicates: 0, refused: [], dead: null,
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
  // plots out of view are not drawn: keep what they would show now for when they come in
  for (const [key, p] of Object.entries(stac.plots)) p.frozen = stac.paused && !p.visible ? plotColumns(key, p) : null;
  $("pause").textContent = stac.paused ? "Resume" : "Pause";
  $("pause").classList.toggle("on", stac.paused);
  stac.dirty = true;
});
$("follow").addEventListener("click", followLive);
$("rescale").addEventListener("click", () => { stac.yRanges = {}; fitY(true); });
$("autoscale").addEventListener("change", (e) => { stac.autoscale = e.target.checked; stac.dirty = true; });
$("window").addEventListener("change", (e) => { stac.windowS = Number(e.target.value); followLive(); });
$("counts-fit").addEventListener("change", (e) => { stac.countsFit = e.target.checked; stac.dirty = true; });
$("raw-step").addEventListener("change", (e) => { stac.rawStep = Number(e.target.value); stac.dirty = true; });
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
// stac.plots[key] = {u: the uPlot, columns(): its data arrays, minSpan, counts: a raw plot}
function legendOpts() {
  // the legend is the cursor read-out; its marks are line samples, dashed for a reference
  return { show: true, live: true, markers: {
    dash: (u, i) => (u.series[i].dash ? "dashed" : "solid"), fill: () => "transparent" } };
}
function plotOpts(yLabel, series, height, extra = {}) {
  return {
    width: 600, height, legend: legendOpts(),
    cursor: {
      // the cursor moves on every plot at once; a drag selects in its own plot only
      sync: { key: "stac", filters: { pub: (type) => type !== "mousedown" && type !== "mouseup" } },
      drag: { x: true, y: false, setScale: false },  // a drag selects a time span: zoom to it
      bind: {
        dblclick: () => () => { followLive(); return null; },
        mousedown: (u, targ, handler) => (e) => {
          if (e.shiftKey || e.button === 1) { startPan(u, e); return null; }
          if (e.button === 0) handler(e);
          return null;
        },
      },
    },
    scales: { x: { time: false, auto: false }, y: extra.y || { auto: false } },
    axes: [
      { label: "time (s)", labelSize: 16, size: 36 },
      { size: 64, label: yLabel, labelSize: 18, ...(extra.yAxis || {}) },
    ],
    series: [{ label: "time (s)", value: (u, v) => (v == null ? "—" : v.toFixed(2)) }, ...series],
    hooks: { setSelect: [zoomToSelection], ready: [(u) => u.over.addEventListener("wheel", (e) => wheelZoom(u, e), { passive: false })],
             ...(extra.hooks || {}) },
  };
}
const num = (d) => (u, v) => (v == null ? "—" : v.toFixed(d));
function forceSeries(axis, withModel) {
  const ref = { label: `${axis} reference`, stroke: REF, width: 1.6, dash: [6, 4], spanGaps: false, value: num(3) };
  if (!withModel) return [ref];
  return [{ label: `${axis} estimate`, stroke: PRED, width: 1.6, spanGaps: false, value: num(3) }, ref];
}
function torqueSeries(withModel) {
  const ref = AXES.slice(3).map((a, i) => ({ label: a + " ref", stroke: TORQUE_COLOURS[i], width: 1.4, dash: [6, 4], value: num(4) }));
  if (!withModel) return ref;
  return [...AXES.slice(3).map((a, i) => ({ label: a, stroke: TORQUE_COLOURS[i], width: 1.6, value: num(4) })), ...ref];
}
function addPlot(key, parent, opts, columns, minSpan, counts = false) {
  const el = document.createElement("div");
  el.id = "plot-" + key; el.className = "plot";
  const old = $("plot-" + key);
  if (old) old.replaceWith(el); else parent.appendChild(el);
  const u = new uPlot(opts, columns(), el);
  stac.plots[key] = { u, columns, minSpan, counts, visible: false, stale: true, frozen: null };
  inView.observe(el);
}
function makePlots(meta) {
  const withModel = meta.model !== null, withRef = meta.ft_url !== null;
  if (withRef || withModel) {
    for (const a of ["Fx", "Fy", "Fz"]) {
      const i = AXES.indexOf(a);
      const cols = withModel ? () => [stac.xs, stac.pred[i], stac.ref[i]] : () => [stac.xs, stac.ref[i]];
      addPlot(a, $("panel-force"), plotOpts(`${a} (N)`, forceSeries(a, withModel), 120), cols, 0.5);
    }
    const tcols = withModel ? () => [stac.xs, ...stac.pred.slice(3), ...stac.ref.slice(3)] : () => [stac.xs, ...stac.ref.slice(3)];
    addPlot("T", $("panel-torque"), plotOpts("torque (N·m)", torqueSeries(withModel), 160), tcols, 0.004);
  }
  const raw = meta.raw, n = raw.channels.length;
  for (let s = 0; s < raw.sensors; s++) {
    const series = raw.channels.map((c, k) => ({ label: c, stroke: CHANNEL_COLOURS[c] || "#333", width: 1.3,
      spanGaps: true, value: num(0), _k: s * n + k }));
    const opts = plotOpts(`sensor ${s} counts`, series, 190, {
      // asinh: linear near 0, logarithmic above, so the dark level and full scale both show
      y: { distr: 4, asinh: 1, auto: false, range: (u, lo, hi) => [lo, hi] },
      yAxis: { splits: countSplits, values: (u, vs) => vs.map((v) => (v == null ? "" : v.toLocaleString("en"))) },
      hooks: { drawClear: [(u) => drawBands(u, raw)] },
    });
    addPlot("S" + s, $("raw-plots"), opts, () => [stac.xs, ...raw.channels.map((_, k) => stac.counts[s * n + k])], 100, true);
  }
  resizePlots();
}
function countSplits(u, axis, min, max) {  // decades over the whole range, else round steps
  const decades = [0, 10, 100, 1000, 10000, 100000].filter((v) => v >= min && v <= max);
  if (decades.length >= 4) return decades;
  const raw = (max - min) / 4, mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((f) => f * mag).find((v) => v >= raw);
  const out = [];
  for (let v = Math.ceil(min / step) * step; v <= max; v += step) out.push(v);
  return out;
}
function drawBands(u, raw) {  // the saturation and dark bands, from the meta's thresholds
  const { ctx } = u, { left, top, width } = u.bbox;
  const y0 = u.valToPos(0, "y", true), yDark = u.valToPos(raw.dark_counts, "y", true);
  const ySat = u.valToPos(raw.full_scale, "y", true);
  ctx.save();
  ctx.fillStyle = "rgba(198, 40, 40, 0.13)"; ctx.fillRect(left, top, width, ySat - top);
  ctx.fillStyle = "rgba(39, 75, 143, 0.13)"; ctx.fillRect(left, yDark, width, y0 - yDark);
  ctx.font = `${11 * devicePixelRatio}px system-ui`; ctx.textAlign = "right";
  const x = left + width - 4 * devicePixelRatio;
  if (ySat > top) { ctx.fillStyle = "#a02020"; ctx.textBaseline = "bottom"; ctx.fillText(`saturated ≥ ${raw.full_scale}`, x, ySat - 1); }
  if (yDark < y0) { ctx.fillStyle = "#274b8f"; ctx.textBaseline = "top"; ctx.fillText(`dark: ${raw.dark_channel} < ${raw.dark_counts}`, x, yDark + 1); }
  ctx.restore();
}
function resizePlots() {
  for (const { u } of Object.values(stac.plots)) {
    const el = u.root.parentElement;
    if (el && el.clientWidth > 0) u.setSize({ width: el.clientWidth, height: u.height });
  }
}
window.addEventListener("resize", resizePlots);

// ---------------------------------------------------------------- zoom, pan, follow live
function setView(min, max) {
  if (!(max > min)) return;
  stac.follow = false; stac.view = { min, max };
  $("follow").disabled = false;
  stac.dirty = true;
  applyScales();
}
function followLive() {
  stac.follow = true; stac.view = null;
  $("follow").disabled = true;
  stac.dirty = true;
  applyScales();
}
function zoomToSelection(u) {
  const sel = u.select;
  if (sel.width < 3) return;
  const min = u.posToVal(sel.left, "x"), max = u.posToVal(sel.left + sel.width, "x");
  u.setSelect({ left: 0, top: 0, width: 0, height: 0 }, false);
  setView(min, max);
}
function wheelZoom(u, e) {
  e.preventDefault();
  const { min, max } = u.scales.x;
  const at = u.posToVal(e.offsetX, "x"), f = e.deltaY < 0 ? 0.8 : 1.25;
  setView(at - (at - min) * f, at + (max - at) * f);
}
function startPan(u, e) {
  const x0 = e.clientX, { min, max } = u.scales.x, perPx = (max - min) / u.over.clientWidth;
  const move = (ev) => { const d = (ev.clientX - x0) * perPx; setView(min - d, max - d); };
  const up = () => { window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up); };
  window.addEventListener("mousemove", move);
  window.addEventListener("mouseup", up);
}

function xRange(u) {  // the time span a plot shows: the view, or the newest window
  if (!stac.follow && stac.view) return stac.view;
  const xs = u.data[0];
  if (!xs.length) return { min: 0, max: 1 };
  const t1 = xs[xs.length - 1];
  return { min: Math.max(t1 - stac.windowS, xs[0]), max: Math.max(t1, xs[0] + 1) };
}
function shown(u, range) {  // finite values a plot shows in `range`
  const xs = u.data[0], out = [];
  for (let i = xs.length - 1; i >= 0 && xs[i] >= range.min; i--) {
    if (xs[i] > range.max) continue;
    for (let k = 1; k < u.data.length; k++) { const y = u.data[k][i]; if (y !== null && Number.isFinite(y)) out.push(y); }
  }
  return out;
}
function rangeOf(ys, minSpan) {
  if (!ys.length) return [-minSpan, minSpan];
  let lo = Infinity, hi = -Infinity;
  for (const y of ys) { if (y < lo) lo = y; if (y > hi) hi = y; }
  const pad = Math.max((hi - lo) * 0.1, minSpan / 2);
  return [lo - pad, hi + pad];
}
function fitOne(key, p, force) {
  if (p.counts && !stac.countsFit) {  // the whole range of counts, both bands in view
    stac.yRanges[key] = [0, 1.5 * stac.meta.raw.full_scale];
  } else if (force || stac.autoscale || !stac.yRanges[key]) {
    const [lo, hi] = rangeOf(shown(p.u, xRange(p.u)), p.minSpan);
    stac.yRanges[key] = p.counts ? [Math.max(lo, 0), hi] : [lo, hi];
  }
}
function fitY(force) {
  for (const [key, p] of Object.entries(stac.plots)) fitOne(key, p, force);
  stac.dirty = true;
}
function plotColumns(key, p) {
  const cols = p.columns().map((a) => a.slice());  // copies: a paused view keeps what it showed
  return p.counts ? rawColumns(cols) : cols;
}
function refresh(key, p, data) {  // one plot: its data (unless paused), y fit, x and y scales
  p.u.batch(() => {
    if (data && !stac.paused) p.u.setData(plotColumns(key, p), false);
    else if (p.frozen) { p.u.setData(p.frozen, false); p.frozen = null; }
    fitOne(key, p, false);
    p.u.setScale("x", xRange(p.u));
    p.u.setScale("y", { min: stac.yRanges[key][0], max: stac.yRanges[key][1] });
  });
}
// Only plots in view are drawn (a browser's main thread is shared with the messages whose
// latency the page measures); one scrolled into view is brought up to date at once.
function applyScales(data = false) {
  for (const [key, p] of Object.entries(stac.plots)) {
    if (!p.visible) { p.stale = true; continue; }
    refresh(key, p, data || p.stale);
    p.stale = false;
  }
}
const inView = new IntersectionObserver((entries) => {
  for (const e of entries) {
    const p = Object.values(stac.plots).find((q) => q.u.root.parentElement === e.target);
    if (p) { p.visible = e.isIntersecting; if (p.visible) stac.dirty = true; }
  }
});
function rawColumns(cols) {  // with several LED steps, one step's samples (the others null)
  if (stac.rawSteps.length < 2) return cols;
  const keep = stac.steps.map((s) => s === stac.rawStep);
  return [cols[0], ...cols.slice(1).map((a) => a.map((v, i) => (keep[i] ? v : null)))];
}
function redraw() {
  handlePending();
  if (stac.dirty && stac.xs.length) {
    const t0 = performance.now();
    stac.dirty = false;
    applyScales(true);
    stac.redrawBatch.push(performance.now() - t0);  // the main thread's time the messages wait
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
function showRawWarnings(msg) {  // from the newest sample of every LED step
  const raw = stac.meta.raw, n = raw.channels.length;
  stac.raw[msg.step] = msg;
  const warnings = [];
  for (const [s, m] of Object.entries(stac.raw)) {
    m.saturated.forEach((sat, k) => {
      if (sat) warnings.push(`sensor ${Math.floor(k / n)} ${raw.channels[k % n]} saturated (${raw.full_scale}) at step ${s}`);
    });
    m.dark.forEach((dark, i) => { if (dark) warnings.push(`sensor ${i} dark (${raw.dark_channel} < ${raw.dark_counts} counts) at step ${s}`); });
    m.status.forEach((bits, i) => {
      for (const [bit, name] of raw.status_bits) if (bits & bit && name !== "saturated") warnings.push(`sensor ${i}: ${name}`);
    });
  }
  const text = [...new Set(warnings)].map((w) => `<li>${w}</li>`).join("");
  if ($("warnings").innerHTML !== text) $("warnings").innerHTML = text;
}
function noteStep(step) {  // several LED steps: the raw plots show one at a time
  if (stac.rawSteps.includes(step)) return;
  stac.rawSteps.push(step);
  stac.rawSteps.sort((a, b) => a - b);
  if (stac.rawStep === null) stac.rawStep = step;
  $("raw-step").innerHTML = stac.rawSteps.map((s) => `<option value="${s}"${s === stac.rawStep ? " selected" : ""}>${s}</option>`).join("");
  $("raw-step-label").hidden = stac.rawSteps.length < 2;
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
  if (s.ft) {
    rows.push(["F/T samples", s.ft.received]);
    // a simulated F/T sensor drops samples on purpose (its ft_loss): not a fault of the link
    const sim = s.ft.simulated_loss;
    if (sim === null || sim === undefined) rows.push(["F/T lost", s.ft.lost, s.ft.lost > 0]);
    else rows.push(["F/T lost on purpose (simulated)", s.ft.lost, false, `the simulated sensor drops samples with probability ft_loss=${sim}`]);
  }
  const lat = stac.latency;
  rows.push(["latency to browser p50 / p99", `${fmt(percentile(lat, 0.5), 1)} / ${fmt(percentile(lat, 0.99), 1)} ms`,
    false, "from a sample's arrival at the host to this page, over the last 2,000 estimates"]);
  if (stac.meta && stac.meta.benchmark) {  // the benchmark's references (tools/bench/live.py)
    rows.push(["WebSocket alone p50 / p99", `${fmt(percentile(stac.bare, 0.5), 1)} / ${fmt(percentile(stac.bare, 0.99), 1)} ms`,
      false, "a bare message in the estimate's own WebSocket message, timed the same way"]);
    rows.push(["WebSocket echo p50 / p99", `${fmt(echo.p50_ms, 1)} / ${fmt(echo.p99_ms, 1)} ms`, false, "half the round trip"]);
  }
  if (s.error) rows.push(["error", s.error, true]);
  $("link").innerHTML = rows.map(([k, v, bad, why]) => `<dt${why ? ` title="${why}"` : ""}>${k}</dt><dd class="${bad ? "bad" : ""}">${v}</dd>`).join("");
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
function maeRow(name, mae, digitsF, digitsT) {
  return `<tr><th>${name}</th>` + AXES.map((a, i) => `<td>${fmt(mae[a], i < 3 ? digitsF : digitsT)}</td>`).join("") + "</tr>";
}
function showMAE(msg) {  // running MAE overall and during contact (reference |F| >= contact_n)
  const contact = `in contact (reference |F| ≥ ${stac.meta.contact_n} N)`;
  $("mae").innerHTML = `<thead><tr><th>running MAE (N, N·m)</th>${AXES.map((a) => `<th>${a}</th>`).join("")}</tr></thead><tbody>` +
    maeRow("overall", msg.mae, 3, 4) + maeRow(contact, msg.mae_contact || {}, 3, 4) + "</tbody>";
}
// An estimate is stamped the moment its message is handed to the page and queued; the work
// it causes (plot data, the face, Snake) runs for everything queued at the next animation
// frame, which draws it anyway: a burst that arrives after the machine stalled the browser
// is stamped at once and handled in one go, not one message's work after another's.
function noteArrival(msg, arrived) {
  if (msg.seq <= stac.lastSeq) return;  // a repeat: onEstimate counts it, nothing to time
  stac.lastSeq = msg.seq;
  const lat = arrived - msg.arrival_ms;
  stac.latency.push(lat); stac.latencyBatch.push(lat);
  if (stac.latency.length > 2000) stac.latency.splice(0, stac.latency.length - 2000);
  stac.arrivals.push(performance.now());
}
// A benchmark's reference: a probe the server sends in the same message as an estimate, stamped when the
// estimate reached the event loop: what the socket and this page alone cost that message.
function noteBare(msg, arrived) {
  if (typeof msg.sent_ms !== "number") return;
  const lat = arrived - msg.sent_ms;
  stac.bare.push(lat); stac.bareBatch.push(lat);
  if (stac.bare.length > 2000) stac.bare.splice(0, stac.bare.length - 2000);
}
function handlePending() {
  const batch = stac.pending;
  if (!batch.length) return;
  stac.pending = [];
  stac.batches += 1;
  const t0 = performance.now();
  for (const msg of batch) onEstimate(msg);
  stac.handleBatch.push(performance.now() - t0);
}
setInterval(handlePending, 250);  // no animation frames in a hidden tab: keep up anyway
function onEstimate(msg) {
  // an estimate seen already (or older than the newest) would break the increasing order
  if (stac.seqs.length && msg.seq <= stac.seqs[stac.seqs.length - 1]) { stac.duplicates += 1; return; }
  stac.received += 1;
  stac.last = msg;
  stac.xs.push(msg.t);
  stac.seqs.push(msg.seq);
  stac.steps.push(msg.step);
  const values = msg.force ? [...msg.force, ...msg.torque] : AXES.map(() => null);
  AXES.forEach((_, i) => { stac.pred[i].push(values[i]); stac.ref[i].push(null); });
  msg.counts.forEach((c, k) => { (stac.counts[k] || (stac.counts[k] = stac.xs.map(() => null))).push(c); });
  for (const [key, , ...wrench] of msg.refs || []) {
    const idx = indexOfSeq(stac.seqs, key);
    if (idx >= 0) {
      wrench.forEach((v, i) => { stac.ref[i][idx] = v; });
      stac.refsReceived += 1;
    }
  }
  while (stac.xs.length > 2 && stac.xs[0] < msg.t - KEEP_S) {
    stac.xs.shift(); stac.seqs.shift(); stac.steps.shift();
    for (const a of stac.pred) a.shift();
    for (const a of stac.ref) a.shift();
    for (const a of stac.counts) a.shift();
  }
  if (msg.mae) showMAE(msg);
  stac.dirty = true;
  noteStep(msg.step);
  if (stac.meta) showRawWarnings(msg);
  if (msg.force) {
    showRegion(msg);
    showSnakeInput(msg);
  }
  if (msg.snake) showSnake(msg.snake);
}
stac.onEstimate = onEstimate;  // for tests: replay a message
function onMeta(meta) {
  const first = stac.meta === null;
  stac.meta = meta;
  const m = meta.model, withModel = m !== null;
  $("source").textContent = `${meta.url}${meta.ft_url ? "  +  F/T " + meta.ft_url : ""}  ·  ` +
    (withModel ? `model ${m.path || ""} (${m.targets.join(", ")})` : "no model");
  document.body.classList.toggle("no-model", !withModel);
  $("no-model").hidden = withModel;
  $("tare").hidden = !withModel;  // raw counts have no baseline to zero
  if (!withModel) { $("no-model-note").textContent = meta.no_model.note; $("no-model-hint").textContent = meta.no_model.hint; }
  $("panel-region").hidden = !withModel;
  $("tab-snake").hidden = !withModel;
  if (!withModel && location.hash === "#snake") showTab("live");  // no estimates to steer with
  $("panel-force").hidden = $("panel-torque").hidden = !withModel && meta.ft_url === null;
  $("force-title").textContent = withModel ? "Force" : "Reference force";
  $("torque-title").textContent = withModel ? "Torque" : "Reference torque";
  if (!withModel) $("mae").hidden = true;
  if (first) makePlots(meta);
  buildFace(meta.geometry);
  buildKeypad(meta);
  showSnake(meta.snake);
  if (meta.error) showDead(meta.error);
}
// A dead session (the device unplugged, the stream ended with an error): said in a banner
// and on the connection badge; the server stays up, so the page keeps what it plotted.
function showDead(why) {
  stac.dead = why;
  $("dead-why").textContent = why;
  $("dead").hidden = false;
  $("conn").textContent = "ended"; $("conn").className = "badge off";
}

let socket = null;
function send(obj) { if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(obj)); }
function connect() {
  socket = new WebSocket(`ws://${location.host}/ws?token=${encodeURIComponent(TOKEN)}`);
  socket.onopen = () => { if (!stac.dead) { $("conn").textContent = "live"; $("conn").className = "badge on"; } };
  socket.onclose = () => { $("conn").textContent = "offline"; $("conn").className = "badge off"; setTimeout(connect, 1000); };
  socket.onmessage = (ev) => {
    const arrived = performance.timeOrigin + performance.now();
    const data = JSON.parse(ev.data);  // an array: what the server queued in one turn
    for (const msg of Array.isArray(data) ? data : [data]) onMessage(msg, arrived);
  };
}
function onMessage(msg, arrived) {
  switch (msg.type) {
    case "estimate": noteArrival(msg, arrived); stac.pending.push(msg); break;
    case "ping": send({ type: "pong", id: msg.id }); break;
    case "probe": noteBare(msg, arrived); break;
    case "stats": stac.stats = msg; break;
    case "meta": handlePending(); onMeta(msg); break;  // queued estimates first: in order
    case "snake": handlePending(); showSnake(msg.snake); break;
    case "refused": stac.refused.push(msg); console.warn("server refused a message:", msg.message); break;
    case "error": stac.stats = { ...(stac.stats || {}), error: msg.message }; showDead(msg.message); break;
  }
}
// A benchmark's page (meta.benchmark: tools/bench/live.py) reports its latencies once a
// second; any other page keeps them to itself.
setInterval(() => {
  if (stac.meta && stac.meta.benchmark && (stac.latencyBatch.length || stac.bareBatch.length)) {
    // at most the server's limit per list: a tab the browser throttled may have piled up more
    const cut = (a) => a.slice(-4096);
    send({ type: "latency", values: cut(stac.latencyBatch), handle: cut(stac.handleBatch), redraw: cut(stac.redrawBatch),
           bare: cut(stac.bareBatch) });
  }
  stac.latencyBatch = []; stac.handleBatch = []; stac.redrawBatch = []; stac.bareBatch = [];
}, 1000);

connect();
requestAnimationFrame(redraw);
if (location.hash === "#snake") showTab("snake");
