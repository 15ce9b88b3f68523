"""``report.html``: one self-contained, offline page with the 3D view, the plane table,
the stereonet and the rose diagram.

Plotly draws all three views; its JavaScript bundle, shipped inside the ``plotly`` Python
package, is written into the page, so the file opens without a network. Arrays travel as
base64 typed arrays (plotly's own JSON encoding), which keeps a 150k-point view near 10 MB.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path, plain
from ..orientation import orientation_from_normals
from ..projection import great_circle_xy, pole_density, pole_xy
from ..reconstruct.georef import describe_georeference
from .scene import MAX_DISPLAY_POINTS, ReportScene, load_scene

#: Great circles drawn for this many of the largest planes only; all poles are drawn.
MAX_GREAT_CIRCLES = 30

COLUMNS = [
    ("region_id", "Plane", 0),
    ("strike", "Strike", 1),
    ("dip", "Dip", 1),
    ("dip_direction", "Dip dir.", 1),
    ("normal_uncertainty_deg", "± (°)", 2),
    ("area_m2", "Area (m²)", 2),
    ("n_points", "Points", 0),
    ("fit_residual", "Residual (m)", 4),
]


def palette(n: int) -> list[str]:
    from plotly.colors import qualitative

    colors = qualitative.Alphabet
    return [colors[i % len(colors)] for i in range(n)]


def build_report(outdir, path=None, *, max_points: int | None = None, title: str | None = None) -> Path:
    """Write ``report.html`` for a measured output folder; returns its path."""
    outdir = Path(outdir)
    scene = load_scene(outdir, max_points=max_points or MAX_DISPLAY_POINTS)
    html = render(scene, title=title or f"GeoStructure: {Path(scene.source).name or outdir.name}")
    path = Path(path or outdir / "report.html")
    with atomic_path(path) as tmp:
        tmp.write_text(html, encoding="utf-8")
    return path


def _georeference_note(record: dict | None) -> dict | None:
    """What the reader must know about a reconstruction's tie to the world: the method, and a
    warning when its angles are approximate."""
    if not record:
        return None
    warning = None
    if record.get("source") == "cameras-level":
        warning = "up assumed from the cameras (the photos taken level): dips approximate, azimuths relative to the view, not to north"
    elif record.get("approximate"):
        warning = "approximate: up from the cameras, heading from GPS; give control points for true angles"
    return {"text": describe_georeference(record), "warning": warning}


def render(scene: ReportScene, title: str) -> str:
    from plotly.offline import get_plotlyjs

    payload = {
        "title": title,
        "scene": figure_3d(scene),
        "stereonet": figure_stereonet(scene),
        "rose": figure_rose(scene),
        "planes": table_rows(scene),
        "columns": [{"key": k, "label": label, "digits": d} for k, label, d in COLUMNS]
        + ([{"key": "truth_error", "label": "Truth error (°)", "digits": 2}] if scene.truth else []),
        "meta": {
            "source": scene.source,
            "crs": scene.crs,
            "offset": scene.offset.tolist(),
            "frame": scene.frame.name,
            "points_total": scene.n_points_total,
            "points_shown": len(scene.points),
            "n_planes": len(scene.planes),
            "georeference": _georeference_note(scene.georeference),
        },
    }
    data = json.dumps(plain(payload), separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    assets = resources.files("geostructure.report") / "assets"
    page = (assets / "report.html").read_text(encoding="utf-8")
    return (
        page.replace("{{TITLE}}", _escape(title))
        .replace("{{CSS}}", (assets / "report.css").read_text(encoding="utf-8"))
        .replace("{{PLOTLY}}", get_plotlyjs())
        .replace("{{PAYLOAD}}", data)
        .replace("{{APP}}", (assets / "report.js").read_text(encoding="utf-8"))
    )


def figure_3d(scene: ReportScene) -> dict:
    """Traces in a fixed order the page's script relies on (see ``trace`` below)."""
    import plotly.graph_objects as go

    colors = palette(max(len(scene.planes), 1))
    up = scene.frame.matrix[2]
    p = scene.points
    labelled = scene.point_region >= 0
    fig = go.Figure()
    fig.add_trace(
        go.Scatter3d(  # 0 filtered cloud, by elevation
            x=p[:, 0],
            y=p[:, 1],
            z=p[:, 2],
            mode="markers",
            name="filtered cloud",
            visible=False,
            marker=dict(size=1.5, color=(p @ up).astype(np.float32), colorscale="Earth", showscale=False),
            hoverinfo="skip",
        )
    )
    region = scene.point_region[labelled]
    fig.add_trace(
        go.Scatter3d(  # 1 regions, one colour each
            x=p[labelled, 0],
            y=p[labelled, 1],
            z=p[labelled, 2],
            mode="markers",
            name="regions",
            marker=dict(
                size=1.5,
                color=(region % len(colors)).astype(np.float32) + 0.5,
                cmin=0,
                cmax=len(colors),
                colorscale=_stepped(colors),
                showscale=False,
            ),
            hoverinfo="skip",
        )
    )
    fig.add_trace(_voxel_mesh(scene))  # 2 voxel planes
    fig.add_trace(_plane_mesh(scene, colors))  # 3 region planes
    fig.add_trace(
        go.Mesh3d(
            x=[],
            y=[],
            z=[],
            i=[],
            j=[],
            k=[],
            color="#ffd400",
            opacity=1.0,  # 4 highlight
            name="selected",
            hoverinfo="skip",
            flatshading=True,
        )
    )
    fig.add_trace(
        go.Scatter3d(
            x=[],
            y=[],
            z=[],
            mode="lines",
            name="selected outline",
            hoverinfo="skip",  # 5
            line=dict(color="#111111", width=8),
        )
    )
    for trace in _axes(scene):  # 6.. north and up
        fig.add_trace(trace)
    fig.update_layout(
        margin=dict(l=0, r=0, t=0, b=0),
        showlegend=False,
        uirevision="keep",
        scene=dict(aspectmode="data", xaxis_title="x", yaxis_title="y", zaxis_title="z"),
    )
    return _figure_json(fig)


def _stepped(colors):
    n = len(colors)
    scale = []
    for i, c in enumerate(colors):
        scale += [[i / n, c], [(i + 1) / n, c]]
    return scale


def _voxel_mesh(scene: ReportScene):
    """Each voxel plane as a square of the voxel's edge, coloured by its dip direction."""
    import plotly.graph_objects as go

    c, n = scene.voxel_centroids.astype(np.float64), scene.voxel_normals.astype(np.float64)
    helper = np.where(np.abs(n[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    a = np.cross(n, helper)
    a /= np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-12)
    b = np.cross(n, a)
    h = 0.45 * scene.voxel_edge
    corners = np.stack([c - h * a - h * b, c + h * a - h * b, c + h * a + h * b, c - h * a + h * b], axis=1)
    dip_direction = orientation_from_normals(n, scene.frame).dip_direction if len(n) else np.zeros(0)
    i, j, k = _quads(len(c))
    xyz = corners.reshape(-1, 3).astype(np.float32)
    return go.Mesh3d(
        x=xyz[:, 0],
        y=xyz[:, 1],
        z=xyz[:, 2],
        i=i,
        j=j,
        k=k,
        name="voxel planes",
        visible=False,
        intensity=np.repeat(dip_direction, 4).astype(np.float32),
        intensitymode="vertex",
        cmin=0,
        cmax=360,
        colorscale="Twilight",
        showscale=False,
        flatshading=True,
        hoverinfo="skip",
    )


def _quads(n: int):
    base = 4 * np.arange(n, dtype=np.int32)
    i = np.concatenate([base, base])
    j = np.concatenate([base + 1, base + 2])
    k = np.concatenate([base + 2, base + 3])
    return i, j, k


def _plane_mesh(scene: ReportScene, colors):
    import plotly.graph_objects as go

    corners = scene.planes.local_corners.reshape(-1, 3)
    n = len(scene.planes)
    i, j, k = _quads(n)
    text = np.repeat([hover_text(row, scene.truth.get(row["region_id"])) for row in scene.planes.rows()], 4)
    face_colors = [colors[f % n] for f in range(n)] * 2 if n else []
    return go.Mesh3d(
        x=corners[:, 0] if n else [],
        y=corners[:, 1] if n else [],
        z=corners[:, 2] if n else [],
        i=i,
        j=j,
        k=k,
        facecolor=face_colors,
        opacity=0.55,
        name="region planes",
        flatshading=True,
        text=text.tolist(),
        customdata=np.repeat(np.arange(n), 4),
        hovertemplate="%{text}<extra></extra>",
    )


def hover_text(row: dict, truth: dict | None) -> str:
    text = (
        f"<b>Plane {row['region_id']}</b><br>strike {row['strike']:.1f}°, dip {row['dip']:.1f}°, "
        f"dip direction {row['dip_direction']:.1f}° (± {row.get('normal_uncertainty_deg', float('nan')):.2f}°)"
        f"<br>area {row['area_m2']:.2f} m², {row['n_points']:,} points, residual {row['fit_residual']:.4f} m"
    )
    if truth:
        text += f"<br>truth '{truth['surface']}': error {float(truth['normal_error_deg']):.2f}°"
    return text


def _axes(scene: ReportScene):
    """North and up arrows from the cloud's lowest corner, a fifth of its size long."""
    import plotly.graph_objects as go

    p = scene.points if len(scene.points) else np.zeros((1, 3), np.float32)
    lo, size = p.min(axis=0).astype(float), float(np.ptp(p, axis=0).max() or 1.0)
    traces = []
    for name, vector, color in (("N", scene.frame.matrix[1], "#d62728"), ("Up", scene.frame.matrix[2], "#1f77b4")):
        tip = lo + 0.2 * size * vector
        traces.append(
            go.Scatter3d(
                x=[lo[0], tip[0]],
                y=[lo[1], tip[1]],
                z=[lo[2], tip[2]],
                mode="lines+text",
                text=["", name],
                textfont=dict(color=color, size=14),
                name=name,
                line=dict(color=color, width=6),
                hoverinfo="skip",
            )
        )
    return traces


def figure_stereonet(scene: ReportScene) -> dict:
    """Poles (all), great circles (largest planes), exponential Kamb density, primitive circle."""
    import plotly.graph_objects as go

    dd, dip = scene.planes.dip_direction, scene.planes.dip
    fig = go.Figure()
    if len(dd) >= 3:
        x, y, density = pole_density(dd, dip)
        fig.add_trace(
            go.Contour(
                x=x,
                y=y,
                z=density,
                colorscale="Blues",
                showscale=True,
                ncontours=8,
                hoverinfo="skip",
                contours=dict(coloring="fill", showlines=False),
                opacity=0.7,
                colorbar=dict(title="Kamb σ", thickness=10, len=0.6),
            )
        )
    theta = np.linspace(0, 2 * np.pi, 181)
    fig.add_trace(
        go.Scatter(
            x=np.sin(theta),
            y=np.cos(theta),
            mode="lines",
            line=dict(color="black", width=1.5),
            hoverinfo="skip",
            name="primitive",
        )
    )
    gx, gy = [], []
    for i in range(min(len(dd), MAX_GREAT_CIRCLES)):
        x, y = great_circle_xy(dd[i], dip[i])
        gx += [*x, None]
        gy += [*y, None]
    fig.add_trace(
        go.Scatter(
            x=gx,
            y=gy,
            mode="lines",
            line=dict(color="rgba(0,0,0,0.45)", width=1),
            hoverinfo="skip",
            name="great circles",
        )
    )
    px, py = pole_xy(dd, dip)
    fig.add_trace(
        go.Scatter(
            x=px,
            y=py,
            mode="markers",
            name="poles",
            customdata=np.arange(len(dd)),
            marker=dict(color="#d62728", size=7, line=dict(color="white", width=1)),
            text=[hover_text(r, scene.truth.get(r["region_id"])) for r in scene.planes.rows()],
            hovertemplate="%{text}<extra></extra>",
        )
    )
    fig.add_trace(
        go.Scatter(
            x=[], y=[], mode="lines", name="selected circle", hoverinfo="skip", line=dict(color="#e6a100", width=3)
        )
    )
    fig.add_trace(
        go.Scatter(
            x=[],
            y=[],
            mode="markers",
            name="selected pole",
            hoverinfo="skip",
            marker=dict(color="#ffd400", size=14, line=dict(color="black", width=1.5)),
        )
    )
    axis = dict(visible=False, range=[-1.12, 1.12], fixedrange=True)
    fig.update_layout(
        xaxis=dict(axis, scaleanchor="y"),
        yaxis=axis,
        showlegend=False,
        plot_bgcolor="white",
        margin=dict(l=10, r=10, t=30, b=10),
        height=380,
        title=dict(text="Poles and great circles, lower hemisphere (equal area)", font=dict(size=13)),
        annotations=[dict(x=0, y=1.08, text="N", showarrow=False, font=dict(size=14))],
    )
    return _figure_json(fig)


def figure_rose(scene: ReportScene, bin_width: float = 10.0) -> dict:
    import plotly.graph_objects as go

    strike = scene.planes.strike
    both = np.concatenate([strike, (strike + 180) % 360])
    edges = np.arange(0, 360 + bin_width, bin_width)
    counts, _ = np.histogram(both, edges)
    fig = go.Figure(
        go.Barpolar(
            r=counts,
            theta=edges[:-1] + bin_width / 2,
            width=bin_width,
            marker_color="#4c78a8",
            marker_line_color="black",
            marker_line_width=0.5,
            hovertemplate="%{theta}°: %{r}<extra></extra>",
        )
    )
    fig.update_layout(
        polar=dict(angularaxis=dict(rotation=90, direction="clockwise")),
        showlegend=False,
        height=340,
        margin=dict(l=30, r=30, t=40, b=20),
        title=dict(text="Strikes (rose diagram)", font=dict(size=13)),
    )
    return _figure_json(fig)


def table_rows(scene: ReportScene) -> list[dict]:
    """Plane rows for the page: table values, info text, 3D corners and stereonet data."""
    rows = []
    for row, corners in zip(scene.planes.rows(), scene.planes.local_corners):
        truth = scene.truth.get(row["region_id"])
        out = {key: row.get(key) for key, _, _ in COLUMNS}
        out["corners"] = np.round(corners, 4).tolist()
        out["great_circle"] = [np.round(a, 4).tolist() for a in great_circle_xy(row["dip_direction"], row["dip"])]
        out["pole"] = [float(a) for a in pole_xy(row["dip_direction"], row["dip"])]
        if truth:
            out["truth_error"] = float(truth["normal_error_deg"])
            out["truth"] = {
                "surface": truth["surface"],
                "strike": float(truth["true_strike"]),
                "dip": float(truth["true_dip"]),
                "dip_direction": float(truth["true_dip_direction"]),
            }
        rows.append(out)
    return rows


def _figure_json(fig) -> dict:
    """The figure as plain JSON, numpy arrays as plotly's base64 typed arrays."""
    import plotly.io as pio

    return json.loads(pio.to_json(fig, validate=False))


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
