"use strict";
// Teleop input: W/A/S/D/Q/E and an on-screen stick, sent with the page's visibility and focus as one
// `teleop` message every heartbeat period and at once on any change. The server's dead-man decides; this side
// lets go by itself whenever the page is hidden or blurred (keys cannot be trusted after a blur: their keyup
// may never come).

const KEY_AXES = { // fractions of the console's limits
  w: [0.5, 0, 0], s: [-0.5, 0, 0], a: [0, 0.5, 0], d: [0, -0.5, 0], q: [0, 0, 0.5], e: [0, 0, -0.5],
};

class TeleopInput {
  constructor({ send, stick, knob, onLocalChange }) {
    this.send = send; // (obj) => bool
    this.keys = new Set();
    this.stickAxes = null; // [vx, wz] while the stick is held
    this.seq = 0;
    this.periodMs = 100;
    this.stick = stick;
    this.knob = knob;
    this.onLocalChange = onLocalChange || (() => {});
    this.timer = null;
    this.bind();
  }

  start(periodS) {
    this.periodMs = Math.max(20, Math.round(periodS * 1000));
    if (this.timer) clearInterval(this.timer);
    this.timer = setInterval(() => this.beat(), this.periodMs);
    this.beat();
  }

  visible() { return document.visibilityState === "visible"; }
  focused() { return document.hasFocus(); }

  axes() {
    if (!this.visible() || !this.focused()) return [0, 0, 0];
    if (this.stickAxes) return [this.stickAxes[0], 0, this.stickAxes[1]];
    const sum = [0, 0, 0];
    for (const k of this.keys) KEY_AXES[k].forEach((v, i) => { sum[i] += v; });
    return sum.map((v) => Math.max(-1, Math.min(1, v)));
  }

  held() { return this.axes().some((v) => v !== 0); }

  beat() {
    const [vx, vy, wz] = this.axes();
    this.seq = (this.seq + 1) % 2147483647;
    this.send({ type: "teleop", visible: this.visible(), focused: this.focused(), vx, vy, wz, seq: this.seq });
  }

  letGo() {
    this.keys.clear();
    this.stickAxes = null;
    this.placeKnob(0, 0);
    this.stick.classList.remove("active");
    document.querySelectorAll("kbd.down").forEach((k) => k.classList.remove("down"));
    this.beat();
    this.onLocalChange();
  }

  bind() {
    window.addEventListener("keydown", (ev) => {
      const k = ev.key.toLowerCase();
      if (!(k in KEY_AXES) || ev.ctrlKey || ev.metaKey || ev.altKey) return;
      ev.preventDefault();
      if (this.keys.has(k)) return; // auto-repeat: already held
      // a key still held down through a let-go (blur, hidden page, lost socket) repeats, but must be pressed
      // again to drive: nothing restarts motion by itself
      if (ev.repeat) return;
      this.keys.add(k);
      document.querySelector(`kbd[data-key="${k}"]`)?.classList.add("down");
      this.beat();
      this.onLocalChange();
    });
    window.addEventListener("keyup", (ev) => {
      const k = ev.key.toLowerCase();
      if (!this.keys.delete(k)) return;
      document.querySelector(`kbd[data-key="${k}"]`)?.classList.remove("down");
      this.beat();
      this.onLocalChange();
    });
    document.addEventListener("visibilitychange", () => this.letGo());
    window.addEventListener("blur", () => this.letGo());
    window.addEventListener("focus", () => this.beat());
    window.addEventListener("pagehide", () => this.letGo());

    const move = (ev) => {
      const r = this.stick.getBoundingClientRect();
      const radius = r.width / 2;
      let dx = (ev.clientX - (r.left + radius)) / radius;
      let dy = (ev.clientY - (r.top + radius)) / radius;
      const n = Math.hypot(dx, dy);
      if (n > 1) { dx /= n; dy /= n; }
      this.placeKnob(dx, dy);
      const dead = (v) => (Math.abs(v) < 0.08 ? 0 : v);
      // up = forward, left = turn left (positive yaw rate)
      this.stickAxes = [dead(-dy), dead(-dx)];
      this.beatSoon();
      this.onLocalChange();
    };
    this.stick.addEventListener("pointerdown", (ev) => {
      this.stick.setPointerCapture(ev.pointerId);
      this.stick.classList.add("active");
      move(ev);
    });
    this.stick.addEventListener("pointermove", (ev) => { if (this.stickAxes) move(ev); });
    for (const name of ["pointerup", "pointercancel", "lostpointercapture"]) {
      this.stick.addEventListener(name, () => { if (this.stickAxes) this.letGo(); });
    }
  }

  // while the stick moves, at most one extra message per 40 ms (the server allows a steady 50 a second)
  beatSoon() {
    const now = performance.now();
    if (this.lastSoon && now - this.lastSoon < 40) return;
    this.lastSoon = now;
    this.beat();
  }

  placeKnob(dx, dy) {
    const r = this.stick.clientWidth / 2 - this.knob.clientWidth / 2;
    this.knob.style.transform = `translate(${dx * r}px, ${dy * r}px)`;
  }
}
