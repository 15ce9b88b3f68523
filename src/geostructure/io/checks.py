"""What the readers refuse or warn of in the coordinates they read, whatever the format:
NaN, infinity and coordinates beyond any survey's; too few points; coordinates stored in
steps coarser than the points lie (32-bit floats far from the origin, a coarse LAS scale).
Each check names the file; the streamed reader runs them chunk by chunk.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from geostructure.core.bounds import column_max, column_min, first_bad_coordinates
from geostructure.core.cloud import MAX_COORDINATE
from geostructure.errors import GeoStructureWarning, InputError


def check_points(points: np.ndarray, path, offset=None) -> None:
    """Refuse coordinates no measurement can use: NaN/inf, too few, degenerate; ``points``
    relative to ``offset`` when given."""
    if len(points) == 0:
        raise InputError(f"{path}: holds no points.")
    check_coordinates(points, path, offset=offset)
    if len(points) < 3:
        raise InputError(f"{path}: holds {len(points)} point(s); a plane needs at least 3.")


def check_coordinates(points: np.ndarray, path, first: int = 0, offset=None) -> None:
    """Refuse NaN/inf coordinates and ones beyond :data:`MAX_COORDINATE`; ``first`` is the
    number of the first of ``points`` in the file (a chunk's), for the message; ``points``
    relative to ``offset`` (3,) when given."""
    problem = first_bad_coordinates(points, MAX_COORDINATE, offset)
    if problem is None:
        return
    kind, count, row = problem
    if kind == "not finite":
        raise InputError(
            f"{path}: {count:,} point(s) have NaN or infinite coordinates (the first is point number "
            f"{first + row + 1:,}, counting from 1)."
        )
    raise InputError(
        f"{path}: point number {first + row + 1:,} (counting from 1) has a coordinate beyond {MAX_COORDINATE:.0e}, which no survey "
        f"uses (float64 keeps no millimetres there); the file may be damaged."
    )


#: A stored coordinate step below this share of the cloud's extent is never checked against
#: the point spacing: no surface the detector resolves has fewer than 10,000 steps across.
STEP_CHECK_SHARE = 1e-4
#: Stored steps this many point spacings wide leave a lattice, not a surface: refused.
MAX_STEP_SPACINGS = 4.0


def ply_step(points: np.ndarray, vertex_dtype: np.dtype) -> tuple[float, str] | None:
    """The step PLY vertices are stored in, and how, for :func:`check_coordinate_step`: 1 for
    integer axes; else the 32-bit float spacing at the largest coordinate among ``points``;
    None when every axis is a double."""
    if not len(points):
        return None
    if any(np.issubdtype(vertex_dtype[a], np.integer) for a in "xyz"):
        return 1.0, "as integers, in steps of"
    single = [i for i, a in enumerate("xyz") if vertex_dtype[a] == np.float32]
    if not single:
        return None
    largest = float(np.max(np.abs(np.r_[column_min(points)[single], column_max(points)[single]])))
    return float(np.spacing(np.float32(largest))), f"as 32-bit floats, which at {largest:,.0f} round to steps of"


def las_step(scales) -> tuple[float, str]:
    """The step LAS/LAZ points are stored in (the header's coarsest scale), and how."""
    return float(np.max(scales)), "on the LAS scale, in steps of"


#: Values per axis :func:`observed_step` reads.
STEP_SAMPLE = 20_000


def observed_step(points: np.ndarray, sample: int = STEP_SAMPLE, seed: int = 0) -> tuple[float, str] | None:
    """The step a file without a declared one (text, E57) holds its coordinates in, for
    :func:`check_coordinate_step`: on the coarsest axis, the least gap between distinct
    values of a sample of its points. Coordinates that vary freely give gaps far under any
    spacing; a cloud rounded to 0.5 m, or written as 32-bit floats at a UTM northing, gives
    the step itself, and was measured as if exact (23 planes of normal (0, 1, 0)).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> free = rng.random((5000, 3)) * 10
    >>> observed_step(free)[0] < 1e-4, observed_step(np.round(free * 2) / 2)[0]
    (True, 0.5)
    """
    if len(points) < 10:
        return None
    rows = np.random.default_rng(seed).choice(len(points), size=min(sample, len(points)), replace=False)
    steps = []
    for axis in range(points.shape[1]):
        values = np.unique(points[rows, axis])
        gaps = np.diff(values)
        steps.append(float(gaps.min()) if len(gaps) else 0.0)
    return max(steps), "with a least step between values of"


#: An observed step (:func:`observed_step`) is warned of from two point spacings, not a
#: quarter: a cloud sampled on a grid (a terrain model's cells) holds a lattice at its
#: spacing (1.1 of the spacing :func:`~geostructure.core.density.point_spacing` reads on a
#: square grid), with nothing rounded.
OBSERVED_WARN_SPACINGS = 2.0


def check_coordinate_step(points: np.ndarray, stored_step: tuple[float, str] | None, path) -> None:
    """Refuse a cloud whose stored coordinates are rounded to steps of more than four times
    its point spacing (32-bit floats at UTM northings round to 0.5 m): its points are heaped
    on that grid, a dozen or more to a node, and the planes found would be the grid's. Warn
    from a quarter of the spacing (a drone LAZ stored to 1 cm at 6 mm spacing): the rounding
    is noise of step / sqrt(12) on every plane, and facets a few steps across are lost. The
    spacing is read only when the step is coarse for the cloud's extent. ``stored_step``: the
    step and how it is stored, said before it (:func:`ply_step`, :func:`las_step`: "on the
    LAS scale, in steps of"), or None (doubles: nothing to check)."""
    if stored_step is None or len(points) < 10:
        return
    step, stored = stored_step
    with np.errstate(invalid="ignore", over="ignore"):  # non-finite rows give NaN: refused by check_points
        extent = float(np.max(column_max(points) - column_min(points)))
    if not step > STEP_CHECK_SHARE * extent:
        return
    from geostructure.core.density import point_spacing  # lazy: only for a coarsely stored cloud

    local = points - points.mean(axis=0)
    spacing = point_spacing(local, distinct=False)
    # Most points nine or more to a spot: copies of a scan, or the storage grid's nodes. The
    # grid's, when the distinct points lie no farther apart than two steps; a scan's copies
    # are judged on their distinct points.
    distinct = spacing or point_spacing(local)
    heaped = spacing == 0 and distinct < 2 * step
    if heaped or step > MAX_STEP_SPACINGS * spacing > 0:
        ratio = "" if heaped else f", {step / spacing:.0f} times its point spacing ({spacing:.3g})"
        raise InputError(
            f"{path}: its coordinates are stored {stored} {step:g}{ratio}, so its points are heaped on that grid, not "
            f"on their surfaces; save it with finer coordinates (double precision, a finer LAS scale, or shifted "
            f"near the origin) and measure that."
        )
    spacing = distinct
    warn_from = OBSERVED_WARN_SPACINGS * spacing if stored.startswith("with a least step") else spacing / 4
    if step > warn_from:
        warnings.warn(
            f"{path}: its coordinates are stored {stored} {step:g}, {step / spacing:.2g} times its point "
            f"spacing: the rounding adds noise of about {step / np.sqrt(12):.2g} to every plane, and facets "
            f"a few steps across are lost.",
            GeoStructureWarning,
            stacklevel=2,
        )


def check_step_once(points: np.ndarray, step: tuple[float, str] | None, path: Path, steps_checked: set) -> None:
    """:func:`check_coordinate_step` on a file's first chunk, unless an earlier
    file stored its coordinates in the same step."""
    if step is not None and step[0] not in steps_checked:
        check_coordinate_step(points, step, path)
        steps_checked.add(step[0])
