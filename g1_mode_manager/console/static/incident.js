"use strict";
// The Last incident card: the newest file of the mode manager's flight recorder (GET /incident/last), its cause and
// mode, tilt, commanded and measured velocity and the mode over its window, the e-stop's steps with their times
// (seconds from the stop), and the file to download. Asked again every POLL_MS while the page is visible: the
// console answers 304 while the newest file is the same one, so a hidden or idle page costs nothing.

const INCIDENT_POLL_MS = 2000;

class IncidentCard {
  constructor({ token }) {
    this.query = token ? `?token=${encodeURIComponent(token)}` : "";
    this.etag = null;
    this.incident = null; // the last good answer's incident (null: none yet)
    this.colors = {}; // mode -> the head LED's colour for it, from the node's parameters
    this.timer = null;
    this.velocity = new IncidentChart(document.getElementById("plot-incident-velocity"), {
      unit: "m/s, rad/s", series: [
        { key: "cmd_vx", label: "commanded vx", color: "#4da3ff" },
        { key: "meas_vx", label: "measured vx (odometry)", color: "#3ccf6e" },
        { key: "cmd_wz", label: "commanded wz", color: "#b48cff" },
        { key: "meas_wz", label: "measured wz", color: "#f2c14e" },
      ],
    });
    this.tilt = new IncidentChart(document.getElementById("plot-incident-tilt"), {
      unit: "rad", zeroBased: true, minRange: 0.1, series: [{ key: "tilt", label: "tilt", color: "#ff8a65" }],
    });
    document.addEventListener("visibilitychange", () => this.schedule(0));
    window.addEventListener("resize", () => this.draw());
  }

  start() { this.schedule(0); }

  schedule(ms) {
    clearTimeout(this.timer);
    this.timer = setTimeout(() => this.poll(), ms);
  }

  async poll() {
    if (document.visibilityState !== "visible") return; // visibilitychange asks again once it is shown
    try {
      const r = await fetch(`/incident/last${this.query}`,
        { cache: "no-store", headers: this.etag ? { "If-None-Match": this.etag } : {} });
      if (r.status === 200) {
        const body = await r.json();
        this.etag = r.headers.get("ETag");
        this.show(body);
      } else if (r.status !== 304) {
        this.status(`the console answered ${r.status}`, "bad");
      }
    } catch (err) {
      this.status(`no answer from the console: ${err.message}`, "bad");
    } finally {
      this.schedule(INCIDENT_POLL_MS);
    }
  }

  // The head LED's colour of each mode (the node's head_led_<mode>: "r g b pattern ..."), for the mode band.
  looks(nodeParams) {
    const colors = {};
    for (const [name, text] of Object.entries(nodeParams || {})) {
      const rgb = name.startsWith("head_led_") && typeof text === "string" ? text.trim().split(/\s+/, 3) : null;
      if (rgb && rgb.length === 3) colors[name.slice("head_led_".length).toUpperCase()] = `rgb(${rgb.join(",")})`;
    }
    if (JSON.stringify(colors) === JSON.stringify(this.colors)) return;
    this.colors = colors;
    this.draw();
  }

  status(text, kind) {
    const box = document.getElementById("incident-status");
    box.className = `answer ${kind || ""}`;
    box.textContent = text;
  }

  show(body) {
    const inc = body.incident;
    const link = document.getElementById("incident-download");
    const set = (id, text) => { document.getElementById(id).textContent = text; };
    if (!inc) {
      this.incident = null;
      this.status(`no incident yet in ${body.folder}`, "");
      ["incident-when", "incident-cause", "incident-mode"].forEach((id) => set(id, "–"));
      link.hidden = true;
      document.getElementById("incident-steps").replaceChildren();
      this.draw();
      return;
    }
    set("incident-when", new Date(inc.began * 1000).toLocaleString());
    link.href = `/incident/file/${encodeURIComponent(inc.name)}${this.query}`;
    link.textContent = `Download ${inc.name} (${(inc.size / 1024).toFixed(0)} KiB)`;
    link.hidden = false;
    if (inc.error) { // the file is there but cannot be read: say so, and keep it downloadable
      this.incident = null;
      this.status(inc.error, "bad");
      set("incident-cause", inc.kind);
      set("incident-mode", "?");
      document.getElementById("incident-steps").replaceChildren();
      this.draw();
      return;
    }
    this.incident = inc;
    this.status(`${inc.kind}: ${inc.start.toFixed(1)} s to +${inc.end.toFixed(1)} s around the stop`, "");
    set("incident-cause", inc.cause);
    set("incident-mode", inc.mode);
    document.getElementById("incident-steps").replaceChildren(...inc.steps.map((s) => {
      const li = document.createElement("li");
      li.dataset.step = s.step;
      li.dataset.t = String(s.t);
      li.textContent = `${s.t >= 0 ? "+" : ""}${s.t.toFixed(3)} s · ${s.step}${s.detail ? `: ${s.detail}` : ""}`;
      return li;
    }));
    this.draw();
  }

  draw() {
    this.velocity.draw(this.incident);
    this.tilt.draw(this.incident, this.colors);
  }
}
