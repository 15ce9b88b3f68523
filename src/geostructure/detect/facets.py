"""Small facets on rough rock: local planes on a fine grid and planar region growing on them.

The voxel pipeline (the paper's) fits one plane per voxel, so a joint face must span a few
voxels to be found, and a voxel must be large against the noise for its normal to mean
anything: on a rough outcrop at 3 cm spacing that puts the smallest face found near a
metre across, while most joints are half that. Here the local planes are as fine as DSE's
per-point normals (Riquelme et al. 2014) but come from a grid, not a neighbour search:

1. **Local planes** (:mod:`.cells`): a grid of twice the point spacing; each cell's plane is
   the least-squares plane of its 3 x 3 x 3 block of cells (about 30 points, as DSE's 30
   neighbours), from additive moments. Its surface variation lambda_0 / (lambda_0 +
   lambda_1 + lambda_2) (Pauly et al. 2002) is near 0 on a plane and up to 1/3 where the
   block straddles an edge or a step; such cells belong to no facet, which keeps two faces
   meeting at an edge apart.
2. **Growing**: two touching cells join when their normals are within ``max_angle``
   degrees and each cell's points lie (their mean) within ``max_offset`` of the other's
   plane (the coplanarity test; it separates parallel joints of one set that step past
   each other). The facets are the connected components of that graph (``scipy.sparse.
   csgraph``).
3. **Points**: each point takes its cell's facet when it lies on the cell's plane.

The thresholds come from the cloud itself (:func:`facet_thresholds`): the point spacing and
the noise of the local fits, so a LiDAR cloud at 1 cm and an SfM cloud at 3 cm are treated
alike. Where the local planes wander more than :data:`MAX_CELL_SCATTER` (rock rough at the
cloud's own spacing, as a dense LiDAR scan sees it), the grid is coarsened. Why a grid rather
than per-point neighbours: ``docs/methods.md``, "Facets".
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from geostructure.core.bounds import column_min
from geostructure.core.density import point_spacing
from geostructure.core.gridkeys import binned_sums
from geostructure.core.sampling import sampled_blocks
from geostructure.core.threads import run_blocks, run_tasks
from geostructure.detect.cells import CellGrid, CellPlanes, grid_planes, neighbour_pairs, with_sparse_cells_filled
from geostructure.detect.gridscatter import far_scatter, sampled_far_scatter
from geostructure.detect.roughfacets import RoughFacets, detect_rough_facets

#: The grid's edge in point spacings (:func:`point_spacing`), so that a block of 3 x 3 x 3
#: cells holds some 16 to 30 points of a surface, as DSE's 30 neighbours. On outcrop seeds 4,
#: 5 and 7 and the 1 cm face, 1.35 found 91 to 95% of the facets; 1.6, 84 to 92%; 2.25, 78
#: to 80%.
CELL_EDGE = 1.35
#: Largest angle (degrees) between local planes two cells apart for them to be trusted (its
#: 40th percentile, :data:`~geostructure.detect.gridscatter.SCATTER_PERCENTILE`, on the surface's cells); where they
#: wander more, the grid's edge is doubled, up to COARSENING_ROUNDS times, and where they
#: still do (a noisy SfM cloud), no facet is trusted: every point is left to the voxel
#: growing. Measured (as medians, which decided until 2026-12-05): 3.3 to 4.7 on rough
#: SfM-like outcrops at 2.5 to 3 cm; on the LiDAR-like one at 1 cm, over 5 on the first grid
#: and 4.1 on the doubled one.
MAX_CELL_SCATTER = 5.0
COARSENING_ROUNDS = 3
#: The angle threshold is this many times the median angle between touching cells' planes
#: (2.5 found 1 to 2% more facets than 2 or 3.5 on outcrop seeds 4 and 5).
ANGLE_FACTOR = 2.5
#: A facet narrower than this many cells of its grid (the short side of its rectangle) is a
#: ribbon along an edge where two surfaces meet, not a plane: the cells that straddle the
#: edge fit planes between the two, alike along the edge, and grow into a strip one cell
#: wide whose normal is fixed only along it. On a 5M-point quarry (faces dipping 70 deg
#: meeting level berms) 60 of the 61 planes after its 8 surfaces were such strips, 0.84 to
#: 1.05 cells across and dipping 60 to 68 deg; on the rough outcrop (seed 0) one of its
#: 1,556 facets is under two cells across, and none on the observatory.
MIN_FACET_CELLS_ACROSS = 2.0
#: Above this many points, the scatter that decides whether to coarsen the grid is read on
#: this many cells drawn at random (:func:`~geostructure.detect.gridscatter.sampled_far_scatter`), and only the grid
#: chosen gets its planes: at 8M observatory points each whole grid took some 19 s, and
#: three were built. Below it, every grid is fitted whole, as before.
SCATTER_SAMPLE_POINTS = 1_000_000
SCATTER_SAMPLE_CELLS = 200_000
#: On such a cloud the scatter is read on a sample of whole blocks of the grid, this many of
#: the coarsest grid's cells wide, drawn by a hash of their key (about
#: SCATTER_SAMPLE_POINTS points in all), so that no grid but the chosen one is built on the
#: whole cloud: at 8M observatory points, building and coarsening the whole grids took 13 s
#: of the detector's 26.
SCATTER_BLOCK_CELLS = 8
#: The scatter is read on a tenth of those cells first, which decides when it lies farther
#: than this share of MAX_CELL_SCATTER from it (8M observatory, three seeds: a tenth read
#: 26.2-26.6, 13.24-13.26 and 3.08-3.11 deg where all read 26.5, 13.13 and 3.09).
QUICK_SCATTER_MARGIN = 0.2


@dataclass(frozen=True)
class FacetThresholds:
    """What two neighbouring points must satisfy to belong to one facet."""

    max_angle: float  # degrees between their normals
    max_offset: float  # distance from one to the other's plane (cloud units)
    max_variation: float  # surface variation of either
    spacing: float  # the cloud's median point spacing, for reference


def planar_components(
    points: np.ndarray, normals: np.ndarray, labels: np.ndarray, thresholds: FacetThresholds, normal_of=None
) -> np.ndarray:
    """Which grown facets are planes (True) and which drifted round a curved surface (False).

    Connected components have no reference normal, so on a smooth curved surface (a Poisson
    mesh's rounded edges, a dome) they grow round it. A facet is planar when its points lie
    within twice the coplanarity offset of its least-squares plane (RMS) and four in five of
    local ``normals`` within twice the angle of the plane's normal. ``normals`` are the
    points' own (N, 3), or, with ``normal_of`` (N,), a table the points index (their cells').
    """
    n = int(labels.max(initial=-1)) + 1
    if n == 0:
        return np.zeros(0, dtype=bool)
    # Unlabelled points go to a spare bin n, and every per-point value is gathered a column
    # at a time from a small per-facet table into one of four buffers the cloud's size:
    # no masked copies, and no fresh arrays, whose pages cost their first touch (at 8M
    # points 2.9 s, then 1 s, then less).
    bins = np.where(labels >= 0, labels, n)
    count = np.bincount(bins, minlength=n + 1)[:n].astype(np.float64)
    # A label may hold no point (its cells lost them all): it is no plane, and must not
    # turn the covariances to NaN.
    held = np.maximum(count, 1.0)
    # np.take into a buffer with mode "clip": the indices are all in range, and with
    # "raise" numpy buffers the output, a fresh array again.
    d, work = np.empty((3, len(points))), np.empty(len(points))
    for a in range(3):
        np.copyto(d[a], points[:, a])
    sums = run_tasks([partial(np.bincount, bins, d[a], n + 1) for a in range(3)])
    means = [np.append(total[:n] / held, 0.0) for total in sums]

    def centre_rows(rows: slice) -> None:  # elementwise: split over the cores, the same bits
        for a in range(3):
            d[a, rows] -= np.take(means[a], bins[rows], out=work[rows], mode="clip")

    run_blocks(centre_rows, len(points))
    # The six sums of products (symmetric: six, not nine), each whole in one thread.
    products = binned_sums(d, bins, n + 1)[1][:n] / held[:, None]
    cov = np.empty((n, 3, 3))
    for c, (a, b) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        cov[:, a, b] = cov[:, b, a] = products[:, c]
    values, vectors = np.linalg.eigh(cov)
    residual = np.sqrt(np.maximum(values[:, 0], 0.0))
    normal = np.vstack([vectors[:, :, 0], np.zeros(3)]).T.copy()  # (3, n + 1), the spare bin zero
    own = normals if normal_of is None else np.ascontiguousarray(normals.T)
    dot, term = d[0], d[1]
    cos_limit = np.cos(np.radians(2.0 * thresholds.max_angle))

    def aligned_rows(rows: slice) -> None:
        t, w, b = term[rows], work[rows], bins[rows]
        dot[rows] = 0.0
        for a in range(3):
            np.take(normal[a], b, out=t, mode="clip")
            t *= normals[rows, a] if normal_of is None else np.take(own[a], normal_of[rows], out=w, mode="clip")
            dot[rows] += t
        np.copyto(w, np.abs(dot[rows], out=dot[rows]) >= cos_limit)

    run_blocks(aligned_rows, len(points))
    share = np.bincount(bins, work, n + 1)[:n] / held  # the aligned points' share
    return (count > 0) & (residual <= 2.0 * thresholds.max_offset) & (share >= 0.8)


@dataclass
class FacetDetection:
    """Facets found on a cloud: ``labels`` (N,) numbers each point's planar facet (0, 1, ...
    by size) or -1; ``curved`` (N,) marks the points of grown groups that were not planar."""

    labels: np.ndarray
    curved: np.ndarray
    thresholds: FacetThresholds
    cell_edge: float  # the grid's edge the local planes were computed on
    far_scatter: float
    rough: RoughFacets | None = None  # where no grid was trusted: the rough rock's facets
    extra: dict | None = None  # more for run.json: a survey's facets found in tiles say so
    #: A thinned survey's facets: each one's plane from all the survey's points of it
    #: (:class:`~geostructure.detect.tilejoin.FacetPlanes`), by the labels' numbers.
    survey: object = None

    def record(self) -> dict:
        """What ``run.json`` says of the detection."""
        return {
            **detection_record(
                self.thresholds,
                self.cell_edge,
                self.far_scatter,
                int(self.labels.max(initial=-1)) + 1,
                int(self.curved.sum()),
            ),  # fmt: skip
            **({} if self.rough is None else self.rough.record()),
            **(self.extra or {}),
        }


def detection_record(thresholds: FacetThresholds, cell_edge: float, far_scatter: float, n_facets: int,
                     curved_points: int) -> dict:  # fmt: skip
    """What ``run.json`` says of a facet detection, in memory or in tiles."""
    return {
        "detector": "facets",
        "facet_thresholds": {k: float(v) for k, v in vars(thresholds).items()},
        "cell_edge": cell_edge,
        "far_scatter_deg": far_scatter,
        "planar_facets": n_facets,
        "curved_points": curved_points,
    }


def voxel_majority(point_voxel: np.ndarray, labels: np.ndarray, n_voxels: int) -> np.ndarray:
    """Each voxel's most common point label (-1 for a voxel none of whose points has one).

    Examples
    --------
    >>> voxel_majority(np.array([0, 0, 0, 1, 2]), np.array([4, 4, 1, -1, 2]), 4).tolist()
    [4, -1, 2, -1]
    """
    out = np.full(n_voxels, -1, dtype=np.int64)
    ok = (point_voxel >= 0) & (labels >= 0)
    if not ok.any():
        return out
    # One int64 code a (voxel, label) pair, sorted as the pairs are: np.unique over rows
    # (axis=0) took 1.8 s at 8M points, over codes a third of that.
    n_labels = int(labels[ok].max()) + 1
    codes, counts = np.unique(point_voxel[ok] * n_labels + labels[ok], return_counts=True)
    voxel, label = codes // n_labels, codes % n_labels
    order = np.lexsort((-counts, voxel))  # by voxel, the most common label first
    first = order[np.r_[True, np.diff(voxel[order]) != 0]]
    out[voxel[first]] = label[first]
    return out


def facet_thresholds(cells: CellPlanes, spacing: float, pairs=None) -> FacetThresholds:
    """Thresholds read from the cloud: spacing, local-fit noise and how local planes scatter.

    - the offset a cell may lie off its neighbour's plane is 3 times the median local-fit
      residual (the noise and roughness at the block's scale), at least a third of the
      point spacing;
    - the angle is :data:`ANGLE_FACTOR` times the median angle between touching cells'
      normals, clipped to 5 to 15 degrees: above the scatter of one rough face, below the
      angle at which joints of different sets meet;
    - the surface variation is 3 times its median, clipped to 0.01 to 0.1.
    """
    defined = cells.defined
    source, target = neighbour_pairs(cells) if pairs is None else pairs
    cosine = np.abs(pair_dots(cells.normal, source, cells.normal, target))
    scatter = float(np.degrees(np.median(np.arccos(np.clip(cosine, 0.0, 1.0))))) if len(source) else 0.0
    if not defined.any():
        return thresholds_from_medians(scatter, None, None, spacing)
    return thresholds_from_medians(scatter, float(np.median(cells.residual[defined])),
                                   float(np.median(cells.variation[defined])), spacing)  # fmt: skip


def thresholds_from_medians(scatter: float, residual: float | None, variation: float | None, spacing: float):
    """:func:`facet_thresholds`' rule from the medians it reads (the angle between touching
    cells' planes in degrees, and the defined cells' residual and variation, None where no
    cell is defined), however they were read: on the whole grid, or over tiles."""
    return FacetThresholds(
        max_angle=float(np.clip(ANGLE_FACTOR * scatter, 5.0, 15.0)),
        max_offset=spacing if residual is None else max(3.0 * residual, spacing / 3.0),
        max_variation=0.01 if variation is None else float(np.clip(3.0 * variation, 0.01, 0.1)),
        spacing=spacing,
    )


def pair_dots(a: np.ndarray, ia: np.ndarray, b: np.ndarray, ib: np.ndarray, less=None) -> np.ndarray:
    """Row i: ``a[ia[i]] . b[ib[i]]`` of (n, 3) ``a`` and ``b``, or with ``less=(c, ic)``
    ``(a[ia[i]] - c[ic[i]]) . b[ib[i]]``: a column at a time through reused buffers, not
    (pairs, 3) gathers (at 8M points the pairs' row gathers touched over a gigabyte).

    Examples
    --------
    >>> a = np.array([[1.0, 2.0, 3.0], [0.0, 1.0, 0.0]])
    >>> pair_dots(a, np.array([0, 1]), a, np.array([1, 1])).tolist()
    [2.0, 1.0]
    >>> pair_dots(a, np.array([0]), a, np.array([0]), less=(a, np.array([1]))).tolist()
    [12.0]
    """
    out = np.zeros(len(ia))
    first, second = np.empty(len(ia)), np.empty(len(ia))

    def dot_rows(rows: slice) -> None:  # elementwise: split over the cores, the same bits
        o, f, g, i, j = out[rows], first[rows], second[rows], ia[rows], ib[rows]
        for k in range(a.shape[1]):
            np.take(a[:, k], i, out=f, mode="clip")  # "raise" buffers a copy
            if less is not None:
                f -= np.take(less[0][:, k], less[1][rows], out=g, mode="clip")
            f *= np.take(b[:, k], j, out=g, mode="clip")
            o += f

    run_blocks(dot_rows, len(ia))
    return out


def grow_cells(cells: CellPlanes, thresholds: FacetThresholds, pairs=None) -> np.ndarray:
    """Each cell's facet (0, 1, ..., most points first) or -1 (an edge, or a facet of one cell).

    Examples
    --------
    >>> g = np.mgrid[0:1:40j, 0:1:40j].reshape(2, -1).T
    >>> roof = np.c_[g, np.where(g[:, 0] < 0.5, g[:, 0], 1 - g[:, 0])]  # two faces meeting at a ridge
    >>> from geostructure.detect.cells import cell_planes
    >>> cells = cell_planes(roof, 0.05)
    >>> labels = grow_cells(cells, facet_thresholds(cells, point_spacing(roof)))
    >>> int(labels.max() + 1)
    2
    """
    source, target = neighbour_pairs(cells) if pairs is None else pairs
    flat, (source, target) = agreeing_pairs(cells, thresholds, (source, target))
    return ranked_components(len(cells), source, target, flat, cells.count)


def agreeing_pairs(cells: CellPlanes, thresholds: FacetThresholds, pairs) -> tuple[np.ndarray, tuple]:
    """Which cells are flat enough to grow (their surface variation), and which of the
    touching ``pairs`` agree: both flat, their normals within the angle, each cell's points
    within the offset of the other's plane. Local: a pair's test reads its two cells alone,
    so tiles with halos test the pairs of their own cells as the whole grid does."""
    source, target = pairs
    flat = cells.defined & (cells.variation <= thresholds.max_variation)
    # Each test on the pairs that passed the one before: the gathered (pairs, 3) rows are
    # the largest arrays here, and at 8M points most pairs fail the first tests.
    ok = flat[source] & flat[target]
    source, target = source[ok], target[ok]
    ok = np.abs(pair_dots(cells.normal, source, cells.normal, target)) >= np.cos(np.radians(thresholds.max_angle))
    source, target = source[ok], target[ok]
    ok = np.ones(len(source), dtype=bool)
    for a, b in ((source, target), (target, source)):  # each cell's points on the other's plane
        ok &= (
            np.abs(pair_dots(cells.centroid, b, cells.normal, a, less=(cells.block_centroid, a)))
            <= thresholds.max_offset
        )
    return flat, (source[ok], target[ok])


def ranked_components(
    n: int, source: np.ndarray, target: np.ndarray, flat: np.ndarray, count: np.ndarray
) -> np.ndarray:
    """The connected components of ``n`` cells joined by the pairs (``source``, ``target``),
    flat cells only, of two cells or more, numbered by the points they hold (``count`` per
    cell), most first; -1 for the rest."""
    graph = coo_matrix((np.ones(len(source), dtype=np.int8), (source, target)), shape=(n, n))
    _, component = connected_components(graph, directed=False)
    component = np.where(flat, component, -1)
    n_components = int(component.max(initial=-1)) + 1
    grown = component >= 0
    if not grown.any():
        return np.full(n, -1)
    cells_in = np.bincount(component[grown], minlength=n_components)
    component = np.where(grown & (cells_in[np.maximum(component, 0)] >= 2), component, -1)
    grown = component >= 0
    points_in = np.bincount(component[grown], weights=count[grown], minlength=n_components)
    order = np.argsort(-points_in, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return np.where(grown, rank[np.maximum(component, 0)], -1)


def label_points(points: np.ndarray, cells: CellPlanes, cell_label: np.ndarray, max_offset: float) -> np.ndarray:
    """Each point's facet: its cell's, when it lies within ``max_offset`` of the cell's plane;
    otherwise -1.

    Points of edge cells are not handed to a touching facet: tried, that labelled 99% of
    the points instead of 95% and found no more facets, but the facets it grew reached
    into their neighbours and their planes split joints apart (on the 8 x 5 m 1 cm face,
    two sets' spacing came out 17 and 25% short instead of within 7%).
    """
    own = cell_label[cells.point_cell]
    return np.where((own >= 0) & (cells.point_offset(points, cells.point_cell) <= max_offset), own, -1)


def coarsened_planes(points: np.ndarray, edge: float) -> CellPlanes:
    """The cells' planes on the grid of ``edge`` over ``points``, the edge doubled up to
    :data:`COARSENING_ROUNDS` times while the planes two cells apart scatter more than
    :data:`MAX_CELL_SCATTER`. Each coarser grid is summed from the finer one's moments,
    without going back to the points. Above :data:`SCATTER_SAMPLE_POINTS` points the
    scatter is read on a sample of blocks (:func:`sampled_edge`) and only the chosen grid
    is built on the whole cloud."""
    if len(points) > SCATTER_SAMPLE_POINTS:
        grid = CellGrid.of(points, sampled_edge(points, edge))
        return with_sparse_cells_filled(grid_planes(grid), grid)
    grid = CellGrid.of(points, edge)
    for _ in range(COARSENING_ROUNDS):
        if len(grid) < 100:
            break
        cells = grid_planes(grid)
        if far_scatter(cells) <= MAX_CELL_SCATTER:
            return with_sparse_cells_filled(cells, grid)
        grid = grid.coarser()
    return with_sparse_cells_filled(grid_planes(grid), grid)


def sampled_edge(points: np.ndarray, edge: float, seed: int = 0) -> float:
    """The edge :func:`coarsened_planes` chooses, its scatter read on
    :data:`SCATTER_SAMPLE_CELLS` cells of a hash-drawn sample of whole blocks of the grid
    (:func:`edge_blocks`), drawn among the cells whose planes and partners' planes lie in
    their block. The blocks are a spatial sample, and each block whole: a cell's neighbours
    are all there."""
    lower = column_min(points)
    block_edge, fraction = edge_blocks(edge, len(points))
    drawn = sampled_blocks(points, lower, block_edge, fraction, seed, shift=0.5)
    return edge_of_blocks(points[drawn], edge, lower, fraction, seed)


def edge_blocks(edge: float, n_points: int) -> tuple[float, float]:
    """The blocks :func:`sampled_edge` reads the scatter in: their edge,
    :data:`SCATTER_BLOCK_CELLS` of the coarsest grid's cells (a power of two times ``edge``:
    every grid's cells nest in them), and the share of them drawn, for a cloud of
    ``n_points``. They are anchored half a block below the cloud's corner (``shift=0.5`` in
    :func:`~geostructure.core.sampling.sampled_blocks`): surfaces at the cloud's bounds (its
    ground) lie mid-block, not in the face layers no cell is drawn from."""
    return edge * 2**COARSENING_ROUNDS * SCATTER_BLOCK_CELLS, SCATTER_SAMPLE_POINTS / n_points


def edge_of_blocks(sub: np.ndarray, edge: float, lower, fraction: float, seed: int = 0) -> float:
    """:func:`sampled_edge` from the points ``sub`` of the drawn blocks (:func:`edge_blocks`,
    gathered in memory or chunk by chunk), the grid anchored at the cloud's corner ``lower``."""
    grid = CellGrid.of(sub, edge, lower)
    for level in range(COARSENING_ROUNDS):
        if len(grid) / fraction < 100:
            break
        across = SCATTER_BLOCK_CELLS * 2 ** (COARSENING_ROUNDS - level)  # this grid's cells a block
        within = (grid.cell_key - 1 + across // 2) % across
        inner = np.flatnonzero(np.all((within >= 1) & (within <= across - 4), axis=1))  # block to +3
        if _sampled_scatter(grid, seed, inner) <= MAX_CELL_SCATTER:
            break
        grid = grid.coarser()
    return grid.edge


def _sampled_scatter(grid, seed: int, among: np.ndarray) -> float:
    """:func:`~geostructure.detect.gridscatter.sampled_far_scatter` on a tenth of the cells, or all near the limit."""
    quick = sampled_far_scatter(grid, SCATTER_SAMPLE_CELLS // 10, seed, among=among)
    if abs(quick - MAX_CELL_SCATTER) > QUICK_SCATTER_MARGIN * MAX_CELL_SCATTER:
        return quick
    return sampled_far_scatter(grid, SCATTER_SAMPLE_CELLS, seed, among=among)


def detect_facets(points: np.ndarray) -> FacetDetection:
    """Local planes on a grid, thresholds from the cloud, facets grown and checked for planarity.

    Parameters
    ----------
    points : (N, 3) array
        The cloud's local coordinates (``Cloud.local``, filtered).

    Returns
    -------
    FacetDetection
        Each point's planar facet (``labels``, 0, 1, ... by size, -1 for none), the points
        of grown groups that were not planar (``curved``), the thresholds read from the
        cloud, the grid's edge and scatter, and on rough rock the rough facets (``rough``).

    Examples
    --------
    >>> g = np.mgrid[0:1:40j, 0:1:40j].reshape(2, -1).T
    >>> roof = np.c_[g, np.where(g[:, 0] < 0.5, g[:, 0], 1 - g[:, 0])]
    >>> found = detect_facets(roof)
    >>> int(found.labels.max() + 1), bool((found.labels >= 0).mean() > 0.9)
    (2, True)
    """
    points = np.asarray(points, dtype=np.float64)
    spacing = point_spacing(points)
    cells = coarsened_planes(points, CELL_EDGE * spacing)
    edge, scatter = cells.edge, far_scatter(cells)
    pairs = neighbour_pairs(cells)  # for the thresholds and the growing both
    thresholds = facet_thresholds(cells, spacing, pairs)
    if scatter > MAX_CELL_SCATTER:
        # Rough at every scale tried (an SfM cloud of real rock): no grid facet is trusted;
        # the facets are grown on each point's own plane, and the rest (the face itself, a
        # noisy wall) is left to the voxel growing.
        rough = detect_rough_facets(points, spacing)
        return FacetDetection(rough.labels, np.zeros(len(points), bool), thresholds, edge, scatter, rough)
    labels = label_points(points, cells, grow_cells(cells, thresholds, pairs), thresholds.max_offset)
    labels, curved = planar_facets(points, cells.normal, labels, thresholds, normal_of=cells.point_cell)
    return FacetDetection(labels, curved, thresholds, edge, scatter)


def planar_facets(points, normals, labels, thresholds, normal_of=None) -> tuple[np.ndarray, np.ndarray]:
    """The grown groups (``labels``) that are planar facets, numbered afresh (0, 1, ...),
    and the points of those that are not (curved), as :func:`planar_components` tells
    them; ``normals`` and ``normal_of`` as it takes them.

    A group of one or two points spans no plane: its normal, and so its planarity, is
    whatever the rounding of its coordinates makes it (a cloud moved to UTM flipped some,
    and with them which voxels were grown again). Such a group is no facet, nor curved.
    """
    planar = planar_components(points, normals, labels, thresholds, normal_of=normal_of)
    spans = np.bincount(labels[labels >= 0], minlength=len(planar)) >= 3
    planar &= spans
    curved = (labels >= 0) & ~(planar | ~spans)[np.maximum(labels, 0)] if len(planar) else np.zeros(len(points), bool)
    renumber = np.full(len(planar) + 1, -1)
    renumber[np.flatnonzero(planar)] = np.arange(int(planar.sum()))
    return renumber[labels], curved
