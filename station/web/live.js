// Runs in progress: poll /api/runs and update each unit's numbers and its Allan curve in
// place (station/web/pages.py names the cells with data-run, data-unit and data-field).
// Text goes in through textContent only: nothing from the server is parsed as markup.
"use strict";
(function () {
  const POLL_MS = 2000;
  const COLORS = ["#1565c0", "#2e7d32", "#c62828"];
  const SVG_NS = "http://www.w3.org/2000/svg";

  function drawAllan(svg, curve) {
    svg.querySelectorAll("polyline").forEach((p) => p.remove());
    const w = Number(svg.getAttribute("width")), h = Number(svg.getAttribute("height"));
    const tau = curve.tau_s;
    const values = curve.adev_deg_h.flat().filter((v) => v);
    if (!tau.length || !values.length) return;
    const g3 = (v) => Number(v.toPrecision(3)).toString();
    const label = (name, words) => {
      const node = svg.querySelector("text." + name);
      if (node) node.textContent = words;
    };
    label("adev-max", g3(Math.max(...values)) + " deg/h");
    label("adev-min", g3(Math.min(...values)) + " deg/h");
    label("tau-range", "tau " + g3(Math.min(...tau)) + " to " + g3(Math.max(...tau)) + " s");
    const x0 = Math.log10(Math.min(...tau)), x1 = Math.log10(Math.max(...tau)) + 1e-9;
    const y0 = Math.log10(Math.min(...values)), y1 = Math.log10(Math.max(...values)) + 1e-9;
    curve.adev_deg_h.forEach((axis, i) => {
      const pts = [];
      axis.forEach((v, j) => {
        if (!v) return;
        const x = (Math.log10(tau[j]) - x0) / (x1 - x0) * (w - 10) + 5;
        const y = h - 5 - (Math.log10(v) - y0) / (y1 - y0) * (h - 10);
        pts.push(x.toFixed(1) + "," + y.toFixed(1));
      });
      const line = document.createElementNS(SVG_NS, "polyline");
      line.setAttribute("fill", "none");
      line.setAttribute("stroke", COLORS[i % 3]);
      line.setAttribute("points", pts.join(" "));
      svg.appendChild(line);
    });
  }

  // as station/web/html.py's clock(): h:mm:ss (mm:ss.s under a minute's worth of digits)
  function clock(seconds, decimals) {
    const scale = 10 ** decimals;
    const total = Math.round(Math.max(0, seconds) * scale);
    const h = Math.floor(total / (3600 * scale));
    const m = Math.floor((total % (3600 * scale)) / (60 * scale));
    const s = (total % (60 * scale)) / scale;
    const sec = s.toFixed(decimals).padStart(decimals ? 3 + decimals : 2, "0");
    return h ? `${h}:${String(m).padStart(2, "0")}:${sec}` : `${m}:${sec}`;
  }

  // as station/web/html.py's utc(): to the second
  function utc(stamp) {
    if (!stamp) return "-";
    return stamp.length >= 19 && stamp[10] === "T"
      ? stamp.slice(0, 19).replace("T", " ") + " UTC" : stamp;
  }

  // as station/web/pages.py's _shown()
  function shown(value, how) {
    if (value === null || value === undefined) return "-";
    if (how === "clock") return clock(Number(value), Number(value) >= 60 ? 0 : 1);
    if (how === "countdown") return clock(Number(value), 0);
    if (how === "percent") return (100 * Number(value)).toFixed(0) + " %";
    return String(value);
  }

  // as station/web/pages.py's run_phase()
  function phase(run) {
    if (run.state !== "recording") return "finished";
    return run.recorder_gone ? "gone" : "live";
  }

  function update(doc) {
    const sections = Array.from(document.querySelectorAll("section.run"));
    const seen = sections.map((s) => s.dataset.run + " " + s.dataset.phase).sort().join("\n");
    const now = doc.runs.map((r) => r.run + " " + phase(r)).sort().join("\n");
    if (seen !== now) { window.location.reload(); return; }
    for (const run of doc.runs) {
      const section = sections.find((s) => s.dataset.run === run.run);
      const flush = section.querySelector('[data-field="last_flush_utc"]');
      if (flush) flush.textContent = utc(run.last_flush_utc);
      for (const unit of run.units) {
        const row = Array.from(section.querySelectorAll("tr[data-unit]"))
          .find((r) => r.dataset.unit === unit.unit);
        if (!row) continue;
        row.querySelectorAll("[data-field]").forEach((cell) => {
          cell.textContent = shown(unit[cell.dataset.field], cell.dataset.format);
        });
        const bar = row.querySelector("progress[data-bar]");
        if (bar && unit.progress !== null) bar.value = unit.progress;
        const curve = run.allan.find((c) => c.unit === unit.unit);
        const svg = row.querySelector("svg.allan");
        if (curve && svg) drawAllan(svg, curve);
      }
    }
    document.body.dataset.polled = String(Number(document.body.dataset.polled || 0) + 1);
  }

  async function poll() {
    try {
      const answer = await fetch("/api/runs", { credentials: "same-origin" });
      if (answer.ok) update(await answer.json());
    } catch (err) {
      // the server away for a moment: the next poll tries again
    }
    window.setTimeout(poll, POLL_MS);
  }
  window.setTimeout(poll, POLL_MS);
})();
