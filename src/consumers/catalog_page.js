"use strict";
(function () {
  const body = document.body;
  window.addEventListener("error", function () {
    body.dataset.errors = String(Number(body.dataset.errors || 0) + 1);
  });
  const SVG = "http://www.w3.org/2000/svg";
  const W = 900, H = 380, L = 70, R = 20, T = 15, B = 45;
  const COLOURS = ["#1f77b4", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2"];

  function el(tag, attrs, parent) {
    const e = document.createElementNS(SVG, tag);
    for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(e);
    return e;
  }

  function html(tag, text, parent) {
    const e = document.createElement(tag);
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }

  function range(values, log) {
    let lo = Infinity, hi = -Infinity;
    for (const v of values) {
      if (v === null || !isFinite(v) || (log && v <= 0)) continue;
      if (v < lo) lo = v;
      if (v > hi) hi = v;
    }
    if (!(lo <= hi)) return null;
    if (log) { lo = Math.log10(lo); hi = Math.log10(hi); }
    if (hi === lo) { hi += 0.5; lo -= 0.5; }
    return [lo, hi];
  }

  function ticks(lo, hi, n) {
    const step = Math.pow(10, Math.floor(Math.log10((hi - lo) / n)));
    const k = [1, 2, 5, 10].find(function (m) { return (hi - lo) / (step * m) <= n; });
    const s = step * k, out = [];
    for (let t = Math.ceil(lo / s) * s; t <= hi + 1e-9 * s; t += s) out.push(t);
    return out;
  }

  function label(v) {
    const a = Math.abs(v);
    return (a !== 0 && (a < 1e-3 || a >= 1e5)) ? v.toExponential(1) : String(+v.toPrecision(6));
  }

  function draw(state) {
    const d = state.data, svg = state.svg;
    while (svg.firstChild) svg.removeChild(svg.firstChild);
    const entry = d.entries[state.entry], ch = state.channel;
    const xs = d.x.values;
    const all = [];
    entry.series.forEach(function (s) { all.push.apply(all, s.values[ch]); });
    const log = state.log && range(all, true) !== null;
    const yr = range(all, log), xr = range(xs, false);
    if (!yr || !xr) {
      el("text", { x: W / 2, y: H / 2, "text-anchor": "middle" }, svg).textContent = "no finite values";
      return;
    }
    const px = function (x) { return L + (x - xr[0]) / (xr[1] - xr[0]) * (W - L - R); };
    const py = function (y) { return H - B - (y - yr[0]) / (yr[1] - yr[0]) * (H - T - B); };
    el("rect", { x: L, y: T, width: W - L - R, height: H - T - B, fill: "none", stroke: "#999" }, svg);
    for (const t of ticks(xr[0], xr[1], 8)) {
      el("line", { x1: px(t), x2: px(t), y1: T, y2: H - B, stroke: "#eee" }, svg);
      el("text", { x: px(t), y: H - B + 16, "text-anchor": "middle", "font-size": 12 }, svg).textContent = label(t);
    }
    for (const t of ticks(yr[0], yr[1], 6)) {
      el("line", { x1: L, x2: W - R, y1: py(t), y2: py(t), stroke: "#eee" }, svg);
      el("text", { x: L - 6, y: py(t) + 4, "text-anchor": "end", "font-size": 12 }, svg).textContent = label(log ? Math.pow(10, t) : t);
    }
    el("text", { x: (L + W - R) / 2, y: H - 8, "text-anchor": "middle", "font-size": 13 }, svg).textContent = d.x.name + " (" + d.x.unit + ")";
    const c = d.channels[ch];
    el("text", { x: 14, y: (T + H - B) / 2, "text-anchor": "middle", "font-size": 13, transform: "rotate(-90 14 " + (T + H - B) / 2 + ")" }, svg).textContent = c.name + " (" + c.unit + ")" + (log ? ", log" : "");
    entry.series.forEach(function (s, k) {
      let path = "", pen = false;
      s.values[ch].forEach(function (v, i) {
        if (v === null || !isFinite(v) || (log && v <= 0)) { pen = false; return; }
        const y = log ? Math.log10(v) : v;
        path += (pen ? "L" : "M") + px(xs[i]).toFixed(1) + " " + py(y).toFixed(1);
        pen = true;
      });
      el("path", { d: path, fill: "none", stroke: COLOURS[k % COLOURS.length], "stroke-width": 1.3 }, svg);
      if (s.label) {
        el("text", { x: W - R - 8, y: T + 16 + 15 * k, "text-anchor": "end", "font-size": 12, fill: COLOURS[k % COLOURS.length] }, svg).textContent = s.label;
      }
    });
    state.px = px; state.xr = xr;
  }

  function readout(state, ev) {
    const rect = state.svg.getBoundingClientRect();
    const sx = (ev.clientX - rect.left) / rect.width * W;
    if (!state.xr || sx < L || sx > W - R) { state.readout.textContent = ""; return; }
    const x = state.xr[0] + (sx - L) / (W - L - R) * (state.xr[1] - state.xr[0]);
    const xs = state.data.x.values;
    let best = 0;
    for (let i = 1; i < xs.length; i++) if (Math.abs(xs[i] - x) < Math.abs(xs[best] - x)) best = i;
    const entry = state.data.entries[state.entry];
    const parts = entry.series.map(function (s) {
      const v = s.values[state.channel][best];
      return (s.label ? s.label + ": " : "") + (v === null ? "–" : label(v));
    });
    state.readout.textContent = state.data.x.name + " = " + label(xs[best]) + "  " + parts.join("  ");
  }

  function csv(state) {
    const d = state.data, entry = d.entries[state.entry];
    const head = [d.x.name + " (" + d.x.unit + ")"];
    entry.series.forEach(function (s) {
      d.channels.forEach(function (c) { head.push((s.label ? s.label + " " : "") + c.name); });
    });
    const rows = [head.join(",")];
    d.x.values.forEach(function (x, i) {
      const row = [x];
      entry.series.forEach(function (s) { s.values.forEach(function (v) { row.push(v[i] === null ? "" : v[i]); }); });
      rows.push(row.join(","));
    });
    return rows.join("\n") + "\n";
  }

  function select(options, parent, text, chosen, onchange) {
    if (options.length < 2) return;
    const lab = html("label", text + " ", parent);
    const s = html("select", undefined, lab);
    options.forEach(function (o, i) { const op = html("option", o, s); op.value = String(i); });
    s.value = String(chosen);
    s.addEventListener("change", function () { onchange(Number(s.value)); });
  }

  function setup(div, data) {
    // The middle entry first, as the previews hold an axis at its middle sample.
    const state = { data: data, entry: Math.floor(data.entries.length / 2), channel: 0, log: true };
    const controls = html("div", undefined, div);
    controls.className = "controls";
    const redraw = function () { draw(state); };
    select(data.channels.map(function (c) { return c.name; }), controls, "channel", 0, function (v) { state.channel = v; redraw(); });
    select(data.entries.map(function (e) { return e.label; }), controls, "entry", state.entry, function (v) { state.entry = v; redraw(); });
    const lab = html("label", "", controls);
    const box = html("input", undefined, lab);
    box.type = "checkbox"; box.checked = true;
    lab.appendChild(document.createTextNode(" log scale"));
    box.addEventListener("change", function () { state.log = box.checked; redraw(); });
    const dl = html("button", "download curve (CSV)", controls);
    dl.type = "button";
    dl.addEventListener("click", function () {
      const a = document.createElement("a");
      a.href = URL.createObjectURL(new Blob([csv(state)], { type: "text/csv" }));
      a.download = (div.closest("section").dataset.name || "curve") + ".csv";
      a.click();
    });
    state.svg = el("svg", { viewBox: "0 0 " + W + " " + H, role: "img" }, div);
    state.readout = html("div", "", div);
    state.readout.className = "readout";
    if (data.held.length) html("div", "held at: " + data.held.join(", "), div).className = "held";
    state.svg.addEventListener("mousemove", function (ev) { readout(state, ev); });
    redraw();
  }

  const plots = JSON.parse(document.getElementById("plot-data").textContent);
  let rendered = 0;
  document.querySelectorAll("div.plot").forEach(function (div) {
    const data = plots[Number(div.dataset.table)];
    if (!data) return;
    setup(div, data);
    rendered += 1;
  });
  body.dataset.rendered = String(rendered);

  // Filter: show the tables whose name or schema contains the text (also from #filter=TEXT).
  const box = document.getElementById("filter");
  function applyFilter() {
    const q = box.value.trim().toLowerCase();
    let shown = 0;
    document.querySelectorAll("section.table").forEach(function (s) {
      const hit = !q || (s.dataset.name + " " + s.dataset.schema).toLowerCase().indexOf(q) >= 0;
      s.hidden = !hit;
      if (hit) shown += 1;
    });
    document.querySelectorAll(".toc li").forEach(function (li) {
      li.hidden = q && li.textContent.toLowerCase().indexOf(q) < 0;
    });
    body.dataset.shown = String(shown);
  }
  const m = /^#filter=(.*)$/.exec(location.hash);
  if (m) box.value = decodeURIComponent(m[1]);
  box.addEventListener("input", applyFilter);
  applyFilter();
  window.addEventListener("load", function () {
    let broken = 0;
    document.querySelectorAll("img").forEach(function (img) {
      if (!img.complete || img.naturalWidth === 0) broken += 1;
    });
    body.dataset.brokenImages = String(broken);
  });
})();
