"""``report.html``: one self-contained, offline page with the 3D view, the plane table,
the stereonet and the rose diagram.

Plotly draws all three views; its JavaScript bundle, shipped inside the ``plotly`` Python
package, is written into the page, so the file opens without a network. Arrays travel as
base64 typed arrays (plotly's own JSON encoding), which keeps a 150k-point view near 10 MB.
"""

from __future__ import annotations

import html
import json
import re
from importlib import resources
from pathlib import Path

import numpy as np

from geostructure.core.orientation import whole_azimuth
from geostructure.core.projection import (
    great_circle_xy,
    pole_density,
    pole_xy,
    rose_counts,
    rose_title_lines,
    small_circle_xy,
)
from geostructure.io.atomic import atomic_path, json_ready
from geostructure.io.survey_files import describe
from geostructure.reconstruct.georef import describe_georeference
from geostructure.report.kinematic_tables import kinematic_table, set_swatch
from geostructure.report.kinematics_net import kinematic_traces
from geostructure.report.scene import MAX_DISPLAY_POINTS, ReportScene, load_scene
from geostructure.report.spacing_plot import figure_spacing
from geostructure.report.stereonet import MIN_CONTOUR_POLES
from geostructure.report.view3d import figure_3d, figure_json, hover_text, panel_title, plane_colors, set_color
from geostructure.report.words import traces_per_set
from geostructure.rockmass.notes import (
    bent_face,
    block_phrase,
    jv_phrase,
    off_face_scope,
    rqd_phrase,
    set_notes,
    trace_cell,
)

#: Great circles drawn for this many of the largest planes only; all poles are drawn.
MAX_GREAT_CIRCLES = 30
NET_HEIGHT, ROSE_HEIGHT = 400, 360  # pixels

#: The plane table's columns: key in planes.csv, label ({unit}: the cloud's length unit), decimals.
COLUMNS = [
    ("region_id", "Plane", 0),
    ("strike", "Strike", 1),
    ("dip", "Dip", 1),
    ("dip_direction", "Dip dir.", 1),
    ("normal_uncertainty_deg", "± (°)", 2),
    ("area_m2", "Area (m²)", 2),
    ("n_points", "Points", 0),
    ("fit_residual", "Roughness ({unit})", 4),
    ("planarity", "Planarity", 3),
]


def build_report(outdir, path=None, *, max_points: int | None = None, title: str | None = None) -> Path:
    """Write ``report.html`` for a measured output folder; returns its path."""
    outdir = Path(outdir)
    scene = load_scene(outdir, max_points=max_points or MAX_DISPLAY_POINTS)
    page = render(scene, title=title or f"GeoStructure: {source_title(scene) or outdir.name}")
    path = Path(path or outdir / "report.html")
    with atomic_path(path) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return path


def source_title(scene: ReportScene) -> str:
    """The input's file name as a title, or several files' names as :func:`~geostructure.io.survey_files.describe`
    names them (``run.json``'s ``input`` is their paths joined, which no file name can be cut
    from)."""
    return describe([Path(p).name for p in scene.inputs]) if scene.inputs else Path(scene.source).name


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


def side_panels() -> tuple:
    """The figures beside the 3D view, top to bottom: the one place a new panel is added.
    Each is (its element's id, a function of the :class:`~geostructure.report.scene.ReportScene`
    giving its Plotly figure, or None where the folder has nothing to draw); the page draws
    them in this order, the stereonet also answering a click on a plane.

    Examples
    --------
    >>> [name for name, _ in side_panels()]
    ['stereonet', 'rose', 'spacing']
    """
    return (("stereonet", figure_stereonet), ("rose", figure_rose), ("spacing", figure_spacing))


def render(scene: ReportScene, title: str) -> str:
    from plotly.offline import get_plotlyjs

    unit = scene.unit  # the plane table's sizes are in the cloud's unit
    payload = {
        "title": title,
        "scene": figure_3d(scene),
        **{name: draw(scene) for name, draw in side_panels()},
        "side_panels": [name for name, _ in side_panels()],
        "planes": table_rows(scene),
        "columns": [{"key": k, "label": label.format(unit=unit), "digits": d} for k, label, d in COLUMNS]
        + ([{"key": "set", "label": "Set", "digits": 0}] if "set" in scene.planes.extra else [])
        + ([{"key": "joint", "label": "Joint", "digits": 0}] if "joint" in scene.planes.extra else [])
        + ([{"key": "kinematics", "label": "Kinematics", "digits": None}] if scene.plane_kinematics else [])
        + ([{"key": "truth_error", "label": "Truth error (°)", "digits": 2}] if scene.truth else []),
        "meta": {
            "source": scene.source,
            "crs": scene.crs,
            "unit": unit,
            "offset": scene.offset.tolist(),
            "frame": scene.frame.name
            + (f" (grid convergence {scene.north['grid_convergence_deg']:+.2f}°)" if scene.north else ""),
            "points_total": scene.n_points_total,
            "points_shown": len(scene.points),
            "n_planes": len(scene.planes),
            "georeference": _georeference_note(scene.georeference),
        },
    }
    data = script_json(json_ready(payload))
    assets = resources.files("geostructure.report") / "assets"
    page = (assets / "report.html").read_text(encoding="utf-8")
    return fill_template(
        page,
        {
            "TITLE": _escape(title),
            "CSS": (assets / "report.css").read_text(encoding="utf-8"),
            "PLOTLY": get_plotlyjs(),
            "PANELS": "".join(f'<div id="{name}"></div>' for name, _ in side_panels()),
            "SETS": set_table(scene) + kinematic_table(scene),
            "PAYLOAD": data,
            "APP": (assets / "report.js").read_text(encoding="utf-8"),
        },
    )


_PLACEHOLDER = re.compile(r"\{\{([A-Z]+)\}\}")


def fill_template(page: str, values: dict[str, str]) -> str:
    """The page with each ``{{NAME}}`` replaced by ``values[NAME]``, in one pass over the
    template only: text that comes in through a value (a file name holding ``{{PAYLOAD}}``)
    is never scanned for placeholders again, so it cannot break out of its place.

    Examples
    --------
    >>> fill_template("<b>{{A}}</b>{{B}}", {"A": "{{B}}", "B": "x"})
    '<b>{{B}}</b>x'
    """
    return _PLACEHOLDER.sub(lambda m: values[m.group(1)], page)


def script_json(value) -> str:
    """``value`` as JSON safe inside a ``<script>`` element: ``<``, ``>`` and ``&`` written as
    JSON escapes, so no text from a user's file can close the element or open a comment.

    Examples
    --------
    >>> print(script_json({"name": "</script><img src=x>"}))
    {"name":"\\u003c/script\\u003e\\u003cimg src=x\\u003e"}
    """
    text = json.dumps(value, separators=(",", ":"), allow_nan=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _net_title(scene: ReportScene) -> list[str]:
    if not scene.kinematics:
        return ["Poles and great circles", "lower hemisphere, equal area"]
    kinematics = scene.kinematics
    sections = kinematics.get("sections") or []
    if len(sections) < 2:
        slope = kinematics["slope"]
        slopes = f"slope {slope['dip']:.0f}/{whole_azimuth(slope['dip_direction'])}"
    else:  # the legend shows or hides each section's envelopes
        slopes = "sections " + ", ".join(
            f"{s['slope']['dip']:.0f}/{whole_azimuth(s['slope']['dip_direction'])}" for s in sections
        )
    return ["Poles and kinematic envelopes", f"{slopes}, friction {kinematics['friction_deg']:g}°, lower hemisphere"]


def figure_stereonet(scene: ReportScene) -> dict:
    """Poles (all), great circles (largest planes), exponential Kamb density, primitive circle."""
    import plotly.graph_objects as go

    dd, dip = scene.planes.dip_direction, scene.planes.dip
    fig = go.Figure()
    if len(dd) >= MIN_CONTOUR_POLES:
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
            showlegend=False,
        )
    )
    if scene.sets:  # each set's mean great circle and alpha95 cone instead of the planes' circles
        for row in scene.sets:
            color = set_color(int(row["set"]))
            x, y = great_circle_xy(row["dip_direction"], row["dip"])
            fig.add_trace(
                go.Scatter(
                    x=x,
                    y=y,
                    mode="lines",
                    line=dict(color=color, width=3),
                    name=f"set {int(row['set'])}",
                    hoverinfo="skip",
                )  # fmt: skip
            )
            x, y = small_circle_xy((row["dip_direction"] + 180.0) % 360.0, 90.0 - row["dip"], row["alpha95_deg"])
            fig.add_trace(
                go.Scatter(
                    x=x,
                    y=y,
                    mode="lines",
                    line=dict(color=color, width=1.5, dash="dot"),
                    name=f"set {int(row['set'])} alpha95",
                    hoverinfo="skip",
                    showlegend=False,
                )  # fmt: skip
            )
    else:
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
    for trace in kinematic_traces(scene.kinematics):  # under the poles, which stay clickable
        fig.add_trace(trace)
    px, py = pole_xy(dd, dip)
    pole_colors = plane_colors(scene) if scene.sets else "#d62728"
    fig.add_trace(
        go.Scatter(
            x=px,
            y=py,
            mode="markers",
            name="poles",
            customdata=np.arange(len(dd)),
            marker=dict(color=pole_colors, size=7, line=dict(color="white", width=1)),
            text=[
                hover_text(r, scene.truth.get(r["region_id"]), scene.unit, scene.metres_per_unit)
                for r in scene.planes.rows()
            ],
            hovertemplate="%{text}<extra></extra>",
        )
    )
    fig.add_trace(
        go.Scatter(
            x=[],
            y=[],
            mode="lines",
            name="selected circle",
            hoverinfo="skip",
            line=dict(color="#e6a100", width=3),
            showlegend=False,
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
            showlegend=False,
        )
    )
    axis = dict(visible=False, range=[-1.12, 1.12], fixedrange=True)
    title, top = panel_title(_net_title(scene), NET_HEIGHT)
    # With kinematics, a legend under the net names each envelope (a click hides one; a face
    # tested in sections has one entry a section, so that overlapping sections can be told
    # apart); without, the net alone.
    legend = [t for t in fig.data if t.showlegend is not False and t.name]
    below = 30 + 19 * len(legend) if scene.kinematics else 10
    fig.update_layout(
        xaxis=dict(axis, scaleanchor="y"),
        yaxis=axis,
        showlegend=bool(scene.kinematics),
        legend=dict(font=dict(size=9), orientation="v", tracegroupgap=0, yanchor="top", y=-0.02, x=0),
        plot_bgcolor="white",
        margin=dict(l=10, r=10, t=top, b=below),
        height=NET_HEIGHT + below,
        title=title,
        annotations=[dict(x=0, y=1.08, text="N", showarrow=False, font=dict(size=14))],
    )
    return figure_json(fig)


def figure_rose(scene: ReportScene, bin_width: float = 10.0) -> dict:
    import plotly.graph_objects as go

    edges, counts, n_used = rose_counts(scene.planes.strike, scene.planes.dip, bin_width)
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
    title, top = panel_title(rose_title_lines(n_used), ROSE_HEIGHT)
    fig.update_layout(
        polar=dict(
            angularaxis=dict(rotation=90, direction="clockwise"),
            radialaxis=dict(nticks=4, tickfont=dict(size=9), angle=45, tickangle=45),
        ),
        showlegend=False,
        height=ROSE_HEIGHT,
        margin=dict(l=30, r=30, t=top, b=20),
        title=title,
    )
    return figure_json(fig)


#: The set table's columns: key in sets.csv, label, decimals.
SET_COLUMNS = [
    ("set", "Set", 0),
    ("n_planes", "Planes", 0),
    ("area_m2", "Area (m²)", 2),
    ("dip", "Dip", 1),
    ("dip_direction", "Dip dir.", 1),
    ("fisher_k", "Fisher K", 0),
    ("alpha95_deg", "α95 (°)", 1),
    ("spherical_variance", "Sph. variance", 3),
]
#: ... and, when the spacing was measured, these.
ROCK_COLUMNS = [
    ("n_joints", "Joints", 0),
    ("spacing_m", "Spacing (m)", 2),
    ("spacing_class", "Spacing class", None),
    ("p10_per_m", "P10 (1/m)", 2),
    ("p32_per_m", "P32 (1/m)", 2),
    ("joint_trace_mean_m", "Trace (m)", 1),
    ("persistence", "Persistence", None),
]


def _set_cell(value, digits: int | None) -> str:
    """A cell of the set table: words as they are (``digits`` None), a figure to ``digits``
    decimals; a dash for neither (NaN, or a column a folder written before it lacks)."""
    if digits is None:
        return _escape(value) if value else "—"
    return f"{value:,.{digits}f}" if value is not None and np.isfinite(value) else "—"


def set_table(scene: ReportScene) -> str:
    """The joint sets as an HTML table (empty when the folder has none)."""
    if not scene.sets:
        return ""
    columns = SET_COLUMNS + (ROCK_COLUMNS if "spacing_m" in scene.sets[0] else [])
    head = "".join(f"<th>{label}</th>" for _, label, _ in columns)
    rows = []
    for row in scene.sets:
        swatch = set_swatch(int(row["set"]))
        cells = [
            _escape(trace_cell(row, digits))
            if key == "joint_trace_mean_m" and trace_cell(row)
            else _set_cell(row.get(key), digits)
            for key, _, digits in columns
        ]
        rows.append("<tr>" + "".join(f"<td>{swatch if i == 0 else ''}{c}</td>" for i, c in enumerate(cells)) + "</tr>")
    extra = scene.planes.extra
    unassigned = int((extra["set"] < 0).sum())
    off_face = off_face_scope(*(int((extra[k] > 0).sum()) if k in extra else 0 for k in ("ground", "clutter")))
    caption = f"Joint sets ({unassigned} plane{'s' if unassigned != 1 else ''} in no set{off_face})"
    rock = scene.rock_mass
    measured = "spacing_m" in scene.sets[0]
    jv = rock.get("jv_per_m3") if rock else None  # null in run.json when no set has a spacing
    if measured and jv is not None and np.isfinite(jv):
        caption += jv_phrase(rock["jv_per_m3"], scene.sets).replace("; Jv", "; volumetric joint count Jv", 1)
        block = rock.get("block_volume_m3")
        if block is not None and np.isfinite(block):
            caption += f", block volume {block:.3g} m³ (Palmström, 36/Jv³)"
            if rock.get("block_size_class"):  # folders before 2026-12-05 have none
                caption += f", {rock['block_size_class']} (ISRM)"
        else:
            caption += block_phrase(float("nan"), "", scene.sets)
        if rock.get("rqd_from_jv") is not None:  # folders before 2026-12-05 have none
            caption += rqd_phrase(
                rock["rqd_from_jv"],
                rock.get("rqd_min_by_direction"),
                rock.get("rqd_max_by_direction"),
                bound=block is None or not np.isfinite(block),
            )
    notes = [note for row in scene.sets for note in set_notes(int(row["set"]), row)] if measured else []
    per_set = traces_per_set(scene.sets) if scene.traces else ""
    if scene.traces:  # the fracture traces (traces.csv), as the terminal gives them
        notes.append(f"Traces: {len(scene.traces):,} drawn (traces.csv)" + (f"; {per_set}." if per_set else "."))
    notes = "".join(
        f'<p class="note">{_escape(n)}</p>'
        for n in notes + [bent_face((rock or {}).get("face_bend_deg", 0), (rock or {}).get("face_sections", 1))]
        if n
    )
    return (
        f'<table id="sets"><caption>{_escape(caption)}</caption><thead><tr>{head}</tr></thead>'
        f"<tbody>{''.join(rows)}</tbody></table>{notes}"
    )


def table_rows(scene: ReportScene) -> list[dict]:
    """Plane rows for the page: table values, info text, 3D corners and stereonet data."""
    rows, square_metres = [], scene.metres_per_unit**2
    for row, corners in zip(scene.planes.rows(), scene.planes.local_corners):
        truth = scene.truth.get(row["region_id"])
        out = {key: row.get(key) for key, _, _ in COLUMNS + [("set", "", 0), ("joint", "", 0)] if key in row}
        out["area_m2"] = row["area_m2"] * square_metres  # the plane table holds the cloud's unit squared
        if scene.plane_kinematics:
            out["kinematics"] = scene.plane_kinematics.get(row["region_id"], "")
        for key in ("set", "joint"):  # -1 is "none": a blank cell, and "in no set" in the info line
            if key in out and out[key] is not None and out[key] < 0:
                out[key] = None
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


def _escape(text) -> str:
    """Text from a user's file as HTML: every markup character escaped, quotes included."""
    return html.escape(str(text), quote=True)
