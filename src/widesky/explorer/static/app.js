// widesky sky explorer: the page's logic (no libraries; everything comes from this server).
"use strict";
const $ = (id) => document.getElementById(id);
const form = $("controls");
let info = null, pinned = null, pick = null;          // pick: {u, v} of the clicked direction
const latest = { A: null, B: null };                   // latest spectra / irradiance per side
const irr = { A: null, B: null };

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

function showOutputs() {
  for (const el of form.querySelectorAll("input[type=range]")) {
    const out = el.nextElementSibling;
    if (out && out.tagName === "OUTPUT") out.textContent = el.value;
  }
}

async function getJSON(url, opts) {
  const r = await fetch(url, opts);
  const body = await r.json();
  if (!r.ok) throw new Error(body.error || r.statusText);
  return body;
}

// --- images: at most one request in flight per side; a newer state replaces the queued one ---------
const inflight = { A: false, B: false }, queued = { A: null, B: null };
async function render(side, p) {
  if (inflight[side]) { queued[side] = p; return; }
  inflight[side] = true;
  try {
    const t0 = performance.now();
    const r = await fetch("/api/render?" + p.toString());
    if (!r.ok) { const b = await r.json(); throw new Error(b.error); }
    const blob = await r.blob();
    const img = $("img" + side), old = img.src;
    img.src = URL.createObjectURL(blob);
    if (old.startsWith("blob:")) URL.revokeObjectURL(old);
    const server = parseFloat(r.headers.get("X-Total-Seconds")) * 1000;
    const evalms = parseFloat(r.headers.get("X-Render-Seconds")) * 1000;
    const txt = `render ${evalms.toFixed(0)} ms, image ${server.toFixed(0)} ms, round trip ${(performance.now() - t0).toFixed(0)} ms`;
    if (side === "A") { $("timeA").textContent = txt; status("ready"); }
    img.dataset.state = p.toString();
  } catch (e) { status(e.message, true); }
  inflight[side] = false;
  if (queued[side]) { const q = queued[side]; queued[side] = null; render(side, q); }
}

let irrTimer = null;
function update() {
  showOutputs();
  applyZoom();
  const p = params();
  render("A", p);
  clearTimeout(irrTimer);
  irrTimer = setTimeout(() => { loadIrradiance("A", p); if (pick) loadSpectrum("A", p); }, 120);
  if ($("site").hidden === false) loadSun();
}

async function loadSun() {
  try {
    const s = await getJSON("/api/sun?" + params().toString());
    $("sunpos").textContent = `sun: elevation ${s.elevation.toFixed(2)} deg, azimuth ${s.azimuth.toFixed(2)} deg`;
  } catch (e) { $("sunpos").textContent = e.message; }
}

async function loadIrradiance(side, p) {
  try { irr[side] = await getJSON("/api/irradiance?" + p.toString()); drawIrradiance(); }
  catch (e) { irr[side] = null; status(e.message, true); drawIrradiance(); }
}

async function loadSpectrum(side, p) {
  p = new URLSearchParams(p); p.set("u", pick.u); p.set("v", pick.v);
  try {
    const s = await getJSON("/api/spectrum?" + p.toString());
    latest[side] = s;
    if (side === "A") $("dirinfo").textContent =
      `(zenith ${s.zenith_deg.toFixed(1)} deg, azimuth ${s.azimuth_deg.toFixed(1)} deg, ${s.gamma_deg.toFixed(1)} deg from the sun)`;
  } catch (e) { latest[side] = null; status(e.message, true); }
  drawSpectrum();
}

// --- plots -----------------------------------------------------------------------------------------
const COLORS = ["#1f5fa8", "#d9541e", "#2a9d4a", "#8e44ad", "#888"];
function plot(canvas, series, ylabel, logy) {
  const ctx = canvas.getContext("2d"), W = canvas.width, H = canvas.height, L = 72, R = 10, T = 10, B = 34;
  ctx.clearRect(0, 0, W, H);
  const xs = series.flatMap((s) => s.x), ys = series.flatMap((s) => s.y).filter((v) => isFinite(v) && (!logy || v > 0));
  if (!xs.length || !ys.length) { ctx.fillText("no data", W / 2 - 20, H / 2); return; }
  const x0 = Math.min(...xs), x1 = Math.max(...xs);
  let y0 = logy ? Math.min(...ys) : Math.min(0, ...ys), y1 = Math.max(...ys);
  if (y1 <= y0) y1 = y0 + 1;
  const f = logy ? Math.log10 : (v) => v, fy0 = f(y0), fy1 = f(y1);
  const px = (x) => L + (x - x0) / (x1 - x0) * (W - L - R);
  const py = (y) => H - B - (f(y) - fy0) / (fy1 - fy0) * (H - T - B);
  ctx.strokeStyle = "#999"; ctx.fillStyle = "#333"; ctx.font = "11px sans-serif"; ctx.lineWidth = 1;
  ctx.strokeRect(L, T, W - L - R, H - T - B);
  for (let x = Math.ceil(x0 / 400) * 400; x <= x1; x += 400) {
    ctx.textAlign = "center"; ctx.fillText(String(x), px(x), H - B + 14); ctx.textAlign = "left";
    ctx.beginPath(); ctx.moveTo(px(x), H - B); ctx.lineTo(px(x), H - B + 4); ctx.stroke();
  }
  ctx.textAlign = "center"; ctx.fillText("wavelength [nm]", (L + W - R) / 2, H - 4); ctx.textAlign = "left";
  ctx.textAlign = "right";
  for (let k = 0; k <= 4; k++) {
    const fv = fy0 + (fy1 - fy0) * k / 4, v = logy ? Math.pow(10, fv) : fv;
    ctx.fillText(v.toPrecision(3), L - 4, py(v) + 4);
  }
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
  const cell = (r, plane, key) => r ? r[plane].integrated[key].toFixed(1) : "";
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

// --- controls --------------------------------------------------------------------------------------
function applyZoom() {
  const z = parseFloat($("zoom").value);
  for (const side of ["A", "B"]) $("img" + side).style.transform = `scale(${z})`;
}

function fillDataset() {
  const d = info.datasets[parseInt($("dataset").value || "0", 10)];
  $("dsinfo").textContent = `${d.name}: ${d.wavelength_nm.length} channels ${d.wavelength_nm[0]}-${d.wavelength_nm[d.wavelength_nm.length - 1]} nm` +
    (d.synthetic ? " (SYNTHETIC test dataset)" : "");
  const ch = $("channel"); ch.innerHTML = "";
  for (const c of d.channels) ch.add(new Option(c === "rgb" ? "sRGB composite" : c, c));
  const set = (name, lo, hi) => { const el = form.elements[name]; el.min = lo; el.max = hi;
    if (parseFloat(el.value) < lo || parseFloat(el.value) > hi) el.value = Math.min(Math.max(parseFloat(el.value), lo), hi); };
  set("visibility", Math.min(...d.visibility_km), Math.max(...d.visibility_km));
  if (!form.elements.visibility.dataset.init) { form.elements.visibility.value = 50; form.elements.visibility.dataset.init = 1; }
  set("albedo", Math.min(...d.albedo), Math.max(...d.albedo));
  set("altitude", Math.min(...d.altitude_m), Math.max(...d.altitude_m));
  set("elevation", Math.min(...d.elevation_deg), Math.max(...d.elevation_deg));
  $("quantity").querySelector("option[value=polarisation]").disabled = !d.polarisation;
  if (!d.polarisation && $("quantity").value === "polarisation") $("quantity").value = "sky";
}

function hourToTime() {
  const t = form.elements.time.value || "2024-06-21T10:00", h = parseFloat($("hour").value);
  const hh = String(Math.floor(h)).padStart(2, "0"), mm = String(Math.round((h % 1) * 60)).padStart(2, "0");
  form.elements.time.value = t.slice(0, 10) + "T" + hh + ":" + mm;
}

function onPick(ev, side) {
  const img = $("img" + side), rect = img.getBoundingClientRect();
  pick = { u: Math.min(Math.max((ev.clientX - rect.left) / rect.width, 0), 1),
           v: Math.min(Math.max((ev.clientY - rect.top) / rect.height, 0), 1) };
  for (const s of ["A", "B"]) {
    const m = $("mark" + s), im = $("img" + s);
    m.style.left = (pick.u * im.width * parseFloat($("zoom").value) - 7) + "px";
    m.style.top = (pick.v * im.height * parseFloat($("zoom").value) - 7) + "px";
    m.style.display = "block";
  }
  loadSpectrum("A", params());
  if (pinned) loadSpectrum("B", pinned);
}

async function save(format) {
  const name = $("savename").value;
  try {
    const r = await getJSON("/api/save?" + params({ name, format }).toString(), { method: "POST" });
    $("saved").innerHTML = "";
    for (const f of r.written) {
      const a = document.createElement("a"); a.href = "/files/" + encodeURIComponent(f); a.textContent = f;
      a.download = f; $("saved").append(a, " ");
    }
    status("saved " + r.written.join(", ") + " in " + r.output_dir);
  } catch (e) { status(e.message, true); }
}

async function start() {
  try { info = await getJSON("/api/info"); } catch (e) { status(e.message, true); return; }
  const ds = $("dataset");
  info.datasets.forEach((d) => ds.add(new Option(d.name, d.index)));
  const rs = $("response");
  info.responses.forEach((r) => rs.add(new Option(r, r)));
  fillDataset();
  form.addEventListener("input", (ev) => {
    if (ev.target.id === "hour") hourToTime();
    if (ev.target.name === "dataset") fillDataset();
    if (ev.target.name === "sun") { $("site").hidden = form.elements.sun.value !== "site"; $("manual").hidden = !$("site").hidden; }
    if (ev.target.id === "response") { drawIrradiance(); return; }
    if (ev.target.id === "zoom") { showOutputs(); applyZoom(); return; }
    update();
  });
  form.addEventListener("submit", (ev) => ev.preventDefault());
  $("imgA").addEventListener("click", (ev) => onPick(ev, "A"));
  $("imgB").addEventListener("click", (ev) => onPick(ev, "B"));
  $("logy").addEventListener("change", drawSpectrum);
  $("pin").addEventListener("click", () => {
    pinned = params(); $("figB").hidden = false; $("unpin").disabled = false;
    $("stateB").textContent = ["elevation", "azimuth", "visibility", "albedo"].map((k) => `${k} ${pinned.get(k)}`).join(", ");
    render("B", pinned); loadIrradiance("B", pinned); if (pick) loadSpectrum("B", pinned);
  });
  $("unpin").addEventListener("click", () => {
    pinned = null; latest.B = null; irr.B = null; $("figB").hidden = true; $("unpin").disabled = true;
    drawSpectrum(); drawIrradiance();
  });
  $("savepng").addEventListener("click", () => save("png"));
  $("saveexr").addEventListener("click", () => save("exr"));
  update();
}
start();
