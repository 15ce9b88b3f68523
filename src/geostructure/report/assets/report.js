// The report's behaviour: layers, plane selection shared by 3D view, stereonet and table.
(function () {
  "use strict";
  const P = JSON.parse(document.getElementById("payload").textContent);
  const TRACE = { filtered: 0, regions: 1, voxels: 2, planes: 3, highlight: 4, outline: 5 };
  const NET = P.stereonet.data.length;            // selected circle and pole: its last two traces
  const palette = P.scene.data[TRACE.planes].facecolor || [];
  const config = { responsive: true, displaylogo: false };
  const fmt = (v, d) => (v === null || v === undefined || Number.isNaN(v)) ? "" :
    (d === null ? esc(v) : Number(v).toLocaleString("en-US", { minimumFractionDigits: d, maximumFractionDigits: d }));
  // Text that came from a user's file (a truth surface's name, a unit, a label) reaches
  // innerHTML only through esc(): as text, never as markup.
  const esc = v => String(v ?? "").replace(/[&<>"']/g, c =>
    ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]);
  let selected = null;

  const m = P.meta;
  document.getElementById("meta").textContent =
    `${m.n_planes} planes · ${m.points_total.toLocaleString("en-US")} filtered points ` +
    `(${m.points_shown.toLocaleString("en-US")} drawn) · frame ${m.frame}` +
    (m.crs ? ` · CRS ${m.crs.length > 40 ? m.crs.slice(0, 40) + "…" : m.crs}` : "") +
    ` · 3D coordinates are relative to offset (${m.offset.map(v => v.toFixed(2)).join(", ")})` +
    (m.georeference ? ` · georeference: ${m.georeference.text}` : "");
  if (m.georeference && m.georeference.warning) {
    const note = document.createElement("p");
    note.id = "georef-warning";
    note.className = "warning";
    note.textContent = `Angles are approximate: ${m.georeference.warning}.`;
    document.getElementById("meta").after(note);
  }

  const scene = document.getElementById("scene3d");
  const net = document.getElementById("stereonet");
  const t0 = performance.now();
  window.reportTimings = { parsed: t0 };
  const ready = [
    Plotly.newPlot(scene, P.scene.data, P.scene.layout, config).then(() => { window.reportTimings.scene = performance.now(); }),
    Plotly.newPlot(net, P.stereonet.data, P.stereonet.layout, config).then(() => { window.reportTimings.net = performance.now(); }),
    // the other side panels (report.html.side_panels), each where the folder has one
    ...P.side_panels.filter(id => id !== "stereonet")
      .map(id => P[id] ? Plotly.newPlot(id, P[id].data, P[id].layout, config) : Promise.resolve()),
  ];

  document.querySelectorAll("#layers input").forEach(box => {
    const trace = P.scene.data[TRACE[box.dataset.layer]];
    if (trace) box.checked = trace.visible !== false;  // as the figure opens (the cloud when no plane)
    box.addEventListener("change", () =>
      Plotly.restyle(scene, { visible: box.checked }, [TRACE[box.dataset.layer]]));
  });

  function infoHtml(p) {
    let html = `<b>Plane ${p.region_id}</b>: strike <b>${fmt(p.strike, 1)}°</b>, dip <b>${fmt(p.dip, 1)}°</b>, ` +
      `dip direction <b>${fmt(p.dip_direction, 1)}°</b> (± ${fmt(p.normal_uncertainty_deg, 2)}°) · ` +
      `area ${fmt(p.area_m2, 2)} m² · ${fmt(p.n_points, 0)} points · roughness (RMS fit residual) ${fmt(p.fit_residual, 4)} ${esc(P.meta.unit)} · planarity ${fmt(p.planarity, 3)}`;
    if (p.set !== undefined) html += ` · ${p.set === null ? "in no set" : `set ${p.set}`}`;
    if (p.joint !== undefined && p.joint !== null) html += `, a facet of joint ${p.joint} (joints.csv)`;
    if (p.truth) {
      const t = p.truth;
      html += `<br>Ground truth '${esc(t.surface)}': strike ${fmt(t.strike, 1)}°, dip ${fmt(t.dip, 1)}°, ` +
        `dip direction ${fmt(t.dip_direction, 1)}° · measured vs truth: <b>${fmt(p.truth_error, 2)}°</b>`;
    }
    return html;
  }

  function select(id) {
    const p = P.planes.find(q => q.region_id === id);
    if (!p) return;
    selected = id;
    document.getElementById("info").innerHTML = infoHtml(p);
    const c = p.corners;
    Plotly.restyle(scene, { x: [c.map(v => v[0])], y: [c.map(v => v[1])], z: [c.map(v => v[2])],
                            i: [[0, 0]], j: [[1, 2]], k: [[2, 3]] }, [TRACE.highlight]);
    const loop = [0, 1, 2, 3, 0].map(n => c[n]);
    Plotly.restyle(scene, { x: [loop.map(v => v[0])], y: [loop.map(v => v[1])], z: [loop.map(v => v[2])] },
                   [TRACE.outline]);
    Plotly.restyle(net, { x: [p.great_circle[0], [p.pole[0]]], y: [p.great_circle[1], [p.pole[1]]] },
                   [NET - 2, NET - 1]);
    document.querySelectorAll("#planes tbody tr").forEach(tr => {
      const on = Number(tr.dataset.id) === id;
      tr.classList.toggle("selected", on);
      if (on) tr.scrollIntoView({ block: "nearest" });
    });
  }

  scene.on("plotly_click", ev => {
    const pt = ev.points && ev.points[0];
    if (pt && pt.curveNumber === TRACE.planes) {
      const id = pt.customdata !== undefined ? pt.customdata : Math.floor(pt.pointNumber / 4);
      select(P.planes[id] ? P.planes[id].region_id : id);
    }
  });
  net.on("plotly_click", ev => {
    const pt = ev.points && ev.points[0];
    if (pt && pt.customdata !== undefined) select(P.planes[pt.customdata].region_id);
  });

  // Table: click a header to sort (again to reverse), a row to select its plane.
  const columns = P.columns;
  const thead = document.querySelector("#planes thead");
  const tbody = document.querySelector("#planes tbody");
  let sortKey = "region_id", ascending = true;
  thead.innerHTML = "<tr>" + columns.map(c => `<th data-key="${esc(c.key)}">${esc(c.label)}</th>`).join("") + "</tr>";
  function drawRows() {
    const rows = P.planes.slice().sort((a, b) => {
      const x = a[sortKey] ?? -Infinity, y = b[sortKey] ?? -Infinity;
      return (x < y ? -1 : x > y ? 1 : 0) * (ascending ? 1 : -1);
    });
    tbody.innerHTML = rows.map(p => `<tr data-id="${esc(p.region_id)}"${p.region_id === selected ? ' class="selected"' : ""}>` +
      columns.map((c, n) => `<td>${n === 0 ? `<span class="swatch" style="background:${palette[p.region_id] || "#999"}"></span>` : ""}` +
        `${fmt(p[c.key], c.digits)}</td>`).join("") + "</tr>").join("");
    thead.querySelectorAll("th").forEach(th => {
      th.classList.toggle("asc", th.dataset.key === sortKey && ascending);
      th.classList.toggle("desc", th.dataset.key === sortKey && !ascending);
    });
  }
  thead.addEventListener("click", ev => {
    const key = ev.target.closest("th") && ev.target.closest("th").dataset.key;
    if (!key) return;
    ascending = key === sortKey ? !ascending : true;
    sortKey = key;
    drawRows();
  });
  tbody.addEventListener("click", ev => {
    const tr = ev.target.closest("tr");
    if (tr) select(Number(tr.dataset.id));
  });
  drawRows();

  Promise.all(ready).then(() => { window.reportTimings.ready = performance.now(); window.reportReady = true; document.body.dataset.ready = "true"; });
})();
