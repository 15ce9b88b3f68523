"""How far a grid's local planes wander at their own scale: the detector trusts a grid
whose neighbouring cells' normals agree, and coarsens it otherwise (:mod:`.facets`).

The scatter is the angle between a cell's normal and that of the cell two steps along each
axis, read on the surface's cells (:func:`surface_cells`) so that clutter does not decide
it; on the whole grid (:func:`far_scatter`) or on a random sample of its cells
(:func:`sampled_far_scatter`), whose blocks are fitted alone.
"""

from __future__ import annotations

import numpy as np

from geostructure.core.threads import run_blocks
from geostructure.detect.cells import CENTRE, SURFACE_VARIATION, CellGrid, CellPlanes, block_fit, block_moments

#: The grid's scatter is read on the thin blocks when they hold this share of the points.
SURFACE_SHARE = 0.5

#: The scatter is this percentile of the angles, not their median: the grid is trusted when
#: two pairs of cells in five are smooth at its scale, for the points no facet takes go to
#: the voxel growing anyway. A noisy road before a face and level ground behind its crest
#: (a third of a 40 x 16 m cut's points) lifted the median past the limit, the grid was
#: doubled and the recall fell from 94% to 85%; at the 40th percentile it stays (93%). No
#: face of the spacing table, the 1 cm face or the observatory chooses another grid.
SCATTER_PERCENTILE = 40.0


def far_scatter(cells: CellPlanes) -> float:
    """The angle (degrees, :data:`SCATTER_PERCENTILE`) between a cell's normal and that of
    the cell two steps along each axis: how much the local planes wander over about a
    block's width. Read on the surface's cells (:func:`surface_cells`), so that clutter does
    not decide the grid."""
    among = surface_cells(cells.defined, cells.variation, cells.count)

    def angles_of(rows: slice) -> list[np.ndarray]:  # a block of cells, each axis's pairs
        found = []
        for axis_offset in (CENTRE + 9, CENTRE + 3, CENTRE + 1):  # +x, +y, +z
            one = cells.neighbour[rows, axis_offset]
            two = np.where(one >= 0, cells.neighbour[np.maximum(one, 0), axis_offset], -1)
            ok = (two >= 0) & among[rows]
            ok[ok] &= among[two[ok]]
            cosine = np.abs(np.einsum("ij,ij->i", cells.normal[rows][ok], cells.normal[two[ok]]))
            found.append(np.arccos(np.clip(cosine, 0.0, 1.0)))
        return found

    angles = np.concatenate([a for block in run_blocks(angles_of, len(cells)) for a in block])
    return float(np.degrees(np.percentile(angles, SCATTER_PERCENTILE))) if len(angles) else 0.0


def surface_cells(defined, variation, count) -> np.ndarray:
    """The cells whose scatter decides whether a grid is trusted: those whose block is thin
    (``variation`` at most :data:`SURFACE_VARIATION`), where they hold
    :data:`SURFACE_SHARE` of the points or more; else every cell with a plane (``defined``).

    A bush's shell of noisy points is a volume, not a surface, and its cells' planes point
    every way: on a 20 x 8 m outcrop twelve bushes (39% of the points, 40% of the cells) made
    the median scatter 8.35 degrees where the rock's is 3.6, and the grid was coarsened to
    where no facet was trusted (recall 0.14; 0.80 now, the bushes hiding 16% of the face).
    The rock's blocks have a median variation of 0.003 (nine in ten under 0.008), the
    bushes' 0.12 (nine in ten over 0.056). A cloud noisy all over has few thin blocks, and
    is read whole.

    Examples
    --------
    >>> surface_cells(np.ones(3, bool), np.array([0.002, 0.2, 0.004]), np.array([9, 2, 9])).tolist()
    [True, False, True]
    """
    defined = np.asarray(defined, dtype=bool)
    thin = defined & (np.asarray(variation) <= SURFACE_VARIATION)
    count = np.asarray(count, dtype=np.float64)
    return thin if count[thin].sum() >= SURFACE_SHARE * count[defined].sum() else defined


def sampled_far_scatter(grid: CellGrid, n_sample: int, seed: int = 0, among=None) -> float:
    """:func:`far_scatter` estimated on ``n_sample`` cells drawn at random, their planes
    and those of the cells two steps along each axis fitted alone: the same percentile of a
    random sample of the same angles, without the whole grid's planes. Drawn over cells, not
    over space, so no part of the cloud is left out (windows of it were tried: at 8M
    observatory points six of them read 4.9 degrees where the whole cloud reads 11).
    ``among`` (indices) limits the draw to those cells."""
    rng = np.random.default_rng(seed)
    pool = np.arange(len(grid)) if among is None else np.asarray(among)
    cells = np.sort(pool[rng.choice(len(pool), min(n_sample, len(pool)), replace=False)])  # sorted: faster finds
    steps = grid.steps()
    along = []
    for axis_offset in (CENTRE + 9, CENTRE + 3, CENTRE + 1):  # +x, +y, +z
        one = grid.find(grid.codes[cells] + steps[axis_offset])
        two = grid.find(grid.codes[cells] + 2 * steps[axis_offset])
        ok = (one >= 0) & (two >= 0)  # as far_scatter: two steps through an occupied cell
        along.append(np.stack([cells[ok], two[ok]], axis=1))
    pairs = np.concatenate(along)
    wanted, where = np.unique(pairs, return_inverse=True)
    values, normal, _, defined = block_fit(block_moments(grid, wanted))
    with np.errstate(invalid="ignore", divide="ignore"):
        variation = values[:, 0] / values.sum(axis=1)
    among = surface_cells(defined, np.nan_to_num(variation, nan=1.0), grid.moments[wanted, 0])
    a, b = where.reshape(-1, 2).T
    ok = among[a] & among[b]
    cosine = np.abs(np.einsum("ij,ij->i", normal[a[ok]], normal[b[ok]]))
    angles = np.arccos(np.clip(cosine, 0.0, 1.0))
    return float(np.degrees(np.percentile(angles, SCATTER_PERCENTILE))) if ok.any() else 0.0
