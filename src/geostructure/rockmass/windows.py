"""Circular windows: trace intensity and mean trace length free of censoring.

A trace cut by the edge of the exposure reads short, and one longer than the exposure
cannot be measured at all, so the mean of the traces seen (the ``joint_trace_mean_m`` of
the planes, 71% of them censored on the DICE Lastoni SW half) says little. Circular
windows (Mauldon 1998; Zhang & Einstein 1998; Mauldon, Dunne & Rohrbaugh 2001; what DICE
offers) read the two numbers from counts alone, whatever the traces' lengths and however
many run out of sight: on circles of radius ``r`` laid wholly on the exposed face,

- ``n`` traces cross a circle's rim and ``m`` trace ends lie inside it;
- the mean trace length is ``(pi r / 2) (n / m)``;
- the areal intensity P21 (trace length per area) is ``n / (4 r)`` per window;
- the density of traces P20 is ``m / (2 pi r^2)``.

Each estimate holds for traces of any length distribution and any orientations, provided the
window is wholly on the rock. The windows here are laid on a grid of their own diameter over
each face section's occupancy grid (:class:`~geostructure.rockmass.exposure.Exposure`), kept
where :data:`MIN_COVER` of the disc is exposed; the radius is the largest of
:data:`RADIUS_CELLS` (in the occupancy grid's cells, so in point spacings) that lays at least
:data:`MIN_WINDOWS` windows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Radii tried, largest first, in occupancy-grid cells (each some point spacings across).
RADIUS_CELLS = (64, 48, 32, 24, 16, 12, 8)
#: Windows a radius must lay to be taken.
MIN_WINDOWS = 3
#: The share of a window's disc that must be exposed: the occupancy grid has pinholes.
MIN_COVER = 0.9


@dataclass
class WindowEstimate:
    """What circular windows of ``radius`` (m) read of one set's traces: ``windows`` laid,
    ``crossings`` (n) of their rims and trace ``ends`` (m) inside, and the estimates from
    them (NaN where a count is 0): ``mean_length`` (m), ``p21`` (1/m), ``p20`` (1/m^2)."""

    radius: float
    windows: int
    crossings: int
    ends: int

    @property
    def mean_length(self) -> float:
        return float(np.pi * self.radius / 2.0 * self.crossings / self.ends) if self.ends else float("nan")

    @property
    def p21(self) -> float:
        return float(self.crossings / (4.0 * self.radius * self.windows)) if self.windows else float("nan")

    @property
    def p20(self) -> float:
        return float(self.ends / (2.0 * np.pi * self.radius**2 * self.windows)) if self.windows else float("nan")


def window_centres(occupied: np.ndarray, radius_cells: int) -> np.ndarray:
    """The centres (K, 2), in grid cells, of windows of ``radius_cells`` laid on a grid of
    their diameter over ``occupied`` (a 2D bool grid), kept where :data:`MIN_COVER` of the
    disc is occupied.

    Examples
    --------
    >>> window_centres(np.ones((40, 20), dtype=bool), 5).tolist()
    [[5.0, 5.0], [5.0, 15.0], [15.0, 5.0], [15.0, 15.0], [25.0, 5.0], [25.0, 15.0], [35.0, 5.0], [35.0, 15.0]]
    """
    r = int(radius_cells)
    shape = np.asarray(occupied.shape)
    if np.any(shape < 2 * r):
        return np.zeros((0, 2))
    offsets = np.mgrid[-r : r + 1, -r : r + 1].reshape(2, -1).T
    disc = offsets[np.hypot(offsets[:, 0], offsets[:, 1]) <= r]
    centres = np.stack(np.meshgrid(np.arange(r, shape[0] - r + 1, 2 * r), np.arange(r, shape[1] - r + 1, 2 * r),
                                   indexing="ij"), axis=-1).reshape(-1, 2)  # fmt: skip
    cells = centres[:, None, :] + disc[None, :, :]
    inside = np.all((cells >= 0) & (cells < shape), axis=2)
    covered = np.zeros(cells.shape[:2], dtype=bool)
    covered[inside] = occupied[cells[inside][:, 0], cells[inside][:, 1]]
    return centres[covered.mean(axis=1) >= MIN_COVER].astype(np.float64)


def count_in_windows(polylines_uv: list, centres: np.ndarray, radius: float) -> tuple[int, int]:
    """(n, m): the rim crossings and the trace ends inside windows of ``radius`` at
    ``centres`` (K, 2), of traces given as polylines on the face (each (V, 2), in the same
    coordinates). A trace crosses a rim where some of its vertices lie inside the circle and
    some outside (its vertices lie a spacing apart, so a trace cannot jump a rim).

    Examples
    --------
    >>> through = np.c_[np.linspace(-3, 3, 61), np.zeros(61)]  # crosses the rim twice, no end inside
    >>> half = np.c_[np.linspace(0, 3, 31), np.full(31, 0.5)]  # one end inside, one crossing
    >>> count_in_windows([through, half], np.array([[0.0, 0.0]]), 1.0)
    (3, 1)
    """
    n = m = 0
    for line in polylines_uv:
        line = np.asarray(line, dtype=np.float64)
        if len(line) < 2:
            continue
        inside = np.hypot(*(line[:, None, :] - centres[None, :, :]).transpose(2, 0, 1)) < radius  # (V, K)
        changes = np.count_nonzero(inside[1:] != inside[:-1], axis=0)
        n += int(changes.sum())
        m += int(inside[0].sum() + inside[-1].sum())
    return n, m


def window_estimate(polylines_uv: list, occupied: np.ndarray, lower, cell: float) -> WindowEstimate | None:
    """Circular windows on one face (its occupancy grid ``occupied``, ``lower`` corner and
    ``cell`` size, in the polylines' coordinates): the largest radius of :data:`RADIUS_CELLS`
    that lays :data:`MIN_WINDOWS` windows, and what they read; None when none does."""
    for radius_cells in RADIUS_CELLS:
        grid = window_centres(occupied, radius_cells)
        if len(grid) >= MIN_WINDOWS:
            radius = radius_cells * cell
            centres = np.asarray(lower, dtype=np.float64) + (grid + 0.5) * cell
            n, m = count_in_windows(polylines_uv, centres, radius)
            return WindowEstimate(radius, len(grid), n, m)
    return None


def set_window_estimates(traces, exposures, n_sets: int, metres: float = 1.0) -> list:
    """Per set, the circular windows' estimate (:class:`WindowEstimate`, or None) of the face's
    fracture traces (:class:`~geostructure.detect.traces.Traces`, in the cloud's unit, which
    ``metres`` turns into the exposures' metres), pooled over the face's sections: each
    section lays its own windows, and only the vertices near its plane (within a radius) count."""
    estimates: list = [None] * n_sets
    if traces is None or not len(traces) or not exposures:
        return estimates
    polylines = [np.asarray(p, dtype=np.float64) * metres for p in traces.polylines()]
    for s in range(n_sets):
        mine = [p for p, k in zip(polylines, traces.set) if k == s]
        total = None
        for face in exposures:
            # A section's windows on its own plane; another section's traces stay off it.
            near = [face.project(p) for p in mine]
            far = [np.abs((p - face.origin) @ face.normal) for p in mine]
            found = window_estimate([uv for uv, d in zip(near, far) if np.median(d) < 16 * face.cell],
                                    face.occupied, face.lower, face.cell)  # fmt: skip
            if found is None:
                continue
            if total is None:
                total = found
            elif np.isclose(found.radius, total.radius):
                total = WindowEstimate(total.radius, total.windows + found.windows, total.crossings + found.crossings,
                                       total.ends + found.ends)  # fmt: skip
        estimates[s] = total
    return estimates


#: Scanlines for the traces' P10 lie this many occupancy cells apart (each a few spacings).
SCANLINE_STEP_CELLS = 8


def trace_direction(polylines_uv: list) -> np.ndarray | None:
    """The traces' mean direction on the face (unit, 2D): the axial mean of their chords,
    weighted by length; None without a trace."""
    chords = np.array([np.asarray(p)[-1] - np.asarray(p)[0] for p in polylines_uv if len(p) >= 2]).reshape(-1, 2)
    if not len(chords):
        return None
    values, vectors = np.linalg.eigh(chords.T @ chords)
    return vectors[:, -1]


def trace_p10(polylines_uv: list, occupied: np.ndarray, lower, cell: float, along=None) -> tuple[float, int, float]:
    """Linear intensity P10 (crossings per metre) of traces on scanlines laid across them:
    lines perpendicular to the traces' mean direction (``along``, or :func:`trace_direction`),
    :data:`SCANLINE_STEP_CELLS` apart over the face's occupancy grid, counted only where the
    face is exposed. Returns (P10, crossings, exposed scanline length); NaN without any.

    Examples
    --------
    >>> rows = [np.c_[np.full(11, x), np.linspace(0.0, 10.0, 11)] for x in np.arange(0.5, 10.0, 1.0)]  # 10 vertical traces 1 m apart
    >>> p10, crossings, length = trace_p10(rows, np.ones((100, 100), dtype=bool), np.zeros(2), 0.1)
    >>> round(p10, 1), crossings
    (1.0, 120)
    """
    direction = trace_direction(polylines_uv) if along is None else np.asarray(along, dtype=np.float64)
    if direction is None:
        return float("nan"), 0, 0.0
    lower = np.asarray(lower, dtype=np.float64)
    shape = np.asarray(occupied.shape)
    across = np.array([-direction[1], direction[0]])  # the scanlines' direction
    corners = lower + np.array([[0, 0], [shape[0], 0], [0, shape[1]], [shape[0], shape[1]]]) * cell
    offsets = (corners - lower) @ direction
    reach = (corners - lower) @ across
    step = cell / 2.0
    samples = np.arange(reach.min(), reach.max() + step, step)
    lines = [np.asarray(t, dtype=np.float64) for t in polylines_uv if len(t) >= 2]
    vertices = np.vstack(lines) if lines else np.zeros((0, 2))
    # Segments between a trace's consecutive vertices, none across two traces.
    ends = np.cumsum([len(t) for t in lines])
    first = np.ones(len(vertices), dtype=bool)
    first[np.r_[0, ends[:-1]]] = False
    a, b = vertices[:-1][first[1:]], vertices[1:][first[1:]]
    along_a, along_b = (a - lower) @ direction, (b - lower) @ direction
    crossings, length = 0, 0.0
    for offset in np.arange(offsets.min() + SCANLINE_STEP_CELLS * cell / 2, offsets.max(), SCANLINE_STEP_CELLS * cell):
        line = lower + offset * direction + samples[:, None] * across
        ij = np.floor((line - lower) / cell).astype(np.int64)
        inside = np.all((ij >= 0) & (ij < shape), axis=1)
        exposed = np.zeros(len(line), dtype=bool)
        exposed[inside] = occupied[ij[inside, 0], ij[inside, 1]]
        length += float(exposed.sum() * step)
        side_a, side_b = along_a - offset, along_b - offset
        k = np.flatnonzero((side_a < 0) != (side_b < 0))
        if not len(k):
            continue
        t = side_a[k] / (side_a[k] - side_b[k])
        at = a[k] + t[:, None] * (b[k] - a[k])
        cij = np.floor((at - lower) / cell).astype(np.int64)
        ok = np.all((cij >= 0) & (cij < shape), axis=1)
        crossings += int(occupied[cij[ok, 0], cij[ok, 1]].sum())
    return (crossings / length if length > 0 else float("nan")), crossings, length


def set_trace_p10(traces, exposures, n_sets: int, metres: float = 1.0) -> list[tuple[float, float]]:
    """Per set, (P10 per metre, exposed scanline length in metres) of the face's fracture
    traces (:func:`trace_p10`), pooled over the face's sections as
    :func:`set_window_estimates` pools its windows; (NaN, 0) without traces."""
    out = [(float("nan"), 0.0)] * n_sets
    if traces is None or not len(traces) or not exposures:
        return out
    polylines = [np.asarray(p, dtype=np.float64) * metres for p in traces.polylines()]
    for s in range(n_sets):
        mine = [p for p, k in zip(polylines, traces.set) if k == s]
        if not mine:
            continue
        crossings, length = 0, 0.0
        for face in exposures:
            near = [face.project(p) for p, d in ((p, np.abs((p - face.origin) @ face.normal)) for p in mine)
                    if np.median(d) < 16 * face.cell]  # fmt: skip
            if near:
                _, n, exposed = trace_p10(near, face.occupied, face.lower, face.cell)
                crossings, length = crossings + n, length + exposed
        out[s] = (crossings / length if length > 0 else float("nan"), length)
    return out
