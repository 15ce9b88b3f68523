"""The kinematic envelopes on the report's stereonet, as plotly traces (``kinematics.json``)."""

from __future__ import annotations

import numpy as np

from geostructure.core.orientation import whole_azimuth
from geostructure.core.projection import enu_vectors, equal_area_xy, great_circle_xy, pole_xy, small_circle_xy
from geostructure.report.view3d import TOPPLING_COLOR


def _line_xy(trend, plunge):
    return equal_area_xy(enu_vectors(np.asarray(trend, float), np.asarray(plunge, float)))


def envelope_curves(kinematics: dict) -> list[tuple[str, str, str, np.ndarray, np.ndarray]]:
    """(name, colour, dash, x, y) of each envelope: the slope's great circle, the planar
    daylight envelope and its lateral limits, the friction cones of poles and of lines, the
    toppling envelope and its lateral limits, and the circle of lines plunging 90 - slope dip
    inside which direct toppling's intersections lie.

    Examples
    --------
    >>> curves = envelope_curves({"slope": {"dip": 60.0, "dip_direction": 180.0}, "friction_deg": 30.0,
    ...                           "lateral_limit_deg": 20.0})
    >>> [c[0] for c in curves][:3]
    ['slope (wedge daylight envelope)', 'planar daylight envelope', 'pole friction cone']
    """
    slope, friction = kinematics["slope"], float(kinematics["friction_deg"])
    alpha, psi, limit = float(slope["dip_direction"]), float(slope["dip"]), float(kinematics["lateral_limit_deg"])
    curves = [("slope (wedge daylight envelope)", "black", "solid", *great_circle_xy(alpha, psi))]
    azimuth = np.linspace(alpha - 90.0, alpha + 90.0, 121)
    apparent = np.degrees(np.arctan(np.tan(np.radians(psi)) * np.cos(np.radians(azimuth - alpha))))
    curves.append(("planar daylight envelope", "#1f4fd1", "solid", *pole_xy(azimuth, apparent)))
    curves.append(("pole friction cone", "#d62728", "dash", *small_circle_xy(0.0, 90.0, friction)))
    curves.append(("line friction cone", "#9b30b0", "dash", *small_circle_xy(0.0, 90.0, 90.0 - friction)))
    plunge = np.linspace(0.0, 90.0, 31)
    for side in (-1.0, 1.0):
        x, y = _line_xy(np.full_like(plunge, alpha + 180.0 + side * limit), plunge)
        curves.append(("planar lateral limit", "#1f4fd1", "dot", x, y))
        x, y = _line_xy(np.full_like(plunge, alpha + side * limit), plunge)
        curves.append(("toppling lateral limit", TOPPLING_COLOR, "dot", x, y))
    if psi - friction > 0:
        arc = np.linspace(alpha - limit, alpha + limit, 41)
        curves.append(("toppling envelope", TOPPLING_COLOR, "solid", *_line_xy(arc, np.full_like(arc, psi - friction))))
    if psi < 90.0:
        curves.append(("direct toppling circle", "saddlebrown", "dashdot", *small_circle_xy(0.0, 90.0, psi)))
    return curves


def kinematic_traces(kinematics: dict) -> list:
    """Plotly traces of :func:`envelope_curves`, and a star on each critical wedge the sets'
    means form; [] without kinematics."""
    import plotly.graph_objects as go

    if not kinematics:
        return []
    seen = set()
    traces = []
    for section in kinematics.get("sections") or [None]:
        # A face tested in sections: every section's envelopes are drawn (the net shows no
        # legend to switch them with), each trace named by its section; kinematics.png has a
        # net per section.
        view = kinematics if section is None else {**kinematics, "slope": section["slope"]}
        group = None
        if section is not None:
            slope = section["slope"]
            group = f"section {section['section']}: slope {slope['dip']:.0f}/{whole_azimuth(slope['dip_direction'])}"
        for name, color, dash, x, y in envelope_curves(view):
            traces.append(
                go.Scatter(
                    x=x,
                    y=y,
                    mode="lines",
                    name=group or name,
                    legendgroup=group or name,
                    showlegend=(group or name) not in seen,
                    line=dict(color=color, width=1.8, dash=dash),
                    hoverinfo="skip",
                )
            )
            seen.add(group or name)
    drawn = set()
    for wedge in kinematics.get("set_mean_wedges", []):  # the critical wedges of the sets' means
        a, b = wedge["sets"]
        if (a, b) in drawn:  # critical in more than one section: the same line
            continue
        drawn.add((a, b))
        x, y = _line_xy([wedge["trend"]], [wedge["plunge"]])
        traces.append(
            go.Scatter(
                x=x,
                y=y,
                mode="markers",
                name=f"wedge of set means {a} and {b}",
                marker=dict(symbol="star", size=16, color="black", line=dict(color="white", width=1)),
                hovertemplate=f"wedge of set means {a} and {b}<br>plunge {wedge['plunge']:.0f}° toward "
                f"{whole_azimuth(wedge['trend'])}<extra></extra>",
            )
        )
    return traces
