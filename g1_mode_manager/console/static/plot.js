"use strict";
// Small charts on a canvas: a strip chart (the last `windowS` seconds of some series from the console's samples)
// and bars (one value per joint). A null value is a gap or "no data" (that source is not there or went stale),
// never a zero.

// The canvas at its shown width (its aspect kept) and the device's pixel ratio: the context and the size to draw in.
function fitCanvas(c, fallbackHeight) {
  const ratio = window.devicePixelRatio || 1;
  const w = c.clientWidth || 600;
  const h = Math.round(w * (c.height / c.width)) || fallbackHeight;
  if (c.width !== Math.round(w * ratio)) {
    const aspect = c.height / c.width;
    c.width = Math.round(w * ratio);
    c.height = Math.round(w * ratio * aspect);
  }
  const g = c.getContext("2d");
  g.setTransform(ratio, 0, 0, ratio, 0, 0);
  g.clearRect(0, 0, w, h);
  g.font = "11px system-ui, sans-serif";
  return { g, w, h };
}

// The legend's keys in as many rows as the width needs (a phone, a narrow card); pad.t is set below them.
function layoutLegend(g, series, w, pad) {
  const keys = [];
  let lx = pad.l;
  let ly = 11;
  for (const { label, color } of series) {
    const width = g.measureText(label).width + 14;
    if (lx > pad.l && lx + width > w - pad.r) { lx = pad.l; ly += 13; }
    keys.push({ label, color, lx, ly });
    lx += width + 16;
  }
  pad.t = ly + 7;
  return keys;
}

class StripChart {
  constructor(canvas, { series, unit, windowS = 30, minRange = 0.2, zeroBased = false }) {
    this.canvas = canvas;
    this.series = series; // [{ key, label, color }]
    this.unit = unit;
    this.windowS = windowS;
    this.minRange = minRange;
    this.zeroBased = zeroBased;
  }

  draw(samples) {
    const { g, w, h } = fitCanvas(this.canvas, 160);
    const end = samples.length ? samples[samples.length - 1].t : 0;
    const start = end - this.windowS;
    const shown = samples.filter((s) => s.t >= start);
    let lo = Infinity;
    let hi = -Infinity;
    for (const s of shown) {
      for (const { key } of this.series) {
        const v = s[key];
        if (v !== null && v !== undefined) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
      }
    }
    if (!isFinite(lo)) { lo = 0; hi = this.minRange; }
    if (this.zeroBased) lo = Math.min(lo, 0);
    if (hi - lo < this.minRange) hi = lo + this.minRange;
    const pad = { l: 42, r: 8, t: 0, b: 16 };
    const keys = layoutLegend(g, this.series, w, pad);
    const x = (t) => pad.l + ((t - start) / this.windowS) * (w - pad.l - pad.r);
    const y = (v) => h - pad.b - ((v - lo) / (hi - lo)) * (h - pad.t - pad.b);
    g.strokeStyle = "#2a323c";
    g.fillStyle = "#8b96a5";
    g.lineWidth = 1;
    for (const v of [lo, (lo + hi) / 2, hi]) {
      g.beginPath(); g.moveTo(pad.l, y(v)); g.lineTo(w - pad.r, y(v)); g.stroke();
      g.fillText(v.toFixed(2), 2, y(v) + 4);
    }
    g.fillText(`${this.unit} · last ${this.windowS} s`, pad.l, h - 3);
    for (const { key, color } of this.series) {
      g.strokeStyle = color;
      g.lineWidth = 2;
      g.beginPath();
      let pen = false;
      for (const s of shown) {
        const v = s[key];
        if (v === null || v === undefined) { pen = false; continue; }
        if (pen) g.lineTo(x(s.t), y(v)); else g.moveTo(x(s.t), y(v));
        pen = true;
      }
      g.stroke();
    }
    for (const { label, color, lx: kx, ly: ky } of keys) {
      g.fillStyle = color;
      g.fillRect(kx, ky - 6, 10, 3);
      g.fillText(label, kx + 14, ky);
    }
  }
}

// One bar per joint, in the motor order, grouped by limb (a gap and a label under each group): a signed value
// such as target - measured. Bars beyond `limit` (and the ±limit lines) are drawn in the warning colour.
class JointBars {
  constructor(canvas, { unit, minRange = 0.1, color = "#4da3ff", over = "#ff4d4d" }) {
    this.canvas = canvas;
    this.unit = unit;
    this.minRange = minRange;
    this.color = color;
    this.over = over;
    this.names = [];
  }

  static group(name) {
    if (name.startsWith("waist")) return "waist";
    const side = name.startsWith("left") ? "left" : "right";
    return `${side} ${/hip|knee|ankle/.test(name) ? "leg" : "arm"}`;
  }

  draw(values, limit, title, empty) {
    const { g, w, h } = fitCanvas(this.canvas, 140);
    const pad = { l: 42, r: 8, t: 18, b: 16 };
    g.fillStyle = "#8b96a5";
    if (!values) {
      g.fillText(empty, pad.l, h / 2);
      return;
    }
    const span = Math.max(this.minRange, limit || 0, ...values.map((v) => Math.abs(v))) * 1.1;
    const mid = pad.t + (h - pad.t - pad.b) / 2;
    const y = (v) => mid - (v / span) * ((h - pad.t - pad.b) / 2);
    const groups = [];
    this.names.forEach((name, i) => {
      const label = JointBars.group(name);
      if (!groups.length || groups[groups.length - 1].label !== label) groups.push({ label, first: i, last: i });
      else groups[groups.length - 1].last = i;
    });
    const gap = 6;
    const slot = (w - pad.l - pad.r - gap * (groups.length - 1)) / Math.max(1, values.length);
    const x = (i) => pad.l + i * slot + gap * groups.findIndex((gr) => i >= gr.first && i <= gr.last);
    g.strokeStyle = "#2a323c";
    g.lineWidth = 1;
    for (const v of [-span / 1.1, 0, span / 1.1]) {
      g.beginPath(); g.moveTo(pad.l, y(v)); g.lineTo(w - pad.r, y(v)); g.stroke();
      g.fillText(v.toFixed(2), 2, y(v) + 4);
    }
    if (limit) {
      g.strokeStyle = this.over;
      g.setLineDash([4, 4]);
      for (const v of [-limit, limit]) { g.beginPath(); g.moveTo(pad.l, y(v)); g.lineTo(w - pad.r, y(v)); g.stroke(); }
      g.setLineDash([]);
    }
    values.forEach((v, i) => {
      g.fillStyle = limit && Math.abs(v) > limit ? this.over : this.color;
      const top = Math.min(y(v), y(0));
      g.fillRect(x(i) + 1, top, Math.max(1, slot - 2), Math.max(1, Math.abs(y(v) - y(0))));
    });
    g.fillStyle = "#8b96a5";
    for (const gr of groups) {
      const text = gr.label;
      const centre = (x(gr.first) + x(gr.last) + slot) / 2;
      g.fillText(text, centre - g.measureText(text).width / 2, h - 3);
    }
    g.fillStyle = "#e8ecf1";
    g.fillText(`${title} (${this.unit})`, pad.l, 12);
  }
}

// An incident over its whole window, in seconds from the stop (t = 0, a red line): series of [t, value] points, each
// drawn on its own (they come at their own times), the e-stop's steps as dashed marks, and under the plot, if given,
// the mode over time as a band in each mode's colour.
class IncidentChart {
  constructor(canvas, { series, unit, minRange = 0.2, zeroBased = false }) {
    this.canvas = canvas;
    this.series = series; // [{ key, label, color }]
    this.unit = unit;
    this.minRange = minRange;
    this.zeroBased = zeroBased;
  }

  // incident: { start, end, series: { key: [[t, v], ...] }, steps: [{ t }], modes: [[t, mode], ...] } or null;
  // colors: mode -> css colour, for the band (none: no band).
  draw(incident, colors) {
    const { g, w, h } = fitCanvas(this.canvas, 150);
    g.fillStyle = "#8b96a5";
    if (!incident) {
      g.fillText("no incident", 42, h / 2);
      return;
    }
    const start = incident.start;
    const end = Math.max(incident.end, start + 0.1);
    let lo = Infinity;
    let hi = -Infinity;
    for (const { key } of this.series) {
      for (const [, v] of incident.series[key] || []) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    }
    if (!isFinite(lo)) { lo = 0; hi = this.minRange; }
    if (this.zeroBased) lo = Math.min(lo, 0);
    if (hi - lo < this.minRange) hi = lo + this.minRange;
    const band = colors && incident.modes && incident.modes.length ? 13 : 0;
    const pad = { l: 42, r: 8, t: 0, b: 28 + band };
    const keys = layoutLegend(g, this.series, w, pad);
    const x = (t) => pad.l + ((Math.min(end, Math.max(start, t)) - start) / (end - start)) * (w - pad.l - pad.r);
    const y = (v) => h - pad.b - ((v - lo) / (hi - lo)) * (h - pad.t - pad.b);
    g.strokeStyle = "#2a323c";
    g.lineWidth = 1;
    for (const v of [lo, (lo + hi) / 2, hi]) {
      g.beginPath(); g.moveTo(pad.l, y(v)); g.lineTo(w - pad.r, y(v)); g.stroke();
      g.fillText(v.toFixed(2), 2, y(v) + 4);
    }
    // seconds from the stop along the bottom: a tick every 1, 2, 5, 10 ... s, as many as fit
    const step = [1, 2, 5, 10, 20, 50, 100, 200].find((s) => (end - start) / s <= 8) || 500;
    for (let t = Math.ceil(start / step) * step; t <= end; t += step) {
      const text = `${t > 0 ? "+" : ""}${t}`;
      g.fillText(text, x(t) - g.measureText(text).width / 2, h - 15);
    }
    g.fillText(`${this.unit} · s from the stop`, pad.l, h - 3);
    if (band) {
      const top = h - pad.b + 4;
      incident.modes.forEach(([t, mode], i) => {
        const next = i + 1 < incident.modes.length ? incident.modes[i + 1][0] : end;
        const x0 = x(t);
        const x1 = x(next);
        g.fillStyle = colors[mode] || "#5a6472";
        g.fillRect(x0, top, Math.max(1, x1 - x0), band - 3);
        if (x1 - x0 > g.measureText(mode).width + 6) {
          g.fillStyle = "#0b0d10";
          g.fillText(mode, x0 + 3, top + band - 5);
        }
      });
    }
    g.setLineDash([3, 3]);
    g.strokeStyle = "#c9d1db";
    for (const { t } of incident.steps || []) {
      g.beginPath(); g.moveTo(x(t), pad.t); g.lineTo(x(t), h - pad.b); g.stroke();
    }
    g.setLineDash([]);
    g.strokeStyle = "#ff4d4d";
    g.lineWidth = 2;
    g.beginPath(); g.moveTo(x(0), pad.t); g.lineTo(x(0), h - pad.b); g.stroke();
    for (const { key, color } of this.series) {
      g.strokeStyle = color;
      g.lineWidth = 2;
      g.beginPath();
      (incident.series[key] || []).forEach(([t, v], i) => (i ? g.lineTo(x(t), y(v)) : g.moveTo(x(t), y(v))));
      g.stroke();
    }
    for (const { label, color, lx: kx, ly: ky } of keys) {
      g.fillStyle = color;
      g.fillRect(kx, ky - 6, 10, 3);
      g.fillText(label, kx + 14, ky);
    }
  }
}
