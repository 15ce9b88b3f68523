"""Fracture traces: the lines a geologist maps by hand where fractures cut the rock's surface.

Three kinds, in one table (:class:`Traces`):

- **plane traces**: a discontinuity the planes found (a facet of a joint) cuts the surface
  along the line its plane shares with the surface around it; its trace is that line across
  the plane's points (:func:`plane_traces`). A plane lying along the surface (within
  :data:`MIN_CUT_DEG`) has no trace line: it *is* the surface (Compass's "surface effect").
- **dark lines**: most fractures on real rock show no face, only a trace, darker than the
  rock either side (an open crack, its shadow, its weathering). Where the cloud has colour,
  each patch of the face is laid flat and its dark lines drawn (:mod:`.tracepatches`,
  :mod:`.traceimage`).
- **valleys**: the same drawn on each point's depth below the surface around it, toward the
  rock (:mod:`.tracechannels`): a crack too faint to be dark, but cut into the rock. A
  valley along a dark line is that line again.

An image line over a plane's own points, along its trace, is that plane's trace already and
is dropped. Every length is in point spacings.

Each trace has its chord and length, the set whose mean plane holds its direction
(:func:`trace_sets`) and, where it bends out of its chord enough to define one, its own plane
(:func:`trace_planes`; DICE's coplanarity and colinearity, and not the surface itself).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.threads import tree_query
from geostructure.detect.tracechannels import DARK_LINE, VALLEY
from geostructure.detect.tracepatches import MIN_CHORD, VERTEX_STEP, dark_line_traces, nearest_spacing, patch_tiles

#: A plane cuts the surface along a trace only when their normals are this far apart (degrees).
MIN_CUT_DEG = 20.0
#: A trace belongs to the set whose mean plane holds its direction within this (degrees).
SET_ANGLE_DEG = 15.0
#: Neighbours giving the surface's normal around a plane or a trace: a disc about ten
#: spacings across, wider than most facets, so that a facet's own points do not make the
#: surface (with 100, most facets read as the surface itself and lost their trace).
SURFACE_NEIGHBOURS = 300

PLANE = "plane"
#: The kinds drawn from a patch's image, not from a plane.
IMAGE_LINES = (DARK_LINE, VALLEY)


@dataclass
class Traces:
    """Traces as polylines: ``vertices`` (V, 3) in the cloud's local coordinates, trace ``k``
    from ``start[k]`` to ``start[k + 1]``; per trace its ``source`` (:data:`PLANE` or
    :data:`DARK_LINE`), the plane's ``region_id`` (-1 for a dark line), its ``set`` (-1: none)
    and its fitted plane's unit ``normal`` (NaN where none was fitted); ``censored_ends``,
    how many of its two ends lie at the exposure's edge, where it may run on out of sight
    (:func:`~geostructure.rockmass.tracemaps.censored_ends`; 0 until the rock mass reads it)."""

    vertices: np.ndarray
    start: np.ndarray
    source: np.ndarray
    region_id: np.ndarray
    set: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    normal: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    n_points: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    contrast: np.ndarray = field(default_factory=lambda: np.zeros(0))
    censored_ends: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __post_init__(self):
        n = len(self.start) - 1
        if len(self.set) != n:
            self.set = np.full(n, -1, dtype=np.int64)
        if len(self.normal) != n:
            self.normal = np.full((n, 3), np.nan)
        if len(self.n_points) != n:
            self.n_points = np.zeros(n, dtype=np.int64)
        if len(self.contrast) != n:
            self.contrast = np.full(n, np.nan)
        if len(self.censored_ends) != n:
            self.censored_ends = np.zeros(n, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.start) - 1

    @classmethod
    def from_polylines(cls, polylines: list, source: list, region_id: list) -> Traces:
        start = np.concatenate([[0], np.cumsum([len(p) for p in polylines])]).astype(np.int64)
        vertices = np.vstack(polylines) if polylines else np.zeros((0, 3))
        return cls(vertices, start, np.asarray(source, dtype=object), np.asarray(region_id, dtype=np.int64))

    def polylines(self) -> list[np.ndarray]:
        return [self.vertices[a:b] for a, b in zip(self.start[:-1], self.start[1:])]

    @property
    def chord(self) -> np.ndarray:
        """Each trace's chord (the straight line between its ends), in the cloud's unit."""
        ends = self.vertices[self.start[1:] - 1] - self.vertices[self.start[:-1]] if len(self) else np.zeros((0, 3))
        return np.linalg.norm(ends, axis=1)

    @property
    def length(self) -> np.ndarray:
        """Each trace's length along its polyline, in the cloud's unit."""
        steps = np.linalg.norm(np.diff(self.vertices, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(steps)])
        return cum[self.start[1:] - 1] - cum[self.start[:-1]] if len(self) else np.zeros(0)

    @property
    def direction(self) -> np.ndarray:
        """Each trace's unit chord direction."""
        ends = self.vertices[self.start[1:] - 1] - self.vertices[self.start[:-1]]
        return ends / np.maximum(np.linalg.norm(ends, axis=1, keepdims=True), 1e-300)

    def subset(self, keep) -> Traces:
        keep = np.flatnonzero(np.asarray(keep)) if np.asarray(keep).dtype == bool else np.asarray(keep)
        lines = self.polylines()
        out = Traces.from_polylines([lines[k] for k in keep], list(self.source[keep]), list(self.region_id[keep]))
        out.set, out.normal, out.n_points = self.set[keep], self.normal[keep], self.n_points[keep]
        out.contrast, out.censored_ends = self.contrast[keep], self.censored_ends[keep]
        return out


def surface_normals(points: np.ndarray, tree: cKDTree, at: np.ndarray, k: int = SURFACE_NEIGHBOURS) -> np.ndarray:
    """The surface's unit normal around each point of ``at``: the least axis of its ``k``
    nearest points of the cloud."""
    if not len(at):
        return np.zeros((0, 3))
    _, idx = tree_query(tree, at, min(k, len(points)))
    near = points[np.atleast_2d(idx)]
    near = near - near.mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", near, near))
    return vectors[:, :, 0]


def plane_traces(points, tree, labels, plane_normals, tested, spacing: float) -> list:
    """Each tested plane's trace (see the module): ``(polyline, region index)`` pairs."""
    out = []
    order = np.argsort(labels, kind="stable")
    sorted_labels = labels[order]
    planes = np.flatnonzero(tested)
    bounds = np.searchsorted(sorted_labels, np.column_stack([planes, planes + 1]))
    big = bounds[:, 1] - bounds[:, 0] >= 3  # three points or more make a centre worth a trace
    planes, bounds = planes[big], bounds[big]
    centres = np.array([points[order[a:b]].mean(axis=0) for a, b in bounds]).reshape(-1, 3)
    surfaces = surface_normals(points, tree, centres)  # one query for every plane's centre
    for plane, (a, b), centre, surface in zip(planes, bounds, centres, surfaces):
        mine = points[order[a:b]]
        line = np.cross(plane_normals[plane], surface)
        if np.linalg.norm(line) < np.sin(np.radians(MIN_CUT_DEG)):
            continue  # the plane lies along the surface: no trace line
        line /= np.linalg.norm(line)
        along = (mine - centre) @ line
        low, high = np.percentile(along, [2.0, 98.0])
        if high - low < MIN_CHORD * spacing:
            continue
        steps = np.linspace(low, high, max(2, int(np.ceil((high - low) / (VERTEX_STEP * spacing))) + 1))
        out.append((centre + steps[:, None] * line, int(plane)))
    return out


def trace_sets(direction: np.ndarray, set_normals: np.ndarray) -> np.ndarray:
    """The set whose mean plane holds each trace direction within :data:`SET_ANGLE_DEG`
    (the nearest such), -1 for none.

    Examples
    --------
    >>> trace_sets(np.array([[1.0, 0, 0], [0, 0, 1.0]]), np.array([[0, 0, 1.0], [0, 1.0, 0]])).tolist()
    [0, 1]
    """
    if not len(set_normals) or not len(direction):
        return np.full(len(direction), -1, dtype=np.int64)
    out_of_plane = np.degrees(np.arcsin(np.clip(np.abs(direction @ np.asarray(set_normals).T), 0.0, 1.0)))
    nearest = np.argmin(out_of_plane, axis=1)
    return np.where(out_of_plane[np.arange(len(direction)), nearest] <= SET_ANGLE_DEG, nearest, -1)


def trace_planes(traces: Traces, surface: np.ndarray, spacing: float) -> np.ndarray:
    """A plane fitted to each trace that bends enough to define one (NaN otherwise): its
    vertices leave their chord's line by two spacings or more (not colinear), lie within half a
    spacing of one plane (coplanar), and that plane is not the surface (its normal at least
    :data:`MIN_CUT_DEG` from the surface's, ``surface`` per trace)."""
    out = np.full((len(traces), 3), np.nan)
    for k, line in enumerate(traces.polylines()):
        if len(line) < 4:
            continue
        centred = line - line.mean(axis=0)
        values, vectors = np.linalg.eigh(centred.T @ centred / len(line))
        spread = np.sqrt(np.maximum(values, 0.0))  # ascending: out of plane, across, along
        if spread[1] < 2.0 * spacing or spread[0] > 0.5 * spacing:
            continue
        normal = vectors[:, 0]
        if abs(normal @ surface[k]) > np.cos(np.radians(MIN_CUT_DEG)):
            continue
        out[k] = normal
    return out


def find_traces(
    points: np.ndarray, spacing: float | None = None, *, grey=None, labels=None, plane_normals=None, tested=None,
    plane_sets=None, set_normals=None, tree: cKDTree | None = None,
) -> Traces:  # fmt: skip
    """Every trace of a face (see the module).

    Parameters
    ----------
    points : (N, 3) array
        The face's points (the ground and the clutter left out).
    spacing : float, optional
        The points' spacing; their median distance to their nearest neighbour when not given
        (the scale a trace one or two points wide shows at).
    grey : (N,) array, optional
        Their brightness; without it, no dark lines.
    labels : (N,) int array, optional
        Each point's plane (-1: none), with ``plane_normals`` (P, 3) and which planes are
        discontinuities (``tested``, (P,) bool): their traces.
    plane_sets : (P,) int array, optional
        Each plane's set (-1: none): its trace's.
    set_normals : (S, 3) array, optional
        The sets' mean normals, for the dark lines' sets.
    tree : cKDTree, optional
        The points' tree, when the caller holds one.

    Returns
    -------
    Traces

    Examples
    --------
    A face with one dark line across it:

    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0, 3, (20000, 2))
    >>> points = np.column_stack([xy, 0.002 * rng.normal(size=len(xy))])
    >>> grey = np.where(np.abs(xy[:, 1] - 1.2 - 0.2 * xy[:, 0]) < 0.012, 0.2, 0.6) + 0.02 * rng.normal(size=len(xy))
    >>> traces = find_traces(points, grey=grey)
    >>> longest = int(np.argmax(traces.chord))
    >>> bool(traces.chord[longest] > 1.0), round(float(abs(traces.direction[longest] @ [0.98, 0.196, 0])), 2)
    (True, 1.0)
    """
    points = np.asarray(points, dtype=np.float64)
    tree = cKDTree(points) if tree is None else tree
    dark = grey is not None and len(points) >= 50
    if dark:  # one neighbour query gives the spacing and what the dark lines read
        spacing, tiles, nearest = patch_tiles(points, tree, spacing)
    elif spacing is None:
        spacing = nearest_spacing(points, tree)
    lines, source, region, contrast = [], [], [], []
    if labels is not None and plane_normals is not None and len(plane_normals):
        tested = np.ones(len(plane_normals), dtype=bool) if tested is None else np.asarray(tested, dtype=bool)
        for line, plane in plane_traces(points, tree, np.asarray(labels), np.asarray(plane_normals), tested, spacing):
            lines.append(line)
            source.append(PLANE)
            region.append(plane)
            contrast.append(np.nan)
    if dark:
        own = _plane_trace_lookup(points, labels, lines, region) if lines else None
        for line, strength, kind in dark_line_traces(
            points, np.asarray(grey, dtype=np.float64), spacing, tree, tiles, nearest
        ):
            if own is not None and own(line, spacing):
                continue
            lines.append(line)
            source.append(kind)
            region.append(-1)
            contrast.append(strength)
    traces = Traces.from_polylines(lines, source, region)
    traces.contrast = np.asarray(contrast, dtype=np.float64)
    if not len(traces):
        return traces
    sets = np.full(len(traces), -1, dtype=np.int64)
    if set_normals is not None and len(set_normals):
        sets = trace_sets(traces.direction, np.asarray(set_normals, dtype=np.float64))
    if plane_sets is not None:
        from_plane = traces.region_id >= 0
        sets[from_plane] = np.asarray(plane_sets)[traces.region_id[from_plane]]
    traces.set = sets
    middles = traces.vertices[(traces.start[:-1] + traces.start[1:] - 1) // 2]
    traces.normal = trace_planes(traces, surface_normals(points, tree, middles), spacing)
    if plane_normals is not None:  # a plane's trace has its plane
        from_plane = traces.region_id >= 0
        traces.normal[from_plane] = np.asarray(plane_normals)[traces.region_id[from_plane]]
    if set_normals is not None and len(set_normals):
        # A fracture's trace lies in its plane: a dark line in no set's plane that defines
        # no plane of its own is the trace of nothing the face shows (on the Lastoni SW half
        # none of 23 such lines traced a mapped fracture).
        orphan = np.isin(traces.source, IMAGE_LINES) & (traces.set < 0) & ~np.isfinite(traces.normal[:, 0])
        if orphan.any():
            traces = traces.subset(~orphan)
    traces.n_points = points_along(traces, tree, spacing)
    return traces


def points_along(traces: Traces, tree: cKDTree, spacing: float) -> np.ndarray:
    """The cloud's points within a spacing of each trace (sampled every half spacing)."""
    out = np.zeros(len(traces), dtype=np.int64)
    for k, line in enumerate(traces.polylines()):
        steps = np.linalg.norm(np.diff(line, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(steps)])
        at = np.linspace(0.0, cum[-1], max(2, int(cum[-1] / (0.5 * spacing)) + 1))
        samples = np.column_stack([np.interp(at, cum, line[:, a]) for a in range(3)])
        near = tree.query_ball_point(samples, spacing)
        out[k] = len(set().union(*near)) if len(near) else 0
    return out


def _plane_trace_lookup(points, labels, lines, region):
    """A test of whether a dark line runs over a plane's own points along that plane's trace
    (within :data:`SET_ANGLE_DEG`): that plane's trace already."""
    on_plane = np.flatnonzero(np.asarray(labels) >= 0)
    if not len(on_plane):
        return None
    tree = cKDTree(points[on_plane])
    trace_of = {plane: line[-1] - line[0] for line, plane in zip(lines, region)}

    def covered(line, spacing):
        distance, idx = tree.query(line)
        near = distance <= 1.5 * spacing
        if near.mean() < 0.6:
            return False
        planes, counts = np.unique(np.asarray(labels)[on_plane[idx[near]]], return_counts=True)
        plane = int(planes[np.argmax(counts)])
        if plane not in trace_of:
            return False
        a, b = line[-1] - line[0], trace_of[plane]
        cosine = abs(a @ b) / max(np.linalg.norm(a) * np.linalg.norm(b), 1e-300)
        return bool(cosine >= np.cos(np.radians(SET_ANGLE_DEG)))

    return covered
