"""How densely a cloud is sampled: its point spacing, read from its points alone.

The facet detector sizes its grid by it (:mod:`.facets`), the readers compare a file's stored
coordinate step with it (:func:`~.io.checks.check_coordinate_step`), and the exposure sizes
its occupancy cells by it (:mod:`.exposure`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.bounds import column_max, column_min
from geostructure.core.sampling import order_free_sample, sampled_blocks
from geostructure.core.threads import tree_query

#: Points sampled to measure the point spacing.
SPACING_SAMPLE = 20_000
#: Above this many points the spacing is read in a sample of whole blocks of the cloud
#: (:func:`point_spacing`): the tree over 8M points took 3 s to build, for 20,000 queries.
SPACING_TREE_POINTS = 2_000_000
#: Those blocks are this fraction of the cloud's extent wide.
SPACING_BLOCKS_ACROSS = 64


def point_spacing(points: np.ndarray, sample: int = SPACING_SAMPLE, seed: int = 0, *, distinct: bool = True) -> float:
    """The cloud's point spacing, 1 / sqrt(surface density), from the distance r_8 of a
    random sample of its points to their 8th nearest neighbour: 8 points in a disc of
    radius r_8 give density 8 / (pi r_8^2). On a square grid of spacing s it reads 0.89 s;
    unlike the nearest-neighbour distance, it reads a random (Poisson) scatter right too,
    whose nearest neighbours lie at half its spacing.

    Where many points are written more than once (merged copies of one scan, overlapping
    tiles), their copies are read as neighbours at distance 0 and the spacing comes out short
    (by sqrt 2 for a cloud written twice, which cut a plane into 1,937 facets; nine copies
    read 0, and sized the facet detector's grid at 0). When over :data:`MAX_COPIED_SHARE` of
    the probes have a copy, the spacing is read on the distinct points, unless ``distinct``
    is False.

    Examples
    --------
    >>> g = np.mgrid[0:10:0.1, 0:10:0.1].reshape(2, -1).T  # a square grid 0.1 apart
    >>> grid = np.c_[g, np.zeros(len(g))]
    >>> round(point_spacing(grid) / 0.1, 2), point_spacing(np.repeat(grid, 2, axis=0)) == point_spacing(grid)
    (0.89, True)
    >>> xy = np.random.default_rng(0).random((10_000, 2)) * 10  # 100 points a square unit
    >>> round(point_spacing(np.c_[xy, np.zeros(len(xy))]), 2)
    0.1
    """
    spacing, copied = _spacing_of(points, sample, seed)
    if (spacing > 0 and copied <= MAX_COPIED_SHARE) or len(points) < 2 or not distinct:
        return spacing
    # A sort of the rows: paid only by a cloud with copies in it.
    unique = np.unique(points, axis=0)
    return _spacing_of(unique, sample, seed)[0] if len(unique) < len(points) else spacing


#: The share of probes with a copy of themselves (another point at distance 0) above which
#: :func:`point_spacing` reads the distinct points: a tenth of a cloud copied shortens the
#: spacing by about 5%, no matter to the grid it sizes.
MAX_COPIED_SHARE = 0.1


def _spacing_of(points: np.ndarray, sample: int, seed: int) -> tuple[float, float]:
    """:func:`point_spacing` as the points give it, copies and all, and the share of its
    probes that have a copy."""
    k = min(9, len(points))
    if len(points) > SPACING_TREE_POINTS:
        found = _block_sampled_r8(points, sample, seed)
        if found is not None:
            return found[0] * float(np.sqrt(np.pi / (k - 1))), found[1]
    probe = points[order_free_sample(points, min(sample, len(points)), seed)]
    tree = cKDTree(points, balanced_tree=False, compact_nodes=False)  # built fast: queried once
    distance = tree_query(tree, probe, k)[0]
    copied = float(np.mean(distance[:, 1] == 0.0)) if k > 1 else 0.0  # column 0 is the probe itself
    return float(np.median(distance[:, -1])) * float(np.sqrt(np.pi / max(k - 1, 1))), copied


def _block_sampled_r8(points: np.ndarray, sample: int, seed: int) -> tuple[float, float] | None:
    """The median r_8 of :func:`point_spacing`, read in a hash-drawn sample of whole blocks
    (:func:`spacing_blocks`); with it, the share of its probes that have a copy. None when
    too few probes are that far inside."""
    lower, edge, fraction = spacing_blocks(column_min(points), column_max(points), len(points))
    return r8_in_blocks(points[sampled_blocks(points, lower, edge, fraction, seed)], lower, edge, sample, seed)


def spacing_blocks(lower, upper, n_points: int) -> tuple[np.ndarray, float, float]:
    """The blocks :func:`point_spacing` reads a large cloud's spacing in: their anchor, their
    edge (:data:`SPACING_BLOCKS_ACROSS` across the cloud) and the share of them drawn (to hold
    some :data:`SPACING_TREE_POINTS` / 4 points), from the cloud's bounds and size alone, so
    that a cloud read in chunks draws the same blocks
    (:func:`~geostructure.core.sampling.sampled_blocks`).

    Examples
    --------
    >>> lower, edge, fraction = spacing_blocks(np.zeros(3), np.array([64.0, 10.0, 5.0]), 10_000_000)
    >>> lower.tolist(), edge, fraction
    ([-0.5, -0.5, -0.5], 1.0, 0.05)
    """
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    # Blocks start half a block below the cloud's corner, so that surfaces at its bounds (the
    # ground, at the lowest points) lie mid-block, not along a face where no probe counts.
    edge = float((upper - lower).max()) / SPACING_BLOCKS_ACROSS
    return lower - edge / 2, edge, SPACING_TREE_POINTS / 4 / n_points


def r8_in_blocks(sub: np.ndarray, lower, edge: float, sample: int, seed: int) -> tuple[float, float] | None:
    """The median r_8 of the points of the drawn blocks ``sub`` (the cubes of ``edge`` from
    ``lower``), from probes at least twice the median r_8 inside their block: their 8 nearest
    neighbours are then the whole cloud's, unless farther than that (the sparsest tail, which
    does not move the median). With it, the share of those probes that have a copy; None
    when too few probes are that far inside."""
    if len(sub) < 9:
        return None
    probe = order_free_sample(sub, min(4 * sample, len(sub)), seed)
    tree = cKDTree(sub, balanced_tree=False, compact_nodes=False)
    distance = tree_query(tree, sub[probe], 9)[0]
    r8 = distance[:, -1]
    within = sub[probe] - (lower + np.floor((sub[probe] - lower) / edge) * edge)
    room = np.minimum(within.min(axis=1), (edge - within).min(axis=1))
    inside = room >= 2.0 * np.median(r8)  # chosen by position alone: no bias to dense or sparse
    if inside.sum() < sample // 4:
        return None
    return float(np.median(r8[inside])), float(np.mean(distance[inside, 1] == 0.0))


def spacing_of_blocks(sub: np.ndarray, lower, edge: float, sample: int = SPACING_SAMPLE, seed: int = 0):
    """:func:`point_spacing` of a cloud too large to hold, from the points ``sub`` of its
    drawn blocks (:func:`spacing_blocks`, gathered chunk by chunk): the same value as the
    whole cloud gives, or None where too few probes lie inside their blocks (the cloud is
    then read on a tree of all its points). Where many probes have a copy, the spacing is
    read on the distinct points of the blocks (in memory: of the cloud)."""
    found = r8_in_blocks(sub, lower, edge, sample, seed)
    if found is not None and found[1] > MAX_COPIED_SHARE:
        found = r8_in_blocks(np.unique(sub, axis=0), lower, edge, sample, seed)
    return None if found is None else found[0] * float(np.sqrt(np.pi / 8))
