// hydrohil live panel: draws the server's min/max frames on canvases, sends steering requests.
// No libraries: a frame holds at most ~1000 blocks per trace (the server decimates), which a 2D canvas
// draws in well under a millisecond per trace.
"use strict";
const token = new URLSearchParams(location.search).get("token");
const q = token ? "?token=" + encodeURIComponent(token) : "";
const $ = (id) => document.getElementById(id);
let state = null, frame = null, frames = 0, fpsCount = 0, paused = false, view = { window: 10, end_k: null, paused: false };
let pausedAt = null, ws = null;

// what is drawn comes with the state (hydrohil/panel/views.py): the paper's rig or a circuit's signals
let PLOTS = {}, MODES = null;

function buildPlots(view) {
  const list = $("plot-list");
  list.innerHTML = "";
  const add = (id, title, height) => {
    const c = document.createElement("canvas");
    c.id = id; c.dataset.title = title; c.setAttribute("height", height); list.appendChild(c); return c;
  };
  PLOTS = {};
  for (const pl of view.plots) { add(pl.id, pl.title, pl.height); PLOTS[pl.id] = pl.series; }
  MODES = view.modes;
  if (MODES) add("c-modes", MODES.title, Math.max(24, 20 * MODES.rows.length));
  PLOTS["c-jitter"] = [["jitter_us", "#455a64", 1]];            // (its canvas is the page's own, below the list)
  for (const id of [...Object.keys(PLOTS), ...(MODES ? ["c-modes"] : [])]) zoomable($(id));
}

async function api(path, body) {
  const r = await fetch(path + q, body === undefined ? {} :
    { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) });
  const data = await r.json().catch(() => ({ error: r.statusText }));
  if (!r.ok || data.error) { $("message").textContent = "refused: " + (data.error || r.status); throw new Error(data.error); }
  if (body !== undefined) $("message").textContent = "";     // (a change accepted clears the last refusal)
  return data;
}

function connect() {
  ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws" + q);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => ws.send(JSON.stringify(view));
  ws.onmessage = (m) => { frame = parseFrame(m.data); frames++; fpsCount++; $("frames").textContent = frames; draw(); };
  ws.onclose = () => { $("status").textContent = "disconnected"; $("status").className = "pill bad"; setTimeout(connect, 1000); };
}

function parseFrame(buf) {
  const n = new DataView(buf).getUint32(0, true);
  const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
  const nc = head.columns.length, off = 4 + n, len = head.n;
  const lo = new Float32Array(buf, off, nc * len), hi = new Float32Array(buf, off + 4 * nc * len, nc * len);
  head.lo = {}; head.hi = {};
  head.columns.forEach((c, i) => { head.lo[c] = lo.subarray(i * len, (i + 1) * len); head.hi[c] = hi.subarray(i * len, (i + 1) * len); });
  return head;
}

function sizeCanvas(c) {
  const w = c.clientWidth * devicePixelRatio, h = (+c.getAttribute("height")) * devicePixelRatio;
  if (c.width !== w) { c.width = w; c.height = h; c.style.height = c.getAttribute("height") + "px"; }
  const g = c.getContext("2d"); g.setTransform(devicePixelRatio, 0, 0, devicePixelRatio, 0, 0); return g;
}

function xRange(f) {
  const span = f.block * f.h, t1 = (f.b0 + f.n) * span, t0 = Math.max(t1 - f.window, f.b0 * span);
  return [t1 - f.window, t1, t0];
}

// Ticks at round values (1, 2, 2.5 or 5 × 10^k apart, about n of them over [lo, hi]), labelled with as many
// decimals as the step needs: 200 / 400 / 600, not 212.6 / 420.3 / 628.0.
function niceTicks(lo, hi, n) {
  const raw = (hi - lo) / n, mag = Math.pow(10, Math.floor(Math.log10(raw))), r = raw / mag;
  const m = r <= 1 ? 1 : r <= 2 ? 2 : r <= 2.5 ? 2.5 : r <= 5 ? 5 : 10, step = m * mag;
  const dec = Math.min(20, Math.max(0, -Math.floor(Math.log10(step) + 1e-9) + (m === 2.5 ? 1 : 0)));
  const out = [];
  for (let i = Math.ceil(lo / step - 1e-9); i * step <= hi + step * 1e-9; i++) {
    const v = i * step;
    out.push([v, (Math.abs(v) < step * 1e-9 ? 0 : v).toFixed(dec)]);
  }
  return out;
}

function drawPlot(c, series, f) {
  const g = sizeCanvas(c), W = c.clientWidth, H = +c.getAttribute("height"), L = 52, R = 8, T = 14, B = 14;
  g.clearRect(0, 0, W, H);
  g.fillStyle = "#333"; g.font = "11px sans-serif"; g.fillText(c.dataset.title, L, 11);
  if (!f || !f.n) return;
  let ymin = Infinity, ymax = -Infinity;
  for (const [col, , s] of series) {
    const lo = f.lo[col], hi = f.hi[col];
    for (let i = 0; i < f.n; i++) {
      const a = lo[i] * s, b = hi[i] * s;
      if (a === a) { if (a < ymin) ymin = a; if (a > ymax) ymax = a; }
      if (b === b) { if (b < ymin) ymin = b; if (b > ymax) ymax = b; }
    }
  }
  if (!(ymax >= ymin)) return;
  if (ymax - ymin < 1e-9) { ymax += 1; ymin -= 1; }
  const pad = (ymax - ymin) * 0.06; ymin -= pad; ymax += pad;
  const [t0, t1] = xRange(f), span = f.block * f.h;
  const X = (t) => L + (t - t0) / (t1 - t0) * (W - L - R), Y = (v) => T + (ymax - v) / (ymax - ymin) * (H - T - B);
  g.strokeStyle = "#eee"; g.fillStyle = "#666"; g.lineWidth = 1;
  for (const [v, label] of niceTicks(ymin, ymax, 4)) {
    const y = Y(v);
    g.beginPath(); g.moveTo(L, y); g.lineTo(W - R, y); g.stroke(); g.fillText(label, 2, y + 4);
  }
  g.fillText(t0.toFixed(2) + " s", L, H - 2); g.fillText(t1.toFixed(2) + " s", W - R - 50, H - 2);
  for (const [col, color, s, dash] of series) {
    const lo = f.lo[col], hi = f.hi[col];
    g.strokeStyle = color; g.setLineDash(dash || []); g.lineWidth = 1.2; g.beginPath();
    let pen = false;
    for (let i = 0; i < f.n; i++) {
      const a = lo[i], b = hi[i];
      if (a !== a) { pen = false; continue; }
      const x = X((f.b0 + i + 0.5) * span);
      if (!pen) { g.moveTo(x, Y(b * s)); pen = true; } else g.lineTo(x, Y(b * s));
      if (b !== a) g.lineTo(x, Y(a * s));
    }
    g.stroke(); g.setLineDash([]);
  }
  let lx = W - R - 10;
  for (let j = series.length - 1; j >= 0; j--) {
    const txt = series[j][0]; lx -= g.measureText(txt).width + 18;
    g.fillStyle = series[j][1]; g.fillRect(lx, 4, 12, 3); g.fillStyle = "#333"; g.fillText(txt, lx + 14, 11);
  }
}

function drawModes(c, f) {
  const g = sizeCanvas(c), W = c.clientWidth, H = +c.getAttribute("height"), L = 52, R = 8, T = 14;
  g.clearRect(0, 0, W, H); g.fillStyle = "#333"; g.font = "11px sans-serif"; g.fillText(c.dataset.title, L, 11);
  if (!f || !f.n) return;
  const [t0, t1] = xRange(f), span = f.block * f.h, rows = MODES.rows;
  const hRow = (H - T - 2) / rows.length, X = (t) => L + (t - t0) / (t1 - t0) * (W - L - R);
  rows.forEach(([col, label, colors, names], r) => {
    g.fillStyle = "#666"; g.fillText(label.slice(0, 8), 2, T + r * hRow + hRow * 0.7);
    let last = null;
    for (let i = 0; i < f.n; i++) {
      const a = f.lo[col][i], b = f.hi[col][i];
      if (a !== a) continue;
      last = a === b ? a : null;
      g.fillStyle = a === b ? colors[a % colors.length] || "#999" : "#9e9e9e";
      const x0 = X((f.b0 + i) * span), x1 = X((f.b0 + i + 1) * span);
      g.fillRect(x0, T + r * hRow, Math.max(x1 - x0, 1), hRow - 1);
    }
    if (last !== null && names[last] !== undefined) {          // the mode now, by name, at the strip's right end
      g.fillStyle = "#333"; const txt = names[last]; g.fillText(txt, W - R - g.measureText(txt).width - 2, T + r * hRow + hRow * 0.7);
    }
  });
}

function drawHist(c, f) {
  const g = sizeCanvas(c), W = c.clientWidth, H = +c.getAttribute("height"), L = 40, B = 14, T = 14;
  g.clearRect(0, 0, W, H); g.fillStyle = "#333"; g.font = "11px sans-serif"; g.fillText(c.dataset.title, L, 11);
  const h = f && f.jitter_hist; if (!h || !h.total) return;
  const n = h.counts.length, lmax = Math.log10(Math.max(...h.counts) + 1), bw = (W - L - 8) / n;
  h.counts.forEach((v, i) => {
    const bh = Math.log10(v + 1) / lmax * (H - T - B);
    g.fillStyle = i === 0 ? "#90a4ae" : "#546e7a"; g.fillRect(L + i * bw, H - B - bh, Math.max(bw - 1, 1), bh);
  });
  g.fillStyle = "#666";
  [[1, "≤0"], [11, "1 µs"], [21, "10 µs"], [31, "100 µs"], [41, "1 ms"]].forEach(([i, s]) => g.fillText(s, L + i * bw, H - 2));
  g.fillText("log", 2, T + 10);
}

function draw() {
  const f = frame;
  if (!f) return;
  for (const [id, series] of Object.entries(PLOTS)) drawPlot($(id), series, f);
  if (MODES) drawModes($("c-modes"), f);
  drawHist($("c-hist"), f);
  if (f.k_max >= 0) $("tplant").textContent = (f.k_max * f.h).toFixed(2);
  const c = f.counters, rows = [["steps", c.steps], ["overruns", c.overruns], ["late commands", c.late_commands],
    ["watchdog trips", c.watchdog_trips + " (" + c.watchdog_trips_unexplained + " unexplained)"],
    ["watchdog now", f.n && f.hi.watchdog[f.n - 1] > 0 ? "ACTIVE" : "ok"], ["packets lost", c.packets_lost],
    ["telemetry lost", c.telemetry_lost_steps + " steps"], ["jitter max", (c.jitter_max_ns / 1e3).toFixed(1) + " µs"]];
  $("counters").innerHTML = rows.map(([k, v]) => `<tr><td>${k}</td><td>${v}</td></tr>`).join("");
}

// -- zoom while paused ------------------------------------------------------------------------------
let drag = null;
function zoomable(c) {
  c.addEventListener("mousedown", (e) => { if (paused && frame) drag = { c, x0: e.offsetX }; });
  c.addEventListener("mouseup", (e) => {
    if (!drag || !frame) return;
    const W = c.clientWidth, [t0, t1] = xRange(frame), tx = (x) => t0 + (x - 52) / (W - 60) * (t1 - t0);
    const a = tx(Math.min(drag.x0, e.offsetX)), b = tx(Math.max(drag.x0, e.offsetX)); drag = null;
    if (b - a > 0.005) { view.window = Math.max(b - a, 0.5); view.end_k = Math.round(b / frame.h); sendView(); }
  });
  c.addEventListener("dblclick", () => { if (paused) { view.window = +$("window").value; view.end_k = pausedAt; sendView(); } });
}
function sendView() { if (ws && ws.readyState === 1) ws.send(JSON.stringify(view)); }

$("window").onchange = () => { view.window = +$("window").value; sendView(); };
$("pause").onclick = () => {
  paused = !paused; $("pause").textContent = paused ? "live" : "pause";
  pausedAt = paused && frame ? frame.k_max : null;
  view.paused = paused; view.end_k = paused ? pausedAt : null; view.window = +$("window").value; sendView();
};
$("start").onclick = () => api("/api/run/start", {}).then(refresh);
$("stop").onclick = () => api("/api/run/stop", {}).then(refresh);
// the built-in controller takes gains, a held reference and a reset (not a Python one, not an open loop's)
const steerableController = () => state.controller === "builtin" && state.controller_type !== "python" &&
  !(state.view.kind === "circuit" && !state.view.reference);
$("reset").onclick = () => api("/api/steer", { op: "reset" }).then(() => steerableController() &&
  api("/api/steer", { op: "reset", target: "controller" }).catch(() => 0)).then(refresh);
$("record").onclick = () => api(state && state.recording ? "/api/record/stop" : "/api/record/start", {}).then(refresh);
// the reference in its display unit: mm on the paper's rig, the measured signal's on a circuit
const refShown = () => (state && state.view.reference ? state.view.reference.shown : [1e3, "mm"]);
$("ref-hold").onclick = () => api("/api/steer", { op: "reference", value: +$("ref-value").value / refShown()[0] }).then(refresh);
$("ref-scenario").onclick = () => api("/api/steer", { op: "reference", value: null }).then(refresh);
$("fault-type").onchange = buildFaultFields;
$("fault-on").onclick = () => {
  const type = $("fault-type").value, fault = { type };
  for (const inp of $("fault-fields").querySelectorAll("[data-name]")) {
    if (inp.value === "") continue;
    const v = inp.tagName === "SELECT" ? inp.value : +inp.value;
    fault[inp.dataset.name] = inp.tagName === "SELECT" && /^\d+$/.test(v) ? +v : v;
  }
  api("/api/steer", { op: "fault_on", fault }).then(refresh);
};

// tunables in display units: pressure in bar
const UNIT = { supply_pressure: [1e5, "bar"], mass: [1, "kg"], force: [1, "N"], friction_scale: [1, "–"] };  // SI per unit shown
function buildForms() {
  $("tunables").innerHTML = state.tunable_schema.map((t) => {
    const [s, u] = UNIT[t.name] || [1, t.unit];
    return `<div class="row" title="${t.description}"><label>${t.name.replace("_", " ")} [${u}]</label>` +
      `<input id="tun-${t.name}" type="number" step="any" value="${+(state.tunables[t.name] / s).toPrecision(6)}">` +
      `<button id="set-${t.name}">set</button></div>`;
  }).join("");
  // a field being edited is not overwritten by the applied value until it is set (or the set is refused)
  for (const t of state.tunable_schema) {
    const inp = $("tun-" + t.name);
    inp.onfocus = inp.oninput = () => { inp.dataset.edited = "1"; };
    $("set-" + t.name).onclick = () => api("/api/steer", { op: "set", name: t.name,
      value: +inp.value * (UNIT[t.name] || [1])[0] }).finally(() => { delete inp.dataset.edited; }).then(refresh);
  }
  const gains = Object.keys(state.gains);
  $("controller-box").style.display = steerableController() ? "" : "none";
  $("gains").innerHTML = gains.map((g) => `<div class="row"><label>${g}</label>` +
    `<input id="gain-${g}" type="number" step="any" value="${state.gains[g]}"><button id="set-${g}">set</button></div>`).join("");
  for (const g of gains) {
    const inp = $("gain-" + g);
    inp.onfocus = inp.oninput = () => { inp.dataset.edited = "1"; };
    $("set-" + g).onclick = () => api("/api/steer", { op: "gains", [g]: +inp.value }).finally(() => { delete inp.dataset.edited; }).then(refresh);
  }
  $("ref-label").textContent = `reference [${refShown()[1]}]`;
  $("tunables-box").style.display = state.tunable_schema.length ? "" : "none";
  $("faults-box").style.display = state.fault_schema.length ? "" : "none";
  $("fault-type").innerHTML = state.fault_schema.map((f) => `<option>${f.type}</option>`).join("");
  buildFaultFields();
  buildPlots(state.view);
  if (state.view.kind === "circuit") buildCircuitForms(state.view);
}
// a circuit: its inputs held from the page (or back on their drive), any parameter changed (display units)
function buildCircuitForms(cv) {
  const free = cv.inputs.filter((i) => !i.controller);
  $("inputs-box").style.display = free.length ? "" : "none";
  $("inputs").innerHTML = free.map((i) => `<div class="row" title="${i.description} (${i.lo}..${i.hi} ${i.unit})">` +
    `<label>${i.name} [${i.shown[1]}]</label><input id="in-${i.name}" type="number" step="any">` +
    `<button id="hold-${i.name}">hold</button><button id="free-${i.name}">drive</button></div>`).join("");
  for (const i of free) {
    const inp = $("in-" + i.name);
    inp.onfocus = inp.oninput = () => { inp.dataset.edited = "1"; };
    $("hold-" + i.name).onclick = () => api("/api/steer", { op: "input", name: i.name, value: +inp.value / i.shown[0] })
      .finally(() => { delete inp.dataset.edited; }).then(refresh);
    $("free-" + i.name).onclick = () => api("/api/steer", { op: "input", name: i.name, value: null }).then(refresh);
  }
  $("circuit-faults-box").style.display = cv.faults.length ? "" : "none";
  $("params-box").style.display = cv.params.length ? "" : "none";
  $("param-name").innerHTML = cv.params.map((q) => `<option>${q.name}</option>`).join("");
  const current = () => cv.params.find((q) => q.name === $("param-name").value);
  const show = () => {
    const q = current(); if (!q) return;
    const v = state.values[q.name] !== undefined ? state.values[q.name] : q.value;     // (null: not given)
    const shown = (x, none) => (x === null ? none : +(x * q.shown[0]).toPrecision(6));
    $("param-label").textContent = `[${q.shown[1]}]`;
    $("param-value").value = shown(v, "");
    $("param-info").textContent = `${q.description}; ${shown(q.lo, "−∞")} .. ${shown(q.hi, "∞")} ${q.shown[1]}` +
      (v === null ? " (not given)" : "");
  };
  $("param-name").onchange = show; show();
  $("param-set").onclick = () => { const q = current(); api("/api/steer", { op: "set", name: q.name, value: +$("param-value").value / q.shown[0] }).then(refresh); };
}
function buildFaultFields() {
  const f = state.fault_schema.find((x) => x.type === $("fault-type").value);
  if (!f) { $("fault-fields").innerHTML = ""; return; }
  $("fault-fields").innerHTML = f.fields.map((fl) => `<div class="row" title="${fl.description}"><label>${fl.name}</label>` +
    (fl.kind === "choice" ? `<select data-name="${fl.name}">${fl.choices.map((c) => `<option>${c}</option>`).join("")}</select>`
      : `<input data-name="${fl.name}" type="number" step="any" value="${fl.default ?? ""}" placeholder="${fl.description}">`) + "</div>").join("");
}

// text from the scenario file or a message, as text in the page's HTML
const esc = (t) => String(t).replace(/[&<>"']/g, (ch) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[ch]);
// lists are rebuilt only when they change (a button being clicked is never replaced under the pointer)
function setHTML(id, html) { if ($(id).dataset.html !== html) { $(id).innerHTML = html; $(id).dataset.html = html; } }

async function refresh() {
  const first = state === null;
  state = await api("/api/state");
  if (first) {
    buildForms();
    $("scenario").textContent = state.scenario + (state.plant === "c" ? " · C plant" : " · Python plant");
  }
  // the values applied (from this page or another) shown, except in the field being edited
  for (const t of state.tunable_schema) {
    const inp = $("tun-" + t.name), v = +(state.tunables[t.name] / (UNIT[t.name] || [1])[0]).toPrecision(6);
    if (inp && !inp.dataset.edited && +inp.value !== v) inp.value = v;
  }
  for (const [g, v] of Object.entries(state.gains)) {
    const inp = $("gain-" + g);
    if (inp && !inp.dataset.edited && +inp.value !== v) inp.value = v;
  }
  for (const i of (state.view.inputs || [])) {               // a held input shows its value, else blank (its drive)
    const inp = $("in-" + i.name);
    if (!inp || inp.dataset.edited) continue;
    inp.placeholder = "drive";
    inp.value = state.held[i.name] !== undefined ? +(state.held[i.name] * i.shown[0]).toPrecision(6) : "";
  }
  const st = $("status");
  st.textContent = state.running ? (state.lockstep ? "running (lock-step)" : "running") : (state.ended ? "ended" : "stopped");
  st.className = "pill " + (state.running ? "ok" : "warn");
  const v = state.verdict, vd = $("verdict");
  vd.textContent = v ? v.verdict + (v.reasons.length ? ": " + v.reasons.join("; ") : "") : "";
  vd.className = "pill " + (v ? (v.valid ? "ok" : "bad") : "");
  $("session").textContent = (state.session || "") + (state.plant_address ? " · your controller → " + state.plant_address : "");
  setHTML("faults-active", state.faults.map((f) => `<li>${f.type} (slot ${f.slot}) <button data-slot="${f.slot}">off</button></li>`).join(""));
  // a circuit scenario's faults: each switched on or off from now on (its schedule no longer applies)
  setHTML("circuit-faults", (state.view.faults || []).map((f) => {
    const sw = state.switched[f.slot], now = sw === undefined ? "scheduled" : sw ? "on" : "off";
    return `<li title="${esc(f.why || "switched from now on; its schedule no longer applies")}">faults[${f.slot}] ` +
      `${esc(f.type)} (${esc(f.what)}) <span id="cf-state-${f.slot}">${now}</span>` + (f.switchable ?
      ` <button id="cf-on-${f.slot}" data-slot="${f.slot}" data-on="1">on</button>` +
      (f.off ? ` <button id="cf-off-${f.slot}" data-slot="${f.slot}" data-on="0">off</button>` : "") : "") + "</li>";
  }).join(""));
  for (const b of $("circuit-faults").querySelectorAll("button")) b.onclick = () => api("/api/steer", { op: "fault", slot: +b.dataset.slot, on: b.dataset.on === "1" }).then(refresh);
  for (const b of $("faults-active").querySelectorAll("button")) b.onclick = () => api("/api/steer", { op: "fault_off", slot: +b.dataset.slot }).then(refresh);
  $("record").textContent = state.recording ? "stop recording" : "record";
  $("rec-state").textContent = state.recording ? "recording " + state.recording.name : "";
  setHTML("recordings", state.recordings.map((r) => `<li><a href="/recordings/${r.name}.zip${q}" download>${r.name}</a> ` +
    `${r.steps} steps, ${r.verdict}, report ${r.report}</li>`).join(""));
  setHTML("events", state.events.slice().reverse().map((e) => `<li>k=${e.k} (${e.t.toFixed(3)} s) ${e.process}: ${e.op} ` +
    `${e.name ? e.name + "=" + (e.value ?? "its drive") : ""}${e.fault ? e.fault.type : ""}${e.slot !== undefined ? " slot " + e.slot : ""}` +
    `${e.on !== undefined ? (e.on ? " on" : " off") : ""}</li>`).join(""));
}

setInterval(() => { $("fps").textContent = fpsCount; fpsCount = 0; }, 1000);
setInterval(() => refresh().catch(() => 0), 1000);
refresh().catch(() => 0);
connect();
