"""Merge coplanar regions: one surface broken by a gap (a gully, a bush, a doorway) is one plane.

Region growing only joins voxels that touch, so a bedding surface cut by a gully, or a wall
cut by a projecting bay, comes out as several regions of the same plane. This step joins
regions whose planes agree within the growth's own limits (normals within ``theta``, the
centroids within the offset limit along the pair's mean normal) and whose gap is no wider than the
smaller of the two (so distant outcrops that happen to be coplanar stay apart). It is not
in the paper; ``Params(merge=False)`` gives the paper's regions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import DisjointSet
from scipy.spatial import cKDTree

from geostructure.detect.voxel import VoxelPlanes

#: With the facet detector, the coplanar merge joins only regions of this many points or more:
#: a wall split by a bay is one plane, while the separate exposures of a rock joint stay the
#: separate facets a geologist maps (joined, their centroid would fall between them). A count
#: of points, not voxels: the voxel edge follows the cloud's extent, the points its sampling.
MERGE_MIN_POINTS = 5000


@dataclass
class RegionSummary:
    """Plane of each region from its voxels: centroid, unit normal, diameter (cloud units) and
    weight (points)."""

    centroid: np.ndarray
    normal: np.ndarray
    diameter: np.ndarray
    weight: np.ndarray


def summarise_regions(voxels: VoxelPlanes, labels: np.ndarray, n_regions: int) -> RegionSummary:
    """Point-weighted plane of each region, from the voxel centroids' spread plus each
    voxel's own thickness along its normal (its points are not kept here)."""
    mask = labels >= 0
    lab, w = labels[mask], voxels.count[mask].astype(float)
    c, n, r = voxels.centroid[mask], voxels.normal[mask], voxels.residual[mask]
    total = np.bincount(lab, w, n_regions)
    centroid: np.ndarray = np.stack([np.bincount(lab, w * c[:, a], n_regions) for a in range(3)], axis=1)
    centroid /= np.maximum(total, 1e-300)[:, None]
    d = c - centroid[lab]
    scatter = np.empty((n_regions, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            entry = w * (d[:, i] * d[:, j] + r**2 * n[:, i] * n[:, j])
            scatter[:, i, j] = scatter[:, j, i] = np.bincount(lab, entry, n_regions)
    _, vectors = np.linalg.eigh(scatter)
    lo = np.full((n_regions, 3), np.inf)
    hi = np.full((n_regions, 3), -np.inf)
    np.minimum.at(lo, lab, c)
    np.maximum.at(hi, lab, c)
    diameter = np.linalg.norm(np.where(np.isfinite(hi - lo), hi - lo, 0.0), axis=1)
    return RegionSummary(centroid, vectors[:, :, 0], diameter, total)


def merge_coplanar(
    voxels: VoxelPlanes, labels: np.ndarray, theta: float, offset_limit: float, min_voxels: int = 3, max_rounds: int = 5
) -> tuple[np.ndarray, int]:
    """Relabel voxel regions so that coplanar regions separated by a small gap share a label.

    Parameters
    ----------
    voxels : VoxelPlanes
    labels : (V,) int
        Region of each voxel plane, -1 for none.
    theta : float
        Largest angle between the two regions' normals, degrees.
    offset_limit : float
        Largest distance between the two centroids along the pair's mean normal (cloud units).
    min_voxels : int
        Regions with fewer voxels have no reliable plane and are left alone.

    Returns
    -------
    labels : (V,) int
        Regions numbered 0..m-1 again.
    merges : int
        How many joins were made.

    Rounds repeat on the merged regions until none joins: a wall that region growing cut into
    several small pieces is first put together, and only then, as one large region with a
    well-determined plane, can it reach across a gap wider than any of its pieces.
    """
    total = 0
    for _ in range(max_rounds):
        labels, merges = _merge_round(voxels, labels, theta, offset_limit, min_voxels)
        total += merges
        if not merges:
            break
    return labels, total


def _merge_round(voxels, labels, theta, offset_limit, min_voxels):
    n_regions = int(labels.max()) + 1 if len(labels) and labels.max() >= 0 else 0
    if n_regions < 2:
        return labels.copy(), 0
    size = np.bincount(labels[labels >= 0], minlength=n_regions)
    regions = np.flatnonzero(size >= min_voxels)
    summary = summarise_regions(voxels, labels, n_regions)
    normal, centroid = summary.normal[regions], summary.centroid[regions]
    diameter, weight = summary.diameter[regions], summary.weight[regions]
    pairs = _coplanar_pairs(normal, centroid, weight, np.cos(np.radians(theta)), offset_limit)
    joined = DisjointSet(range(n_regions))
    order = np.argsort(labels, kind="stable")
    starts = np.searchsorted(labels[order], np.arange(n_regions + 1))
    members = {r: voxels.centroid[order[starts[r] : starts[r + 1]]] for r in regions[np.unique(pairs)]}
    trees = {r: cKDTree(pts) for r, pts in members.items()}
    merges = 0
    for i, j in pairs:
        a, b = regions[i], regions[j]
        if joined.connected(a, b):  # joined through others already: nothing to test
            continue
        nearest, _ = trees[b].query(members[a], k=1)
        if nearest.min() <= min(diameter[i], diameter[j]) and joined.merge(a, b):
            merges += 1
    if not merges:
        return labels.copy(), 0
    root = np.array([joined[r] for r in range(n_regions)])
    _, renumbered = np.unique(root, return_inverse=True)
    out = np.full_like(labels, -1)
    out[labels >= 0] = renumbered[labels[labels >= 0]]
    return out, merges


def _coplanar_pairs(normal, centroid, weight, cos_theta, offset_limit, block=512):
    """(i, j) with i < j whose normals agree and whose centroids lie within ``offset_limit`` of
    each other along the pair's weighted mean normal (not along either normal alone: a 1 degree
    difference over a 4 m gap is 7 cm); in row blocks, so memory stays O(block x regions)."""
    own = np.einsum("ij,ij->i", centroid, normal)
    found = []
    for start in range(0, len(normal), block):
        rows = slice(start, start + block)
        cos = normal[rows] @ normal.T
        sign = np.where(cos < 0, -1.0, 1.0)
        a = normal[rows] @ centroid.T - own[rows, None]  # j's centroid from i's plane (signed)
        b = own[None, :] - centroid[rows] @ normal.T  # the same along j's normal
        wi, wj = weight[rows, None], weight[None, :]
        length = np.sqrt(wi**2 + wj**2 + 2 * wi * wj * np.abs(cos))
        offset = np.abs(wi * a + sign * wj * b) / length
        i, j = np.nonzero((np.abs(cos) >= cos_theta) & (offset <= offset_limit))
        i += start
        found.append(np.c_[i, j][i < j])
    return np.concatenate(found) if found else np.zeros((0, 2), int)


def absorbing_planes(regions: list, small: np.ndarray, theta: float, offset_limit: float) -> np.ndarray:
    """For each region plane (:class:`~geostructure.detect.rectangle.RegionPlane`), the large plane that takes
    it in, or -1: ``small`` (bool, per plane) ones only, never into each other.

    A sparse stretch of a surface (the ground between an observatory's walls, sampled at a
    third of their density) breaks into small facets the growing cannot join to the
    surface's large region, and :func:`merge_coplanar` leaves regions under its size alone
    so that a rock joint's separate exposures stay separate facets. A small plane lies on
    a large one when its normal is within ``theta`` degrees of the large one's, its centroid
    and its rectangle's four corners within ``offset_limit`` of the large plane, and its
    rectangle no farther beyond the large rectangle than its own diameter (the gap
    :func:`merge_coplanar` allows): a piece of that surface. Of several, the one its
    centroid lies nearest to.

    Examples
    --------
    >>> from geostructure.detect.rectangle import region_plane
    >>> g, p = (np.mgrid[0:s:n, 0:s:n].reshape(2, -1).T for s, n in ((10, 41j), (1, 6j)))
    >>> ground = region_plane(np.c_[g, np.zeros(len(g))])
    >>> piece = region_plane(np.c_[p + 3, np.full(len(p), 0.01)])  # 1 cm above the ground
    >>> wall = region_plane(np.c_[np.full(len(p), 3.0), p + [3, 0]])  # standing on it
    >>> absorbing_planes([ground, piece, wall], np.array([False, True, True]), 5.0, 0.05).tolist()
    [-1, 0, -1]
    """
    small = np.asarray(small, dtype=bool)
    target = np.full(len(regions), -1)
    large = np.flatnonzero(~small)
    if not len(large) or not small.any():
        return target
    normal = np.array([regions[j].normal for j in large])
    centroid = np.array([regions[j].centroid for j in large])
    centre = np.array([regions[j].center for j in large])
    u, v = np.array([regions[j].u for j in large]), np.array([regions[j].v for j in large])
    half = np.array([[regions[j].width / 2, regions[j].height / 2] for j in large])
    cos_theta = np.cos(np.radians(theta))
    for i in np.flatnonzero(small):
        piece = regions[i]
        points = np.vstack([piece.centroid, piece.corners])  # (5, 3)
        height = np.abs(np.einsum("lk,lpk->lp", normal, points[None, :, :] - centroid[:, None, :]))
        along = piece.center - centre
        reach = max(piece.width, piece.height) / 2 + np.hypot(piece.width, piece.height)  # a gap of its size
        inside = (np.abs(np.einsum("lk,lk->l", u, along)) <= half[:, 0] + reach) & (
            np.abs(np.einsum("lk,lk->l", v, along)) <= half[:, 1] + reach
        )
        fits = (np.abs(normal @ piece.normal) >= cos_theta) & (height.max(axis=1) <= offset_limit) & inside
        if fits.any():
            target[i] = large[np.flatnonzero(fits)[np.argmin(height[fits, 0])]]
    return target
