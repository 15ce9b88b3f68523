"""Found traces scored against the traces of a field map, beside what the rule gives for nothing.

The rule (``../shared/data/dice_lastoni_sw/README.md``; the one the project is judged by):

- a mapped fracture is a disc (centre, unit normal, radius) fitted to a hand-drawn trace; its
  **trace line** is where the disc cuts the local surface: the disc's normal crossed with the
  surface's normal from the :data:`SURFACE_POINTS` cloud points nearest the disc's centre;
- it is **traced** when some found trace has at least :data:`SHARE` of its length (its
  :data:`SAMPLES` samples along its polyline) within :data:`TOLERANCE` of the disc's plane
  and within radius + :data:`TOLERANCE` of its centre, and its chord runs within
  :data:`MAX_ANGLE` degrees of the disc's trace line;
- **trace precision**: the share of found traces that trace at least one mapped fracture;
- **null model** (:func:`null_segments`): as many straight segments, with the same chords,
  at random points of the cloud in random directions along the local surface, scored the
  same way: what the rule gives for nothing, printed beside every score.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from geostructure.detect.traces import surface_normals
from geostructure.rockmass.windows import (
    MIN_WINDOWS,
    RADIUS_CELLS,
    count_in_windows,
    trace_direction,
    trace_p10,
    window_centres,
)

#: The rule's tolerances: 5 cm (in metres; scaled to the cloud's unit by the caller), 60% of
#: 11 samples, 15 degrees, the surface from 30 points.
TOLERANCE = 0.05
SHARE = 0.6
SAMPLES = 11
MAX_ANGLE = 15.0
SURFACE_POINTS = 30


@dataclass(frozen=True)
class TraceScore:
    """Per mapped fracture whether it is ``traced`` (M,); per found trace whether it traces one
    (``useful``, (T,))."""

    traced: np.ndarray
    useful: np.ndarray

    @property
    def n_traced(self) -> int:
        return int(self.traced.sum())

    @property
    def precision(self) -> float:
        return float(self.useful.mean()) if len(self.useful) else float("nan")


def local_normals(points: np.ndarray, tree: cKDTree, at: np.ndarray, k: int = SURFACE_POINTS) -> np.ndarray:
    """The surface's unit normal at each of ``at``: the least axis of its ``k`` nearest points
    (:func:`~geostructure.detect.traces.surface_normals` at the rule's 30)."""
    return surface_normals(points, tree, at, k)


def trace_lines(points: np.ndarray, tree: cKDTree, centres: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Each disc's trace line (unit): its normal crossed with the surface's at its centre."""
    line = np.cross(normals, local_normals(points, tree, centres))
    return line / np.maximum(np.linalg.norm(line, axis=1, keepdims=True), 1e-300)


def polyline_samples(polylines: list, n: int = SAMPLES) -> np.ndarray:
    """``n`` points evenly spaced along each polyline's length, (T, n, 3)."""
    out = np.zeros((len(polylines), n, 3))
    for k, line in enumerate(polylines):
        line = np.asarray(line, dtype=np.float64)
        cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
        at = np.linspace(0.0, cum[-1], n)
        out[k] = np.column_stack([np.interp(at, cum, line[:, a]) for a in range(3)])
    return out


def score_traces(polylines, centres, normals, radius, lines, *, tolerance: float = TOLERANCE) -> TraceScore:
    """Score found traces (a list of (n, 3) polylines) against mapped discs (``centres``,
    unit ``normals``, ``radius``, their trace ``lines``), all in one frame; ``tolerance`` in
    its unit (see the module).

    Examples
    --------
    A disc of radius 0.3 in the plane x = 0 on a level surface, its trace line along y; one
    trace along it, one across it:

    >>> along = np.array([[0.0, -0.25, 0], [0.0, 0.25, 0]])
    >>> across = np.array([[-0.25, 0.0, 0], [0.25, 0.0, 0]])
    >>> s = score_traces([along, across], np.zeros((1, 3)), np.array([[1.0, 0, 0]]), np.array([0.3]),
    ...                  np.array([[0.0, 1, 0]]))
    >>> s.traced.tolist(), s.useful.tolist()
    ([True], [True, False])
    """
    centres, normals = np.asarray(centres, dtype=np.float64), np.asarray(normals, dtype=np.float64)
    radius, lines = np.asarray(radius, dtype=np.float64), np.asarray(lines, dtype=np.float64)
    traced = np.zeros(len(centres), dtype=bool)
    useful = np.zeros(len(polylines), dtype=bool)
    if not len(polylines) or not len(centres):
        return TraceScore(traced, useful)
    samples = polyline_samples(polylines)
    chord = samples[:, -1] - samples[:, 0]
    half = 0.5 * np.linalg.norm(chord, axis=1)
    chord /= np.maximum(2 * half[:, None], 1e-300)
    middle = samples[:, SAMPLES // 2]
    tree = cKDTree(middle)
    cos_limit = np.cos(np.radians(MAX_ANGLE))
    for j in range(len(centres)):
        # a trace can reach the disc only if its middle lies within its half chord of it
        near = np.asarray(tree.query_ball_point(centres[j], radius[j] + tolerance + half.max()), dtype=np.int64)
        if not len(near):
            continue
        offset = samples[near] - centres[j]
        inside = (np.abs(offset @ normals[j]) <= tolerance) & (np.linalg.norm(offset, axis=2) <= radius[j] + tolerance)
        aligned = np.abs(chord[near] @ lines[j]) >= cos_limit
        hit = near[(inside.mean(axis=1) >= SHARE) & aligned]
        if len(hit):
            traced[j] = True
            useful[hit] = True
    return TraceScore(traced, useful)


def null_segments(points: np.ndarray, tree: cKDTree, chords, seed: int = 0) -> list[np.ndarray]:
    """The null model's segments: one per chord, centred at a random point of the cloud, in a
    random direction along the surface there (seeded)."""
    chords = np.asarray(chords, dtype=np.float64)
    rng = np.random.default_rng(seed)
    at = rng.choice(len(points), len(chords), replace=len(chords) > len(points))
    surface = local_normals(points, tree, points[at])
    direction = rng.normal(size=(len(at), 3))
    direction -= np.einsum("ij,ij->i", direction, surface)[:, None] * surface
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-300)
    half = 0.5 * chords[:, None] * direction
    return [np.stack([points[i] - h, points[i] + h]) for i, h in zip(at, half)]


def set_trace_figures(trace_sets, chords, measured_means, published, mapped_sets, mapped_chords,
                      max_angle: float = 20.0) -> dict:  # fmt: skip
    """Per published set (label -> unit mean normal): the found traces of the measured set
    nearest it within ``max_angle`` degrees (``measured_means`` (S, 3), each trace's set in
    ``trace_sets``, -1 for none), their count, summed chord and median chord, beside the
    map's traces of that label (``mapped_sets``, ``mapped_chords``).

    Examples
    --------
    >>> figures = set_trace_figures(np.array([0, 0, -1]), np.array([0.5, 0.7, 2.0]), np.array([[1.0, 0, 0]]),
    ...                             {"1": np.array([1.0, 0, 0])}, np.array(["1", "1", ""]), np.array([0.6, 0.8, 1.0]))
    >>> figures["1"]["found_chord_sum"], figures["1"]["mapped_chord_sum"], figures["1"]["measured_set"]
    (1.2, 1.4, 0)
    """
    out = {}
    means = np.asarray(measured_means, dtype=np.float64).reshape(-1, 3)
    for label, normal in published.items():
        angle = np.degrees(np.arccos(np.clip(np.abs(means @ normal), 0.0, 1.0))) if len(means) else np.zeros(0)
        nearest = int(np.argmin(angle)) if len(angle) and angle.min() <= max_angle else -1
        found = np.asarray(chords)[np.asarray(trace_sets) == nearest] if nearest >= 0 else np.zeros(0)
        mapped = np.asarray(mapped_chords)[np.asarray(mapped_sets) == label]
        out[label] = {
            "measured_set": nearest,
            "found_traces": int(len(found)),
            "found_chord_sum": float(found.sum()),
            "found_chord_median": float(np.median(found)) if len(found) else float("nan"),
            "mapped_traces": int(len(mapped)),
            "mapped_chord_sum": float(mapped.sum()),
            "mapped_chord_median": float(np.median(mapped)) if len(mapped) else float("nan"),
        }
    return out


def mapped_segments(centres: np.ndarray, radius: np.ndarray, lines: np.ndarray) -> list[np.ndarray]:
    """The map's traces as segments: each disc's chord (``2 radius``, DICE's) along its trace
    line (:func:`trace_lines`) through its centre."""
    half = np.asarray(radius, dtype=np.float64)[:, None] * np.asarray(lines, dtype=np.float64)
    return [np.stack([c - h, c + h]) for c, h in zip(np.asarray(centres, dtype=np.float64), half)]


def window_figures(face, found: list, mapped: list, null: list) -> dict:
    """Circular windows (:mod:`~geostructure.rockmass.windows`) laid once on ``face`` (an
    :class:`~geostructure.rockmass.exposure.Exposure`, in the polylines' metres) and read for
    the found traces, the map's and the null model's of one set: the same windows for all,
    so the three stand side by side; {} when no window fits."""

    for radius_cells in RADIUS_CELLS:
        grid = window_centres(face.occupied, radius_cells)
        if len(grid) >= MIN_WINDOWS:
            break
    else:
        return {}
    radius = radius_cells * face.cell
    centres = face.lower + (grid + 0.5) * face.cell
    out = {"window_radius_m": float(radius), "windows": int(len(grid))}
    # One set of scanlines too, across the map's traces of the set, for the three alike.
    along = trace_direction([face.project(line) for line in mapped])
    for name, lines in (("found", found), ("mapped", mapped), ("null", null)):
        uv = [face.project(line) for line in lines]
        n, m = count_in_windows(uv, centres, radius)
        out[f"{name}_window_mean_m"] = float(np.pi * radius / 2 * n / m) if m else float("nan")
        out[f"{name}_window_p21_per_m"] = float(n / (4 * radius * len(grid)))
        out[f"{name}_p10_per_m"] = trace_p10(uv, face.occupied, face.lower, face.cell, along)[0] if uv else 0.0
    return out
