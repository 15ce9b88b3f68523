"""Voxel fit: a best-fit plane per occupied voxel, from additive moments.

Each voxel keeps its point count, coordinate sums and sums of products (relative to the
voxel's own corner, so large coordinates cost no precision). Moments add: chunks or tiles
of a cloud larger than memory can be accumulated with :func:`add_moments` and fitted once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.gridkeys import (
    binned_sums,
    check_voxel_count,
    floor_index,
    unique_key_rows,
    unique_keys,
)

#: Index pairs of the 6 distinct entries of a symmetric 3x3 matrix.
_I, _J = np.triu_indices(3)


@dataclass
class VoxelMoments:
    """Additive moments of the points in each occupied voxel.

    keys : (V, 3) int64 voxel indices; count : (V,); sums : (V, 3) and products : (V, 6)
    (xx, xy, xz, yy, yz, zz), all of coordinates relative to the voxel's corner.
    """

    keys: np.ndarray
    count: np.ndarray
    sums: np.ndarray
    products: np.ndarray
    edge: float
    origin: np.ndarray


@dataclass(frozen=True)
class CloudMoments:
    """A whole cloud's voxel moments and each point's voxel (``inverse``, (N,)), kept by the
    automatic choice at the zeta it chose so that the local filter, on the same grid, does
    not sum them again (2.3 s at 8M points)."""

    moments: VoxelMoments
    inverse: np.ndarray

    def on_grid(self, edge: float, origin) -> bool:
        """Whether these are the moments of the grid of ``edge`` anchored at ``origin``."""
        return self.moments.edge == edge and bool(np.array_equal(self.moments.origin, origin))


@dataclass
class VoxelPlanes:
    """The fitted voxel planes (only voxels with enough points and a planar fit).

    centroid : (V, 3) in the cloud's local coordinates; normal : (V, 3) unit;
    residual : (V,) RMS distance of the voxel's points to its plane (cloud units);
    curvature : (V,) smallest eigenvalue over the eigenvalue sum (0 for a perfect plane);
    count : (V,); keys : (V, 3); point_voxel : (N,) index into these arrays for each
    point, -1 where the point's voxel was not kept.
    """

    centroid: np.ndarray
    normal: np.ndarray
    residual: np.ndarray
    curvature: np.ndarray
    count: np.ndarray
    keys: np.ndarray
    point_voxel: np.ndarray
    edge: float

    def __len__(self) -> int:
        return len(self.centroid)


def voxel_edge(points: np.ndarray, zeta: float) -> float:
    """The voxel edge: ``zeta`` times the largest extent of the cloud (the paper's point space)."""
    extent = float(np.max(column_max(points) - column_min(points)))
    return zeta * extent


def voxel_counts(points: np.ndarray, edge: float, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points in every occupied voxel, and each point's voxel index: :func:`accumulate_moments`'
    counts and inverse map without its sums (a density probe needs only these).

    Examples
    --------
    >>> counts, inverse = voxel_counts(np.array([[0.1, 0.1, 0.1], [0.2, 0.3, 0.1], [1.5, 0.2, 0.1]]), 1.0, np.zeros(3))
    >>> counts[inverse].tolist()
    [2, 2, 1]
    """
    unique, inverse = _grouped_voxels(points, edge, np.asarray(origin, float))
    return np.bincount(inverse, minlength=len(unique)), inverse


def accumulate_moments(points: np.ndarray, edge: float, origin: np.ndarray):
    """Moments of every occupied voxel, and each point's voxel index (inverse map)."""
    origin = np.asarray(origin, float)
    rel = np.empty((3, len(points)))
    unique, inverse = _grouped_voxels(points, edge, origin, rel)
    n = len(unique)
    count = np.bincount(inverse, minlength=n).astype(np.float64)
    sums, products = binned_sums(rel, inverse, n)
    return VoxelMoments(unique, count, sums, products, edge, origin), inverse


def _grouped_voxels(points: np.ndarray, edge: float, origin: np.ndarray, rel=None) -> tuple[np.ndarray, np.ndarray]:
    """Each point's voxel at ``edge`` from ``origin``: the occupied voxels' keys and the
    inverse map; given ``rel`` (3, N), each point's coordinates about its voxel's corner are
    written there too. Keys and coordinates as rows, column by column, through one buffer:
    no array the cloud's size is allocated twice."""
    check_voxel_count(points, edge, origin)
    key = np.empty((3, len(points)), dtype=np.int64)
    scratch = np.empty(len(points) if rel is None else 0)
    for a in range(3):
        row = scratch if rel is None else rel[a]
        floor_index(points[:, a], origin[a], edge, key[a], row)
        if rel is not None:  # the point less its voxel's corner (keys == unique[inverse])
            np.multiply(key[a], edge, out=row)
            row += origin[a]
            np.subtract(points[:, a], row, out=row)
    return unique_key_rows(key)


def add_moments(a: VoxelMoments, b: VoxelMoments) -> VoxelMoments:
    """Sum the moments of two chunks (same edge and origin) voxel by voxel."""
    if a.edge != b.edge or not np.array_equal(a.origin, b.origin):
        raise ValueError("moments must share voxel edge and origin to be added")
    unique, inverse = unique_keys(np.vstack([a.keys, b.keys]))

    def total(x, y):
        stacked = np.concatenate([x, y])
        if stacked.ndim == 1:
            return np.bincount(inverse, stacked, len(unique))
        return np.stack([np.bincount(inverse, stacked[:, c], len(unique)) for c in range(stacked.shape[1])], 1)

    return VoxelMoments(
        unique, total(a.count, b.count), total(a.sums, b.sums), total(a.products, b.products), a.edge, a.origin
    )


def covariance_from_moments(count, sums, products) -> tuple[np.ndarray, np.ndarray]:
    """Mean (V, 3) and covariance (V, 3, 3) from count, sums and sums of products."""
    count = np.maximum(np.asarray(count, dtype=np.float64), 1.0)
    mean = sums / count[:, None]
    second = np.zeros((len(count), 3, 3))
    second[:, _I, _J] = products / count[:, None]
    second[:, _J, _I] = second[:, _I, _J]
    cov = second - mean[:, :, None] * mean[:, None, :]
    return mean, cov


#: A voxel's points lie along a line, not on a plane, when their spread across the line (the
#: second eigenvalue) is under LINE_WIDTH of their spread along it and no more than
#: LINE_SPREAD times their noise (the smallest): points 0.1 mm about a line 5 m long gave
#: four "planes" of arbitrary azimuth.
LINE_WIDTH = 0.01
LINE_SPREAD = 4.0


def fit_planes(moments: VoxelMoments, min_points: int = 5) -> tuple[np.ndarray, ...]:
    """Centroid, unit normal, RMS residual and curvature of every voxel with ``min_points``.

    Voxels with fewer points give no plane (one or two points define none; a handful define
    a poor one). The normal is the eigenvector of the smallest covariance eigenvalue.
    """
    keep = moments.count >= max(min_points, 3)
    mean, cov = covariance_from_moments(moments.count[keep], moments.sums[keep], moments.products[keep])
    values, vectors = np.linalg.eigh(cov)
    values = np.clip(values, 0.0, None)
    normal = vectors[:, :, 0]
    residual = np.sqrt(values[:, 0])
    total = values.sum(axis=1)
    curvature = np.divide(values[:, 0], total, out=np.ones_like(total), where=total > 0)
    # A voxel whose points lie along a line (a pole, a cable, a rod) has no plane: its second
    # eigenvalue is small beside its largest, and no larger than its noise, which the
    # smallest measures. (A noisy plane's strip cut by the voxel's corner is not a line: its
    # second eigenvalue is a fair share of its largest.)
    thin = values[:, 1] <= LINE_WIDTH * values[:, 2]
    linear = (thin & (values[:, 1] <= LINE_SPREAD * values[:, 0])) | (values[:, 1] <= 1e-6 * values[:, 2])
    curvature[linear] = 1.0
    centroid = moments.origin + moments.keys[keep] * moments.edge + mean
    return keep, centroid, normal, residual, curvature


def fit_voxels(points: np.ndarray, zeta: float, *, min_points: int = 5, max_curvature: float = 0.05) -> VoxelPlanes:
    """The paper's voxel fit: a plane in each occupied voxel of edge ``zeta`` x extent.

    Parameters
    ----------
    points : (N, 3) float64
        Local (offset-centred) coordinates.
    zeta : float
        Voxel-size factor; the edge is ``zeta`` times the largest extent of the cloud.
    min_points : int
        Voxels with fewer points fit no plane.
    max_curvature : float
        Voxels whose smallest eigenvalue is more than this fraction of the eigenvalue sum
        are not planar (an edge, a corner, clutter) and are dropped.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> pts = np.c_[rng.random((2000, 2)) * 10, np.zeros(2000)]
    >>> vp = fit_voxels(pts, 0.2)
    >>> bool(np.allclose(np.abs(vp.normal[:, 2]), 1))
    True
    """
    edge = voxel_edge(points, zeta)
    if not edge > 0:
        raise ValueError("the cloud has no extent")
    moments, inverse = accumulate_moments(points, edge, column_min(points))
    voxels, kept_index = voxel_planes_from_moments(moments, min_points, max_curvature)
    lookup = np.full(len(moments.keys), -1, dtype=np.int64)
    lookup[kept_index] = np.arange(len(kept_index))
    voxels.point_voxel = lookup[inverse]
    return voxels


def voxel_planes_from_moments(
    moments: VoxelMoments, min_points: int = 5, max_curvature: float = 0.05
) -> tuple[VoxelPlanes, np.ndarray]:
    """The voxel planes of accumulated moments (of a whole cloud, or summed over its chunks
    with :func:`add_moments`), and the rows of ``moments`` they came from. Their
    ``point_voxel`` is empty: the points are not at hand."""
    keep, centroid, normal, residual, curvature = fit_planes(moments, min_points)
    planar = curvature <= max_curvature
    kept_index = np.flatnonzero(keep)[planar]
    voxels = VoxelPlanes(
        centroid=centroid[planar],
        normal=normal[planar],
        residual=residual[planar],
        curvature=curvature[planar],
        count=moments.count[kept_index].astype(np.int64),
        keys=moments.keys[kept_index],
        point_voxel=np.zeros(0, dtype=np.int64),
        edge=moments.edge,
    )
    return voxels, kept_index


def subset_voxels(voxels: VoxelPlanes, keep: np.ndarray) -> VoxelPlanes:
    """The voxel planes where ``keep`` (V,) is true, with each point's index remapped (-1 for
    the points of the others).

    Examples
    --------
    >>> v = fit_voxels(np.random.default_rng(0).random((400, 3)) * [4, 4, 0.01], zeta=0.25)
    >>> len(subset_voxels(v, np.arange(len(v)) < 3))
    3
    """
    keep = np.asarray(keep, dtype=bool)
    index = np.full(len(voxels) + 1, -1, dtype=np.int64)  # the last entry maps -1 to -1
    index[np.flatnonzero(keep)] = np.arange(int(keep.sum()))
    return VoxelPlanes(
        centroid=voxels.centroid[keep],
        normal=voxels.normal[keep],
        residual=voxels.residual[keep],
        curvature=voxels.curvature[keep],
        count=voxels.count[keep],
        keys=voxels.keys[keep],
        point_voxel=index[voxels.point_voxel],
        edge=voxels.edge,
    )
