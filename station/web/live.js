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

  function update(doc) {
    const sections = Array.from(document.querySelectorAll("section.run"));
    const shown = sections.map((s) => s.dataset.run).sort().join("\n");
    const now = doc.runs.map((r) => r.run).sort().join("\n");
    if (shown !== now) { window.location.reload(); return; }
    for (const run of doc.runs) {
      const section = sections.find((s) => s.dataset.run === run.run);
      for (const key of ["state", "last_flush_utc"]) {
        const cell = section.querySelector(`[data-field="${key}"]`);
        if (cell) cell.textContent = run[key] === null ? "" : String(run[key]);
      }
      for (const unit of run.units) {
        const row = Array.from(section.querySelectorAll("tr[data-unit]"))
          .find((r) => r.dataset.unit === unit.unit);
        if (!row) continue;
        row.querySelectorAll("[data-field]").forEach((cell) => {
          const value = unit[cell.dataset.field];
          cell.textContent = value === null ? "" : String(value);
        });
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
