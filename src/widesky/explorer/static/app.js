// widesky sky explorer: the page's logic (no libraries; everything comes from this server).
//
// Speed (issue 36): a slider move asks only for what it changes. Sky-state and view sliders fetch the new
// image before its display mapping (half floats, /api/render?format=raw) and the page maps it to sRGB itself, so
// an exposure move needs no request at all; a tilted-plane move asks only for the irradiance (the server
// keeps each sky state's patch radiance); the irradiance and clicked spectrum follow a sky-state move once
// the slider rests. A request made stale by a newer state is cancelled (AbortController) when it has been
// running for a while; a young one is left to finish and the newest state follows it.
"use strict";
const $ = (id) => document.getElementById(id);
const form = $("controls");
const TOKEN = document.querySelector("meta[name=widesky-token]").content;
const VIEW_CSS = 512;                                  // the image's size on the page at zoom 1 [CSS px]
// parameters that change the sky image (everything else: exposure, plane and response are handled here)
const IMAGE_KEYS = ["dataset", "sun", "elevation", "azimuth", "lat", "lon", "time", "tz", "visibility", "albedo",
  "altitude", "quantity", "channel", "view", "view_azimuth", "resolution"];
let info = null, pinned = null, pick = null;           // pick: {u, v} of the clicked direction
const latest = { A: null, B: null };                   // latest spectra per side
const irr = { A: null, B: null };                      // latest irradiance per side
const images = { A: null, B: null };                   // {kind, n, ref, data: Uint16Array (half floats), state} per side
window.wideskyShown = {};                              // side -> {state, time}: when each image was drawn

function status(text, isError) { const s = $("status"); s.textContent = text; s.className = isError ? "error" : ""; }

function params(extra) {
  const p = new URLSearchParams();
  for (const el of form.elements) {
    if (!el.name || el.type === "button") continue;
    if (el.type === "radio" && !el.checked) continue;
    p.set(el.name, el.value);
  }
  for (const [k, v] of Object.entries(extra || {})) p.set(k, v);
  return p;
}

function imageParams(p) {
  const q = new URLSearchParams();
  for (const k of IMAGE_KEYS) if (p.has(k)) q.set(k, p.get(k));
  return q;
}

function showOutputs() {
  for (const el of form.querySelectorAll("input[type=range]")) {
    const out = el.nextElementSibling;
    if (out && out.tagName === "OUTPUT" && el.id !== "zoom") out.textContent = el.value;
  }
  $("zoomout").textContent = zoom().toFixed(zoom() < 10 ? 2 : 1).replace(/\.?0+$/, "") + "x";
}

async function getJSON(url, opts) {
  const r = await fetch(url, opts);
  const body = await r.json();
  if (!r.ok) throw new Error(body.error || r.statusText);
  return body;
}

function post(url) { return getJSON(url, { method: "POST", headers: { "X-Widesky-Token": TOKEN } }); }

// --- display mapping, as the server's PNG (skymodel.render._display): exposure relative to the disc's 99th
// percentile (the values arrive divided by it, as half floats), clip to [0, 1], 16-bit levels, the sRGB table ---
const SRGB8 = (() => {
  const t = new Uint8Array(65536);
  for (let i = 0; i < 65536; i++) {
    const v = i / 65535, s = v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
    t[i] = Math.round(s * 255);
  }
  return t;
})();
const DIVERGING = [[59, 76, 192], [221, 221, 221], [180, 4, 38]];   // Moreland (2009) cool to warm
const HALF = (() => {                 // IEEE half float (the raw image's values) -> number
  const t = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) {
    const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 31, f = h & 1023;
    t[h] = e === 0 ? s * f * Math.pow(2, -24) : e === 31 ? (f ? NaN : s * Infinity) : s * (1 + f / 1024) * Math.pow(2, e - 15);
  }
  return t;
})();

function level(v, scale) {            // float32 arithmetic, as the server's C encoder
  let x = Math.fround(v * scale);
  x = x > 0 ? (x < 1 ? x : 1) : 0;    // NaN -> 0
  return SRGB8[Math.floor(Math.fround(Math.fround(x * 65535) + 0.5))];
}

function paint(side, exposure) {
  const im = images[side]; if (!im) return;
  const cv = $("view" + side), n = im.n;
  if (cv.width !== n) { cv.width = n; cv.height = n; }
  const ctx = cv.getContext("2d"), out = ctx.createImageData(n, n), px = out.data, d = im.data;
  const gain = Math.fround(Math.pow(2, exposure));   // the values arrive divided by the reference (white at 0 EV)
  if (im.kind === "rgb") {
    for (let i = 0, j = 0; i < d.length; i += 3, j += 4) {
      px[j] = level(HALF[d[i]], gain); px[j + 1] = level(HALF[d[i + 1]], gain); px[j + 2] = level(HALF[d[i + 2]], gain);
      px[j + 3] = 255;
    }
  } else if (im.kind === "grey") {
    for (let i = 0, j = 0; i < d.length; i++, j += 4) {
      px[j] = px[j + 1] = px[j + 2] = level(HALF[d[i]], gain); px[j + 3] = 255;
    }
  } else {                            // signed degree of polarisation on the diverging map
    for (let i = 0, j = 0; i < d.length; i++, j += 4) {
      px[j + 3] = 255;
      const v = HALF[d[i]];
      if (Number.isNaN(v)) continue;
      let x = Math.fround(v * gain); x = x > 1 ? 1 : x < -1 ? -1 : x;
      const end = DIVERGING[x < 0 ? 0 : 2], t = Math.abs(x);
      for (let c = 0; c < 3; c++) px[j + c] = Math.round(DIVERGING[1][c] + t * (end[c] - DIVERGING[1][c]));
    }
  }
  ctx.putImageData(out, 0, 0);
  window.wideskyShown[side] = { state: im.state + "&exposure=" + exposure, time: performance.now() };
}

function exposureOf(side) { return parseFloat(side === "A" ? form.elements.exposure.value : pinned.get("exposure")); }

// --- images: one request in flight per side; a newer state aborts an old request or follows a young one ----
const flight = { A: null, B: null }, queued = { A: null, B: null };
const STALE_MS = 100;
async function render(side, p) {
  const q = imageParams(p); q.set("format", "raw");
  const state = q.toString();
  if (flight[side]) {
    if (flight[side].state === state) return;
    if (performance.now() - flight[side].t0 < STALE_MS) { queued[side] = p; return; }
    flight[side].ctl.abort();
  }
  queued[side] = null;
  const f = { state, t0: performance.now(), ctl: new AbortController() };
  flight[side] = f;
  try {
    const r = await fetch("/api/render?" + state, { signal: f.ctl.signal });
    if (!r.ok) { const b = await r.json(); throw new Error(b.error); }
    const buf = await r.arrayBuffer();
    images[side] = { kind: r.headers.get("X-Image-Kind"), n: parseInt(r.headers.get("X-Image-Size"), 10),
                     ref: parseFloat(r.headers.get("X-Reference")), data: new Uint16Array(buf), state };
    const t1 = performance.now();
    paint(side, exposureOf(side));
    const evalms = parseFloat(r.headers.get("X-Render-Seconds")) * 1000;
    const txt = `render ${evalms.toFixed(0)} ms, image ${(parseFloat(r.headers.get("X-Total-Seconds")) * 1000).toFixed(0)} ms, ` +
      `drawn ${(performance.now() - f.t0).toFixed(0)} ms after the request (mapping ${(performance.now() - t1).toFixed(0)} ms)`;
    if (side === "A") { $("timeA").textContent = txt; status("ready"); }
  } catch (e) {
    if (e.name !== "AbortError") status(e.message, true);
  }
  if (flight[side] === f) flight[side] = null;
  if (!flight[side] && queued[side]) { const nq = queued[side]; queued[side] = null; render(side, nq); }
}

// --- irradiance and spectrum: the latest request per side; an older one is aborted --------------------
const irrCtl = { A: null, B: null }, specCtl = { A: null, B: null };
async function loadIrradiance(side, p) {
  if (irrCtl[side]) irrCtl[side].abort();
  const ctl = irrCtl[side] = new AbortController();
  try { irr[side] = await getJSON("/api/irradiance?" + p.toString(), { signal: ctl.signal }); drawIrradiance(); }
  catch (e) { if (e.name === "AbortError") return; irr[side] = null; status(e.message, true); drawIrradiance(); }
}

async function loadSpectrum(side, p) {
  p = new URLSearchParams(p); p.set("u", pick.u); p.set("v", pick.v);
  if (specCtl[side]) specCtl[side].abort();
  const ctl = specCtl[side] = new AbortController();
  try {
    const s = await getJSON("/api/spectrum?" + p.toString(), { signal: ctl.signal });
    latest[side] = s;
    if (side === "A") $("dirinfo").textContent =
      `(zenith ${s.zenith_deg.toFixed(1)} deg, azimuth ${s.azimuth_deg.toFixed(1)} deg, ${s.gamma_deg.toFixed(1)} deg from the sun)`;
  } catch (e) { if (e.name === "AbortError") return; latest[side] = null; status(e.message, true); }
  drawSpectrum();
}

async function loadSun() {
  try {
    const s = await getJSON("/api/sun?" + params().toString());
    $("sunpos").textContent = `sun: elevation ${s.elevation.toFixed(2)} deg, azimuth ${s.azimuth.toFixed(2)} deg`;
  } catch (e) { $("sunpos").textContent = e.message; }
}

let restTimer = null;
function skyChanged() {               // a sky-state or view slider moved: the image now, the rest once it rests
  showOutputs();
  const p = params();
  render("A", p);
  clearTimeout(restTimer);
  restTimer = setTimeout(() => { loadIrradiance("A", p); if (pick) loadSpectrum("A", p); }, 150);
  if ($("site").hidden === false) loadSun();
}

// --- plots: axis ticks at 1, 2 or 5 x 10^k ---------------------------------------------------------------
function niceStep(span, maxTicks) {
  const raw = span / Math.max(maxTicks, 1), p = Math.pow(10, Math.floor(Math.log10(raw)));
  for (const m of [1, 2, 5, 10]) if (m * p >= raw * (1 - 1e-9)) return m * p;
  return 10 * p;
}
// ticks of [lo, hi] (lo < hi) at multiples of a 1-2-5 step; the axis range is widened to whole steps
function niceTicks(lo, hi, maxTicks) {
  const step = niceStep(hi - lo, maxTicks || 5);
  const a = Math.floor(lo / step + 1e-9), b = Math.ceil(hi / step - 1e-9), ticks = [];
  const digits = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
  for (let k = a; k <= b; k++) ticks.push(parseFloat((k * step).toFixed(Math.min(digits + 1, 20))));
  return { lo: a * step, hi: b * step, step, ticks, digits };
}
// decades of [lo, hi] (log axis), with 2 and 5 between when there are few
function logTicks(lo, hi) {
  const a = Math.floor(Math.log10(lo) + 1e-9), b = Math.ceil(Math.log10(hi) - 1e-9), ticks = [];
  const mult = b - a <= 2 ? [1, 2, 5] : [1];
  for (let e = a; e <= b; e++) for (const m of mult) {
    const v = parseFloat((m * Math.pow(10, e)).toPrecision(1));
    if (v >= Math.pow(10, a) * (1 - 1e-9) && v <= Math.pow(10, b) * (1 + 1e-9)) ticks.push(v);
  }
  return { lo: Math.pow(10, a), hi: Math.pow(10, b), ticks };
}
function tickLabel(v, digits) {
  if (v === 0) return "0";
  const a = Math.abs(v);
  if (a >= 1e5 || a < 1e-4) return v.toExponential(0).replace("e+", "e");
  return digits === undefined ? String(v) : v.toFixed(digits);
}

const COLORS = ["#1f5fa8", "#d9541e", "#2a9d4a", "#8e44ad", "#888"];
function plot(canvas, series, ylabel, logy) {
  const ctx = canvas.getContext("2d"), W = canvas.width, H = canvas.height, L = 72, R = 10, T = 10, B = 34;
  ctx.clearRect(0, 0, W, H);
  const xs = series.flatMap((s) => s.x), ys = series.flatMap((s) => s.y).filter((v) => isFinite(v) && (!logy || v > 0));
  if (!xs.length || !ys.length) { ctx.fillText("no data", W / 2 - 20, H / 2); canvas.dataset.xticks = canvas.dataset.yticks = "[]"; return; }
  const xt = niceTicks(Math.min(...xs), Math.max(...xs), 6);
  let ymin = logy ? Math.min(...ys) : Math.min(0, ...ys), ymax = Math.max(...ys);
  if (ymax <= ymin) ymax = logy ? ymin * 10 : ymin + 1;
  const yt = logy ? logTicks(ymin, ymax) : niceTicks(ymin, ymax, 5);
  const x0 = xt.lo, x1 = xt.hi, f = logy ? Math.log10 : (v) => v, fy0 = f(yt.lo), fy1 = f(yt.hi);
  const px = (x) => L + (x - x0) / (x1 - x0) * (W - L - R);
  const py = (y) => H - B - (f(y) - fy0) / (fy1 - fy0) * (H - T - B);
  ctx.strokeStyle = "#999"; ctx.fillStyle = "#333"; ctx.font = "11px sans-serif"; ctx.lineWidth = 1;
  ctx.strokeRect(L, T, W - L - R, H - T - B);
  ctx.textAlign = "center";
  for (const x of xt.ticks) {
    const label = tickLabel(x, xt.digits), half = ctx.measureText(label).width / 2;
    ctx.fillText(label, Math.min(Math.max(px(x), half + 1), W - half - 1), H - B + 14);   // kept inside the canvas
    ctx.beginPath(); ctx.moveTo(px(x), H - B); ctx.lineTo(px(x), H - B + 4); ctx.stroke();
  }
  ctx.fillText("wavelength [nm]", (L + W - R) / 2, H - 4);
  ctx.textAlign = "right";
  ctx.strokeStyle = "#e4e4e4";
  for (const y of yt.ticks) {
    ctx.fillText(tickLabel(y, logy ? undefined : yt.digits), L - 6, py(y) + 4);
    ctx.beginPath(); ctx.moveTo(L, py(y)); ctx.lineTo(W - R, py(y)); ctx.stroke();
  }
  canvas.dataset.xticks = JSON.stringify(xt.ticks); canvas.dataset.yticks = JSON.stringify(yt.ticks);
  ctx.textAlign = "center";
  ctx.save(); ctx.translate(10, (T + H - B) / 2); ctx.rotate(-Math.PI / 2); ctx.fillText(ylabel, 0, 0); ctx.restore();
  ctx.textAlign = "left";
  series.forEach((s, i) => {
    ctx.strokeStyle = s.color || COLORS[i % COLORS.length]; ctx.lineWidth = 1.6; ctx.setLineDash(s.dash || []);
    ctx.beginPath(); let started = false;
    s.x.forEach((x, j) => {
      const y = s.y[j]; if (!isFinite(y) || (logy && y <= 0)) { started = false; return; }
      if (started) ctx.lineTo(px(x), py(y)); else { ctx.moveTo(px(x), py(y)); started = true; }
    });
    ctx.stroke(); ctx.setLineDash([]);
    ctx.fillStyle = ctx.strokeStyle; ctx.fillText(s.label, W - R - 150, T + 14 + 13 * i);
  });
}

function drawSpectrum() {
  const series = [];
  for (const side of ["A", "B"]) {
    const s = latest[side]; if (!s) continue;
    const q = s.quantity === "sun" ? "sun_radiance" : s.quantity === "sky" ? "sky_radiance" : s.quantity;
    if (!s[q]) continue;
    series.push({ x: s.wavelength_nm, y: s[q], label: `${side}: ${s.quantity} [${s.unit}]`, dash: side === "B" ? [5, 3] : [] });
  }
  plot($("spectrum"), series, latest.A ? latest.A.unit : "", $("logy").checked);
}

function drawIrradiance() {
  const series = [];
  for (const side of ["A", "B"]) {
    const r = irr[side]; if (!r) continue;
    const dash = side === "B" ? [5, 3] : [];
    series.push({ x: r.wavelength_nm, y: r.horizontal.global, label: `${side} horizontal global`, dash, color: COLORS[0] });
    series.push({ x: r.wavelength_nm, y: r.tilted.global, label: `${side} tilted global`, dash, color: COLORS[1] });
  }
  plot($("irrplot"), series, "irradiance [W m-2 nm-1]", false);
  const resp = $("response").value || "broadband", body = $("readout").tBodies[0];
  body.innerHTML = "";
  const cell = (r, plane, key) => r && r[plane].integrated[key] !== undefined ? r[plane].integrated[key].toFixed(1) : "";
  const rows = [["global (" + resp + ") [" + (irr.A ? irr.A.units[resp] : "") + "]", resp]];
  for (const [label, key] of rows) {
    const tr = body.insertRow();
    [label, cell(irr.A, "horizontal", key), cell(irr.A, "tilted", key), cell(irr.B, "horizontal", key), cell(irr.B, "tilted", key)]
      .forEach((t) => { tr.insertCell().textContent = t; });
  }
  for (const part of ["direct", "sky_diffuse", "ground_diffuse"]) {
    const tr = body.insertRow();
    const sum = (r, plane) => r ? r[plane].broadband[part].toFixed(1) : "";
    [part + " [W m-2]", sum(irr.A, "horizontal"), sum(irr.A, "tilted"), sum(irr.B, "horizontal"), sum(irr.B, "tilted")]
      .forEach((t) => { tr.insertCell().textContent = t; });
  }
  if (irr.A) {
    const tr = body.insertRow();
    ["angle of incidence [deg]", "", irr.A.aoi_deg.toFixed(1), "", irr.B ? irr.B.aoi_deg.toFixed(1) : ""]
      .forEach((t) => { tr.insertCell().textContent = t; });
  }
}

// --- zoom (1x to 64x) and panning ----------------------------------------------------------------------
function zoom() { return Math.pow(2, parseFloat($("zoom").value)); }
let shownZoom = 1;                    // the zoom the images are laid out at (the slider may already be ahead)

// set the zoom slider's value, keeping the image point under (cx, cy) of frame A (default its centre) in place
function setZoom(value, cx, cy) {
  const frame = $("frameA"), old = shownZoom;
  cx = cx === undefined ? frame.clientWidth / 2 : cx; cy = cy === undefined ? frame.clientHeight / 2 : cy;
  const ux = (frame.scrollLeft + cx) / old, uy = (frame.scrollTop + cy) / old;
  $("zoom").value = Math.min(Math.max(value, 0), 6);
  applyZoom();
  const z = zoom();
  for (const side of ["A", "B"]) {
    const f = $("frame" + side);
    f.scrollLeft = ux * z - cx; f.scrollTop = uy * z - cy;
  }
  showOutputs();
}

function applyZoom() {
  const z = shownZoom = zoom();
  for (const side of ["A", "B"]) {
    const cv = $("view" + side);
    cv.style.width = cv.style.height = (VIEW_CSS * z) + "px";
  }
  placeMarks();
}

function placeMarks() {
  if (!pick) return;
  const z = zoom();
  for (const s of ["A", "B"]) {
    const m = $("mark" + s);
    m.style.left = (pick.u * VIEW_CSS * z - 7) + "px";
    m.style.top = (pick.v * VIEW_CSS * z - 7) + "px";
    m.style.display = "block";
  }
}

function wirePanZoom(side) {
  const frame = $("frame" + side);
  let drag = null;
  frame.addEventListener("pointerdown", (ev) => {
    drag = { x: ev.clientX, y: ev.clientY, sl: frame.scrollLeft, st: frame.scrollTop, moved: false };
  });
  frame.addEventListener("pointermove", (ev) => {
    if (!drag || !(ev.buttons & 1)) return;
    const dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 4) { drag.moved = true; frame.classList.add("dragging"); }
    if (drag.moved) {
      frame.scrollLeft = drag.sl - dx; frame.scrollTop = drag.st - dy;
      const other = $("frame" + (side === "A" ? "B" : "A"));
      other.scrollLeft = frame.scrollLeft; other.scrollTop = frame.scrollTop;
    }
  });
  frame.addEventListener("pointerup", (ev) => {
    const wasDrag = drag && drag.moved;
    drag = null; frame.classList.remove("dragging");
    if (!wasDrag && ev.button === 0) onPick(ev, side);
  });
  frame.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    const rect = frame.getBoundingClientRect();
    setZoom(parseFloat($("zoom").value) + (ev.deltaY < 0 ? 0.25 : -0.25), ev.clientX - rect.left, ev.clientY - rect.top);
  }, { passive: false });
}

// --- datasets --------------------------------------------------------------------------------------------
function fillDatasets(select) {
  const ds = $("dataset"); ds.innerHTML = "";
  info.datasets.forEach((d) => ds.add(new Option(d.name, d.index)));
  if (select !== undefined) ds.value = String(select);
}

async function fillAvailable() {
  if (!info.dataset_dirs.length) { $("loader").hidden = true; return; }
  $("loader").hidden = false;
  const av = await getJSON("/api/datasets"), sel = $("available");
  sel.innerHTML = "";
  for (const f of av.files) {
    const o = new Option(`${av.folders[f.folder]}/${f.name} (${(f.bytes / 1e6).toFixed(0)} MB)` + (f.loaded !== null ? " - open" : ""),
      JSON.stringify({ folder: f.folder, name: f.name }));
    sel.add(o);
  }
  $("loadds").disabled = !av.files.length;
}

async function loadDataset() {
  const choice = JSON.parse($("available").value);
  status(`opening ${choice.name} ...`);
  try {
    const d = await post("/api/load?" + new URLSearchParams(choice).toString());
    info = await getJSON("/api/info");
    fillDatasets(d.index);
    fillDataset();
    await fillAvailable();
    skyChanged();
    status(`opened ${d.name}`);
  } catch (e) { status(e.message, true); }
}

function fillDataset() {
  const d = info.datasets[parseInt($("dataset").value || "0", 10)];
  $("dsinfo").textContent = `${d.name}: ${d.wavelength_nm.length} channels ${d.wavelength_nm[0]}-${d.wavelength_nm[d.wavelength_nm.length - 1]} nm` +
    (d.synthetic ? " (SYNTHETIC test dataset)" : "");
  const ch = $("channel"), keep = ch.value; ch.innerHTML = "";
  for (const c of d.channels) ch.add(new Option(c === "rgb" ? "sRGB composite" : c, c));
  if (d.channels.includes(keep)) ch.value = keep;
  const set = (name, lo, hi) => { const el = form.elements[name]; el.min = lo; el.max = hi;
    if (parseFloat(el.value) < lo || parseFloat(el.value) > hi) el.value = Math.min(Math.max(parseFloat(el.value), lo), hi); };
  set("visibility", Math.min(...d.visibility_km), Math.max(...d.visibility_km));
  if (!form.elements.visibility.dataset.init) { form.elements.visibility.value = 50; form.elements.visibility.dataset.init = 1; }
  set("albedo", Math.min(...d.albedo), Math.max(...d.albedo));
  set("altitude", Math.min(...d.altitude_m), Math.max(...d.altitude_m));
  set("elevation", Math.min(...d.elevation_deg), Math.max(...d.elevation_deg));   // below 0 deg where the dataset has twilight
  $("quantity").querySelector("option[value=polarisation]").disabled = !d.polarisation;
  if (!d.polarisation && $("quantity").value === "polarisation") $("quantity").value = "sky";
}

// --- other controls ---------------------------------------------------------------------------------------
function hourToTime() {
  const t = form.elements.time.value || "2024-06-21T10:00", h = parseFloat($("hour").value);
  const hh = String(Math.floor(h)).padStart(2, "0"), mm = String(Math.round((h % 1) * 60)).padStart(2, "0");
  form.elements.time.value = t.slice(0, 10) + "T" + hh + ":" + mm;
}

function onPick(ev, side) {
  const cv = $("view" + side), rect = cv.getBoundingClientRect();
  pick = { u: Math.min(Math.max((ev.clientX - rect.left) / rect.width, 0), 1),
           v: Math.min(Math.max((ev.clientY - rect.top) / rect.height, 0), 1) };
  placeMarks();
  loadSpectrum("A", params());
  if (pinned) loadSpectrum("B", pinned);
}

async function save(format) {
  const name = $("savename").value.trim();
  if (!$("savename").checkValidity() || !name) {
    status(`file name ${JSON.stringify(name)}: letters, digits, '.', '_' and '-' only (no folders)`, true); return;
  }
  const extra = { name, format, save_resolution: $("saveres").value, overwrite: $("overwrite").checked ? "1" : "0" };
  status(`saving ${name}.${format} at ${extra.save_resolution} px ...`);
  try {
    const r = await post("/api/save?" + params(extra).toString());
    for (const f of r.written) {
      const a = document.createElement("a"); a.href = "/files/" + encodeURIComponent(f); a.textContent = f;
      a.download = f; $("saved").append(a, " ");
    }
    status(`saved ${r.written.join(", ")} (${r.resolution} px, ${(r.bytes / 1e6).toFixed(1)} MB) in ${r.output_dir}; ` +
      `${(r.saved_bytes / 1e6).toFixed(0)} of ${(r.save_budget_bytes / 1e6).toFixed(0)} MB used`);
  } catch (e) { status(e.message, true); }
}

function toggleHelp(show) {
  const h = $("help"); h.hidden = show === undefined ? !h.hidden : !show;
  $("helpbtn").setAttribute("aria-expanded", String(!h.hidden));
}

async function start() {
  try { info = await getJSON("/api/info"); } catch (e) { status(e.message, true); return; }
  fillDatasets();
  const rs = $("response");
  info.responses.forEach((r) => rs.add(new Option(r, r)));
  fillDataset();
  fillAvailable().catch((e) => status(e.message, true));
  $("saveres").max = info.max_save_resolution;
  form.addEventListener("input", (ev) => {
    const t = ev.target, name = t.name || t.id;
    if (t.id === "hour") hourToTime();
    if (name === "dataset") fillDataset();
    if (name === "sun") { $("site").hidden = form.elements.sun.value !== "site"; $("manual").hidden = !$("site").hidden; }
    if (name === "response") { drawIrradiance(); return; }
    if (name === "zoom") { setZoom(parseFloat(t.value)); return; }
    if (name === "exposure") { showOutputs(); paint("A", exposureOf("A")); return; }
    if (name === "surface_tilt" || name === "surface_azimuth") { showOutputs(); loadIrradiance("A", params()); return; }
    if (["savename", "saveres", "overwrite", "available", "logy"].includes(name)) return;
    skyChanged();
  });
  form.addEventListener("submit", (ev) => ev.preventDefault());
  wirePanZoom("A"); wirePanZoom("B");
  $("logy").addEventListener("change", drawSpectrum);
  $("loadds").addEventListener("click", loadDataset);
  $("helpbtn").addEventListener("click", () => toggleHelp());
  document.addEventListener("keydown", (ev) => {
    if (ev.target.tagName === "INPUT" && ["text", "number", "datetime-local"].includes(ev.target.type)) return;
    if (ev.key === "h" || ev.key === "?") toggleHelp();
    else if (ev.key === "+" || ev.key === "=") setZoom(parseFloat($("zoom").value) + 0.5);
    else if (ev.key === "-") setZoom(parseFloat($("zoom").value) - 0.5);
    else if (ev.key === "0") setZoom(0);
  });
  $("pin").addEventListener("click", () => {
    pinned = params(); $("figB").hidden = false; $("unpin").disabled = false;
    $("stateB").textContent = ["elevation", "azimuth", "visibility", "albedo"].map((k) => `${k} ${pinned.get(k)}`).join(", ");
    applyZoom();
    render("B", pinned); loadIrradiance("B", pinned); if (pick) loadSpectrum("B", pinned);
  });
  $("unpin").addEventListener("click", () => {
    pinned = null; latest.B = null; irr.B = null; $("figB").hidden = true; $("unpin").disabled = true;
    drawSpectrum(); drawIrradiance();
  });
  $("savepng").addEventListener("click", () => save("png"));
  $("saveexr").addEventListener("click", () => save("exr"));
  showOutputs();
  applyZoom();
  skyChanged();
}
start();
