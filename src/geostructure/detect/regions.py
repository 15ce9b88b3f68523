"""kNN region growing over voxel planes (after Rabbani et al. 2006).

Seeds are taken in order of best fit (smallest residual). From the current seed, each of
its ``k`` nearest voxel planes joins the region when

- **theta**: the angle between its normal and the reference normal is at most ``theta``
  degrees, and
- **psi**: its centroid lies within ``psi`` voxel edges of the current seed's plane
  (the offset residual of the paper, measured in voxel edges so it keeps its meaning when
  the cloud is scaled: the original code took cloud units).

The reference normal is the region's own plane (refitted from its summed moments as it
grows) by default, so a region cannot drift round a gently curving surface; ``reference=
"seed"`` compares with the current seed as the paper's description does. Neighbours more
than ``max_gap`` voxel edges away are not neighbours, so regions do not jump across gaps.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core import params
from geostructure.core.threads import tree_query
from geostructure.detect.voxel import VoxelPlanes

REFERENCES = params.REFERENCES


@dataclass
class RegionGrowth:
    """``labels`` (V,) gives each voxel plane its region (0, 1, ...) or -1."""

    labels: np.ndarray
    n_regions: int


def neighbour_graph(centroids: np.ndarray, k: int, max_distance: float) -> np.ndarray:
    """Indices (V, k) of each centroid's k nearest others within ``max_distance``; -1 pads."""
    if len(centroids) < 2:
        return np.full((len(centroids), k), -1, dtype=np.int64)
    tree = cKDTree(centroids)
    kq = min(k + 1, len(centroids))
    dist, idx = tree_query(tree, centroids, kq, distance_upper_bound=max_distance)
    idx = np.where(np.isfinite(dist), idx, -1).reshape(len(centroids), kq)
    self_column = idx == np.arange(len(centroids))[:, None]
    idx[self_column] = -1
    # Drop the self column: keep the first k non-self entries per row.
    order = np.argsort(idx < 0, axis=1, kind="stable")
    idx = np.take_along_axis(idx, order, axis=1)[:, :k]
    if idx.shape[1] < k:
        idx = np.pad(idx, ((0, 0), (0, k - idx.shape[1])), constant_values=-1)
    return idx


def grow_regions(
    planes: VoxelPlanes,
    theta: float,
    psi: float,
    k: int,
    *,
    reference: str = "region",
    max_gap: float = 2.0,
    progress=None,
) -> RegionGrowth:
    """Group voxel planes into regions of like orientation and offset.

    Parameters
    ----------
    planes : VoxelPlanes
    theta : float
        Angle threshold in degrees.
    psi : float
        Offset threshold in voxel edges.
    k : int
        Neighbours considered around each seed.
    reference : {"region", "seed"}
        What the angle is measured against.
    max_gap : float
        Neighbours further than this many voxel edges are ignored.
    progress : callable, optional
        Called with the number of voxel planes assigned so far.
    """
    n = len(planes)
    labels = np.full(n, -1, dtype=np.int64)
    if n == 0:
        return RegionGrowth(labels, 0)
    neighbours = neighbour_graph(planes.centroid, k, max_gap * planes.edge)
    normal = planes.normal
    centroid = planes.centroid
    weight = planes.count.astype(np.float64)
    cos_theta = np.cos(np.radians(theta))
    offset_limit = psi * planes.edge
    order = np.argsort(planes.residual, kind="stable")
    region = 0
    assigned = 0
    for start in order:
        if labels[start] >= 0:
            continue
        labels[start] = region
        members = [start]
        ref_normal = normal[start]
        refit_at = 4
        queue = deque([start])
        while queue:
            seed = queue.popleft()
            cand = neighbours[seed]
            cand = cand[cand >= 0]
            cand = cand[labels[cand] < 0]
            if not len(cand):
                continue
            against = ref_normal if reference == "region" else normal[seed]
            aligned = np.abs(normal[cand] @ against) >= cos_theta
            offset = np.abs((centroid[cand] - centroid[seed]) @ normal[seed])
            accepted = cand[aligned & (offset <= offset_limit)]
            if not len(accepted):
                continue
            labels[accepted] = region
            members.extend(accepted.tolist())
            queue.extend(accepted.tolist())
            if reference == "region" and len(members) >= refit_at:
                ref_normal = _weighted_normal(normal[members], weight[members], ref_normal)
                refit_at = int(len(members) * 1.25) + 1
        assigned += len(members)
        region += 1
        if progress is not None:
            progress(assigned)
    return RegionGrowth(labels, region)


def _weighted_normal(normals: np.ndarray, weights: np.ndarray, like: np.ndarray) -> np.ndarray:
    """Principal direction of sign-free normals (the region's mean normal), signed like ``like``."""
    m = (normals * weights[:, None]).T @ normals
    _, vectors = np.linalg.eigh(m)
    n = vectors[:, -1]
    return n if n @ like >= 0 else -n
