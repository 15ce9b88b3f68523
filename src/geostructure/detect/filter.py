"""Mahalanobis outlier filter (paper: "Mitigating Anisotropic Noise").

Two forms:

- ``global``: one mean and covariance for the whole cloud, as the paper's formula reads and
  the original code did. It drops points far from the cloud as a whole, but a floating
  cluster near the middle of a scene sits well inside that one ellipsoid and survives.
- ``local`` (default): each point against the distribution of the points around it (after
  Brophy), taken from additive voxel moments: the 3x3x3 block of voxels around the
  point's own. On a surface that distribution is flat, so a point a few noise widths off
  the surface is many standard deviations out even where the cloud is dense. A point whose
  block holds almost nothing is isolated and dropped too.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from geostructure.core import params
from geostructure.core.bounds import column_max, column_min
from geostructure.core.threads import run_blocks
from geostructure.detect.voxel import accumulate_moments, covariance_from_moments

METHODS = params.FILTER_METHODS


@dataclass
class FilterResult:
    """``keep`` marks the points kept; ``distance`` is each point's Mahalanobis distance."""

    keep: np.ndarray
    distance: np.ndarray
    method: str
    threshold: float

    @property
    def n_removed(self) -> int:
        return int((~self.keep).sum())


def mahalanobis_distance(points: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Mahalanobis distance of each point to a mean and covariance (shared or per point).

    Examples
    --------
    >>> pts = np.array([[2.0, 0, 0], [0, 0, 3.0]])
    >>> mahalanobis_distance(pts, np.zeros(3), np.diag([4.0, 1.0, 9.0])).tolist()
    [1.0, 1.0]
    """
    diff = points - mean
    inv = np.linalg.pinv(cov, hermitian=True)
    if inv.ndim == 2:
        d2 = np.einsum("ni,ij,nj->n", diff, inv, diff)
    else:
        d2 = np.einsum("ni,nij,nj->n", diff, inv, diff)
    return np.sqrt(np.clip(d2, 0.0, None))


def global_filter(points: np.ndarray, threshold: float = 3.0) -> FilterResult:
    """Drop points more than ``threshold`` standard deviations (Mahalanobis) from the cloud."""
    mean = points.mean(axis=0)
    cov = np.cov(points, rowvar=False)
    d = mahalanobis_distance(points, mean, cov)
    return FilterResult(d <= threshold, d, "global", threshold)


#: Fewest points in a block for its covariance to be trusted.
MIN_COVARIANCE_POINTS = 10


def local_filter(
    points: np.ndarray, edge: float, threshold: float = 3.0, isolation: float = 0.1, moments=None
) -> FilterResult:
    """Drop points more than ``threshold`` std from their neighbourhood, or with no neighbourhood.

    Parameters
    ----------
    points : (N, 3) float64
    edge : float
        Voxel edge; the neighbourhood is the 3x3x3 block of voxels around a point's voxel.
    threshold : float
        Mahalanobis distance beyond which a point is an outlier.
    isolation : float
        A block holding fewer than this fraction of the median point's block count (and
        fewer than 10) is isolated: its points are dropped.
    moments : :class:`~geostructure.detect.voxel.CloudMoments`, optional
        The points' voxel moments, already summed (by the automatic choice); used when they
        are on this grid, summed here otherwise.
    """
    origin = column_min(points)
    if moments is not None and moments.on_grid(edge, origin):
        moments, inverse = moments.moments, moments.inverse
    else:
        moments, inverse = accumulate_moments(points, edge, origin)
    blocks = neighbourhoods(moments)
    keep, distance = blocks.judge(points, inverse, blocks.typical_support(), threshold, isolation)
    return FilterResult(keep, distance, "local", threshold)


@dataclass
class Neighbourhoods:
    """Each occupied voxel's 3x3x3 block: its points' mean (local coordinates), inverse
    covariance and count. Built from additive moments, so from a whole cloud or from the sum
    of its chunks' alike; :meth:`judge` then decides any points of those voxels."""

    mean: np.ndarray
    inverse: np.ndarray
    support: np.ndarray
    voxel_count: np.ndarray

    def typical_support(self) -> float:
        """The median over the points of their block's count (``np.median`` over the points,
        read from the voxels: each voxel's block count weighted by its points)."""
        order = np.argsort(self.support, kind="stable")
        ends = np.cumsum(self.voxel_count[order])
        total = int(ends[-1])
        low, high = (total - 1) // 2, total // 2  # the middle point(s), as np.median takes them
        pick = self.support[order][np.searchsorted(ends, [low + 1, high + 1])]
        return float(pick.mean())

    @cached_property
    def entries(self) -> np.ndarray:
        """The inverse covariances as (9, V): row 3 i + j holds entry (i, j) of every voxel."""
        return self.inverse.reshape(-1, 9).T.copy()

    def judge(self, points, voxel, typical: float, threshold: float = 3.0, isolation: float = 0.1):
        """Keep (N,) and Mahalanobis distance (N,) of ``points`` whose voxels are ``voxel``."""
        # The quadratic form from the six distinct entries, each gathered from a voxel table
        # small enough to stay in cache: gathering a 3 x 3 matrix per point cost 2.3 s at 8M.
        # Every gather into one of five buffers (each fresh array the points' length costs
        # its pages' first touch): the same products in the same order as written out.
        # Elementwise, so split by rows over the cores (the same bits in any split).
        a, d = self.entries, np.empty(len(points))

        def distance_rows(rows: slice) -> None:
            cell, d2 = voxel[rows], d[rows]
            x, y, z = (np.take(self.mean[:, i], cell, mode="wrap") for i in range(3))
            for i, deviation in enumerate((x, y, z)):
                np.subtract(points[rows, i], deviation, out=deviation)
            term = np.empty(len(cell))
            d2[:] = 0.0
            for entry, first, second, factor in ((0, x, x, 1.0), (4, y, y, 1.0), (8, z, z, 1.0),
                                                 (1, x, y, 2.0), (2, x, z, 2.0), (5, y, z, 2.0)):  # fmt: skip
                np.take(a[entry], cell, out=term, mode="wrap")  # as a[entry][voxel]; "raise" buffers a copy
                if factor != 1.0:
                    term *= factor
                term *= first
                term *= second
                d2 += term
            np.sqrt(np.clip(d2, 0.0, None, out=d2), out=d2)

        run_blocks(distance_rows, len(points))
        support = self.support[voxel]
        isolated = support < min(max(3.0, isolation * typical), MIN_COVARIANCE_POINTS)
        testable = support >= MIN_COVARIANCE_POINTS
        keep = ~isolated & (~testable | (d <= threshold))
        return keep, np.where(testable, d, 0.0)


def neighbourhoods(moments) -> Neighbourhoods:
    """The :class:`Neighbourhoods` of every voxel of ``moments`` (:class:`~geostructure.detect.voxel.VoxelMoments`)."""
    edge = moments.edge
    count, sums, products = _block_sums(moments.keys, moments.count, moments.sums, moments.products, edge)
    mean, cov = covariance_from_moments(count, sums, products)
    # A perfectly flat patch has a singular covariance; a floor of (edge/1000)^2 keeps it invertible.
    cov = cov + np.eye(3) * (edge * 1e-3) ** 2
    corner = moments.origin + moments.keys * edge
    return Neighbourhoods(corner + mean, np.linalg.inv(cov), count, moments.count)


def _block_sums(keys, count, sums, products, edge):
    """Moments summed over each voxel's 3x3x3 block, shifted to the centre voxel's corner."""
    base = column_max(keys) + 3

    def encode(k):
        k = k + 1
        return (k[:, 0] * base[1] + k[:, 1]) * base[2] + k[:, 2]

    codes = encode(keys)
    order = np.argsort(codes)
    sorted_codes = codes[order]
    total_n = np.zeros_like(count)
    total_s = np.zeros_like(sums)
    total_p = np.zeros_like(products)
    iu, ju = np.triu_indices(3)
    offsets = np.array(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1])).reshape(3, -1).T

    def block_rows(rows: slice) -> None:  # each voxel's 27 terms in the same order in any split
        own, t_n, t_s, t_p = keys[rows], total_n[rows], total_s[rows], total_p[rows]
        for offset in offsets:
            target = encode(own + offset)
            pos = np.minimum(np.searchsorted(sorted_codes, target), len(sorted_codes) - 1)
            hit = sorted_codes[pos] == target
            src = order[pos[hit]]
            n, s, p = count[src], sums[src], products[src]
            # Neighbour moments are about the neighbour's corner; move them to this voxel's corner.
            shift = offset * edge
            p = p + s[:, iu] * shift[ju] + s[:, ju] * shift[iu] + n[:, None] * shift[iu] * shift[ju]
            s = s + n[:, None] * shift
            t_n[hit] += n
            t_s[hit] += s
            t_p[hit] += p

    run_blocks(block_rows, len(keys))
    return total_n, total_s, total_p


def filter_outliers(
    points: np.ndarray, method: str = "local", *, edge: float | None = None, threshold: float = 3.0, moments=None
) -> FilterResult:
    """Run the chosen filter; ``none`` keeps everything; ``moments`` (the local filter's, on
    its grid) saves summing them again."""
    if method == "global":
        return global_filter(points, threshold)
    if method == "local":
        assert edge is not None, "the local filter needs its grid's edge"  # the pipeline always gives it
        return local_filter(points, edge, threshold, moments=moments)
    return FilterResult(np.ones(len(points), bool), np.zeros(len(points)), "none", threshold)
