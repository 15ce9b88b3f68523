"""A face that turns, cut into sections: the straight stretches of its trace on the map.

A road cut that bends or a quarry's corner is several faces, and a slope stability analysis
tests each joint against the face it daylights in, not against their mean plane (two
12 x 6 m faces dipping 75 degrees and turned 90 degrees from each other fit a plane dipping
8). Seen from above, such a face is a band that turns. :func:`face_sections` cuts the band
where it turns, at the break that leaves the two straightest sides (the least squares of
their points about one line each), while the sides turn from each other by
:data:`~geostructure.rockmass.exposure.BENT_FACE` or more, and again inside each side; :meth:`FaceSections.of`
tells which section a point (a plane's centroid) lies in. A face that does not turn
(:func:`~geostructure.rockmass.exposure.face_bend` under :data:`~geostructure.rockmass.exposure.BENT_FACE`) is one section, so a flat
face's results are those of its one mean face.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from geostructure.core.sampling import order_free_sample
from geostructure.rockmass.exposure import (
    BENT_FACE,
    CELL_POINTS,
    Exposure,
    Persistence,
    exposure,
    face_bend,
    mean_face,
    plan_axes,
    plane_persistence,
    trace_turn,
)

#: A side of a cut must be at least this many times longer than wide on the map (the ratio of
#: its spreads along and across its line): shorter, its line turns with the joints' steps
#: (a face dipping 75 degrees and 6 m high is a band 1.6 m wide on the map).
ELONGATED = 2.0
#: Points farther from a side's line than this many times the median are strays (the line is
#: fitted again without them). A band of even width has its median at a quarter of the width:
#: 2.5 medians keep all of it.
STRAY = 2.5
#: The map grid that tells the face's band from stray points (:func:`_dense`): cells across
#: the longest side, and the share of the median point's cell a cell must hold.
MAP_CELLS = 150
SPARSE = 0.25
#: A folded face's walls are told apart by local planes on map blocks this many across its
#: longest side, whose normals' azimuths part by this many degrees (:func:`_by_facing`).
FACING_BLOCKS = 8
FACING_GAP = 45.0
#: Cuts are tried between these shares of the points along the trace: a side needs enough
#: of the face to have a direction.
CUT_RANGE = (0.1, 0.9)


@dataclass(frozen=True)
class FaceSections:
    """The straight stretches of a face's trace on the map, in order along it.

    ``axes`` (2, 3) are the map's east and north in the points' frame; per section,
    ``centres`` (S, 2) and ``directions`` (S, 2) give its line on the map and ``extents``
    (S, 2) where along that line its points lie (from, to, about the centre). ``bend`` is how
    far the whole face turns (:func:`~geostructure.rockmass.exposure.face_bend`).
    """

    axes: np.ndarray
    centres: np.ndarray
    directions: np.ndarray
    extents: np.ndarray
    bend: float = 0.0

    def __len__(self) -> int:
        return len(self.centres)

    @property
    def lengths(self) -> np.ndarray:
        """Each section's length along its line on the map (in the points' unit)."""
        return self.extents[:, 1] - self.extents[:, 0]

    def turns(self) -> np.ndarray:
        """The degrees each section's line turns from the one before it (S - 1)."""
        cosine = np.sum(self.directions[1:] * self.directions[:-1], axis=1)
        return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))

    def of(self, points) -> np.ndarray:
        """Which section each point lies in: the nearest stretch on the map (a point beyond
        a section's end is measured from that end)."""
        plan = np.asarray(points, dtype=np.float64).reshape(-1, 3) @ self.axes.T
        if len(self) == 1:
            return np.zeros(len(plan), dtype=np.int64)
        distance = np.empty((len(plan), len(self)))
        for k, (centre, direction, (lo, hi)) in enumerate(zip(self.centres, self.directions, self.extents)):
            offset = plan - centre
            along = np.clip(offset @ direction, lo, hi)
            distance[:, k] = np.sum((offset - along[:, None] * direction) ** 2, axis=1)
        return np.argmin(distance, axis=1)


def face_sections(points, up=(0.0, 0.0, 1.0), seed: int = 0, bend: float | None = None) -> FaceSections:
    """Cut a face where its trace on the map turns (see the module): one section for a face
    that does not turn (or a terrain, which has no trace), two for a corner, two or more
    along a curve. ``bend``: the face's :func:`~geostructure.rockmass.exposure.face_bend`, when measured already.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, v = rng.random((2, 40_000)) * [[24.0], [6.0]]
    >>> turn = np.radians(90.0) * (u > 12)  # a vertical cut turning a right angle half way along
    >>> x = np.where(u > 12, 12 + (u - 12) * np.cos(turn), u)
    >>> y = np.where(u > 12, (u - 12) * np.sin(turn), 0.0)
    >>> corner = np.column_stack([x, y, v])
    >>> sections = face_sections(corner)
    >>> len(sections), np.round(sections.turns()).tolist(), np.round(sections.lengths).tolist()
    (2, [90.0], [12.0, 12.0])
    >>> first, second = sections.of([[6.0, 0.0, 3.0], [12.0, 9.0, 1.0]])  # a point on each arm
    >>> bool(first != second)
    True
    >>> len(face_sections(corner[x < 12]))  # one arm alone does not turn
    1
    """
    points = np.asarray(points, dtype=np.float64)
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    axes = plan_axes(up)
    sample = points[order_free_sample(points, min(len(points), 60_000), seed + 3)]
    plan = sample @ axes.T
    if bend is None:
        bend = face_bend(sample, up, seed)
    stretches = _stretches(plan[_dense(plan)], turns=True) if bend >= BENT_FACE else [plan]
    if len(stretches) == 1 and bend >= 180.0:  # a bay deeper than wide: cut by where its walls face
        stretches = _by_facing(sample, plan, up) or stretches
    # Numbered from left to right as one faces the rock: along the mean face's strike
    # (right-hand rule), the map's normal turned a right angle.
    normal = mean_face(sample, seed)[1][2]
    across = axes @ (normal if normal @ up >= 0 else -normal)
    strike = np.array([-across[1], across[0]])
    lines = [_line(part) for part in stretches]
    order = np.argsort([centre @ strike for centre, _ in lines], kind="stable")
    stretches, lines = _merged([stretches[k] for k in order], [lines[k] for k in order])
    whole = lines[-1][0] - lines[0][0] if len(lines) > 1 else strike
    directions = np.array([d if d @ whole >= 0 else -d for _, d in lines])  # all in order along the trace
    centres = np.array([c for c, _ in lines])
    extents = np.array([_extent(part, c, d) for part, c, d in zip(stretches, centres, directions)])
    return FaceSections(axes, centres, directions, extents, float(bend))


def section_exposures(points, face: Exposure, up=(0.0, 0.0, 1.0), seed: int = 0):
    """The exposures of a face's sections (:func:`face_sections` of the points that make
    ``face``), each its own mean face and occupancy, with its own ground and clutter left out
    as ``face`` leaves them: (the sections, their exposures, the section of every point). A
    face that does not turn is one section, ``[face]`` and None."""
    points = np.asarray(points, dtype=np.float64)
    on_face = points if face.members is None else points[face.members]
    sections = face_sections(on_face, up, seed, bend=face.bend)
    if len(sections) == 1:
        return sections, [face], None
    point_section = sections.of(points)
    spacing = face.cell / np.sqrt(CELL_POINTS)  # the spacing the face's cells were sized from
    exposures = []
    for k in range(len(sections)):
        mine = point_section == k  # the other sections are not this one's clutter
        members = None if face.members is None else face.members[mine]
        part = exposure(points[mine], up, seed=seed, spacing=spacing, members=members)
        # Its members, as every exposure's, index all the points it is measured with.
        full = np.zeros(len(points), dtype=bool)
        full[np.flatnonzero(mine)[members if members is not None else slice(None)]] = True
        exposures.append(replace(part, members=full))
    return sections, exposures, point_section


def face_sections_of(exposures, point_section, labels, n_planes: int) -> np.ndarray:
    """Each plane's section: the one most of its points lie in."""
    labels = np.asarray(labels)
    mine = labels >= 0
    counts = np.zeros((n_planes, len(exposures)), dtype=np.int64)
    np.add.at(counts, (labels[mine], point_section[mine]), 1)
    return counts.argmax(axis=1)


def sectioned_persistence(points, labels, normals, exposures, plane_section, up=(0.0, 0.0, 1.0)) -> Persistence:
    """Each plane's traces and censoring (:func:`~geostructure.rockmass.exposure.plane_persistence`) on the
    exposure of the section it lies in (``plane_section``, one per plane)."""
    labels = np.asarray(labels)
    if len(exposures) == 1:
        return plane_persistence(points, labels, normals, exposures[0], up)
    out: Persistence | None = None
    labelled = labels >= 0
    for k, face in enumerate(exposures):
        mine = plane_section == k
        own = np.full(len(labels), -1, dtype=labels.dtype)  # no plane to index when there is none
        own[labelled] = np.where(mine[labels[labelled]], labels[labelled], -1)
        part = plane_persistence(points, own, normals, face, up)
        if out is None:
            out = part
        else:
            for name in ("trace_strike", "trace_dip", "trace_face", "censored"):
                getattr(out, name)[mine] = getattr(part, name)[mine]
    assert out is not None, "a face has at least one section"
    return out


def _dense(plan: np.ndarray) -> np.ndarray:
    """The map points where the face is: in cells of a grid :data:`MAP_CELLS` across its
    longest side that hold at least :data:`SPARSE` of the median point's cell. Seen from
    above, the face is a dense band and an SfM cloud's strays are thin streaks off it,
    metres long, along the cameras' rays; a line fitted to a side turns after them."""
    low = plan.min(axis=0)
    cell = max(float(np.ptp(plan, axis=0).max()), 1e-9) / MAP_CELLS
    ij = np.floor((plan - low) / cell).astype(np.int64)
    _, cells, counts = np.unique(ij[:, 0] * (MAP_CELLS + 2) + ij[:, 1], return_inverse=True, return_counts=True)
    held = counts[cells.ravel()]
    return held >= SPARSE * np.median(held)


def _by_facing(sample, plan, up) -> list | None:
    """A folded face's points grouped by the way its walls face: local planes on map blocks
    :data:`FACING_BLOCKS` across the longest side, their normals' azimuths clustered where
    they part by :data:`FACING_GAP` degrees or more. None when they do not part, or a group
    holds under a tenth of the points. (Along its length, each third of a bay deeper than
    wide holds both its side walls, and the trace cut finds no turn.)"""
    low = plan.min(axis=0)
    size = max(float(np.ptp(plan, axis=0).max()), 1e-9) / FACING_BLOCKS
    ij = np.floor((plan - low) / size).astype(np.int64)
    codes, block = np.unique(ij[:, 0] * (FACING_BLOCKS + 2) + ij[:, 1], return_inverse=True)
    block = block.ravel()
    azimuth = np.full(len(codes), np.nan)
    for k in range(len(codes)):
        mine = sample[block == k]
        if len(mine) < 50:
            continue
        normal = np.linalg.svd(mine - mine.mean(axis=0), full_matrices=False)[2][2]
        across = plan_axes(up) @ (normal if normal @ up >= 0 else -normal)
        if np.hypot(*across) >= 0.3:  # a wall, not a ledge or the floor
            azimuth[k] = np.degrees(np.arctan2(across[0], across[1])) % 360.0
    seen = np.flatnonzero(np.isfinite(azimuth))
    if len(seen) < 2:
        return None
    order = seen[np.argsort(azimuth[seen])]
    gaps = np.diff(np.concatenate([azimuth[order], [azimuth[order][0] + 360.0]]))
    cuts = np.flatnonzero(gaps >= FACING_GAP)
    if len(cuts) < 2:  # the azimuths part in one place at most: one way of facing
        return None
    group = np.full(len(codes), -1)
    for g, (start, end) in enumerate(zip(cuts, np.roll(cuts, -1))):
        members = order[(np.arange(start + 1, end + 1 + (len(order) if end < start else 0))) % len(order)]
        group[members] = g
    point_group = group[block]
    parts = [plan[point_group == g] for g in range(len(cuts))]
    if min(len(part) for part in parts) < 0.1 * len(plan):
        return None
    return parts


def _merged(stretches: list, lines: list) -> tuple[list, list]:
    """Neighbouring stretches whose lines turn by less than half a face that turns, joined:
    a bay's back wall is cut in two when the first cut falls in its middle."""
    out, out_lines = [stretches[0]], [lines[0]]
    for part, line in zip(stretches[1:], lines[1:]):
        turn = np.degrees(np.arccos(np.clip(abs(float(out_lines[-1][1] @ line[1])), 0.0, 1.0)))
        if turn < BENT_FACE / 2.0:
            out[-1] = np.concatenate([out[-1], part])
            out_lines[-1] = _line(out[-1])
        else:
            out.append(part)
            out_lines.append(line)
    return out, out_lines


def _line(plan: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The centre and direction of the least-squares line through map points, fitted again
    without the points beyond :data:`STRAY` times the median distance from it: an SfM
    cloud's stray points streak metres off the face, and a side's line turned after them."""
    return _fit_line(plan[_core(plan)])


def _fit_line(plan: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    centre = plan.mean(axis=0)
    return centre, np.linalg.svd(plan - centre, full_matrices=False)[2][0]


def _core(plan: np.ndarray) -> np.ndarray:
    """The map points within :data:`STRAY` median distances of their least-squares line."""
    centre, direction = _fit_line(plan)
    offset = plan - centre
    across = np.abs(offset[:, 0] * direction[1] - offset[:, 1] * direction[0])
    return across <= STRAY * np.median(across)


def _extent(plan, centre, direction) -> tuple[float, float]:
    along = (plan - centre) @ direction
    return float(along.min()), float(along.max())


def _stretches(plan: np.ndarray, turns: bool = False) -> list[np.ndarray]:
    """Map points cut into straight stretches, in order along their line. A stretch that
    turns (``turns``, or its :func:`~geostructure.rockmass.exposure.trace_turn` :data:`~geostructure.rockmass.exposure.BENT_FACE` or
    more) is cut at its best cut (:func:`_best_cut`) when the lines of the two sides turn
    by half that or more (a bend, not the steps of a straight face), and each side is cut
    again: a curve becomes sections that turn by less than a face that turns."""
    centre, direction = _line(plan)
    ordered = plan[np.argsort((plan - centre) @ direction, kind="stable")]
    cut = _best_cut(ordered)
    if cut is None or not (turns or trace_turn(ordered) >= BENT_FACE):
        return [ordered]
    first, last = ordered[:cut], ordered[cut:]
    a, b = _line(first)[1], _line(last)[1]
    turn = np.degrees(np.arccos(np.clip(abs(float(a @ b)), 0.0, 1.0)))
    if turn < BENT_FACE / 2.0 or not (_elongated(first) and _elongated(last)):
        return [ordered]
    return _stretches(first) + _stretches(last)


def _elongated(plan: np.ndarray) -> bool:
    core = plan[_core(plan)]
    spread = np.linalg.svd(core - core.mean(axis=0), compute_uv=False)
    return bool(spread[0] >= ELONGATED * spread[1])


def _best_cut(ordered: np.ndarray) -> int | None:
    """The index that cuts map points (ordered along their line) into the two sides with the
    least sum of squared distances from their own lines, from running sums (every cut at
    once); None for too few points."""
    n = len(ordered)
    lo, hi = int(CUT_RANGE[0] * n), int(CUT_RANGE[1] * n)
    if n < 60 or hi <= lo:
        return None
    p = ordered - ordered.mean(axis=0)
    sums = np.cumsum(np.column_stack([np.ones(n), p, p[:, 0] ** 2, p[:, 0] * p[:, 1], p[:, 1] ** 2]), axis=0)
    total = sums[-1]
    cuts = np.arange(lo, hi)
    before, after = sums[cuts - 1], total - sums[cuts - 1]
    return int(cuts[np.argmin(_line_residual(before) + _line_residual(after))])


def _line_residual(sums: np.ndarray) -> np.ndarray:
    """The sum of squared distances of points from their least-squares line, from their
    running sums (count, x, y, xx, xy, yy): the smaller eigenvalue of their scatter."""
    n, x, y, xx, xy, yy = sums.T
    a, b, c = xx - x * x / n, xy - x * y / n, yy - y * y / n
    return np.maximum((a + c) / 2.0 - np.sqrt(((a - c) / 2.0) ** 2 + b * b), 0.0)
