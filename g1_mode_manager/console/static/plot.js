"use strict";
// A small strip chart on a canvas: the last `windowS` seconds of some series from the console's samples.
// A null value is a gap (that source is not there or went stale), never a zero.

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
    const c = this.canvas;
    const ratio = window.devicePixelRatio || 1;
    const w = c.clientWidth || 600;
    const h = Math.round(w * (c.height / c.width)) || 160;
    if (c.width !== Math.round(w * ratio)) {
      const aspect = c.height / c.width;
      c.width = Math.round(w * ratio);
      c.height = Math.round(w * ratio * aspect);
    }
    const g = c.getContext("2d");
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    g.clearRect(0, 0, w, h);
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
    g.font = "11px system-ui, sans-serif";
    // the legend first, in as many rows as the width needs (a phone, a narrow card)
    const pad = { l: 42, r: 8, t: 0, b: 16 };
    const keys = [];
    let lx = pad.l;
    let ly = 11;
    for (const { label, color } of this.series) {
      const width = g.measureText(label).width + 14;
      if (lx > pad.l && lx + width > w - pad.r) { lx = pad.l; ly += 13; }
      keys.push({ label, color, lx, ly });
      lx += width + 16;
    }
    pad.t = ly + 7;
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
