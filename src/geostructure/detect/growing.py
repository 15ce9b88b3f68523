"""How each detector grows its regions (:data:`~geostructure.detect.registry.DETECTORS`
names them): the paper's voxel growing, and facets grown on the points with the voxel
growing where a facet is curved. Each returns a :class:`Growth`; the pipeline
(:func:`~geostructure.detect.pipeline.measure`) makes the planes of it, whichever grew it."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.core.params import Params
from geostructure.detect.facets import FacetDetection, detect_facets, voxel_majority
from geostructure.detect.merge import MERGE_MIN_POINTS, merge_coplanar
from geostructure.detect.regions import grow_regions
from geostructure.detect.roughfacets import MIN_FACET_POINTS, numbered_by_size
from geostructure.detect.voxel import VoxelPlanes, subset_voxels

#: A voxel more than this share of whose points no facet took goes to the voxel growing with
#: the curved facets' voxels (see :func:`grow_facets_then_voxels`).
UNCLAIMED_SHARE = 0.5


@dataclass
class Growth:
    """Each point's and each voxel's region (-1: none); for facets, also what their detector
    recorded, which regions are facets, rough rock's face directions (``envelope``, None
    elsewhere) and the facets found (``found``, for a thinned survey's)."""

    point_region: np.ndarray
    region_of_voxel: np.ndarray
    facet_record: dict = field(default_factory=dict)
    facet_region: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    envelope: np.ndarray | None = None
    found: FacetDetection | None = None


def grow_voxel_regions(
    filtered: Cloud, voxels: VoxelPlanes, params: Params, report, counts: dict, facets=None, keep=None
) -> Growth:
    """The voxel detector: the paper's region growing over the voxel planes, then the
    coplanar merge. ``facets`` and ``keep`` are the facet detector's and unused."""
    report("regions", 0, None)  # the growing reports its own progress after this
    return Growth(*_voxel_regions(filtered, voxels, params, report, counts))


def grow_facets_then_voxels(
    filtered: Cloud, voxels: VoxelPlanes, params: Params, report, counts: dict, facets=None, keep=None
) -> Growth:
    """The facet detector: facets grown on the points (:func:`~geostructure.detect.facets.detect_facets`,
    or ``facets(filtered, keep, report)``, those found elsewhere: a thinned survey's, in
    tiles of every point), with the voxel growing where a facet is curved or the points are
    unclaimed."""
    report("regions", 0, None)
    found = detect_facets(filtered.local) if facets is None else facets(filtered, keep, report)
    point_region, region_of_voxel, record, is_facet, envelope = _facets_then_voxels(
        filtered, voxels, params, report, counts, found
    )
    return Growth(point_region, region_of_voxel, record, is_facet, envelope, found)


def _voxel_regions(filtered: Cloud, voxels: VoxelPlanes, params: Params, report, counts: dict):
    """The paper's region growing over voxel planes (then the coplanar merge): each point's
    and each voxel's region."""
    growth = grow_regions(
        voxels,
        params.theta,
        params.psi,
        params.k,
        reference=params.reference,
        max_gap=params.max_gap,
        progress=lambda done: report("regions", done, len(voxels)),
    )
    region_of_voxel = growth.labels
    if params.merge:
        region_of_voxel, counts["merges"] = merge_coplanar(
            voxels, growth.labels, params.theta, params.psi * voxels.edge
        )
    counts["regions"] = growth.n_regions
    point_region = np.full(len(filtered), -1, dtype=np.int64)
    fitted = voxels.point_voxel >= 0
    point_region[fitted] = region_of_voxel[voxels.point_voxel[fitted]]
    return point_region, region_of_voxel


def _facets_then_voxels(filtered: Cloud, voxels: VoxelPlanes, params: Params, report, counts: dict, found):
    """Facets grown on a fine grid's local planes (``found``, :func:`~geostructure.detect.facets.detect_facets`'s); where a grown group
    is not planar (it drifted round a curved surface), or where most points of a voxel are in
    no facet (a surface noisier than the grid was chosen for), the paper's voxel region
    growing over those voxels. Also returns which of the regions are facets."""
    sub_counts: dict = {}
    if found.rough is not None:
        # Rough rock: the paper's voxel growing over the whole cloud, as before the rough
        # facets; they take their points out of its regions, except out of large ones.
        every = subset_voxels(voxels, np.ones(len(voxels), dtype=bool))  # as the regrowing below
        whole = _voxel_regions(filtered, every, params, report, sub_counts)
        found = _outside_large_surfaces(found, whole[0])
    point_region = found.labels.copy()
    n_facets = int(point_region.max(initial=-1)) + 1
    # The voxels to grow: those of curved facets, and those most of whose points no facet
    # took (a surface rougher or noisier than the face the grid was chosen for: a road
    # before a rock cut, the far end of an SfM cloud).
    unclaimed = (point_region < 0) | found.curved
    on = voxels.point_voxel >= 0
    total = np.bincount(voxels.point_voxel[on], minlength=len(voxels))
    free = np.bincount(voxels.point_voxel[on & unclaimed], minlength=len(voxels))
    regrow = free > UNCLAIMED_SHARE * total
    regrow[voxels.point_voxel[found.curved & on]] = True
    if found.rough is not None:
        regrow[:] = True  # grown above, whole
    regrown = unclaimed & on
    regrown[on] &= regrow[voxels.point_voxel[on]]
    region_of_voxel = voxel_majority(voxels.point_voxel, point_region, len(voxels))
    if regrow.any():
        if found.rough is not None:
            sub_points, sub_region = whole
        else:
            sub_points, sub_region = _voxel_regions(filtered, subset_voxels(voxels, regrow), params, report, sub_counts)
        take = regrown & (sub_points >= 0)
        point_region[take] = n_facets + sub_points[take]
        region_of_voxel[regrow] = np.where(sub_region >= 0, n_facets + sub_region, -1)
    counts["regions"] = n_facets + sub_counts.get("regions", 0)
    is_facet = np.arange(max(int(point_region.max(initial=-1)), int(region_of_voxel.max(initial=-1))) + 1) < n_facets
    if params.merge:  # large regions of one plane split by a small gap: one plane, as with the voxel growing
        # At least one bin: voxels that all lie in no region (a cloud along a line) index it.
        size = np.bincount(point_region[point_region >= 0], minlength=max(int(region_of_voxel.max(initial=-1)) + 1, 1))
        large = np.where(region_of_voxel >= 0, size[np.maximum(region_of_voxel, 0)] >= MERGE_MIN_POINTS, False)
        merged, merges = merge_coplanar(
            voxels, np.where(large, region_of_voxel, -1), params.theta, params.psi * voxels.edge
        )
        counts["merges"] = sub_counts.get("merges", 0) + merges
        point_region, region_of_voxel, new = _relabel(point_region, region_of_voxel, merged)
        # The merge numbers the regions afresh, so a facet's new number may be past the
        # facets' (it was then held to the voxel regions' size: on a rock cut with a road,
        # the road's one voxel region cost 270 of 440 facets).
        renumbered = np.zeros(int(new.max(initial=-1)) + 1, dtype=bool)
        renumbered[new[:-1][is_facet]] = True
        is_facet = renumbered
    return (
        point_region,
        region_of_voxel,
        found.record(),
        is_facet,
        None if found.rough is None else found.rough.envelope,
    )


def _outside_large_surfaces(found, point_region: np.ndarray):
    """Rough rock's facets (:mod:`.roughfacets`) only where the paper's voxel growing, over
    the whole cloud (each point's region ``point_region``), grew no large surface
    (:data:`~geostructure.detect.merge.MERGE_MIN_POINTS` points or more: a wall, a roof, a road): on the Sceaux
    Castle's noisy facade they had cut its walls apart; on the real outcrop no voxel region
    is that large, and nothing changes."""
    size = np.bincount(point_region[point_region >= 0], minlength=1)
    large = (point_region >= 0) & (size[np.maximum(point_region, 0)] >= MERGE_MIN_POINTS)
    if not large.any():
        return found
    labels = np.where(large, -1, found.labels)
    count = np.bincount(labels[labels >= 0], minlength=int(found.labels.max(initial=-1)) + 1)
    kept = np.flatnonzero(count >= MIN_FACET_POINTS)
    return dataclasses.replace(found, labels=numbered_by_size(labels, kept, count))


def _relabel(point_region: np.ndarray, voxel_region: np.ndarray, merged_voxels: np.ndarray):
    """Carry a merge of the voxels' regions over to the points; regions without a voxel keep
    a number of their own. Also returns the map, old number -> new (its last entry: -1)."""
    n = max(int(point_region.max(initial=-1)), int(voxel_region.max(initial=-1))) + 1
    new = np.full(n + 1, -1, dtype=np.int64)  # the last entry maps -1 to -1
    has = voxel_region >= 0
    new[voxel_region[has]] = merged_voxels[has]
    lonely = np.flatnonzero(new[:n] < 0)
    new[lonely] = int(merged_voxels.max(initial=-1)) + 1 + np.arange(len(lonely))
    return new[point_region], new[voxel_region], new
