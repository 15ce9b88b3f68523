"""From labelled points to region planes: each region's least-squares plane and rectangle
(:func:`~geostructure.detect.rectangle.region_plane`), then the facets that are not planes of their own
dropped (ribbons along edges) or taken into the plane they are a sparse piece of.

:mod:`.pipeline` calls these between the region growing and the plane table.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from geostructure.core.gridkeys import label_order
from geostructure.core.threads import run_tasks
from geostructure.detect.facets import MIN_FACET_CELLS_ACROSS
from geostructure.detect.merge import MERGE_MIN_POINTS, absorbing_planes
from geostructure.detect.rectangle import region_plane, region_planes_of_segments

#: Facets sampled at under this fraction of the cloud's density (1 / spacing^2) may join a
#: large plane they lie on (:func:`absorb_sparse_facets`).
SPARSE_FACET_DENSITY = 0.25

#: Regions of this many points or more have their planes fitted side by side, a batch of
#: :data:`PLANE_BATCH` between two progress reports.
THREADED_PLANE_POINTS = 20_000
PLANE_BATCH = 16
#: Regions of fewer points are fitted all at once (:func:`~geostructure.detect.rectangle.region_planes_of_segments`):
#: one by one, each hull's call to Qhull costs more than its sums.
SEGMENT_PLANE_POINTS = 2000


def region_planes(points, point_region, voxel_region, min_points, method, report, *, min_voxels=3):
    """Region planes (:class:`~geostructure.detect.rectangle.RegionPlane`) of the regions with ``min_points``
    points and ``min_voxels`` voxels (numbers, or arrays per region), largest first, with the
    region ids they came from."""
    n_regions = max(int(voxel_region.max(initial=-1)), int(point_region.max(initial=-1))) + 1
    n_voxels = np.bincount(voxel_region[voxel_region >= 0], minlength=n_regions)
    labelled = point_region >= 0
    sizes = np.bincount(point_region[labelled], minlength=n_regions)
    candidates = np.flatnonzero((sizes >= min_points) & (n_voxels >= min_voxels))
    candidates = candidates[np.argsort(-sizes[candidates], kind="stable")]
    order = label_order(point_region)
    starts = np.searchsorted(point_region[order], np.arange(len(n_voxels) + 1))
    planes = [None] * len(candidates)

    def fit(i: int) -> None:
        region = candidates[i]
        planes[i] = region_plane(points[order[starts[region] : starts[region + 1]]], method)

    # The large regions (first: largest first) side by side, a batch between two progress
    # reports: numpy lets the lock go in their sums and hulls. Small ones one by one: on
    # them the work is Python's, and two threads only wait on each other (the outcrop's
    # 1,556 regions took 0.47 s in threads, 0.38 s in turn).
    n_large = int(np.count_nonzero(sizes[candidates] >= THREADED_PLANE_POINTS))
    for first in range(0, n_large, PLANE_BATCH):
        last = min(first + PLANE_BATCH, n_large)
        run_tasks([partial(fit, i) for i in range(first, last)])
        report("planes", last, len(candidates))
    small = n_large + np.flatnonzero(sizes[candidates[n_large:]] < SEGMENT_PLANE_POINTS)
    if method == "exact" and len(small):
        # The small regions' points one region after another, in one array.
        regions = candidates[small]
        counts = sizes[regions]
        ends = np.cumsum(counts)
        taken = order[np.repeat(starts[regions] - (ends - counts), counts) + np.arange(ends[-1])]
        for i, plane in zip(small.tolist(), region_planes_of_segments(points[taken], np.r_[0, ends])):
            planes[i] = plane  # None where the hull is degenerate: fitted one by one below
    for i in range(n_large, len(candidates)):
        if planes[i] is None:
            fit(i)
        report("planes", i + 1, len(candidates))
    return planes, candidates


def without_ribbons(regions: list, kept: np.ndarray, is_facet: np.ndarray, cell_edge: float):
    """The region planes less the facets narrower than :data:`~geostructure.detect.facets.MIN_FACET_CELLS_ACROSS`
    cells of their grid (the short side of their rectangle), and how many were dropped."""
    across = np.array([min(r.width, r.height) for r in regions], dtype=np.float64)
    ribbon = is_facet[kept] & (across < MIN_FACET_CELLS_ACROSS * cell_edge)
    keep = np.flatnonzero(~ribbon)
    return [regions[i] for i in keep], kept[keep], int(ribbon.sum())


def absorb_sparse_facets(
    points, point_region, regions: list, kept, theta: float, offset_limit: float, spacing: float, method: str = "exact"
):
    """The region planes once the small, sparse facets lying on a large plane are part of it
    (:func:`~geostructure.detect.merge.absorbing_planes`, with ``theta`` and ``offset_limit``; the takers
    fitted again to all their points, their rectangles by ``method``), still
    largest first, and each absorbed region's id -> its taker's.

    Only facets sampled at under :data:`SPARSE_FACET_DENSITY` of the cloud's density (from
    its point ``spacing``) are taken: stretches of a surface too sparse for the growing to
    cross (the observatory's ground, at an eighth of the walls' density, gave six facets of
    33 to 108 points). A rock joint's small exposures beside a large one are sampled as
    densely as the rest and stay facets of their own: taken in, 13 of 1,555 on the 40 x 16 m
    outcrop, they cost 9 of its 1,218 facets found."""
    sizes = np.array([r.n_points for r in regions], dtype=np.int64)
    density = sizes / np.maximum(np.array([r.area for r in regions], dtype=np.float64), 1e-12)
    small = (sizes < MERGE_MIN_POINTS) & (density < SPARSE_FACET_DENSITY / spacing**2)
    target = absorbing_planes(regions, small, theta, offset_limit)
    absorbed = np.flatnonzero(target >= 0)
    if not len(absorbed):
        return regions, kept, {}
    regions = list(regions)
    for taker in np.unique(target[absorbed]):
        members = np.append(kept[absorbed[target[absorbed] == taker]], kept[taker])
        regions[taker] = region_plane(points[np.isin(point_region, members)], method)
    left = np.flatnonzero(target < 0)
    left = left[np.argsort([-regions[i].n_points for i in left], kind="stable")]
    return [regions[i] for i in left], kept[left], {int(kept[i]): int(kept[target[i]]) for i in absorbed}
