"""The report's 3D view: the decimated cloud, the voxel planes and the region rectangles,
as one plotly figure whose traces the page's script switches on and off."""

from __future__ import annotations

import json
from html import escape

import numpy as np

from geostructure.core.orientation import orientation_from_normals
from geostructure.report.scene import ReportScene


def palette(n: int) -> list[str]:
    from plotly.colors import qualitative

    colors = qualitative.Alphabet
    return [colors[i % len(colors)] for i in range(n)]


#: Joint sets' colours (colour-blind safe, Okabe & Ito 2008); planes in no set are grey.
SET_COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")
NO_SET_COLOR = "#9a9a9a"
#: Flexural toppling's poles and envelope on the kinematic nets: a colour no set takes (it
#: was dark orange, beside set 1's vermillion and set 4's orange).
TOPPLING_COLOR = "#17becf"


def set_color(label: int) -> str:
    return NO_SET_COLOR if label < 0 else SET_COLORS[label % len(SET_COLORS)]


#: What the 3D view's other colours mean, after the planes' (the ramp of the points in no plane
#: is plotly's "Earth", dark blue low to white high; the voxel planes' a cyclic one of their
#: dip direction).
OTHER_COLOURS = (
    "points in a plane its colour, the others by height (dark blue low, white high) · voxel planes, when shown, by "
    "dip direction"
)


def colour_key(scene: ReportScene) -> str:
    """The 3D view's colour legend, one line above its key: each set's colour and grey for
    planes in no set (or, without sets, that each plane has a colour of its own), then what
    the points' and the voxel planes' colours mean (the demo's view said none of it).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> colour_key(SimpleNamespace(planes=SimpleNamespace(extra={}))).startswith("planes: a colour each")
    True
    """
    if "set" not in scene.planes.extra:
        return f"planes: a colour each (no joint sets: measure --sets) · {OTHER_COLOURS}<br>"
    sets = sorted({int(s) for s in scene.planes.extra["set"]} - {-1})
    swatch = "<span style='color:{}'>&#9632;</span> {}"
    parts = [swatch.format(set_color(s), f"set {s}") for s in sets] + [swatch.format(NO_SET_COLOR, "no set")]
    return "planes by set: " + "  ".join(parts) + f" · {OTHER_COLOURS}<br>"


def plane_colors(scene: ReportScene) -> list[str]:
    """Each plane's colour: its joint set's when the planes have sets, else one of a palette."""
    if "set" in scene.planes.extra:
        return [set_color(int(s)) for s in scene.planes.extra["set"]] or [NO_SET_COLOR]
    return palette(max(len(scene.planes), 1))


def figure_3d(scene: ReportScene) -> dict:
    """Traces in a fixed order the page's script relies on (see ``trace`` below)."""
    import plotly.graph_objects as go

    colors = plane_colors(scene)
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
            visible=not labelled.any(),  # shown when no plane was found: the cloud, not an empty box
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
    camera = face_camera(p, up, north=scene.frame.matrix[1])
    eye = camera["camera"]["eye"] if camera else PLOTLY_DEFAULT_EYE
    triad, (box_lo, box_hi) = _axes(scene, np.array([eye["x"], eye["y"], eye["z"]]))
    for trace in triad:  # 6.. scale bar (east), north and up
        fig.add_trace(trace)
    if scene.traces:  # last: the fracture traces, drawn over the cloud
        fig.add_trace(_trace_lines(scene.traces))
    pad = 0.02 * float(np.max(box_hi - box_lo) or 1.0)
    ticks = tick_counts(box_hi - box_lo, np.array([eye["x"], eye["y"], eye["z"]]))
    ranges = {f"{a}axis": dict(range=[box_lo[i] - pad, box_hi[i] + pad], title=f"{a} ({scene.unit})",
                               nticks=int(ticks[i])) for i, a in enumerate("xyz")}  # fmt: skip
    key = f"grey bar: {triad[0].name} (east) · red: north · blue: up · axes relative to the header's offset"
    if scene.traces:
        key += f" · dark red lines: {len(scene.traces)} fracture traces"
    key = colour_key(scene) + key
    fig.update_layout(
        margin=dict(l=0, r=0, t=0, b=0),
        showlegend=False,
        uirevision="keep",
        annotations=[
            dict(
                text=key,
                x=0.01,
                y=0.01,
                xref="paper",
                yref="paper",
                xanchor="left",
                yanchor="bottom",
                align="left",
                showarrow=False,
                font=dict(size=11, color="#444"),
            )
        ],  # fmt: skip
        scene=dict(
            aspectmode="data",
            # the caption's band below the scene: the triad at the cloud's near corner was
            # drawn over it (the demo's Up arrow)
            domain=dict(x=[0.0, 1.0], y=[CAPTION_BAND, 1.0]),
            **ranges,
            **camera,
        ),  # fmt: skip
    )
    return figure_json(fig)


#: Where plotly puts the eye when the layout names no camera.
PLOTLY_DEFAULT_EYE = {"x": 1.25, "y": 1.25, "z": 1.25}

#: The share of the 3D view's height under the scene, where the caption is written.
CAPTION_BAND = 0.07


#: A terrain (an airborne survey, a quarry floor) is seen from the south, this many degrees
#: above the horizon, north up the screen as on a map: plotly's default eye, from the
#: north-east corner, cut a 1.2 km survey's near corner off in a 1400 x 900 window.
TERRAIN_VIEW_ELEVATION = 55.0


def _trace_lines(traces: list):
    """The fracture traces (``traces.csv``) as one line layer, polylines apart by gaps."""
    import plotly.graph_objects as go

    xyz = np.vstack([np.vstack([line, np.full((1, 3), np.nan)]) for line in traces]).astype(np.float32)
    return go.Scatter3d(x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2], mode="lines", name="fracture traces",
                        line=dict(color="#d7191c", width=4), hoverinfo="skip", connectgaps=False)  # fmt: skip


def face_camera(points: np.ndarray, up: np.ndarray, north=None) -> dict:
    """A camera looking at an outcrop face along its outward normal, when the cloud is one
    (thin across, and not lying flat); at a terrain (thin across and lying flat) from the
    south (``north``, in cloud axes, given), :data:`TERRAIN_VIEW_ELEVATION` degrees up; {}
    (plotly's default view) for anything else.

    The face is the least-squares plane of the points; of its two sides, the one facing up
    is outward (a slope's face looks up and out). With ``aspectmode="data"`` a direction in
    the data is a direction of the camera's eye, so the eye sits on that normal.

    Examples
    --------
    >>> g = np.random.default_rng(0).random((500, 2)) * [20.0, 8.0]
    >>> wall = np.c_[g[:, 0], 0.05 * g[:, 1], g[:, 1]]  # a face rising to the north, looking south
    >>> eye = face_camera(wall, np.array([0.0, 0.0, 1.0]))["camera"]["eye"]
    >>> round(eye["y"], 2) < 0 < round(eye["z"], 2)
    True
    >>> ground = np.c_[g, 0.01 * g[:, 0]]
    >>> eye = face_camera(ground, np.array([0.0, 0.0, 1.0]), north=np.array([0.0, 1.0, 0.0]))["camera"]["eye"]
    >>> round(eye["x"], 6), eye["y"] < 0 < eye["z"]  # from the south, above
    (0.0, True)
    """
    if len(points) < 10:
        return {}
    p = np.asarray(points, dtype=np.float64)
    values, vectors = np.linalg.eigh(np.cov((p - p.mean(axis=0)).T))
    normal = vectors[:, 0]
    up = np.asarray(up, dtype=np.float64)
    if values[0] > 0.15 * values[1]:
        return {}  # not thin: a building, a blob
    if abs(normal @ up) > np.cos(np.radians(30.0)):  # a terrain
        if north is None:
            return {}
        south = -np.asarray(north, dtype=np.float64)
        south = south - (south @ up) * up
        south /= np.linalg.norm(south)
        angle = np.radians(TERRAIN_VIEW_ELEVATION)
        return _camera(2.0 * (np.cos(angle) * south + np.sin(angle) * up), up)
    normal = normal if normal @ up >= 0 else -normal
    return _camera(2.0 * normal, up)


def _camera(eye: np.ndarray, up: np.ndarray) -> dict:
    return {
        "camera": {
            "eye": {"x": float(eye[0]), "y": float(eye[1]), "z": float(eye[2])},
            "up": {"x": float(up[0]), "y": float(up[1]), "z": float(up[2])},
        }
    }


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


#: A plane whose roughness (RMS fit residual) exceeds this many times the median plane's is a
#: rough surface, not a joint: its rectangle would cover the joints it spans, so it is not drawn.
ROUGH_FACTOR = 3.0


def rough_planes(planes) -> np.ndarray:
    """Which planes are rough surfaces (see :data:`ROUGH_FACTOR`); none among fewer than five.

    Examples
    --------
    >>> from geostructure.core.planes import Planes
    >>> residual = [0.12, 0.01, 0.012, 0.009, 0.011, 0.01]
    >>> rough_planes(Planes(normal=[[0, 0, 1.0]] * 6, fit_residual=residual)).tolist()
    [True, False, False, False, False, False]
    """
    residual = np.asarray(planes.fit_residual, dtype=np.float64)
    if len(residual) < 5 or not np.isfinite(residual).any():
        return np.zeros(len(residual), dtype=bool)
    return residual > ROUGH_FACTOR * np.nanmedian(residual)


def _plane_mesh(scene: ReportScene, colors):
    import plotly.graph_objects as go

    n = len(scene.planes)
    # A rough surface's rectangle shrinks to its centre (drawn as nothing); its points stay.
    corners = np.where(
        rough_planes(scene.planes)[:, None, None],
        scene.planes.local_rect_center[:, None, :],
        scene.planes.local_corners,
    ).reshape(-1, 3)
    i, j, k = _quads(n)
    unit = scene.unit
    text = np.repeat(
        [
            hover_text(row, scene.truth.get(row["region_id"]), unit, scene.metres_per_unit)
            for row in scene.planes.rows()
        ],
        4,
    )
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


def hover_text(row: dict, truth: dict | None, unit: str = "m", metres_per_unit: float = 1.0) -> str:
    """A plane's hover label: its area in square metres, as every table of the page gives
    it, and its roughness in the cloud's length ``unit`` (``metres_per_unit`` metres)."""
    text = (
        f"<b>Plane {row['region_id']}</b><br>"
        + (
            f"strike {row['strike']:.1f}°, dip {row['dip']:.1f}°, dip direction {row['dip_direction']:.1f}°"
            if row["dip_direction"] == row["dip_direction"]
            else f"level (dip {row['dip']:.4f}°)"  # blank: level
        )
        + f" (± {row.get('normal_uncertainty_deg', float('nan')):.2f}°)"
        f"<br>area {row['area_m2'] * metres_per_unit**2:.2f} m², {row['n_points']:,} points, "
        f"roughness {row['fit_residual']:.4f} {escape(unit)}"
    )
    if truth:
        text += f"<br>truth '{escape(str(truth['surface']))}': error {float(truth['normal_error_deg']):.2f}°"
    return text


def scale_length(size: float) -> float:
    """A round length (1, 2 or 5 times a power of ten) near a fifth of ``size``.

    Examples
    --------
    >>> scale_length(23.0), scale_length(0.9), scale_length(1200.0)
    (2.0, 0.1, 200.0)
    """
    raw = 0.2 * size
    power = 10.0 ** np.floor(np.log10(raw))
    return float(next(m * power for m in (5.0, 2.0, 1.0) if m * power <= raw))


def tick_counts(extent: np.ndarray, eye: np.ndarray, most: int = 8) -> np.ndarray:
    """Ticks on each axis in proportion to its length on the screen seen from ``eye``: an
    axis seen end-on (the height of a terrain seen from above) got as many ticks as the
    others, their labels over each other (autzen).

    Examples
    --------
    >>> tick_counts(np.array([600.0, 300.0, 100.0]), np.array([0.0, -1.0, 1.4])).tolist()
    [8, 3, 2]
    """
    toward = np.asarray(eye, dtype=np.float64) / np.linalg.norm(eye)
    across = np.sqrt(np.clip(1.0 - toward**2, 0.0, None))  # an axis's length on the screen, per unit
    seen = np.asarray(extent, dtype=np.float64) * across
    return np.clip(np.round(most * seen / max(float(seen.max()), 1e-12)), 2, most).astype(int)


def screen_axes(eye: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The screen's right, up and toward-the-eye directions (rows) of a camera at ``eye`` (a
    direction from the scene) with ``up`` up the screen."""
    toward = np.asarray(eye, dtype=np.float64)
    toward = toward / np.linalg.norm(toward)
    right = np.cross(-toward, np.asarray(up, dtype=np.float64))
    if np.linalg.norm(right) < 1e-9:  # looking straight down: the screen's right is east-ish
        right = np.cross(np.array([0.0, 1.0, 0.0]), toward)
    right /= np.linalg.norm(right)
    return np.stack([right, np.cross(right, -toward), toward])


def screen_corner(
    points: np.ndarray, eye: np.ndarray, up: np.ndarray, margin: float, drop: float | None = None
) -> np.ndarray:
    """The point ``margin`` left of and ``drop`` (``margin`` unless given) below the cloud's
    bottom-left corner as seen from
    ``eye`` (a direction from the cloud), with ``up`` up the screen, at the depth of the
    cloud's middle: outside the cloud's outline on the screen no point hides it, and
    nearer the eye the perspective pushed it off the view (the demo's terrain).

    Examples
    --------
    >>> wall = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 0.0, 5.0], [10.0, 0.0, 5.0]])
    >>> screen_corner(wall, np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, 1.0]), 1.0).round(6).tolist()
    [-1.0, 0.0, -1.0]
    >>> screen_corner(wall, np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), 1.0).round(6).tolist()
    [11.0, 0.0, -1.0]
    """
    axes = screen_axes(eye, up)
    local = points @ axes.T
    middle = 0.5 * (local[:, 2].min() + local[:, 2].max())
    drop = margin if drop is None else drop  # further down: the perspective lifts the middle depth
    corner = np.array([local[:, 0].min() - margin, local[:, 1].min() - drop, middle])
    return corner @ axes


def _axes(scene: ReportScene, eye: np.ndarray):
    """A triad at the cloud's bottom-left corner as the camera at ``eye`` (a direction, as
    plotly's camera gives it) sees it, in front of the points: east (a scale bar, labelled
    with its round length and the cloud's unit), north and up, all that long; and the
    corners of a box that holds them, so that no label is cut at the view's edge.

    The corner is read on the screen, not along the cloud's axes: at the lowest corner of
    the box, the demo's view from the south cut the arrows at the view's edge, and on a
    face seen along its normal the triad stood over the rock."""
    import plotly.graph_objects as go

    p = scene.points if len(scene.points) else np.zeros((1, 3), np.float32)
    lo, hi = p.min(axis=0).astype(float), p.max(axis=0).astype(float)
    size = float(np.max(hi - lo) or 1.0)
    length = scale_length(size)
    east, north, up = scene.frame.matrix
    # the whole triad left of the cloud on the screen: the scale bar and its label, drawn
    # from the corner rightwards, lay over the cloud's edge
    rightwards = max(0.0, float(east @ screen_axes(eye, up)[0])) * length + 0.12 * size
    origin = screen_corner(p.astype(float), eye, up, margin=0.05 * size + rightwards, drop=0.1 * size)
    triad = ((f"{length:g} {scene.unit}", east, "#555555"), ("N", north, "#d62728"), ("Up", up, "#1f77b4"))
    traces, tips = [], [origin]
    for name, vector, color in triad:
        tip = origin + length * vector
        tips.append(tip + 0.08 * size * vector)  # room for the label past the tip
        traces.append(
            go.Scatter3d(
                x=[origin[0], tip[0]],
                y=[origin[1], tip[1]],
                z=[origin[2], tip[2]],
                mode="lines+text",
                text=["", name],
                textposition="middle right",
                textfont=dict(color=color, size=14),
                name=name,
                line=dict(color=color, width=6),
                hoverinfo="skip",
            )
        )
    corners = np.vstack([lo, hi, *tips])
    return traces, (corners.min(axis=0), corners.max(axis=0))


#: Pixels at the top of a side panel kept for plotly's mode bar: the panel's title is drawn
#: under it, so that the bar, shown while the pointer is over the figure, never hides it.
MODEBAR_PX = 28
LINE_PX = 17


def panel_title(lines: list[str], height: int) -> tuple[dict, int]:
    """A side panel's title (one entry a line) under the mode bar, and the top margin it needs."""
    title = dict(
        text="<br>".join(lines),
        font=dict(size=13),
        x=0.02,
        xanchor="left",
        y=1.0 - MODEBAR_PX / height,
        yref="container",
        yanchor="top",
    )
    return title, MODEBAR_PX + LINE_PX * len(lines) + 8


def figure_json(fig) -> dict:
    """The figure as plain JSON, numpy arrays as plotly's base64 typed arrays."""
    import plotly.io as pio

    return json.loads(pio.to_json(fig, validate=False))
