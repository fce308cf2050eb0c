// datagen monitor: subscribes (MQTT over WebSockets, mqtt.js) to the builds' live status and
// previews (docs/wire-format.md, 'Live status and previews') and draws them. Everything shown
// is set with textContent: a payload is data, never markup.
"use strict";

const $ = (id) => document.getElementById(id);
const statuses = new Map(); // build id -> latest status object
const previews = new Map(); // worker -> {img, caption, url}
let client = null;
let chosen = "";

function el(tag, text, cls) {
  const e = document.createElement(tag);
  if (text !== undefined) e.textContent = String(text);
  if (cls) e.className = cls;
  return e;
}

function duration(s) {
  if (s === null || s === undefined || !isFinite(s)) return "–";
  s = Math.round(s);
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
  return h ? `${h} h ${m} min` : m ? `${m} min ${sec} s` : `${sec} s`;
}

// The broker, the account and the build come from the server's config.json only: a link's
// ?broker=&user=&password= would send the monitor's password wherever the link says.
async function start() {
  const ignored = [...new Set(new URLSearchParams(location.search).keys())];
  if (ignored.length) {
    $("notice").textContent = `ignored ${ignored.join(", ").slice(0, 200)} in this page's address: ` +
      "it connects only to the broker its server names (datagen monitor --broker)";
    $("notice").hidden = false;
  }
  let config = {};
  try { config = await (await fetch("config.json", { cache: "no-store" })).json(); } catch (e) { /* a plain file server */ }
  const broker = config.broker || "";
  chosen = config.build_id || "";
  if (!broker) {
    $("connect").hidden = false;
    $("connect").addEventListener("submit", (ev) => {
      ev.preventDefault();
      connect($("broker-url").value, $("broker-user").value, $("broker-password").value);
    });
    setConnection("no broker given", "off");
    return;
  }
  connect(broker, config.username, config.password);
}

function setConnection(text, cls) {
  $("connection").textContent = text;
  $("connection").className = "badge " + (cls || "");
}

function connect(url, username, password) {
  if (client) client.end(true);
  const random = crypto.getRandomValues(new Uint8Array(16)); // 128 bits: a new id per page load
  const id = "datagen-monitor-" + [...random].map((b) => b.toString(16).padStart(2, "0")).join("");
  client = mqtt.connect(url, { username, password, clientId: id, protocolVersion: 5, reconnectPeriod: 2000, connectTimeout: 10000 });
  client.on("connect", () => {
    setConnection("connected to " + url, "on");
    client.subscribe("datagen/+/live/status", { qos: 0 });
    if (chosen) choose(chosen);
  });
  client.on("reconnect", () => setConnection("reconnecting…", ""));
  client.on("close", () => {
    const over = ["finished", "failed"].includes(statuses.get(chosen)?.state);
    setConnection(over ? "build over; its broker has closed" : "disconnected from " + url, over ? "" : "off");
  });
  client.on("error", (err) => setConnection("error: " + err.message, "off"));
  client.on("message", onMessage);
}

function onMessage(topic, payload) {
  const parts = topic.split("/"); // datagen/<build>/live/status | datagen/<build>/live/preview/<worker>
  const build = parts[1];
  if (parts[3] === "status") {
    if (payload.length === 0) { statuses.delete(build); updateChooser(); return; }
    let status;
    try { status = JSON.parse(new TextDecoder().decode(payload)); } catch (e) { return; }
    statuses.set(build, status);
    updateChooser();
    if (!chosen && statuses.size === 1) choose(build);
    if (build === chosen) render(status);
  } else if (parts[3] === "preview" && build === chosen) {
    showPreview(parts.slice(4).join("/"), payload);
  }
}

function updateChooser() {
  const select = $("builds");
  const ids = [...statuses.keys()].sort();
  select.replaceChildren(...(ids.length ? [] : [el("option", "waiting for builds…")]));
  if (chosen && !statuses.has(chosen)) ids.unshift(chosen);
  for (const id of ids) {
    const s = statuses.get(id);
    const option = el("option", s ? `${id} (${s.state} ${s.durable}/${s.total})` : id);
    option.value = id;
    option.selected = id === chosen;
    select.append(option);
  }
}

function choose(build) {
  if (client && chosen && chosen !== build) client.unsubscribe(`datagen/${chosen}/live/preview/+`);
  if (chosen !== build) {
    for (const p of previews.values()) URL.revokeObjectURL(p.url);
    previews.clear();
    $("previews").replaceChildren();
  }
  chosen = build;
  if (client) client.subscribe(`datagen/${build}/live/preview/+`, { qos: 0 });
  updateChooser();
  if (statuses.has(build)) render(statuses.get(build));
}

$("builds").addEventListener("change", (ev) => choose(ev.target.value));

function render(s) {
  const state = $("state");
  state.textContent = s.message || `${s.state}: ${s.durable}/${s.total} durable`;
  state.className = "state " + s.state;
  state.dataset.state = s.state;
  $("progress").style.width = `${s.total ? (100 * s.durable) / s.total : 0}%`;
  $("count").textContent = `${s.durable} / ${s.total}`;
  $("rate").textContent = Number(s.rate).toFixed(2);
  $("eta").textContent = s.state === "finished" ? "done" : duration(s.eta_s);
  $("published").textContent = s.published;
  $("reissued").textContent = s.reissued;
  plotRate(s.history || []);
  renderWorkers(s.workers || []);
  renderCounters(s);
  renderCampaign(s);
}

function plotRate(history) {
  const canvas = $("rate-plot");
  const ctx = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height, pad = 28;
  ctx.clearRect(0, 0, w, h);
  const rates = []; // samples/s over the 5 s before each point
  for (let i = 1, j = 0; i < history.length; i++) {
    while (j < i - 1 && history[j + 1][0] <= history[i][0] - 5) j++;
    const dt = history[i][0] - history[j][0];
    if (dt > 0) rates.push([history[i][0], (history[i][1] - history[j][1]) / dt]);
  }
  ctx.strokeStyle = "#cbd2d9"; ctx.fillStyle = "#52606d"; ctx.font = "11px sans-serif";
  ctx.beginPath(); ctx.moveTo(pad, 4); ctx.lineTo(pad, h - pad); ctx.lineTo(w - 4, h - pad); ctx.stroke();
  if (rates.length < 1) { ctx.fillText("no rate yet", pad + 8, h / 2); return; }
  const tMax = Math.max(rates[rates.length - 1][0], 1);
  const rMax = Math.max(...rates.map((r) => r[1]), 0.1) * 1.1;
  ctx.fillText(rMax.toFixed(1), 2, 12); ctx.fillText("0", 14, h - pad);
  ctx.fillText(duration(tMax), w - 60, h - 10);
  ctx.strokeStyle = "#3b82f6"; ctx.lineWidth = 2; ctx.beginPath();
  rates.forEach(([t, r], i) => {
    const x = pad + ((w - pad - 4) * t) / tMax, y = h - pad - ((h - pad - 4) * r) / rMax;
    i ? ctx.lineTo(x, y) : ctx.moveTo(x, y);
  });
  ctx.stroke(); ctx.lineWidth = 1;
}

function renderWorkers(workers) {
  const rows = workers.map((w) => {
    const tr = el("tr");
    tr.append(el("td", w.id), el("td", w.state), el("td", w.samples), el("td", w.last_error || "", "error"));
    return tr;
  });
  $("workers").tBodies[0].replaceChildren(...rows);
}

function renderCounters(s) {
  const items = [
    ["worker restarts", s.restarts?.worker ?? 0],
    ["writer restarts", s.restarts?.writer ?? 0],
    ["broker restarts", s.restarts?.broker ?? 0],
    ["samples failed on every attempt", s.failed_samples ?? 0],
    ["rejected control messages", Object.values(s.rejected || {}).reduce((a, b) => a + b, 0)],
    ["resumed from", s.resumed_from ?? 0],
  ];
  for (const [w, state] of Object.entries(s.writers || {})) items.push([`writer ${w}`, state]);
  for (const [why, n] of Object.entries(s.rejected || {})) items.push([`  rejected: ${why}`, n]);
  $("counters").replaceChildren(...items.flatMap(([k, v]) => [el("dt", k), el("dd", v)]));
}

function rateRows(title, table, cls) {
  const box = el("div", undefined, "rates");
  box.append(el("h3", title));
  for (const [name, row] of Object.entries(table)) {
    const line = el("div", undefined, "rate-row");
    const track = el("div", undefined, "track"), fill = el("div", undefined, "fill " + (cls || ""));
    fill.style.width = `${100 * row.rate}%`;
    track.append(fill);
    line.append(el("span", name), track, el("span", row.label));
    box.append(line);
  }
  return box;
}

function renderCampaign(s) {
  const boxes = [];
  const rows = (t) => Object.fromEntries(Object.entries(t || {}).map(([k, r]) => [k, { rate: r.success_rate, label: `${(100 * r.success_rate).toFixed(0)}% of ${r.attempts}` }]));
  if (s.campaign) {
    const c = s.campaign;
    boxes.push(rateRows(`grasp attempts: ${(100 * c.success_rate).toFixed(1)}% of ${c.attempts} succeed`, {}));
    boxes.push(rateRows("by sampler", rows(c.per_sampler)), rateRows("by shape family", rows(c.per_family)));
    const failures = c.attempts - c.successes;
    const modes = Object.fromEntries(Object.entries(c.failure_modes || {}).map(([k, n]) => [k, { rate: failures ? n / failures : 0, label: `${n}` }]));
    boxes.push(rateRows("failure modes (share of failures)", modes, "failure"));
  }
  if (s.navigation) {
    const n = s.navigation;
    boxes.push(rateRows(`navigation: ${n.episodes} episodes`, {
      success: { rate: n.success_rate, label: `${(100 * n.success_rate).toFixed(0)}%` },
      SPL: { rate: n.spl, label: n.spl.toFixed(3) },
    }));
  }
  $("campaign-section").hidden = boxes.length === 0;
  $("campaign").replaceChildren(...boxes);
}

function showPreview(worker, payload) {
  let p = previews.get(worker);
  if (!p) {
    const figure = el("figure");
    p = { img: el("img"), caption: el("figcaption"), url: "" };
    p.img.alt = `latest preview of worker ${worker}`;
    figure.append(p.img, p.caption);
    $("previews").append(figure);
    previews.set(worker, p);
  }
  const url = URL.createObjectURL(new Blob([payload], { type: "image/jpeg" }));
  p.img.src = url;
  if (p.url) URL.revokeObjectURL(p.url);
  p.url = url;
  p.caption.textContent = `worker ${worker}, ${new Date().toLocaleTimeString()}`;
}

start();
