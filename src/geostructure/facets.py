"""Small facets on rough rock: per-point normals and planar region growing on the points.

The voxel pipeline (the paper's) fits one plane per voxel, so a joint face must span a few
voxels to be found, and a voxel must be large against the noise for its normal to mean
anything: on a rough outcrop at 3 cm spacing that puts the smallest face found near a
metre across, while most joints are half that. Here every point gets its own plane, from
its ``k`` nearest neighbours (as DSE, Riquelme et al. 2014, and Facets' kd-tree mode do),
and facets are the connected groups of points whose planes agree:

1. **Normals and planarity**: the covariance of each point's ``k`` neighbours gives its
   normal (the smallest eigenvector) and its surface variation lambda_0 / (lambda_0 +
   lambda_1 + lambda_2) (Pauly et al. 2002): near 0 on a plane, up to 1/3 where the
   neighbourhood straddles an edge or a step. Points above ``max_variation`` are edges and
   belong to no facet, which is what keeps two faces meeting at an edge apart.
2. **Growing**: two neighbouring planar points join when their normals are within
   ``max_angle`` degrees and each lies within ``max_offset`` of the other's plane (the
   coplanarity test; it separates parallel joints of one set that step past each other).
   The facets are the connected components of that graph, found at once by
   ``scipy.sparse.csgraph`` rather than seed by seed.

The thresholds come from the cloud itself (:func:`facet_thresholds`): the point spacing and
the noise of the local fits, so a LiDAR cloud at 1 cm and an SfM cloud at 3 cm are treated
alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

#: Neighbours per point for its normal (DSE's default) and, of those, the nearest used as
#: graph edges.
NORMAL_NEIGHBOURS = 30
GRAPH_NEIGHBOURS = 10
#: Points per batch of covariance matrices (bounds memory at ~50 MB a batch).
BATCH = 100_000


@dataclass
class PointPlanes:
    """Per point: unit ``normal`` (N, 3), ``variation`` (N,), ``residual`` (N,) RMS distance
    of its neighbours to its plane, and the indices (N, k) of its nearest neighbours, the
    point itself first."""

    normal: np.ndarray
    variation: np.ndarray
    residual: np.ndarray
    neighbours: np.ndarray
    distances: np.ndarray


@dataclass(frozen=True)
class FacetThresholds:
    """What two neighbouring points must satisfy to belong to one facet."""

    max_angle: float  # degrees between their normals
    max_offset: float  # distance from one to the other's plane (cloud units)
    max_variation: float  # surface variation of either
    spacing: float  # the cloud's median point spacing, for reference


def point_planes(points: np.ndarray, k: int = NORMAL_NEIGHBOURS) -> PointPlanes:
    """Each point's least-squares plane through its ``k`` nearest neighbours.

    Examples
    --------
    >>> g = np.mgrid[0:1:30j, 0:1:30j].reshape(2, -1).T
    >>> planes = point_planes(np.c_[g, 0.5 * g[:, 0]])
    >>> bool(np.allclose(np.abs(planes.normal @ [-0.5, 0, 1]) / np.hypot(0.5, 1), 1))
    True
    """
    points = np.asarray(points, dtype=np.float64)
    k = min(k, len(points))
    distances, neighbours = cKDTree(points).query(points, k=k, workers=-1)
    normal = np.empty((len(points), 3))
    variation = np.empty(len(points))
    residual = np.empty(len(points))
    for start in range(0, len(points), BATCH):
        block = points[neighbours[start : start + BATCH]]
        centred = block - block.mean(axis=1, keepdims=True)
        values, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", centred, centred) / k)
        values = np.maximum(values, 0.0)
        normal[start : start + BATCH] = vectors[:, :, 0]
        variation[start : start + BATCH] = values[:, 0] / np.maximum(values.sum(axis=1), 1e-300)
        residual[start : start + BATCH] = np.sqrt(values[:, 0])
    return PointPlanes(normal, variation, residual, neighbours, distances)


def facet_thresholds(planes: PointPlanes) -> FacetThresholds:
    """Thresholds read from the cloud: spacing, local-fit noise and how normals scatter.

    - the offset a neighbour may lie off a point's plane is 3 times the median local-fit
      residual (the noise and roughness at the neighbourhood's scale), at least a third of
      the point spacing;
    - the angle is 3 times the median angle between neighbouring normals, clipped to 5 to
      15 degrees: above the scatter of one rough face, below the angle at which joints of
      different sets meet;
    - the surface variation is 3 times its median, clipped to 0.01 to 0.1.
    """
    spacing = float(np.median(planes.distances[:, 1])) if planes.distances.shape[1] > 1 else 0.0
    first = planes.neighbours[:, 1] if planes.neighbours.shape[1] > 1 else np.arange(len(planes.normal))
    cosine = np.abs(np.einsum("ij,ij->i", planes.normal, planes.normal[first]))
    scatter = float(np.degrees(np.median(np.arccos(np.clip(cosine, 0.0, 1.0)))))
    return FacetThresholds(
        max_angle=float(np.clip(3.0 * scatter, 5.0, 15.0)),
        max_offset=max(3.0 * float(np.median(planes.residual)), spacing / 3.0),
        max_variation=float(np.clip(3.0 * np.median(planes.variation), 0.01, 0.1)),
        spacing=spacing,
    )


def grow_facets(points: np.ndarray, planes: PointPlanes, thresholds: FacetThresholds) -> np.ndarray:
    """Label each point with its facet (0, 1, ..., largest first) or -1 (an edge, or alone).

    Examples
    --------
    >>> g = np.mgrid[0:1:40j, 0:1:40j].reshape(2, -1).T
    >>> roof = np.c_[g, np.where(g[:, 0] < 0.5, g[:, 0], 1 - g[:, 0])]  # two faces meeting at a ridge
    >>> planes = point_planes(roof)
    >>> labels = grow_facets(roof, planes, facet_thresholds(planes))
    >>> int(labels.max() + 1), bool(labels[roof[:, 0] < 0.4].min() == labels[roof[:, 0] < 0.4].max())
    (2, True)
    """
    n = len(points)
    m = min(GRAPH_NEIGHBOURS + 1, planes.neighbours.shape[1])
    source = np.repeat(np.arange(n), m - 1)
    target = planes.neighbours[:, 1:m].ravel()
    flat = planes.variation <= thresholds.max_variation
    gap = points[target] - points[source]
    ok = flat[source] & flat[target]
    ok &= np.abs(np.einsum("ij,ij->i", planes.normal[source], planes.normal[target])) >= np.cos(
        np.radians(thresholds.max_angle)
    )
    ok &= np.abs(np.einsum("ij,ij->i", gap, planes.normal[source])) <= thresholds.max_offset
    ok &= np.abs(np.einsum("ij,ij->i", gap, planes.normal[target])) <= thresholds.max_offset
    graph = coo_matrix((np.ones(int(ok.sum()), dtype=np.int8), (source[ok], target[ok])), shape=(n, n))
    _, component = connected_components(graph, directed=False)
    component = np.where(flat, component, -1)
    sizes = np.bincount(component[component >= 0], minlength=1)
    order = np.argsort(-sizes, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    labels = np.where(component >= 0, rank[np.maximum(component, 0)], -1)
    alone = np.bincount(np.maximum(labels, 0), minlength=1)[np.maximum(labels, 0)] < 2
    return np.where(alone, -1, labels)
