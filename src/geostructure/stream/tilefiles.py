"""A spilled survey cut into tiles with halos: each chunk's points written to the files of
the tiles whose core or halo holds them (:func:`route_to_tiles`), and read back one tile at
a time (:class:`TileFile`), here or by a Dask worker on a disk it shares. The tiles are cubes
of whole cells of the facet detector's grid, anchored at the survey's corner, so a cell has
the same key in every tile (:func:`~geostructure.detect.tilejoin.cell_keys`)."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.detect.facets import FacetThresholds
from geostructure.detect.tilejoin import cell_keys
from geostructure.stream.passes import local_points


@dataclass(frozen=True)
class TileFile:
    """One tile's points, core and halo, as the routing pass wrote them: ``{index}.f8`` (local
    coordinates) and ``{index}.rows`` (each point's row in the spill), in ``folder``; its
    core's least cell key ``first``."""

    folder: str
    index: int
    first: tuple
    n_points: int

    def path(self, suffix: str) -> str:
        return str(Path(self.folder) / f"{self.index}.{suffix}")

    def points(self) -> np.ndarray:
        return np.fromfile(self.path("f8"), dtype="<f8").reshape(-1, 3)

    def rows(self) -> np.ndarray:
        return np.fromfile(self.path("rows"), dtype="<i8")


@dataclass(frozen=True)
class TileContext:
    """What every tile task needs: the grid (``edge`` anchored at ``lower``, codes packed
    within ``bound``), the tiles' size and halo, and, once read, the ``thresholds``."""

    edge: float
    lower: np.ndarray
    bound: np.ndarray
    tile_cells: int
    halo_cells: int
    thresholds: FacetThresholds | None = None


def route_to_tiles(chunks, offset, keep, context: TileContext, folder: Path, report=None) -> list[TileFile]:
    """Write each chunk's kept points to the files of the tiles whose core or halo holds
    them (a point near a border goes to up to eight, where the halo is under half a tile), with
    their rows; the tiles that own a point, in key order."""
    folder = Path(folder)
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    tile_cells, halo = context.tile_cells, context.halo_cells
    span = (np.asarray(context.bound, dtype=np.int64) + halo) // tile_cells + 3  # tiles a side, and room
    index, sizes, owning = {}, {}, set()
    for done, chunk in enumerate(chunks, 1):
        local = local_points(chunk, offset)
        kept = np.ones(len(local), dtype=bool) if keep is None else keep.keep(local, chunk)
        rows = chunk.start + np.flatnonzero(kept)
        local = local[kept]
        key = cell_keys(local, context.edge, context.lower) - 1
        # Tile indices from -1 (a halo below the first cell) to the last, packed one an int.
        low, high = (key - halo) // tile_cells + 1, (key + halo) // tile_cells + 1
        mine = key // tile_cells + 1
        for code in np.unique((mine[:, 0] * span[1] + mine[:, 1]) * span[2] + mine[:, 2]):
            owning.add(int(code))
        del key, mine
        reach = int((high - low).max(initial=0)) + 1  # 2 where the halo is under half a tile
        for step in np.ndindex(reach, reach, reach):
            held = np.all(low + step <= high, axis=1) if any(step) else slice(None)
            tile = low[held] + step
            if not len(tile):
                continue
            code = (tile[:, 0] * span[1] + tile[:, 1]) * span[2] + tile[:, 2]
            order = np.argsort(code, kind="stable")
            code = code[order]
            starts = np.flatnonzero(np.r_[True, code[1:] != code[:-1], True])
            points, point_rows = local[held][order], rows[held][order]
            for a, b in zip(starts[:-1], starts[1:]):
                at = index.setdefault(int(code[a]), len(index))
                with open(folder / f"{at}.f8", "ab") as out:
                    points[a:b].tofile(out)
                with open(folder / f"{at}.rows", "ab") as out:
                    point_rows[a:b].astype("<i8").tofile(out)
                sizes[at] = sizes.get(at, 0) + int(b - a)
        if report is not None:
            report("route", done, len(chunks))
    tiles = []
    for code, at in sorted(index.items()):
        if code not in owning:  # halo only: every point of it is another tile's own
            for suffix in ("f8", "rows"):
                (folder / f"{at}.{suffix}").unlink()
            continue
        triple = np.array([code // (span[1] * span[2]), code // span[2] % span[1], code % span[2]]) - 1
        tiles.append(TileFile(str(folder), at, tuple(int(v) * tile_cells + 1 for v in triple), sizes[at]))
    return tiles
