"""The work of one pass over one chunk: pure functions of (chunk, context) whose results add.

Each function here reads its chunk from the spill file, works in the cloud's local
coordinates (the spill's absolute ones less the survey's offset, the same subtraction the
in-memory :class:`~geostructure.core.cloud.Cloud` makes) and returns a partial result that the
engine adds to the others: voxel moments, counts and bounds, each point's plane, hull
vertices, the standard errors' block sums. Nothing in them depends on the chunk's place in
the survey, so the same function runs in a loop or as a Dask task.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.gridkeys import label_order
from geostructure.core.sampling import coordinate_hash
from geostructure.core.voxeltable import VoxelTable
from geostructure.detect.auto import noise_sample
from geostructure.detect.filter import Neighbourhoods, mahalanobis_distance
from geostructure.detect.rectangle import hull_2d
from geostructure.detect.uncertainty import BlockSums, block_sums, plane_coordinates
from geostructure.detect.voxel import VoxelMoments, accumulate_moments, add_moments
from geostructure.stream.source import Chunk


@dataclass
class FilterContext:
    """What decides whether a point survives the outlier filter, for any chunk. Once the
    decisions are in the keep spill (``path``, a byte a point, written by
    :func:`kept_bounds`), later passes read them instead of deciding again."""

    method: str
    threshold: float
    table: VoxelTable | None = None
    blocks: Neighbourhoods | None = None
    typical: float = 0.0
    mean: np.ndarray | None = None
    cov: np.ndarray | None = None
    path: str | None = None
    written: bool = False

    def decide(self, local: np.ndarray) -> np.ndarray:
        if self.method == "none":
            return np.ones(len(local), dtype=bool)
        if self.method == "global":
            return mahalanobis_distance(local, self.mean, self.cov) <= self.threshold
        keep, _ = self.blocks.judge(local, self.table.find(local), self.typical, self.threshold)
        return keep

    def keep(self, local: np.ndarray, chunk: Chunk) -> np.ndarray:
        if self.written:
            return np.fromfile(self.path, dtype=np.bool_, count=len(chunk), offset=chunk.start)
        return self.decide(local)


@dataclass
class VoxelDraw:
    """The whole voxels :func:`~..auto.noise_sample` draws, as a ``keep`` for
    :func:`chunk_moments`: each chunk's points in them."""

    lower: np.ndarray
    edge: float
    n_points: int

    def keep(self, local: np.ndarray, chunk: Chunk) -> np.ndarray:
        return noise_sample(local, self.lower, self.edge, self.n_points)


def local_points(chunk: Chunk, offset) -> np.ndarray:
    return chunk.points() - offset


# --- the passes -----------------------------------------------------------------------------


def hash_sample(chunk: Chunk, context) -> tuple[np.ndarray, np.ndarray]:
    """The chunk's ``n`` points of smallest coordinate hash (hashed as the whole survey is),
    with their hashes: the order-free sample, chunk by chunk."""
    offset, lower, extent, n = context
    local = local_points(chunk, offset)
    h = coordinate_hash(local, 0, lower=lower, extent=extent)
    if len(h) > n:
        chosen = np.argpartition(h, n - 1)[:n]
        local, h = local[chosen], h[chosen]
    return h, local


def merge_samples(a, b, n: int):
    """The ``n`` smallest hashes of two partial samples."""
    if a is None:
        return b
    h, pts = np.concatenate([a[0], b[0]]), np.vstack([a[1], b[1]])
    if len(h) > n:
        chosen = np.argpartition(h, n - 1)[:n]
        h, pts = h[chosen], pts[chosen]
    return h, pts


def chunk_moments(chunk: Chunk, context) -> VoxelMoments | None:
    """Voxel moments of the chunk's points (those the filter keeps, given one) on a grid."""
    offset, edge, origin, keep = context
    local = local_points(chunk, offset)
    if keep is not None:
        local = local[keep.keep(local, chunk)]
    if not len(local):
        return None
    moments, _ = accumulate_moments(local, edge, origin)
    return moments


def chunk_sums(chunk: Chunk, context) -> tuple[int, np.ndarray, np.ndarray]:
    """Count, sum and sum of outer products of the chunk's points: the whole cloud's mean and
    covariance, for the global filter."""
    local = local_points(chunk, context)
    return len(local), local.sum(axis=0), local.T @ local


def kept_bounds(chunk: Chunk, context) -> tuple[int, np.ndarray, np.ndarray]:
    """How many of the chunk's points the filter keeps, and their bounds; the decisions are
    written to the keep spill at the chunk's rows (each chunk its own bytes of one file)."""
    offset, keep = context
    local = local_points(chunk, offset)
    decided = keep.decide(local)
    if keep.path is not None:
        fd = os.open(keep.path, os.O_WRONLY)
        try:
            os.pwrite(fd, decided.astype(np.bool_).tobytes(), chunk.start)
        finally:
            os.close(fd)
    local = local[decided]
    if not len(local):
        return 0, np.full(3, np.inf), np.full(3, -np.inf)
    return len(local), column_min(local), column_max(local)


@dataclass
class LabelContext:
    """What gives a kept point its plane: the fitted voxels' table, each voxel's plane, and
    each plane's centroid and in-plane axes (for its hull)."""

    offset: np.ndarray
    keep: FilterContext
    voxels: VoxelTable
    plane_of_voxel: np.ndarray
    centroid: np.ndarray
    axes: np.ndarray  # (P, 2, 3)
    has_normals: bool = False


def chunk_labels(chunk: Chunk, context: LabelContext):
    """The chunk's filter decision (N,), its kept points (absolute, as read, for the point
    outputs) and their planes (-1 for none), each plane's hull vertices in its own (u, v)
    among the chunk's points, and sums of stored normals."""
    points = chunk.points()
    local = points - context.offset
    keep = context.keep.keep(local, chunk)
    kept = local[keep]
    voxel = context.voxels.find(kept)
    # One entry past the voxels, -1: a point in no voxel, or a cloud with no voxel plane at
    # all (collinear points), takes it.
    plane_of_voxel = np.append(context.plane_of_voxel, -1)
    labels = plane_of_voxel[np.where(voxel >= 0, voxel, len(plane_of_voxel) - 1)].astype(np.int32)
    mine = np.flatnonzero(labels >= 0)
    order = mine[label_order(labels[mine])]
    planes, starts = np.unique(labels[order], return_index=True)
    hulls = {}
    for plane, rows in zip(planes, np.split(order, starts[1:])):
        uv = (kept[rows] - context.centroid[plane]) @ context.axes[plane].T
        hulls[int(plane)] = hull_2d(uv) if len(uv) >= 3 else uv
    normal_sums = None
    if context.has_normals:
        normals = chunk.normals()[keep]
        n = len(context.centroid)
        normal_sums = np.stack([np.bincount(labels[mine], normals[mine, a], n) for a in range(3)], axis=1)
    return keep, points[keep], labels, hulls, normal_sums


def merge_hulls(total: dict, part: dict) -> dict:
    """Each plane's hull of the two partial hulls' vertices."""
    for plane, uv in part.items():
        if plane in total:
            both = np.vstack([total[plane], uv])
            total[plane] = hull_2d(both) if len(both) >= 3 else both
        else:
            total[plane] = uv
    return total


#: In the label spill: a point the outlier filter dropped (-1 is a kept point on no plane).
DROPPED = -2


def read_labels(path: str, chunk: Chunk) -> np.ndarray:
    """The label spill's rows of ``chunk``: each point's plane, -1 for none, :data:`DROPPED`."""
    return np.fromfile(path, dtype="<i4", count=len(chunk), offset=4 * chunk.start)


def chunk_block_sums(chunk: Chunk, context) -> BlockSums:
    """The standard errors' block sums (:func:`~geostructure.detect.uncertainty.block_sums`) of the
    chunk's labelled points, whose planes the label spill holds."""
    offset, labels_path, centroids, axes, ranges = context
    coords = plane_coordinates(local_points(chunk, offset), read_labels(labels_path, chunk), centroids, axes)
    return block_sums(coords, ranges, len(centroids))


class MomentsTotal:
    """The running sum of chunks' voxel moments: partials wait in a list and are added
    together when they outnumber the total's voxels, so each voxel is sorted a few times
    over the whole survey, not once a chunk."""

    def __init__(self):
        self.total: VoxelMoments | None = None
        self.pending: list[VoxelMoments] = []
        self.rows = 0

    def add(self, moments: VoxelMoments | None) -> None:
        if moments is None:
            return
        self.pending.append(moments)
        self.rows += len(moments.keys)
        if self.rows > 2 * (0 if self.total is None else len(self.total.keys)) + 1_000_000:
            self._fold()

    def _fold(self) -> None:
        parts = ([self.total] if self.total is not None else []) + self.pending
        self.pending, self.rows = [], 0
        if not parts:
            return
        whole = parts[0]
        if len(parts) > 1:
            whole = add_moments(
                parts[0],
                VoxelMoments(
                    np.vstack([p.keys for p in parts[1:]]),
                    np.concatenate([p.count for p in parts[1:]]),
                    np.vstack([p.sums for p in parts[1:]]),
                    np.vstack([p.products for p in parts[1:]]),
                    parts[0].edge,
                    parts[0].origin,
                ),
            )
        self.total = whole

    def result(self) -> VoxelMoments | None:
        self._fold()
        return self.total
