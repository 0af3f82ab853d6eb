// Polls the JSON API every two seconds and draws SVG polylines; no libraries, no CDN.
// Times on the axes and in the tables are wall-clock times in the browser's local time
// zone, mapped from the service clock with /api/status `wall_clock`.
"use strict";
const token = new URLSearchParams(location.search).get("token") || "";
const COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];
const POINTS = 300;

async function api(path, method) {
  const r = await fetch(path, { method: method || "GET", headers: { Authorization: "Bearer " + token } });
  if (!r.ok) throw new Error(path + ": " + r.status);
  return r.json();
}

function text(id, v) { document.getElementById(id).textContent = v; }
function fmt(v, d) { return v === null || v === undefined || !isFinite(v) ? "–" : Number(v).toFixed(d); }
function esc(s) { return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/"/g, "&quot;"); }

// Service time (s) → wall-clock milliseconds since the Unix epoch.
let clock = { unix_s: 0, time_s: 0, speedup: 1 };
function wallMs(t) { return 1000 * (clock.unix_s - (clock.time_s - t) / clock.speedup); }
function clockText(ms, withDate) {
  const o = { hour: "2-digit", minute: "2-digit", second: "2-digit", hourCycle: "h23" };
  if (withDate) { o.month = "2-digit"; o.day = "2-digit"; }
  return new Date(ms).toLocaleString([], o);
}

function plot(svgId, legendId, series, unit) {
  const svg = document.getElementById(svgId);
  const pts = series.flatMap(s => s.points.filter(p => p.value !== null));
  if (pts.length === 0) { svg.innerHTML = ""; return; }
  let x0 = Math.min(...pts.map(p => p.time_s)), x1 = Math.max(...pts.map(p => p.time_s));
  let y0 = Math.min(...pts.map(p => p.value)), y1 = Math.max(...pts.map(p => p.value));
  if (x1 <= x0) x1 = x0 + 1;
  if (y1 - y0 < 1e-9) { y0 -= 0.5; y1 += 0.5; }
  const W = 600, H = 220, m = 4, B = 16;
  const sx = t => m + (W - 2 * m) * (t - x0) / (x1 - x0);
  const sy = v => H - B - m - (H - B - 2 * m) * (v - y0) / (y1 - y0);
  let html = "";
  series.forEach((s, i) => {
    const d = s.points.filter(p => p.value !== null).map(p => sx(p.time_s).toFixed(1) + "," + sy(p.value).toFixed(1)).join(" ");
    html += '<polyline fill="none" stroke-width="1.5" stroke="' + COLORS[i % COLORS.length] + '" points="' + d + '" data-series="' + esc(s.name) + '"/>';
  });
  html += '<text class="axis" x="6" y="14">' + y1.toFixed(2) + " " + unit + '</text><text class="axis" x="6" y="' + (H - B - 4) + '">' + y0.toFixed(2) + " " + unit + "</text>";
  // Wall-clock ticks (local time), the date added when the span is a day or more.
  const withDate = (wallMs(x1) - wallMs(x0)) >= 86400000 * 0.99;
  for (let k = 0; k <= 3; k++) {
    const t = x0 + (x1 - x0) * k / 3, ms = Math.round(wallMs(t));
    const anchor = k === 0 ? "start" : k === 3 ? "end" : "middle";
    html += '<text class="axis" text-anchor="' + anchor + '" x="' + sx(t).toFixed(1) + '" y="' + (H - 2) + '" data-time-tick="' + ms + '">' + clockText(ms, withDate) + "</text>";
  }
  svg.innerHTML = html;
  document.getElementById(legendId).innerHTML = series.map((s, i) =>
    '<span style="color:' + COLORS[i % COLORS.length] + '">■ ' + esc(s.name) + '</span>').join(" &nbsp; ");
}

// Acknowledge buttons (operator role only): POST, then redraw.
document.addEventListener("click", async ev => {
  const b = ev.target.closest("button[data-ack-url]");
  if (!b) return;
  b.disabled = true;
  try { await api(b.getAttribute("data-ack-url"), "POST"); } catch (e) { b.textContent = "failed: " + e.message; }
  refresh();
});
document.getElementById("range").addEventListener("change", () => refresh());

async function refresh() {
  try {
    const last = document.getElementById("range").value;
    const span = "last_s=" + last + "&max_points=" + POINTS;
    const [st, chans, offs, alarms, model] = await Promise.all([
      api("/api/status"), api("/api/channels"), api("/api/offsets?" + span),
      api("/api/alarms?limit=50"), api("/api/model")]);
    clock = st.wall_clock;
    const operator = st.role === "operator";
    text("machine", st.machine); text("status", st.status); text("time", fmt(st.time_s, 1));
    text("clock", isFinite(st.time_s) ? clockText(wallMs(st.time_s), true) : "–");
    text("committed", st.committed_samples); text("input", st.input); text("role", st.role);
    document.getElementById("status").className = st.status === "running" ? "ok" : "alarm";
    document.getElementById("stop").innerHTML = st.stop === null ? "" :
      '<span class="alarm">stop requested: ' + esc(st.stop) + "</span> " +
      (operator ? '<button id="ack-stop" data-ack-url="/api/stop/ack">acknowledge stop</button>' : "");
    document.querySelector("#channels tbody").innerHTML = chans.map(c =>
      "<tr><td>" + esc(c.name) + '</td><td class="num" data-channel-raw="' + esc(c.name) + '">' + fmt(c.raw, 3) +
      '</td><td data-channel-raw-unit="' + esc(c.name) + '">' + esc(c.raw_unit) +
      '</td><td class="num" data-channel-value="' + esc(c.name) + '">' + fmt(c.value, 3) +
      '</td><td data-channel-unit="' + esc(c.name) + '">' + esc(c.unit) +
      '</td><td class="' + (c.fault ? "alarm" : "ok") + '">' + (c.fault ? esc(c.fault) : c.raw === null ? "no reading yet" : "ok") + "</td></tr>").join("");
    document.querySelector("#axes tbody").innerHTML = st.axes.map(a =>
      "<tr><td>" + esc(a.name) + '</td><td class="num" data-axis-offset="' + esc(a.name) + '">' + fmt(a.offset_um, 3) +
      '</td><td class="num">' + fmt(a.law_um, 3) + '</td><td title="' + esc(st.legend[a.status] || "") + '">' + esc(a.status) + "</td></tr>").join("");
    document.querySelector("#alarms tbody").innerHTML = alarms.map(a =>
      '<tr class="' + (a.cleared_s === null ? "alarm" : "") + '"><td data-alarm-time="' + Math.round(wallMs(a.time_s)) + '">' +
      clockText(wallMs(a.time_s), true) + "</td><td>" + esc(a.message) + (a.count > 1 ? " (×" + a.count + ")" : "") +
      "</td><td>" + (a.cleared_s === null ? "active" : "cleared") +
      (a.acknowledged_by ? ", acknowledged" : "") + "</td><td>" +
      (operator && !a.acknowledged_by ? '<button data-ack-alarm="' + a.id + '" data-ack-url="/api/alarms/' + a.id + '/ack">acknowledge</button>' : "") +
      "</td></tr>").join("");
    document.getElementById("legend").innerHTML = Object.keys(st.legend).map(k =>
      '<dt data-legend="' + esc(k) + '">' + esc(k) + "</dt><dd>" + esc(st.legend[k]) + "</dd>").join("");
    text("model-source", model.source); text("model", model.config_toml);
    const hist = await Promise.all(chans.map(c =>
      api("/api/history?kind=average&" + span + "&channel=" + encodeURIComponent(c.name))));
    plot("temps", "temps-legend", hist.map((h, i) => ({ name: h.channel + " (" + chans[i].unit + ")", points: h.points })), "");
    const axes = [...new Set(offs.history.map(r => r.axis))];
    const series = [];
    axes.forEach(ax => {
      const rows = offs.history.filter(r => r.axis === ax);
      series.push({ name: ax + " applied offset", points: rows.map(r => ({ time_s: r.time_s, value: r.offset_um })) });
      series.push({ name: ax + " law (−predicted drift)", points: rows.map(r => ({ time_s: r.time_s, value: r.law_um })) });
    });
    plot("offsets", "offsets-legend", series, "µm");
  } catch (e) {
    text("status", "no connection (" + e.message + ")");
    document.getElementById("status").className = "alarm";
  }
}
refresh();
setInterval(refresh, 2000);
