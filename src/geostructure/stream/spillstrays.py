"""Stray points left out of a spilled survey, as :func:`~geostructure.core.strays.stray_points`
leaves them out of a cloud in memory: a point with at most
:data:`~geostructure.core.strays.MIN_NEIGHBOURS` others within
:data:`~geostructure.core.strays.STRAY_RADIUS_SPACINGS` point spacings. One point 100 m below a
2.2 m cut of rock, streamed, gave no plane where the cut alone gives seven: the streamed
run's grids and voxel edge are read from the survey's extent.

The survey's bounds say at once whether any point can be one: only a point more than the
radius beyond the box holding all but the tails of a sample can. Without one, nothing is
read again and the spill is untouched; with one, the points outside that box are gathered
in one pass, the strays told among them by their neighbours, and the spill's files written
again without them.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.density import point_spacing
from geostructure.core.strays import MIN_NEIGHBOURS, STRAY_RADIUS_SPACINGS, TAIL_SHARE
from geostructure.errors import GeoStructureWarning

#: Rows of the spill read for the tails' box: a stride through the whole survey.
BOX_SAMPLE = 200_000
#: The spill's per-point files: name, bytes a point, dtype, columns.
POINT_FILES = (("points.f8", "<f8", 3), ("normals.f8", "<f8", 3), ("vegetation.u1", "u1", 1), ("grey.f4", "<f4", 1))


def spill_points(spill) -> np.ndarray:
    """The spill's absolute coordinates, memory-mapped (N, 3)."""
    return np.memmap(spill.folder / "points.f8", dtype="<f8", mode="r", shape=(spill.n_points, 3))


def without_spill_strays(spill, rows: int) -> None:
    """Leave the stray points out of ``spill`` (in place): its files written again without
    them, its count and bounds updated, ``left_out["strays"]`` counted and a warning given.
    ``rows``: the points read at a time; the spacing is read on the first ``rows`` points.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "cut.xyz"
    >>> g = np.mgrid[0:5:0.05, 0:5:0.05].reshape(2, -1).T
    >>> np.savetxt(path, np.vstack([np.c_[g, 0.01 * g[:, 0]], [[2.0, 2.0, -100.0]]]))
    >>> from geostructure.stream import spill_inputs
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     spill = spill_inputs([path], rows=4_000)
    >>> spill.n_points, spill.lower.round(2).tolist(), spill.left_out
    (10000, [0.0, 0.0, 0.0], {'strays': 1})
    >>> spill.close()
    """
    n = spill.n_points
    if n < 10:
        return
    points = spill_points(spill)
    first = np.asarray(points[: min(n, max(rows, 1000))])
    spacing = point_spacing(first - column_min(first))
    if not spacing > 0:
        return
    radius = STRAY_RADIUS_SPACINGS * spacing
    sample = np.asarray(points[:: max(1, n // BOX_SAMPLE)])
    tail = max(1, int(TAIL_SHARE * len(sample)))
    low = np.array([np.partition(sample[:, a], tail)[tail] for a in range(3)])
    high = np.array([np.partition(sample[:, a], len(sample) - 1 - tail)[len(sample) - 1 - tail] for a in range(3)])
    if np.all(spill.lower >= low - radius) and np.all(spill.upper <= high + radius):
        del points
        return  # no point lies far enough out to be one
    row_parts, point_parts = [], []
    for a in range(0, n, rows):
        part = np.asarray(points[a : a + rows])
        out = np.flatnonzero(np.any((part < low) | (part > high), axis=1))
        row_parts.append(a + out)
        point_parts.append(part[out])
    outside_rows, outside = np.concatenate(row_parts), np.vstack(point_parts)
    far = np.any((outside < low - radius) | (outside > high + radius), axis=1)
    from scipy.spatial import cKDTree  # lazy: only a survey with a far point gets here

    counts = cKDTree(outside).query_ball_point(outside[far], radius, return_length=True)
    strays = np.sort(outside_rows[far][counts - 1 <= MIN_NEIGHBOURS])
    del points
    if not len(strays):
        return
    _rewrite_without(spill, strays, rows)
    spill.left_out = {**(spill.left_out or {}), "strays": len(strays)}
    warnings.warn(
        f"{spill.source}: left out {len(strays):,} stray point(s), each with at most {MIN_NEIGHBOURS} others "
        f"within {STRAY_RADIUS_SPACINGS:g} point spacings ({radius:.3g} in the cloud's unit) (the first is point "
        f"number {int(strays[0]) + 1:,} of the survey, counting from 1): one such point made the survey's extent, "
        f"and every parameter read from it, many times the rock's.",
        GeoStructureWarning,
        stacklevel=3,
    )


def _rewrite_without(spill, strays: np.ndarray, rows: int) -> None:
    """Each of the spill's per-point files written again without the rows ``strays``; the
    count and bounds read again from the points kept."""
    n = spill.n_points
    drop = np.zeros(n, dtype=bool)
    drop[strays] = True
    lower, upper = np.full(3, np.inf), np.full(3, -np.inf)
    for name, dtype, columns in POINT_FILES:
        path = spill.folder / name
        if not path.is_file():
            continue
        source = np.memmap(path, dtype=dtype, mode="r", shape=(n, columns) if columns > 1 else (n,))
        temporary = path.with_name(f".{name}.kept")
        with open(temporary, "wb") as out:
            for a in range(0, n, rows):
                kept = np.asarray(source[a : a + rows])[~drop[a : a + rows]]
                kept.tofile(out)
                if name == "points.f8" and len(kept):
                    lower, upper = np.minimum(lower, column_min(kept)), np.maximum(upper, column_max(kept))
        del source
        os.replace(temporary, path)
    spill.n_points = n - len(strays)
    spill.lower, spill.upper = lower, upper
