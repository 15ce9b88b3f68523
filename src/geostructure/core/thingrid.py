"""The grid a survey too large for memory is thinned on (:mod:`geostructure.stream.thin`):
cubes of one edge from a lower corner, each cell numbered, recorded in ``run.json`` so that
a folder's reader finds the measured points again; and each cell's first point over parts
read one after another, in the files' order (:func:`fold_first`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.gridkeys import MAX_CELLS_PER_AXIS, voxel_keys
from geostructure.core.voxeltable import VoxelTable
from geostructure.errors import GeoStructureError


@dataclass(frozen=True)
class ThinGrid:
    """A grid of cubes of side ``edge`` from ``lower`` (absolute coordinates), its cells
    numbered ``(i * ny + j) * nz + k``."""

    lower: np.ndarray
    edge: float
    shape: tuple[int, int, int]

    @classmethod
    def from_record(cls, record: dict | None) -> ThinGrid | None:
        """The grid a thinned run recorded in ``run.json`` (``thinned``); None for a run
        that thinned nothing."""
        if not record or record.get("cell") is None or "grid_lower" not in record:
            return None
        nx, ny, nz = (int(n) for n in record["grid_shape"])
        return cls(np.asarray(record["grid_lower"], dtype=np.float64), float(record["cell"]), (nx, ny, nz))

    def to_record(self) -> dict:
        return {"cell": self.edge, "grid_lower": self.lower.tolist(), "grid_shape": list(self.shape)}

    @classmethod
    def over(cls, lower, upper, edge: float) -> ThinGrid:
        lower = np.asarray(lower, dtype=np.float64)
        nx, ny, nz = (int(n) for n in np.floor((np.asarray(upper) - lower) / edge).astype(np.int64) + 1)
        shape = (nx, ny, nz)
        if max(shape) > MAX_CELLS_PER_AXIS or float(shape[0]) * shape[1] * shape[2] >= 2.0**62:
            raise GeoStructureError(f"a grid of {edge:g} over the survey has too many cells to number")
        return cls(lower, float(edge), shape)

    def table(self, points: np.ndarray) -> VoxelTable:
        """The cells of ``points`` (one a cell), each found again from any point in it as
        its row in ``points`` (:meth:`~geostructure.core.voxeltable.VoxelTable.find`; -1 for a cell none holds)."""
        return VoxelTable.of(voxel_keys(points, self.edge, self.lower), self.edge, self.lower)

    def codes(self, points: np.ndarray) -> np.ndarray:
        """Each point's cell number (int64)."""
        index = np.floor((points - self.lower) / self.edge).astype(np.int64)
        np.clip(index, 0, np.array(self.shape) - 1, out=index)  # the upper bound's own cell
        _, ny, nz = self.shape
        return (index[:, 0] * ny + index[:, 1]) * nz + index[:, 2]


def _first_of_each(codes, rows, counts, *payload):
    """The first row (in the files' order) of each cell among gathered parts, the cell's
    points counted over all of them, and the first row's ``payload``."""
    order = np.lexsort((rows, codes))
    codes, rows = codes[order], rows[order]
    first = np.ones(len(codes), dtype=bool)
    first[1:] = codes[1:] != codes[:-1]
    counts = np.add.reduceat(counts[order], np.flatnonzero(first)) if len(codes) else counts
    return (codes[first], rows[first], counts, *(p[order][first] for p in payload))


def fold_first(parts, report=None):
    """Each cell's first row over ``parts`` ((codes, rows, counts, *payload) each, as
    :func:`chunk_cells` gives), folded as they come so that memory stays bounded, in the
    files' order; ``report()`` after each part."""
    gathered, held, limit = [], 0, None
    for part in parts:
        gathered.append(part)
        held += len(part[0])
        if report is not None:
            report()
        if limit is None:
            limit = max(4 * held, 1_000_000)
        if held > limit:  # cells seen in several chunks: fold them
            gathered = [_first_of_each(*(np.concatenate(c) for c in zip(*gathered)))]
            held, limit = len(gathered[0][0]), 2 * len(gathered[0][0]) + 1_000_000
    whole = _first_of_each(*(np.concatenate(c) for c in zip(*gathered)))
    order = np.argsort(whole[1])  # the files' order
    return tuple(c[order] for c in whole)
