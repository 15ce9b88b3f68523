"""The face's fracture traces (:mod:`geostructure.detect.traces`) as a rock mass reads them:
found on the face's points, each in its set, and per set their count, total length, median
chord and areal intensity P21 (trace length per exposed area, ISRM 1978; Dershowitz & Herda
1992), beside the planes' own.

The traces carry the fractures that show no face of their own, which the planes miss: on the
DICE Lastoni SW half most mapped fractures are such (docs/rockmass.md).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.orientation import orientation_from_normals
from geostructure.detect.traces import IMAGE_LINES, Traces, find_traces
from geostructure.rockmass.face import FACE
from geostructure.rockmass.tracelengths import TraceLengths
from geostructure.rockmass.windows import set_trace_p10, set_window_estimates

#: The columns ``sets.csv`` adds per set from the traces.
TRACE_SET_COLUMNS = ("traces", "trace_length_sum_m", "trace_chord_median_m", "trace_p21_per_m", "trace_censored",
                     "trace_censored_mean_m", "trace_window_radius_m", "trace_windows", "trace_window_crossings",
                     "trace_window_ends", "trace_window_mean_m", "trace_window_p21_per_m", "trace_p10_per_m",
                     "trace_scanline_m")  # fmt: skip
#: The columns of ``traces.csv`` (one row a trace) and ``trace_vertices.csv`` (one row a vertex).
TRACE_COLUMNS = ("trace_id", "set", "source", "region_id", "length_m", "chord_m", "n_vertices", "n_points",
                 "censored_ends", "contrast", "dip", "dip_direction", "strike", "centre_x", "centre_y",
                 "centre_z")  # fmt: skip
VERTEX_COLUMNS = ("trace_id", "vertex", "x", "y", "z")
#: A dark line over the ground or the clutter for more than this share of its length is theirs,
#: not the rock's.
OFF_FACE_SHARE = 0.5
#: A trace's end within this many occupancy cells (each a few point spacings) of the
#: exposure's edge, the cloud's border or a hole, may run on where the cloud shows nothing:
#: that end is censored (ISRM 1978; Priest & Hudson 1981), as a joint's is. One cell, not
#: the edge cell alone: a dark line stops two ridge scales short of its patch's border (the
#: image's margin), which is a cell or less inside it.
CENSOR_CELLS = 1
#: An end this many occupancy cells or more off every section's plane lies on none of them.
SECTION_REACH_CELLS = 16


def face_traces(points, labels, planes, sets, point_part=None, grey=None, tested=None) -> Traces:
    """The traces of a measured face (:func:`~geostructure.detect.traces.find_traces`):
    the planes' traces of the discontinuities (``tested``: not ground, clutter or the face's
    own surface), the dark lines where the points have a ``grey``, each in a set of
    ``sets`` (:class:`~geostructure.rockmass.sets.JointSets`). ``point_part`` (the face's
    parts, :func:`~geostructure.rockmass.face.face_parts`) drops the dark lines drawn on the
    ground and the clutter.

    Examples
    --------
    >>> from geostructure import measure
    >>> from geostructure.workflows.sets_and_mass import plane_sets
    >>> from geostructure.synthetic import outcrop_scene
    >>> result = measure(outcrop_scene(width=6.0, height=4.0, seed=1).cloud)
    >>> traces = face_traces(result.filtered.local, result.labels, result.planes, plane_sets(result.planes))
    >>> len(traces) > 10, set(traces.source) == {"plane"}
    (True, True)
    """
    # One tree for the traces and the filter below. Balanced where the dark lines will query
    # every point (an unbalanced tree's 8 nearest of all 0.7M outcrop points took 2.1 s, a
    # balanced one's 1.3); built fast where only the planes' few hundred centres and traces
    # are (0.15 s against 0.39 s on that outcrop, its queries as fast).
    balanced = grey is not None
    tree = cKDTree(np.asarray(points, dtype=np.float64), balanced_tree=balanced, compact_nodes=balanced)
    traces = find_traces(points, None, grey=grey, labels=labels, plane_normals=planes.normal, tested=tested,
                         plane_sets=sets.labels, set_normals=sets.mean_normal, tree=tree)  # fmt: skip
    if point_part is None or not len(traces):
        return traces
    keep = np.ones(len(traces), dtype=bool)
    for k, line in enumerate(traces.polylines()):
        if traces.source[k] in IMAGE_LINES:
            _, nearest = tree.query(line)
            keep[k] = np.mean(point_part[nearest] != FACE) <= OFF_FACE_SHARE
    return traces if keep.all() else traces.subset(keep)


def censored_ends(traces: Traces | None, exposures, metres: float = 1.0) -> np.ndarray:
    """Per trace, how many of its two ends lie within :data:`CENSOR_CELLS` of the exposure's
    edge (:meth:`~geostructure.rockmass.exposure.Exposure.edge`: its border and its holes),
    or off it: 0 (seen end to end), 1 or 2. ``exposures``: the face's sections, in metres;
    ``metres``, in one unit of the traces. Each end is read on the section whose plane lies
    nearest it among those whose grid holds it.

    Examples
    --------
    >>> from geostructure.rockmass.exposure import exposure
    >>> g = np.mgrid[0:4:0.02, 0:0.03:0.01, 0:3:0.02].reshape(3, -1).T  # a wall 4 m long, 3 m high
    >>> face = exposure(g, spacing=0.02)
    >>> t = Traces.from_polylines([np.array([[1.0, 0, 1], [2.0, 0, 1.5]]), np.array([[3.0, 0, 1], [4.0, 0, 1.5]]),
    ...                            np.array([[-0.01, 0, 0.5], [4.0, 0, 2.0]])], ["dark line"] * 3, [-1] * 3)
    >>> censored_ends(t, [face]).tolist()
    [0, 1, 2]
    """
    if traces is None:
        return np.zeros(0, dtype=np.int64)
    n = len(traces)
    if not n or not len(exposures):
        return np.zeros(n, dtype=np.int64)
    ends = np.concatenate([traces.vertices[traces.start[:-1]], traces.vertices[traces.start[1:] - 1]])
    at_edge = _at_edge(ends, exposures, metres)
    return at_edge[:n].astype(np.int64) + at_edge[n:].astype(np.int64)


def along_edge(traces: Traces, exposures, metres: float = 1.0, ends: np.ndarray | None = None) -> np.ndarray:
    """Per trace, whether it runs along the exposure's edge: both its ends and its middle
    vertex within :data:`CENSOR_CELLS` of it (:func:`censored_ends`). Such a line is the
    edge's own, where the survey stops or the rock turns out of sight, and cannot be told
    from it: on the Lastoni SW half 48 traces ran so (30 planes' traces, 10 dark lines, 8
    valleys) and 5 of them traced a mapped fracture, where 76 of the other 216 did. ``ends``:
    the traces' :func:`censored_ends`, when the caller holds them.

    Examples
    --------
    >>> from geostructure.rockmass.exposure import exposure
    >>> g = np.mgrid[0:4:0.02, 0:0.03:0.01, 0:3:0.02].reshape(3, -1).T  # a wall 4 m long, 3 m high
    >>> face = exposure(g, spacing=0.02)
    >>> t = Traces.from_polylines([np.array([[0.5, 0, 0.0], [2.0, 0, 0.0], [3.5, 0, 0.0]]),  # along its foot
    ...                            np.array([[2.0, 0, 0.0], [2.0, 0, 1.5], [2.0, 0, 3.0]])],  # across it
    ...                           ["dark line"] * 2, [-1] * 2)
    >>> along_edge(t, [face]).tolist(), censored_ends(t, [face]).tolist()
    ([True, False], [2, 2])
    """
    n = len(traces)
    if not n or not len(exposures):
        return np.zeros(n, dtype=bool)
    middle = traces.vertices[(traces.start[:-1] + traces.start[1:] - 1) // 2]
    ends = censored_ends(traces, exposures, metres) if ends is None else np.asarray(ends)
    return (ends == 2) & _at_edge(middle, exposures, metres)


def _at_edge(at: np.ndarray, exposures, metres: float) -> np.ndarray:
    """Whether each point of ``at`` (the traces' unit) lies within :data:`CENSOR_CELLS` of
    the exposure's edge, or off it; each read on the section whose plane lies nearest it
    among those whose grid holds it."""
    from scipy import ndimage  # imported with the exposure's edge: only with sets

    at = np.asarray(at, dtype=np.float64) * metres
    best = np.full(len(at), np.inf)
    at_edge = np.ones(len(at), dtype=bool)  # on no section's grid: off the exposure
    for face in exposures:
        ij = np.floor((face.project(at) - face.lower) / face.cell).astype(np.int64)
        on_grid = ((ij >= 0) & (ij < face.occupied.shape)).all(axis=1)
        off_plane = np.abs((at - face.origin) @ face.normal)
        nearer = on_grid & (off_plane < SECTION_REACH_CELLS * face.cell) & (off_plane < best)
        near_edge = ndimage.binary_dilation(face.edge(), iterations=CENSOR_CELLS) | ~face.occupied
        best[nearer] = off_plane[nearer]
        at_edge[nearer] = near_edge[ij[nearer, 0], ij[nearer, 1]]
    return at_edge


def trace_set_rows(
    traces: Traces | None, n_sets: int, exposure_area_m2: float, metres: float = 1.0, exposures=()
) -> list[dict]:
    """Per set, the traces' columns of ``sets.csv`` (:data:`TRACE_SET_COLUMNS`), in metres:
    with the face's sections (``exposures``), what circular windows laid on them read
    (:func:`~geostructure.rockmass.windows.set_window_estimates`: a mean trace length and
    a P21 free of censoring; blank where no window fits) and the traces' P10 on scanlines
    across them (:func:`~geostructure.rockmass.windows.set_trace_p10`).

    Examples
    --------
    >>> t = Traces.from_polylines([np.array([[0.0, 0, 0], [1.0, 0, 0]]), np.array([[0.0, 1, 0], [3.0, 1, 0]])],
    ...                           ["plane", "dark line"], [0, -1])
    >>> t.set = np.array([0, 0])
    >>> {k: v for k, v in trace_set_rows(t, 1, 4.0)[0].items() if k in TRACE_SET_COLUMNS[:4]}
    {'traces': 2, 'trace_length_sum_m': 4.0, 'trace_chord_median_m': 2.0, 'trace_p21_per_m': 1.0}
    """
    windows = set_window_estimates(traces, list(exposures), n_sets, metres)
    p10 = set_trace_p10(traces, list(exposures), n_sets, metres)
    rows = []
    for s in range(n_sets):
        mine = np.zeros(0, dtype=bool) if traces is None else traces.set == s
        length = traces.length[mine] * metres if traces is not None else np.zeros(0)
        chord = traces.chord[mine] * metres if traces is not None else np.zeros(0)
        cut = traces.censored_ends[mine] > 0 if traces is not None else np.zeros(0, dtype=bool)
        rows.append({
            "traces": int(mine.sum()),
            "trace_length_sum_m": float(length.sum()),
            "trace_chord_median_m": float(np.median(chord)) if len(chord) else float("nan"),
            "trace_p21_per_m": float(length.sum() / exposure_area_m2) if exposure_area_m2 > 0 else float("nan"),
            "trace_censored": int(np.count_nonzero(cut)),
            # the exponential's mean with censoring, as the joints' (blank where every trace is cut)
            "trace_censored_mean_m": TraceLengths(length, cut).mean,
            **window_columns(windows[s]),
            "trace_p10_per_m": p10[s][0],
            "trace_scanline_m": p10[s][1],
        })  # fmt: skip
    return rows


def window_columns(estimate) -> dict:
    """``sets.csv``'s circular-window columns of one set (:class:`~geostructure.rockmass.windows.WindowEstimate`
    or None: no window fits, every column but the count blank)."""
    if estimate is None:
        nan = float("nan")
        return {"trace_window_radius_m": nan, "trace_windows": 0, "trace_window_crossings": nan,
                "trace_window_ends": nan, "trace_window_mean_m": nan, "trace_window_p21_per_m": nan}  # fmt: skip
    return {
        "trace_window_radius_m": float(estimate.radius),
        "trace_windows": int(estimate.windows),
        "trace_window_crossings": int(estimate.crossings),
        "trace_window_ends": int(estimate.ends),
        "trace_window_mean_m": estimate.mean_length,
        "trace_window_p21_per_m": estimate.p21,
    }


def trace_rows(traces: Traces, frame, offset, metres: float = 1.0) -> list[dict]:
    """``traces.csv``'s rows: per trace its set (blank: none), where it comes from, its plane's
    ``region_id`` (blank for a dark line), length and chord in metres, its vertices and the
    points along it, a dark line's contrast (:func:`~geostructure.detect.traceimage.line_contrast`),
    the plane fitted to it (dip, dip direction and strike; blank where it
    defines none) and its middle vertex in the cloud's coordinates.

    Examples
    --------
    >>> from geostructure.core.orientation import Frame
    >>> t = Traces.from_polylines([np.array([[0.0, 0, 0], [0.5, 0, 0], [1.0, 0, 0.0]])], ["dark line"], [-1])
    >>> row = trace_rows(t, Frame(), np.array([100.0, 0, 0]))[0]
    >>> row["set"], row["length_m"], row["dip"], row["centre_x"]
    ('', 1.0, '', 100.5)
    """
    fitted = np.isfinite(traces.normal[:, 0]) if len(traces) else np.zeros(0, dtype=bool)
    orientation = orientation_from_normals(np.where(fitted[:, None], traces.normal, [0.0, 0.0, 1.0]), frame)
    middle = traces.vertices[(traces.start[:-1] + traces.start[1:] - 1) // 2] + np.asarray(offset)
    length, chord = traces.length * metres, traces.chord * metres
    rows = []
    for k in range(len(traces)):
        rows.append({
            "trace_id": k,
            "set": int(traces.set[k]) if traces.set[k] >= 0 else "",
            "source": str(traces.source[k]),
            "region_id": int(traces.region_id[k]) if traces.region_id[k] >= 0 else "",
            "length_m": float(length[k]),
            "chord_m": float(chord[k]),
            "n_vertices": int(traces.start[k + 1] - traces.start[k]),
            "n_points": int(traces.n_points[k]),
            "censored_ends": int(traces.censored_ends[k]),
            "contrast": float(traces.contrast[k]) if np.isfinite(traces.contrast[k]) else "",
            **({"dip": float(orientation.dip[k]), "dip_direction": float(orientation.dip_direction[k]),
                "strike": float(orientation.strike[k])} if fitted[k] else {"dip": "", "dip_direction": "",
                                                                            "strike": ""}),
            "centre_x": float(middle[k, 0]),
            "centre_y": float(middle[k, 1]),
            "centre_z": float(middle[k, 2]),
        })  # fmt: skip
    return rows


def vertex_columns(traces: Traces, offset) -> dict:
    """``trace_vertices.csv`` as columns: each trace's vertices in order along it, in the
    cloud's coordinates."""
    counts = np.diff(traces.start)
    xyz = traces.vertices + np.asarray(offset)
    return {
        "trace_id": np.repeat(np.arange(len(traces)), counts),
        "vertex": np.concatenate([np.arange(c) for c in counts]) if len(counts) else np.zeros(0, dtype=np.int64),
        "x": xyz[:, 0],
        "y": xyz[:, 1],
        "z": xyz[:, 2],
    }
