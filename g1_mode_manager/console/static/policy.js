"use strict";
// The Policy card: the mode manager's ~/policy/* verbs (each answer shown as the node gave it), the loop's status
// from ~/policy/status, and the policy's targets against the measured joints: the largest |target - measured| over
// time beside the node's engage bound, and target - measured per joint now.

const OTHER_POLICY = "(other)"; // the selector's "type a name or a path" choice (no built-in policy's name)

class PolicyCard {
  constructor({ command }) {
    this.command = command;
    this.history = [];
    this.select = document.getElementById("policy-name");
    this.other = document.getElementById("policy-other");
    this.select.addEventListener("change", () => {
      this.other.hidden = this.select.value !== OTHER_POLICY;
      if (!this.other.hidden) this.other.focus();
    });
    // Typing in the name field types: its keydowns do not reach the page's keys (W/A/S/D/Q/E drive, the space bar
    // is the E-STOP); their keyups still do, so a key held before is still let go. Enter loads.
    this.other.addEventListener("keydown", (ev) => {
      ev.stopPropagation();
      if (ev.key === "Enter") this.send("load");
    });
    this.strip = new StripChart(document.getElementById("plot-policy"), {
      unit: "rad", zeroBased: true, minRange: 0.1, series: [
        { key: "err", label: "largest |target − measured|", color: "#f2c14e" },
        { key: "lim", label: "engage bound", color: "#ff4d4d" },
      ],
    });
    this.bars = new JointBars(document.getElementById("plot-joints"), { unit: "rad" });
  }

  hello(msg) {
    const box = document.getElementById("policy-verbs");
    box.replaceChildren(...(msg.policy_verbs || []).map((verb) => {
      const b = document.createElement("button");
      b.type = "button";
      b.textContent = verb.toUpperCase();
      b.dataset.policyVerb = verb;
      b.addEventListener("click", () => this.send(verb));
      return b;
    }));
    const chosen = this.select.value;
    this.select.replaceChildren(new Option("default", ""),
      ...(msg.policies || []).map((name) => new Option(name, name)),
      new Option("other: a name or a .yaml path…", OTHER_POLICY));
    if ([...this.select.options].some((o) => o.value === chosen)) this.select.value = chosen;
    this.bars.names = msg.joints || [];
    this.history = msg.policy_history || [];
  }

  send(verb) {
    const what = `policy ${verb}`;
    if (verb !== "load") {
      this.command({ type: "policy", verb }, "policy-answer", what);
      return;
    }
    const policy = this.select.value === OTHER_POLICY ? this.other.value.trim() : this.select.value;
    if (this.select.value === OTHER_POLICY && !policy) {
      const box = document.getElementById("policy-answer");
      box.className = "answer bad";
      box.textContent = `${what}: NOT SENT (type a policy's name or a deploy config's path)`;
      return;
    }
    this.command({ type: "policy", verb, policy }, "policy-answer", `${what} ${policy || "(the node's default)"}`);
  }

  // Each state message's plot point, kept for the last 60 s as the page's other plots are.
  sample(msg) {
    if (!msg.policy_sample) return;
    this.history.push(msg.policy_sample);
    const cut = msg.policy_sample.t - 60;
    while (this.history.length && this.history[0].t < cut) this.history.shift();
  }

  render(msg) {
    const p = msg.policy;
    if (!p) return;
    const s = p.status;
    const phase = document.getElementById("policy-phase");
    phase.textContent = s.phase.toUpperCase();
    phase.className = `policy-phase ${s.phase}`;
    this.select.options[0].textContent = p.default ? `default (${p.default})` : "default (the node's)";
    const set = (id, text) => { document.getElementById(id).textContent = text; };
    const none = (v) => v === null || v === undefined;
    const num = (v, digits, unit) => (none(v) ? "–" : `${v.toFixed(digits)} ${unit}`);
    const loaded = !!s.policy; // a status with no policy (unloaded) has nothing to say below its phase
    const bound = p.engage_limit_rad ? ` (engage needs ≤ ${p.engage_limit_rad} on every joint)` : "";
    set("policy-loaded", s.no_status ? "none (no ~/policy/status from the mode manager yet)" : s.policy || "none");
    set("policy-rate", s.rate_hz ? num(s.rate_hz, 1, "Hz") : "not ticking");
    set("policy-p99", loaded ? `${num(s.inference_p99_ms, 2, "ms")} / ${num(s.tick_p99_ms, 2, "ms")}` : "–");
    set("policy-timing", loaded ? `${num(s.state_to_frame_p99_ms, 2, "ms")} / ${num(s.frame_jitter_p99_ms, 2, "ms")}`
      : "–");
    set("policy-scale", loaded ? s.action_scale || "–" : "–");
    const clamped = Object.entries(s.clamped || {});
    set("policy-clamped", !loaded ? "–" : clamped.length ? clamped.map(([j, n]) => `${j} ${n}`).join(", ") : "none");
    set("policy-ticks", loaded ? `${s.ticks} ticks, ${s.overruns} overruns, ${s.skipped} skipped` : "–");
    set("policy-blend", loaded ? `${(100 * s.blend).toFixed(0)} %` : "–");
    set("policy-progress", !loaded ? "–" : none(s.progress) ? "– (runs until stopped)"
      : `${(100 * s.progress).toFixed(1)} %`);
    set("policy-tracking", !loaded ? "–" : none(s.tracking_error_rad) ? "– (no reference motion)"
      : num(s.tracking_error_rad, 3, "rad"));
    set("policy-error", (s.rate_hz ? num(s.max_target_error_rad, 3, "rad") : "–") + bound);
    set("policy-fault", s.last_fault || "none");
    this.draw(p);
  }

  draw(p) {
    const limit = p ? p.engage_limit_rad : null;
    this.strip.draw(this.history.map((x) => ({ ...x, lim: limit })));
    const j = p && p.joints;
    const diff = j ? j.target.map((t, i) => t - j.measured[i]) : null;
    let title = "target − measured per joint";
    if (diff) {
      const worst = diff.reduce((best, v, i) => (Math.abs(v) > Math.abs(diff[best]) ? i : best), 0);
      title += ` · largest: ${(this.bars.names[worst] || "").replace(/_joint$/, "")} ${diff[worst].toFixed(3)}`;
    }
    this.bars.draw(diff, limit, title, "no targets: the policy's loop does not tick");
  }
}
