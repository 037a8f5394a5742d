"use strict";
// The operator console page: one WebSocket to the g1_console process, which talks to the mode manager.
// Everything shown comes from the server's `state` messages; every button sends one command and shows the
// service's answer as it came.

const $ = (id) => document.getElementById(id);
const token = new URLSearchParams(location.search).get("token");
const wsUrl = `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws` +
  (token ? `?token=${encodeURIComponent(token)}` : "");

let ws = null;
let connected = false;
let lastState = null;
let history = [];
let retryMs = 500;
let recoverSteps = []; // the recovery's steps, from the console's hello

const plots = {
  velocity: new StripChart($("plot-velocity"), {
    unit: "m/s", zeroBased: true, series: [
      { key: "cmd", label: "commanded", color: "#4da3ff" },
      { key: "ack", label: "acknowledged", color: "#f2c14e" },
      { key: "meas", label: "measured (odometry)", color: "#3ccf6e" },
      { key: "auto", label: "autonomy", color: "#3fd6e0" },
    ],
  }),
  tilt: new StripChart($("plot-tilt"), {
    unit: "rad", zeroBased: true, minRange: 0.1, series: [{ key: "tilt", label: "tilt", color: "#ff8a65" }],
  }),
};

function send(obj) {
  if (!ws || ws.readyState !== WebSocket.OPEN) return false;
  ws.send(JSON.stringify(obj));
  return true;
}

const policyCard = new PolicyCard({ command });

const incidentCard = new IncidentCard({ token });

const teleop = new TeleopInput({ send, stick: $("stick"), knob: $("knob"), onLocalChange: () => renderTeleop() });

function connect() {
  ws = new WebSocket(wsUrl);
  ws.onopen = () => { connected = true; retryMs = 500; renderConnection(); };
  ws.onmessage = (ev) => {
    let msg;
    try { msg = JSON.parse(ev.data); } catch { return; }
    if (msg.type === "hello") onHello(msg);
    else if (msg.type === "state") onState(msg);
    else if (msg.type === "answer") onAnswer(msg);
    else if (msg.type === "refused") onRefused(msg);
    else if (msg.type === "recover") onRecover(msg);
  };
  ws.onclose = () => {
    connected = false;
    teleop.letGo(); // after a reconnect, driving needs a fresh press
    renderConnection();
    renderTeleop();
    setTimeout(connect, retryMs);
    retryMs = Math.min(5000, retryMs * 2);
  };
}

function onHello(msg) {
  $("you").textContent = `you are ${msg.you}`;
  buildModeButtons(msg.modes);
  buildLocoButtons(msg.verbs);
  recoverSteps = msg.recover_steps || [];
  history = msg.history || [];
  policyCard.hello(msg);
  teleop.start(msg.heartbeat_period_s);
}

function button(label, onClick, attrs = {}) {
  const b = document.createElement("button");
  b.type = "button";
  b.textContent = label;
  for (const [k, v] of Object.entries(attrs)) b.setAttribute(k, v);
  b.addEventListener("click", onClick);
  return b;
}

function buildModeButtons(modes) {
  const box = $("modes");
  box.replaceChildren();
  for (const mode of modes) {
    if (mode === "emergency" || mode === "fault") continue; // the E-STOP is the way there; FAULT is the node's
    box.append(button(mode.toUpperCase(), () => command({ type: "set_mode", mode }, "mode-answer", `set_mode ${mode}`),
      { "data-mode": mode }));
  }
  box.append(button("CLEAR FAULT", () => command({ type: "clear_fault" }, "mode-answer", "clear fault"),
    { "data-action": "clear_fault" }));
}

function buildLocoButtons(verbs) {
  const box = $("loco");
  box.replaceChildren();
  for (const [verb, range] of Object.entries(verbs)) {
    if (!range) {
      box.append(button(verb, () => command({ type: "loco", command: verb }, "loco-answer", `loco ${verb}`),
        { "data-verb": verb }));
      continue;
    }
    const pair = document.createElement("span");
    pair.className = "pair";
    const select = document.createElement("select");
    select.setAttribute("aria-label", `${verb} value`);
    for (let v = range[0]; v <= range[1]; v++) select.append(new Option(String(v), String(v)));
    pair.append(select, button(verb, () => {
      const value = Number(select.value);
      command({ type: "loco", command: verb, value }, "loco-answer", `loco ${verb} ${value}`);
    }, { "data-verb": verb }));
    box.append(pair);
  }
}

function command(obj, answerId, what) {
  const box = $(answerId);
  if (send(obj)) {
    box.className = "answer";
    box.textContent = `${what}: sent, waiting for the answer…`;
  } else {
    box.className = "answer bad";
    box.textContent = `${what}: NOT SENT (no connection to the console)`;
  }
}

function estop() {
  const box = $("estop-answer");
  box.textContent = send({ type: "estop" })
    ? "E-STOP sent, waiting for the mode manager's answer…"
    : "E-STOP NOT SENT: no connection to the console. Use another stop!";
}
$("estop").addEventListener("click", estop);
window.addEventListener("keydown", (ev) => {
  if (ev.code !== "Space") return;
  ev.preventDefault(); // a focused button must not be "clicked" by the space bar instead
  if (!ev.repeat) estop();
});
window.addEventListener("keyup", (ev) => { if (ev.code === "Space") ev.preventDefault(); });

function onAnswer(msg) {
  const verdict = `success=${msg.success}`;
  const extra = msg.to === "loco" ? ` code=${msg.code}` : "";
  const text = `${msg.request} (${msg.by}, ${msg.after_s} s): ${verdict}${extra}: ${msg.message}`;
  const id = msg.to.startsWith("policy_") ? "policy-answer" : { estop: "estop-answer", set_mode: "mode-answer",
    clear_fault: "mode-answer", loco: "loco-answer", hand_over: "drive-answer", take_over: "drive-answer" }[msg.to];
  const box = $(id);
  box.textContent = text;
  if (id !== "estop-answer") box.className = `answer ${msg.success ? "ok" : "bad"}`;
}

function onRefused(msg) {
  $("refused").textContent = `the console refused ${msg.count} of your messages; last: ${msg.kind}: ${msg.reason}`;
  if (msg.to === "recover") {
    $("recover-answer").className = "answer bad";
    $("recover-answer").textContent = `REFUSED: ${msg.reason}`;
  }
}

$("hand-over").addEventListener("click",
  () => command({ type: "hand_over" }, "drive-answer", "hand over to autonomy"));
$("take-over").addEventListener("click", () => command({ type: "take_over" }, "drive-answer", "take over"));

// The recovery's steps as the console reports them to every page: asked (waiting for the robot), then the
// node's answer verbatim. A page opened while one runs shows the steps from the next one on.
$("recover").addEventListener("click", () => command({ type: "recover" }, "recover-answer", "recover"));

function showRecoverSteps(steps) {
  $("recover-steps").replaceChildren(...steps.map((step) => {
    const li = document.createElement("li");
    li.dataset.step = step;
    li.textContent = `${step}: not sent yet`;
    return li;
  }));
}

function recoverStep(step) {
  if (!$("recover-steps").children.length) showRecoverSteps(recoverSteps);
  return $("recover-steps").querySelector(`li[data-step="${step}"]`);
}

function onRecover(msg) {
  const box = $("recover-answer");
  if (msg.event === "started") {
    showRecoverSteps(msg.steps);
    box.className = "answer";
    box.textContent = `recover (${msg.by}): running…`;
  } else if (msg.event === "step" && recoverStep(msg.step)) {
    recoverStep(msg.step).className = "running";
    recoverStep(msg.step).textContent = `${msg.step}: sent, waiting for the robot…`;
  } else if (msg.event === "result" && recoverStep(msg.step)) {
    const li = recoverStep(msg.step);
    li.className = msg.success ? "ok" : "bad";
    li.textContent = `${msg.step}: ${msg.success ? "done" : "FAILED"} after ${msg.took_s} s: ${msg.message}`;
  } else if (msg.event === "done") {
    box.className = `answer ${msg.success ? "ok" : "bad"}`;
    box.textContent = `recover (${msg.by}, ${msg.took_s} s): ${msg.message}`;
  }
}

function onState(msg) {
  lastState = msg;
  if (msg.sample) {
    history.push(msg.sample);
    const cut = msg.sample.t - 60;
    while (history.length && history[0].t < cut) history.shift();
  }
  policyCard.sample(msg);
  render();
}

function setBadge(id, text, kind) {
  const b = $(id);
  b.textContent = text;
  b.className = `badge ${kind || ""}`;
  b.hidden = false;
}

function renderConnection() {
  setBadge("conn", connected ? "console connected" : "console DISCONNECTED", connected ? "ok" : "bad");
  const alert = $("alert");
  if (!connected) {
    alert.hidden = false;
    alert.textContent = "No connection to the console: this page can neither stop nor drive the robot.";
  } else if (lastState && !lastState.mode_fresh) {
    alert.hidden = false;
    alert.textContent = lastState.mode
      ? `The mode manager has been silent for ${lastState.mode_age_s} s: what this page shows may be stale.`
      : "No ~/mode from the mode manager yet: is it running?";
  } else {
    alert.hidden = true;
  }
}

function renderHead(s) {
  const head = $("head");
  const mode = s.mode;
  const led = s.led;
  const root = document.documentElement.style;
  root.setProperty("--led", led ? `rgb(${led.rgb.join(",")})` : "rgb(200, 200, 200)");
  root.setProperty("--period", `${led ? led.period_s : 1}s`);
  head.className = `pattern-${led ? led.pattern : "solid"}`;
  $("mode-name").textContent = mode ? mode.name : "NO MODE";
  $("transition").textContent = mode && mode.transition_in_progress ? `→ ${mode.transition_target} (in progress)` : "";
  if (mode && (mode.name === "EMERGENCY" || mode.name === "FAULT")) {
    setBadge("damp", mode.damp_confirmed ? "damp_confirmed" : "NOT damp_confirmed", mode.damp_confirmed ? "ok" : "bad");
  } else {
    $("damp").hidden = true;
  }
  if (mode) {
    setBadge("link", mode.link_ok ? "link ok" : "LINK LOST", mode.link_ok ? "ok" : "bad");
    setBadge("service", `service ${mode.high_level_service}`, mode.high_level_service === "active" ? "ok" : "warn");
    const posture = mode.posture || "unknown";
    setBadge("posture", `posture ${posture.replace("_", " ")}`,
      posture.startsWith("lying") ? "bad" : posture === "unknown" ? "warn" : posture === "standing" ? "ok" : "");
  }
  setBadge("consoles", `${s.consoles} console${s.consoles === 1 ? "" : "s"}` +
    (s.driving ? ` · ${s.driving} drives` : ""));
  $("mode-note").textContent = !mode ? "" : {
    EMERGENCY: "EMERGENCY is never left: make the robot safe, then restart the mode manager.",
    FAULT: "FAULT: CLEAR FAULT goes to IDLE once every tripped check has been clear for a while.",
  }[mode.name] || "";
  document.querySelectorAll("#modes button[data-mode]").forEach((b) => {
    b.classList.toggle("current", !!mode && b.dataset.mode.toUpperCase() === mode.name);
  });
}

const fmt = (v, digits, unit) => (v === null || v === undefined ? "no data" : `${v.toFixed(digits)} ${unit}`);

function renderHealth(s) {
  const mode = s.mode || {};
  const fill = (id, items) => $(id).replaceChildren(...(items || []).map((t) => {
    const li = document.createElement("li");
    li.textContent = t;
    return li;
  }));
  fill("faults", (mode.faults || []).map((f) => `FAULT ${f}`));
  fill("holds", (mode.holds || []).map((h) => `hold ${h}`));
  fill("warnings", [...(mode.warnings || []), ...(mode.robot_mismatch ? [`mismatch: ${mode.robot_mismatch}`] : [])]);
  const body = s.body;
  if (body) {
    $("battery").textContent = fmt(body.battery_pct, 0, "%");
    const hot = [body.winding_max_c !== null ? `winding ${body.winding_max_c.toFixed(0)} °C` : null,
      body.casing_max_c !== null ? `casing ${body.casing_max_c.toFixed(0)} °C` : null].filter(Boolean);
    $("hottest").textContent = hot.length ? hot.join(", ") : "no data";
    // the plot's source when it is fresher (IMU or odometry) than the body check's 1 Hz value
    const tilt = s.sample && s.sample.tilt !== null ? s.sample.tilt : body.tilt_rad;
    $("tilt").textContent = tilt === null ? "no data" : `${tilt.toFixed(3)} rad (${(tilt * 180 / Math.PI).toFixed(1)}°)`;
  } else {
    $("battery").textContent = "no data (no body checks in /diagnostics)";
    $("hottest").textContent = $("tilt").textContent = "no data";
  }
  $("odometry").textContent = s.odometry || "–";
  $("last-refusal").textContent = mode.last_refusal || "none";
  $("last-error").textContent = mode.last_error || "none";
}

// Who drives the robot (~/mode): the teleop (cmd_vel: this console, g1ctl, a joystick) or the autonomy.
function renderDriver(mode) {
  const box = $("driver");
  const driver = mode ? mode.driver : "unknown";
  const suspended = mode && mode.autonomy_suspended;
  box.className = `driver ${suspended ? "suspended" : driver}`;
  box.textContent = `drives: ${driver}` + (suspended ? ` (${suspended})` : "");
}

// This page's own driving; the dead-man's rules are the teleop's: a page that lets go sends nothing, which
// leaves a driving autonomy alone.
function renderTeleop() {
  const box = $("teleop-status");
  const t = lastState && lastState.teleop;
  const autonomy = !!(lastState && lastState.mode && lastState.mode.driver === "autonomy");
  if (!connected) {
    box.className = "teleop-status blocked";
    box.textContent = "STOPPED: no connection to the console";
  } else if (!teleop.visible() || !teleop.focused()) {
    box.className = "teleop-status blocked";
    box.textContent = autonomy ? "NOT SENDING: this page is hidden or not focused (the autonomy drives on)"
      : "STOPPED: this page is hidden or not focused";
  } else if (t && t.publishing) {
    box.className = "teleop-status driving";
    box.textContent = "DRIVING: cmd_vel published";
  } else if (t && t.why_not && teleop.held()) {
    box.className = "teleop-status blocked";
    box.textContent = `NOT DRIVING: ${t.why_not}`;
  } else {
    box.className = "teleop-status idle";
    box.textContent = autonomy ? "the autonomy drives: hold a key or the stick, or TAKE OVER, to take it back"
      : t && t.driver && !t.you_drive ? `${t.driver} drives` : "not driving: hold a key or the stick";
  }
}

function render() {
  const s = lastState;
  if (!s) return;
  renderConnection();
  renderHead(s);
  renderHealth(s);
  renderDriver(s.mode);
  renderTeleop();
  if (s.refused && Object.keys(s.refused).length) {
    const all = Object.entries(s.refused).map(([k, v]) => `${k} ${v}`).join(", ");
    if (!$("refused").textContent.startsWith("the console refused")) $("refused").textContent = `refused (all consoles): ${all}`;
  }
  $("recover").classList.toggle("current", !!s.recovery); // one runs (any console's)
  plots.velocity.draw(history);
  plots.tilt.draw(history);
  policyCard.render(s);
  incidentCard.looks(s.node_params);
}

window.addEventListener("resize", render);
renderConnection();
connect();
incidentCard.start();
