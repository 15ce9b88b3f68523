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

#: How regions are found: the paper's voxel-plane growing, or facets grown on the points.
DETECTORS = ("facets", "voxel")
#: Neighbours per point for its normal (DSE's default) and, of those, the nearest used as
#: graph edges.
NORMAL_NEIGHBOURS = 30
GRAPH_NEIGHBOURS = 6
#: Points per batch of covariance matrices (bounds memory at ~50 MB a batch).
BATCH = 100_000
#: Largest median angle (degrees) between a point's normal and its farthest neighbour's for
#: the normals to be trusted; rougher than that at the cloud's own spacing (a dense LiDAR
#: scan of rough rock), the cloud is thinned until its neighbourhoods are wide enough.
MAX_FAR_SCATTER = 3.5
THINNING_ROUNDS = 3


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

    @property
    def spacing(self) -> float:
        """The cloud's point spacing: the median distance to the nearest neighbour."""
        return float(np.median(self.distances[:, 1])) if self.distances.shape[1] > 1 else 0.0


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
        # About the point itself (well conditioned), the six distinct moments one by one:
        # much faster than an einsum over (n, k, 3, 3).
        rel = points[neighbours[start : start + BATCH]] - points[start : start + BATCH, None, :]
        mean = rel.mean(axis=1)
        cov = np.empty((len(rel), 3, 3))
        for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)):
            cov[:, i, j] = cov[:, j, i] = (rel[:, :, i] * rel[:, :, j]).mean(axis=1) - mean[:, i] * mean[:, j]
        values, vectors = np.linalg.eigh(cov)
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
    spacing = planes.spacing
    first = planes.neighbours[:, 1] if planes.neighbours.shape[1] > 1 else np.arange(len(planes.normal))
    cosine = np.abs(np.einsum("ij,ij->i", planes.normal, planes.normal[first]))
    scatter = float(np.degrees(np.median(np.arccos(np.clip(cosine, 0.0, 1.0)))))
    return FacetThresholds(
        max_angle=float(np.clip(3.0 * scatter, 5.0, 15.0)),
        max_offset=max(3.0 * float(np.median(planes.residual)), spacing / 3.0),
        max_variation=float(np.clip(3.0 * np.median(planes.variation), 0.01, 0.1)),
        spacing=spacing,
    )


def planar_components(points: np.ndarray, planes: PointPlanes, labels: np.ndarray, thresholds: FacetThresholds):
    """Which grown facets are planes (True) and which drifted round a curved surface (False).

    Connected components have no reference normal, so on a smooth curved surface (a Poisson
    mesh's rounded edges, a dome) they grow round it. A facet is planar when its points lie
    within twice the coplanarity offset of its least-squares plane (RMS) and four in five of
    their normals within twice the angle of the plane's normal.
    """
    n = int(labels.max(initial=-1)) + 1
    if n == 0:
        return np.zeros(0, dtype=bool)
    ok = labels >= 0
    lab, p = labels[ok], points[ok]
    count = np.bincount(lab, minlength=n).astype(np.float64)
    mean = np.stack([np.bincount(lab, p[:, a], n) for a in range(3)], axis=1) / count[:, None]
    d = p - mean[lab]
    cov = (
        np.stack([np.bincount(lab, d[:, a] * d[:, b], n) for a in range(3) for b in range(3)], axis=1).reshape(n, 3, 3)
        / count[:, None, None]
    )
    values, vectors = np.linalg.eigh(cov)
    residual = np.sqrt(np.maximum(values[:, 0], 0.0))
    normal = vectors[:, :, 0]
    aligned = np.abs(np.einsum("ij,ij->i", planes.normal[ok], normal[lab])) >= np.cos(
        np.radians(2.0 * thresholds.max_angle)
    )
    share = np.bincount(lab, aligned.astype(np.float64), n) / count
    return (residual <= 2.0 * thresholds.max_offset) & (share >= 0.8)


@dataclass
class FacetDetection:
    """Facets found on a cloud: ``labels`` (N,) numbers each point's planar facet (0, 1, ...
    by size) or -1; ``curved`` (N,) marks the points of grown groups that were not planar."""

    labels: np.ndarray
    curved: np.ndarray
    thresholds: FacetThresholds
    thinning: float  # grid edge the normals were computed on (0: the cloud as it is)
    far_scatter: float

    def record(self) -> dict:
        """What ``run.json`` says of the detection."""
        return {
            "detector": "facets",
            "facet_thresholds": {k: float(v) for k, v in vars(self.thresholds).items()},
            "thinning": self.thinning,
            "far_scatter_deg": self.far_scatter,
            "planar_facets": int(self.labels.max(initial=-1)) + 1,
            "curved_points": int(self.curved.sum()),
        }


def far_scatter(planes: PointPlanes) -> float:
    """Median angle (degrees) between each point's normal and its farthest neighbour's."""
    far = planes.neighbours[:, -1]
    cosine = np.abs(np.einsum("ij,ij->i", planes.normal, planes.normal[far]))
    return float(np.degrees(np.median(np.arccos(np.clip(cosine, 0.0, 1.0)))))


def thin(points: np.ndarray, edge: float) -> np.ndarray:
    """Indices of one point per grid cell of ``edge`` (the first in the cloud's order)."""
    keys = np.floor((points - points.min(axis=0)) / edge).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    return np.sort(first)


def detect_facets(points: np.ndarray) -> FacetDetection:
    """Per-point planes, thresholds from the cloud, facets grown and checked for planarity.

    When the normals scatter more than :data:`MAX_FAR_SCATTER` at the cloud's own spacing
    (rock rough at that scale), the detection runs on a thinned copy (a grid of twice the
    spacing, then four times, ...) and every point takes the facet of its nearest kept point
    when it lies on that point's plane. When they still scatter more after the last thinning
    (a noisy SfM cloud), no facet is trusted: every point is left to the voxel growing.

    Examples
    --------
    >>> g = np.mgrid[0:1:40j, 0:1:40j].reshape(2, -1).T
    >>> roof = np.c_[g, np.where(g[:, 0] < 0.5, g[:, 0], 1 - g[:, 0])]
    >>> found = detect_facets(roof)
    >>> int(found.labels.max() + 1), found.thinning
    (2, 0.0)
    """
    points = np.asarray(points, dtype=np.float64)
    kept = np.arange(len(points))
    planes = point_planes(points)
    scatter = far_scatter(planes)
    spacing = planes.spacing
    edge = 0.0
    for round_ in range(1, THINNING_ROUNDS + 1):
        if scatter <= MAX_FAR_SCATTER or spacing <= 0:
            break
        trial_edge = 2.0**round_ * spacing
        trial = thin(points, trial_edge)
        if len(trial) < 100:
            break
        kept, edge = trial, trial_edge
        planes = point_planes(points[kept])
        scatter = far_scatter(planes)
    thresholds = facet_thresholds(planes)
    sub = points[kept]
    if scatter > MAX_FAR_SCATTER:  # noisy at every scale tried (a rough SfM cloud): no facet is trusted
        return FacetDetection(np.full(len(points), -1), np.ones(len(points), bool), thresholds, edge, scatter)
    labels = grow_facets(sub, planes, thresholds)
    planar = planar_components(sub, planes, labels, thresholds)
    curved = (labels >= 0) & ~planar[np.maximum(labels, 0)] if len(planar) else np.zeros(len(sub), bool)
    renumber = np.full(len(planar) + 1, -1)
    renumber[np.flatnonzero(planar)] = np.arange(int(planar.sum()))
    labels = renumber[labels]
    if len(kept) < len(points):  # back to every point: the nearest kept point's facet, if on its plane
        _, nearest = cKDTree(sub).query(points, workers=-1)
        off = np.abs(np.einsum("ij,ij->i", points - sub[nearest], planes.normal[nearest]))
        labels = np.where(off <= thresholds.max_offset, labels[nearest], -1)
        curved = curved[nearest]
    return FacetDetection(labels, curved, thresholds, edge, scatter)


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
    pairs, counts = np.unique(np.column_stack([point_voxel[ok], labels[ok]]), axis=0, return_counts=True)
    order = np.lexsort((-counts, pairs[:, 0]))  # by voxel, the most common label first
    first = order[np.r_[True, np.diff(pairs[order, 0]) != 0]]
    out[pairs[first, 0]] = pairs[first, 1]
    return out


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
