"""Voxels found again from the points: a table of a grid's occupied voxels (edge, origin)
that gives any point its voxel's row, by one dense lookup where the voxels' box is small and
by ``searchsorted`` on packed int64 codes otherwise. The streamed passes look a chunk's
points up in the survey's voxels by it; a thinned survey's cells (:mod:`.thingrid`) are
such a table too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.gridkeys import voxel_keys

#: Bits of one voxel index in a lookup code (three pack into an int64).
_BITS = 21


def lookup_codes(keys: np.ndarray) -> np.ndarray:
    """One int64 per voxel index triple (all non-negative, below 2**21), for lookups by
    ``searchsorted`` in a table of the survey's voxels."""
    keys = np.asarray(keys, dtype=np.int64)
    return (keys[:, 0] << (2 * _BITS)) | (keys[:, 1] << _BITS) | keys[:, 2]


#: Entries of a dense index over a table's bounding box of voxel indices, at most: where the
#: box is this small (every grid the automatic zeta gives), a point's voxel is one lookup.
DENSE_LOOKUP = 2**25


@dataclass
class VoxelTable:
    """Voxels of a grid (edge, origin) found again from the points: row ``index[i]`` of the
    table the voxels came from has code ``codes[i]`` (sorted); ``dense``, where the voxels'
    box is small, maps every index in it (from ``low``, of ``span``) straight to its row."""

    edge: float
    origin: np.ndarray
    codes: np.ndarray
    index: np.ndarray
    low: np.ndarray | None = None
    span: np.ndarray | None = None
    dense: np.ndarray | None = None

    @classmethod
    def of(cls, keys, edge: float, origin) -> VoxelTable:
        keys = np.asarray(keys, dtype=np.int64).reshape(-1, 3)
        codes = lookup_codes(keys)
        order = np.argsort(codes)
        table = cls(float(edge), np.asarray(origin, dtype=np.float64), codes[order], order)
        if len(keys):
            low = column_min(keys)
            span = column_max(keys) - low + 1
            if int(np.prod(span)) <= DENSE_LOOKUP:
                table.low, table.span = low, span
                table.dense = np.full(int(np.prod(span)), -1, dtype=np.int32)
                table.dense[table._flat(keys)] = np.arange(len(keys), dtype=np.int32)
        return table

    def _flat(self, keys: np.ndarray) -> np.ndarray:
        low, span = self.low, self.span
        assert low is not None and span is not None  # a dense table's: set with it in of()
        k = keys - low
        return (k[:, 0] * span[1] + k[:, 1]) * span[2] + k[:, 2]

    def find(self, points: np.ndarray) -> np.ndarray:
        """Each point's row in the table, -1 where its voxel is not in it."""
        if not len(self.codes):
            return np.full(len(points), -1, dtype=np.int64)
        keys = voxel_keys(points, self.edge, self.origin)
        if self.dense is not None and self.low is not None and self.span is not None:
            inside = ((keys >= self.low) & (keys < self.low + self.span)).all(axis=1)
            found = np.full(len(keys), -1, dtype=np.int64)
            found[inside] = self.dense[self._flat(keys[inside])]
            return found
        codes = lookup_codes(keys)
        at = np.minimum(np.searchsorted(self.codes, codes), len(self.codes) - 1)
        return np.where(self.codes[at] == codes, self.index[at], -1)
