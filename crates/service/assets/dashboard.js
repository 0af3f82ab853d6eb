// Polls the JSON API every two seconds and draws SVG polylines; no libraries, no CDN.
"use strict";
const token = new URLSearchParams(location.search).get("token") || "";
const COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"];

async function api(path) {
  const r = await fetch(path, { headers: { Authorization: "Bearer " + token } });
  if (!r.ok) throw new Error(path + ": " + r.status);
  return r.json();
}

function text(id, v) { document.getElementById(id).textContent = v; }
function fmt(v, d) { return v === null || v === undefined || !isFinite(v) ? "–" : Number(v).toFixed(d); }

function plot(svgId, legendId, series) {
  const svg = document.getElementById(svgId);
  const pts = series.flatMap(s => s.points.filter(p => p.value !== null));
  if (pts.length === 0) { svg.innerHTML = ""; return; }
  let x0 = Math.min(...pts.map(p => p.time_s)), x1 = Math.max(...pts.map(p => p.time_s));
  let y0 = Math.min(...pts.map(p => p.value)), y1 = Math.max(...pts.map(p => p.value));
  if (x1 <= x0) x1 = x0 + 1;
  if (y1 - y0 < 1e-9) { y0 -= 0.5; y1 += 0.5; }
  const W = 600, H = 220, m = 4;
  const sx = t => m + (W - 2 * m) * (t - x0) / (x1 - x0);
  const sy = v => H - m - (H - 2 * m) * (v - y0) / (y1 - y0);
  let html = "";
  series.forEach((s, i) => {
    const d = s.points.filter(p => p.value !== null).map(p => sx(p.time_s).toFixed(1) + "," + sy(p.value).toFixed(1)).join(" ");
    html += '<polyline fill="none" stroke-width="1.5" stroke="' + COLORS[i % COLORS.length] + '" points="' + d + '" data-series="' + s.name + '"/>';
  });
  html += '<text x="6" y="14" font-size="11">' + y1.toFixed(2) + '</text><text x="6" y="214" font-size="11">' + y0.toFixed(2) + '</text>';
  svg.innerHTML = html;
  document.getElementById(legendId).innerHTML = series.map((s, i) =>
    '<span style="color:' + COLORS[i % COLORS.length] + '">■ ' + s.name + '</span>').join(" &nbsp; ");
}

async function refresh() {
  try {
    const [st, chans, offs, alarms, model] = await Promise.all([
      api("/api/status"), api("/api/channels"), api("/api/offsets?limit=600"),
      api("/api/alarms?limit=50"), api("/api/model")]);
    text("machine", st.machine); text("status", st.status); text("time", fmt(st.time_s, 1));
    text("committed", st.committed_samples); text("input", st.input);
    document.getElementById("status").className = st.status === "running" ? "ok" : "alarm";
    document.querySelector("#channels tbody").innerHTML = chans.map(c =>
      "<tr><td>" + c.name + '</td><td class="num" data-channel-raw="' + c.name + '">' + fmt(c.raw, 3) +
      '</td><td class="num" data-channel-value="' + c.name + '">' + fmt(c.value, 3) +
      '</td><td class="' + (c.fault ? "alarm" : "ok") + '">' + (c.fault || "ok") + "</td></tr>").join("");
    document.querySelector("#axes tbody").innerHTML = st.axes.map(a =>
      "<tr><td>" + a.name + '</td><td class="num" data-axis-offset="' + a.name + '">' + fmt(a.offset_um, 3) +
      '</td><td class="num">' + fmt(a.law_um, 3) + "</td><td>" + a.status + "</td></tr>").join("");
    document.querySelector("#alarms tbody").innerHTML = alarms.map(a =>
      '<tr class="' + (a.cleared_s === null ? "alarm" : "") + '"><td class="num">' + fmt(a.time_s, 1) + "</td><td>" +
      a.message.replace(/</g, "&lt;") + "</td><td>" + (a.cleared_s === null ? "active" : "cleared") +
      (a.acknowledged_by ? ", acknowledged" : "") + "</td></tr>").join("");
    text("model-source", model.source); text("model", model.config_toml);
    const hist = await Promise.all(chans.map(c =>
      api("/api/history?kind=average&limit=600&channel=" + encodeURIComponent(c.name))));
    plot("temps", "temps-legend", hist.map(h => ({ name: h.channel, points: h.points })));
    const axes = [...new Set(offs.history.map(r => r.axis))];
    const series = [];
    axes.forEach(ax => {
      const rows = offs.history.filter(r => r.axis === ax);
      series.push({ name: ax + " applied offset", points: rows.map(r => ({ time_s: r.time_s, value: r.offset_um })) });
      series.push({ name: ax + " law (−predicted drift)", points: rows.map(r => ({ time_s: r.time_s, value: r.law_um })) });
    });
    plot("offsets", "offsets-legend", series);
  } catch (e) {
    text("status", "no connection (" + e.message + ")");
    document.getElementById("status").className = "alarm";
  }
}
refresh();
setInterval(refresh, 2000);
