// r2p ui's page: renders the snapshots `r2p ui` streams (server-sent events from /events; the
// browser reconnects by itself when r2p ui restarts, and r2p ui reopens the bus when the robot
// restarts), plots the selected topic's numeric fields with uPlot, and sends parameter and
// publish requests (/api/*), which r2p runs as `r2p param` / `r2p pub` would.
"use strict";

const $ = (id) => document.getElementById(id);
const MAX_POINTS = 300;
let latest = null;          // the last snapshot
let selected = null;        // the plotted topic's name
let plot = null;            // uPlot instance
let plotKeys = [];          // its series' field paths
let plotData = [[]];        // [times, series…]
let lastCount = -1;         // messages counted when the plot last took a value

function cell(tr, text, cls) {
  const td = document.createElement("td");
  td.textContent = text == null ? "-" : String(text);
  if (cls) td.className = cls;
  tr.appendChild(td);
  return td;
}

function nodeLabel(id) {
  const n = latest && (latest.nodes || []).find((x) => x.node === id);
  return n ? `${id} (${n.name})` : String(id);
}

function classText(c) {
  if (c.class === "HRT") return `HRT every ${c.period_cycles} cycles`;
  if (c.class === "SRT") return `SRT deadline ${c.deadline_us} µs`;
  return c.class;
}

// The numeric leaves of a decoded value: [["x", 1.5], ["v[0]", 2], …]; null (a NaN, which
// JSON cannot carry, or the decoder's "nan"/"inf") stays a field, drawn as a gap, so the plot keeps its series.
function numericFields(v, path, out) {
  if (typeof v === "number" || v === null) out.push([path || "value", v]);
  else if (v === "nan" || v === "inf" || v === "-inf") out.push([path || "value", null]);
  else if (typeof v === "boolean") out.push([path || "value", v ? 1 : 0]);
  else if (Array.isArray(v)) v.forEach((x, i) => numericFields(x, `${path}[${i}]`, out));
  else if (typeof v === "object")
    Object.keys(v).forEach((k) => numericFields(v[k], path ? `${path}.${k}` : k, out));
  return out;
}

function renderBus(b) {
  const el = $("bus");
  if (b.connected) {
    el.textContent = `${b.describe}${b.trace ? (b.ended ? " (read to the end)" : "") : ""}` +
      (b.own_node != null ? ` · r2p ui is node ${b.own_node}` : "");
    el.className = "bus";
  } else {
    el.textContent = `bus down: ${b.error} — opening it again`;
    el.className = "bus down";
  }
  document.body.dataset.connected = b.connected ? "yes" : "no";
}

function renderModules(nodes) {
  const body = $("modules").tBodies[0];
  body.replaceChildren();
  for (const n of nodes) {
    const tr = document.createElement("tr");
    tr.dataset.node = n.node;
    tr.dataset.name = n.name;
    if (n.lost) tr.className = "lost";
    cell(tr, n.node);
    cell(tr, n.name);
    cell(tr, n.kind);
    cell(tr, n.lost ? `LOST (silent ${n.silent_s.toFixed(1)} s)` : n.state, `state state-${n.state}`);
    cell(tr, `${n.uptime_s} s`);
    cell(tr, n.tx_errors);
    cell(tr, n.rx_errors);
    cell(tr, n.dropped);
    cell(tr, n.firmware);
    body.appendChild(tr);
  }
  const sel = $("param-node");
  const names = nodes.filter((n) => !n.lost).map((n) => String(n.node));
  const have = Array.from(sel.options).map((o) => o.value);
  if (names.join() !== have.join()) {
    const keep = sel.value;
    sel.replaceChildren(...nodes.filter((n) => !n.lost).map((n) => new Option(`${n.node} ${n.name}`, n.node)));
    if (names.includes(keep)) sel.value = keep;
  }
}

function renderTopics(topics) {
  const body = $("topics").tBodies[0];
  body.replaceChildren();
  for (const t of topics) {
    const tr = document.createElement("tr");
    tr.dataset.topic = t.topic;
    if (t.topic === selected) tr.className = "selected";
    cell(tr, t.topic);
    cell(tr, t.type);
    cell(tr, nodeLabel(t.publisher));
    cell(tr, t.subscribers && t.subscribers.length ? t.subscribers.map(nodeLabel).join(", ") : "-");
    cell(tr, classText(t.class));
    cell(tr, `${t.rate_hz.toFixed(1)} Hz`);
    cell(tr, t.messages);
    tr.addEventListener("click", () => select(t.topic));
    body.appendChild(tr);
  }
  const sel = $("pub-topic");
  const names = topics.map((t) => t.topic);
  if (names.join() !== Array.from(sel.options).map((o) => o.value).join()) {
    const keep = sel.value;
    sel.replaceChildren(...topics.map((t) => new Option(`${t.topic} (${t.type})`, t.topic)));
    if (names.includes(keep)) sel.value = keep;
  }
}

function select(topic) {
  selected = topic;
  $("selected").textContent = topic;
  if (plot) plot.destroy();
  plot = null;
  plotKeys = [];
  plotData = [[]];
  lastCount = -1;
  $("plot").dataset.points = "0";
  if (latest) renderTopics(latest.topics || []);
}

function renderPlot(snapshot) {
  if (!selected) return;
  const t = (snapshot.topics || []).find((x) => x.topic === selected);
  if (!t) return;
  $("value").textContent = t.latest == null ? "(no message yet)" : JSON.stringify(t.latest, null, 1);
  if (t.latest == null || t.messages === lastCount) return;
  lastCount = t.messages;
  const fields = numericFields(t.latest, "", []);
  if (!fields.length) return;
  const keys = fields.map((f) => f[0]);
  if (!plot || keys.join() !== plotKeys.join()) {
    if (plot) plot.destroy();
    plotKeys = keys;
    plotData = [[], ...keys.map(() => [])];
    const colors = ["#4d7cfe", "#e8590c", "#2f9e44", "#ae3ec9", "#f08c00", "#1098ad", "#c92a2a", "#5c940d"];
    plot = new uPlot({
      width: $("plot").clientWidth || 560, height: 220,
      scales: { x: { time: false } },
      axes: [{ label: "s" }, {}],
      series: [{ label: "t" }, ...keys.map((k, i) => ({ label: k, stroke: colors[i % colors.length] }))],
    }, plotData, $("plot"));
  }
  plotData[0].push(snapshot.bus.at_s);
  fields.forEach((f, i) => plotData[i + 1].push(f[1]));
  if (plotData[0].length > MAX_POINTS) plotData.forEach((s) => s.shift());
  plot.setData(plotData);
  $("plot").dataset.points = String(plotData[0].length);
}

function renderCycle(c) {
  const el = $("cycle");
  el.replaceChildren();
  const p = document.createElement("p");
  p.textContent = c.syncs ? `cycle ${c.cycle} · ${c.syncs} syncs heard · epoch ${c.epoch ? 1 : 0}` :
    "no sync heard (no bus master, or a trace without one)";
  el.appendChild(p);
  const slots = document.createElement("div");
  slots.className = "slots";
  slots.id = "slots";
  const reserved = new Set(c.reserved_slots || []);
  for (let i = 0; i < 64; i++) {
    const s = document.createElement("div");
    s.className = "slot" + (i === 0 || reserved.has(i) ? " reserved" : "");
    s.title = i === 0 ? "slot 0: sync" : `slot ${i}${reserved.has(i) ? ": reserved (HRT)" : ""}`;
    s.textContent = i;
    slots.appendChild(s);
  }
  el.appendChild(slots);
  const load = document.createElement("div");
  load.className = "load";
  load.id = "load";
  for (const k of ["HRT", "SRT", "NRT"]) {
    const span = document.createElement("span");
    span.dataset.class = k;
    span.textContent = `${k} ${(100 * c.load[k]).toFixed(1)} %`;
    load.appendChild(span);
  }
  el.appendChild(load);
}

let latencyPlot = null;     // uPlot instance of the SRT latency histogram

// A bucket's label in milliseconds: "<0.25", …, "≥20".
function bucketLabel(edges, i) {
  return i < edges.length ? `<${edges[i] / 1000}` : `≥${edges[edges.length - 1] / 1000}`;
}

// The SRT latency histogram: uPlot's bar paths, one bar per bucket of r2p ui's edges.
function renderLatency(h) {
  if (!h) return;
  const xs = h.counts.map((_, i) => i);
  if (!latencyPlot) {
    latencyPlot = new uPlot({
      width: $("latency").clientWidth || 560, height: 170,
      legend: { show: false },
      scales: { x: { time: false, range: [-0.5, h.counts.length - 0.5] } },
      axes: [
        { values: (u, splits) => splits.map((i) => (Number.isInteger(i) ? bucketLabel(h.edges_us, i) : "")),
          splits: () => xs, size: 40, label: "ms", labelSize: 14 },
        { label: "messages", size: 60 },
      ],
      series: [{}, { label: "SRT messages", fill: "#4d7cfe88", stroke: "#4d7cfe",
        paths: uPlot.paths.bars({ size: [0.7] }), points: { show: false } }],
    }, [xs, h.counts], $("latency"));
  } else {
    latencyPlot.setData([xs, h.counts]);
  }
  $("latency").dataset.total = String(h.counts.reduce((a, b) => a + b, 0));
}

function render(s) {
  latest = s;
  renderBus(s.bus);
  if (!s.bus.connected) {
    document.querySelectorAll("#modules tbody tr").forEach((tr) => tr.classList.add("lost"));
    return;
  }
  renderModules(s.nodes || []);
  renderTopics(s.topics || []);
  renderPlot(s);
  renderCycle(s.cycle);
  renderLatency(s.srt_latency);
}

function message(id, text, ok) {
  const el = $(id);
  el.textContent = text;
  el.className = "msg " + (ok ? "ok" : "error");
}

async function request(method, url, body) {
  const r = await fetch(url, {
    method, headers: { "Content-Type": "application/json" },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const j = await r.json();
  if (!r.ok) throw new Error(j.error || r.statusText);
  return j;
}

async function readParams() {
  const node = $("param-node").value;
  if (!node) return message("param-msg", "no module to read", false);
  message("param-msg", `reading the parameters of node ${node}…`, true);
  const body = $("params").tBodies[0];
  try {
    const j = await request("GET", `/api/params?node=${encodeURIComponent(node)}`);
    body.replaceChildren();
    for (const p of j.params) {
      const tr = document.createElement("tr");
      tr.dataset.index = p.index;
      cell(tr, p.index);
      cell(tr, p.type || "-");
      cell(tr, p.error ? p.error : p.value, "current");
      const td = document.createElement("td");
      const input = document.createElement("input");
      input.value = p.error ? "" : String(p.value);
      td.appendChild(input);
      tr.appendChild(td);
      const td2 = document.createElement("td");
      const b = document.createElement("button");
      b.textContent = "Set";
      b.className = "set";
      b.addEventListener("click", () => setParam(j.node, p.index, p.type, input.value, tr));
      td2.appendChild(b);
      tr.appendChild(td2);
      body.appendChild(tr);
    }
    message("param-msg", j.params.length ? `${j.params.length} parameters of node ${nodeLabel(j.node)}` :
      `node ${nodeLabel(j.node)} has no parameters`, true);
  } catch (e) {
    message("param-msg", e.message, false);
  }
}

async function setParam(node, index, type, value, tr) {
  message("param-msg", `setting parameter ${index} of node ${node}…`, true);
  try {
    const j = await request("POST", "/api/param", { node: String(node), index, type, value });
    tr.querySelector("td.current").textContent = String(j.value);
    message("param-msg", `parameter ${index} of node ${nodeLabel(node)} is now ${j.type}:${j.value} (saved)`, true);
  } catch (e) {
    message("param-msg", e.message, false);
  }
}

async function publish() {
  const topic = $("pub-topic").value;
  const t = latest && (latest.topics || []).find((x) => x.topic === topic);
  if (!t) return message("pub-msg", "no topic to publish on", false);
  message("pub-msg", `publishing on ${topic}…`, true);
  try {
    await request("POST", "/api/publish", { topic, type: t.type, values: $("pub-values").value });
    message("pub-msg", `published on ${topic}`, true);
  } catch (e) {
    message("pub-msg", e.message, false);
  }
}

$("param-read").addEventListener("click", readParams);
$("pub-send").addEventListener("click", publish);
new EventSource("/events").onmessage = (e) => render(JSON.parse(e.data));
