"""Facets grown tile by tile and joined across the tiles' borders, one entry per facet piece
(docs/tiles.md): what lets a survey larger than memory be grown tile by tile.

Each tile grows its own facets over its core and the sure ring of its halo
(:func:`grow_tile`): the connected components of its agreeing pairs, each a **piece**. Every
pair of touching cells is tested in the tile that owns its first cell, which holds the other
in its sure ring, so a facet of the whole grid is the union of pieces that share a cell: a
cell of one tile's halo that another tile owns. :func:`join_pieces` joins them with
union-find over the pieces alone (a survey's cells never held at once), then ranks the
facets by their points as :func:`~geostructure.detect.facets.ranked_components` does, the
ties by their least cell. The planarity test (:func:`planar_renumbering`) adds the pieces'
moments about each tile's corner and counts, per facet, the points whose cell's plane lies
along the facet's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from geostructure.detect.cells import neighbour_pairs
from geostructure.detect.facets import FacetThresholds, agreeing_pairs

#: Cells of a tile's halo whose planes may differ from the whole grid's (a sparse cell's
#: coarse block reaches three cells out): pairs are tested among the cells inside them.
UNSURE_CELLS = 3


def cell_keys(points: np.ndarray, edge: float, lower) -> np.ndarray:
    """Each point's cell key on the grid of ``edge`` anchored at ``lower``, as
    :class:`~geostructure.detect.cells.CellGrid` numbers its cells (a ring of empty cells
    round the grid: the least key is 1)."""
    return (
        np.floor((np.asarray(points, dtype=np.float64) - np.asarray(lower, dtype=np.float64)) / edge).astype(np.int64)
        + 1
    )


@dataclass
class TilePieces:
    """One tile's facet pieces before the join (P pieces).

    ``cells`` (P,) the tile's own flat cells in each, ``points`` (P,) the points those cells
    hold, ``least`` (P,) the least code of its own cells; ``halo`` (H, 2) the code of each
    halo cell a piece holds and the piece, ``border`` (B, 2) the same for the tile's own
    cells near its border (where another tile's halo reaches); ``moments`` (P, 10) the
    count, sums and sums of products of each piece's labelled points about ``reference``.
    Per own point: ``point`` (its index in the tile's points), ``piece`` (-1 for none) and
    ``normal`` (its cell's plane, for the planarity test)."""

    cells: np.ndarray
    points: np.ndarray
    least: np.ndarray
    halo: np.ndarray
    border: np.ndarray
    moments: np.ndarray
    reference: np.ndarray
    point: np.ndarray
    piece: np.ndarray
    normal: np.ndarray

    def __len__(self) -> int:
        return len(self.cells)


def grow_tile(tile, codes: np.ndarray, first, tile_cells: int, halo_cells: int, thresholds: FacetThresholds,
              points: np.ndarray) -> TilePieces:  # fmt: skip
    """The facet pieces of one tile (a :class:`~geostructure.detect.halo_tiles.CellTile` over
    ``points``, its cells' ``codes`` on the whole grid): the touching pairs of its sure cells
    tested as the whole grid tests them, their components, and its own points labelled
    (:func:`~geostructure.detect.facets.label_points`).

    Parameters
    ----------
    tile : CellTile
        The tile's cells, core and halo.
    codes : (C,) int array
        Each cell's code on the whole grid (:func:`~geostructure.detect.halo_tiles.key_codes`).
    first : (3,) int array
        The least key of the tile's own cells.
    tile_cells, halo_cells : int
        Cells on a side of the tile's core, and of halo round it (more than
        :data:`UNSURE_CELLS`).
    thresholds : FacetThresholds
        The whole grid's.
    points : (N, 3) array
        The tile's points (local coordinates).

    Returns
    -------
    TilePieces
    """
    cells, key, core = tile.cells, tile.key, tile.core
    first = np.asarray(first, dtype=np.int64)
    sure_ring = halo_cells - UNSURE_CELLS
    if sure_ring < 1:
        raise ValueError(f"halo_cells must be more than {UNSURE_CELLS}, not {halo_cells}")
    sure = np.all((key >= first - sure_ring) & (key < first + tile_cells + sure_ring), axis=1)
    source, target = neighbour_pairs(cells)
    keep = sure[source] & sure[target]
    flat, (source, target) = agreeing_pairs(cells, thresholds, (source[keep], target[keep]))
    graph = coo_matrix((np.ones(len(source), dtype=np.int8), (source, target)), shape=(len(cells),) * 2)
    component = np.where(flat, connected_components(graph, directed=False)[1], -1)
    # A piece is a component with two cells or more and one of the tile's own: a single
    # cell has no agreeing pair (every pair of an own cell is tested here), so it is no
    # facet anywhere; one of halo cells alone is grown again, whole, by the tiles that own
    # them.
    grown = component >= 0
    size = np.bincount(component[grown], minlength=len(cells))
    owned = np.bincount(component[grown & core], minlength=len(cells))
    kept = np.flatnonzero((size >= 2) & (owned >= 1))
    piece_of = np.full(len(cells) + 1, -1)
    piece_of[kept] = np.arange(len(kept))
    piece = piece_of[component]  # -1 stays -1 (the last entry)
    own = core & (piece >= 0)
    n = len(kept)
    least = np.full(n, np.iinfo(np.int64).max)
    np.minimum.at(least, piece[own], codes[own])
    # The cells another tile may hold too: the halo's sure ring, and the own cells as near
    # the border as that ring reaches.
    inner = np.all((key >= first + sure_ring) & (key < first + tile_cells - sure_ring), axis=1)
    halo = sure & ~core & (piece >= 0)
    border = own & ~inner
    # The tile's own points, labelled as label_points does.
    mine = np.flatnonzero(core[cells.point_cell])
    cell = cells.point_cell[mine]
    near = cells.point_offset(points[mine], cell) <= thresholds.max_offset
    point_piece = np.where(near, piece[cell], -1)
    reference = cells.corner[own][0] if own.any() else np.zeros(3)
    return TilePieces(
        cells=np.bincount(piece[own], minlength=n),
        points=np.bincount(piece[own], weights=cells.count[own], minlength=n),
        least=least,
        halo=np.column_stack([codes[halo], piece[halo]]),
        border=np.column_stack([codes[border], piece[border]]),
        moments=piece_moments(points[mine] - reference, point_piece, n),
        reference=reference,
        point=mine,
        piece=point_piece,
        normal=cells.normal[cell],
    )


def piece_moments(rel: np.ndarray, piece: np.ndarray, n: int) -> np.ndarray:
    """Count, sums (3) and sums of products (6: xx, xy, xz, yy, yz, zz) of the points ``rel``
    (N, 3) of each of ``n`` pieces (``piece`` (N,), -1 for none): (n, 10)."""
    on = piece >= 0
    index, rel = piece[on], rel[on]
    out = np.zeros((n, 10))
    out[:, 0] = np.bincount(index, minlength=n)
    for a in range(3):
        out[:, 1 + a] = np.bincount(index, rel[:, a], minlength=n)
    for c, (a, b) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        out[:, 4 + c] = np.bincount(index, rel[:, a] * rel[:, b], minlength=n)
    return out


@dataclass
class JoinedFacets:
    """The pieces of every tile joined: ``rank`` (one array per tile, its pieces' facet,
    0, 1, ... by points, most first, before the planarity test), ``count`` (F,) each facet's
    labelled points, ``mean`` (F, 3) their centroid, ``covariance`` (F, 3, 3) about it."""

    rank: list
    count: np.ndarray
    mean: np.ndarray
    covariance: np.ndarray

    def __len__(self) -> int:
        return len(self.count)


def join_pieces(tiles: list) -> JoinedFacets:
    """Join every tile's :class:`TilePieces` (any order) into the whole grid's facets.

    Two pieces are one facet where a cell of one's halo is a cell of the other's own (the
    same code). The facets are numbered as
    :func:`~geostructure.detect.facets.ranked_components` numbers the whole grid's: by the
    points their cells hold, most first, ties by their least cell; those of fewer than two
    cells are none.
    """
    starts, facet = piece_groups(tiles)
    n = len(facet)
    cells = np.bincount(facet, weights=np.concatenate([t.cells for t in tiles] or [np.zeros(0)]), minlength=n)
    points = np.bincount(facet, weights=np.concatenate([t.points for t in tiles] or [np.zeros(0)]), minlength=n)
    least = np.full(n, np.iinfo(np.int64).max)
    np.minimum.at(least, facet, np.concatenate([t.least for t in tiles] or [np.zeros(0, np.int64)]))
    grown = np.flatnonzero(cells >= 2)
    ranked = grown[np.lexsort((least[grown], -points[grown]))]
    rank_of = np.full(n, -1)
    rank_of[ranked] = np.arange(len(ranked))
    piece_rank = rank_of[facet]
    count, mean, covariance = added_moments(tiles, [piece_rank[s:e] for s, e in zip(starts[:-1], starts[1:])],
                                             len(ranked))  # fmt: skip
    return JoinedFacets([piece_rank[s:e] for s, e in zip(starts[:-1], starts[1:])], count, mean, covariance)


def piece_groups(tiles: list) -> tuple[np.ndarray, np.ndarray]:
    """Where each tile's pieces start in one list of all (T + 1,), and each piece's group
    (P,): pieces are one group where a member (a cell or a point: its code or row) of one's
    ``halo`` is a member of another's ``border``."""
    starts = np.cumsum([0] + [len(t) for t in tiles])
    n = int(starts[-1])
    halo = np.concatenate([t.halo + [0, s] for t, s in zip(tiles, starts[:-1])] or [np.zeros((0, 2), int)])
    border = np.concatenate([t.border + [0, s] for t, s in zip(tiles, starts[:-1])] or [np.zeros((0, 2), int)])
    # Each halo member's owner: the piece of another tile that holds it as its own.
    order = np.argsort(border[:, 0], kind="stable")
    codes = border[order, 0]
    at = np.clip(np.searchsorted(codes, halo[:, 0]), 0, max(len(codes) - 1, 0))
    found = codes[at] == halo[:, 0] if len(codes) else np.zeros(len(halo), dtype=bool)
    a, b = halo[found, 1], border[order[at[found]], 1]
    graph = coo_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(n, n))
    return starts, connected_components(graph, directed=False)[1]


def moved_moments(moments: np.ndarray, shift) -> np.ndarray:
    """Moments (M, 10: count, sums, the six sums of products) of points about one reference,
    moved to another: ``shift`` (3,) or (M, 3) the old reference less the new."""
    shift = np.broadcast_to(np.asarray(shift, dtype=np.float64), (len(moments), 3))
    k, s = moments[:, 0], moments[:, 1:4]
    out = moments.copy()
    out[:, 1:4] = s + k[:, None] * shift
    for c, (a, b) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        out[:, 4 + c] += shift[:, a] * s[:, b] + shift[:, b] * s[:, a] + k * shift[:, a] * shift[:, b]
    return out


def added_moments(tiles: list, ranks: list, n: int):
    """Each facet's count, centroid and covariance, its pieces' moments moved from their
    tile's corner to one reference (the first piece's corner) and added."""
    count, first, total = np.zeros(n), np.full((n, 3), np.nan), np.zeros((n, 9))
    for tile, rank in zip(tiles, ranks):
        on = rank >= 0
        if not on.any():
            continue
        m, r = tile.moments[on], rank[on]
        unset = np.isnan(first[r, 0])
        first[r[unset]] = tile.reference
        moved = moved_moments(m, tile.reference - first[r])
        np.add.at(count, r, moved[:, 0])
        np.add.at(total, r, moved[:, 1:])
    held = np.maximum(count, 1.0)
    mean_rel = total[:, :3] / held[:, None]
    covariance = np.empty((n, 3, 3))
    for c, (a, b) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        covariance[:, a, b] = covariance[:, b, a] = total[:, 3 + c] / held - mean_rel[:, a] * mean_rel[:, b]
    return count, np.nan_to_num(first) + mean_rel, covariance


@dataclass(frozen=True)
class FacetPlanes:
    """Each facet's plane from all its points (F facets): their ``count`` (F,), ``centroid``
    (F, 3), the ``normal`` (F, 3) of their least-squares plane and their RMS distance to it,
    ``residual`` (F,)."""

    count: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    residual: np.ndarray

    @classmethod
    def of(cls, count, mean, covariance) -> FacetPlanes:
        """From each facet's count, mean and covariance (population) of its points."""
        if not len(count):
            return cls(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
        values, vectors = np.linalg.eigh(covariance)
        return cls(np.asarray(count, dtype=np.float64), np.asarray(mean, dtype=np.float64), vectors[:, :, 0],
                   np.sqrt(np.maximum(values[:, 0], 0.0)))  # fmt: skip

    def __len__(self) -> int:
        return len(self.count)

    def take(self, rows) -> FacetPlanes:
        return FacetPlanes(self.count[rows], self.centroid[rows], self.normal[rows], self.residual[rows])


def facet_normals(joined: JoinedFacets) -> tuple[np.ndarray, np.ndarray]:
    """Each facet's least-squares plane normal (F, 3) and its points' RMS distance to it (F,)."""
    if not len(joined):
        return np.zeros((0, 3)), np.zeros(0)
    values, vectors = np.linalg.eigh(joined.covariance)
    return vectors[:, :, 0], np.sqrt(np.maximum(values[:, 0], 0.0))


def aligned_counts(piece: np.ndarray, cell_normal: np.ndarray, rank: np.ndarray, normal: np.ndarray,
                   thresholds: FacetThresholds) -> np.ndarray:  # fmt: skip
    """Per facet (``normal`` (F, 3)), how many of one tile's own points (each one's ``piece``
    and its cell's plane ``cell_normal``; the pieces' facets ``rank``) have their cell's
    plane within twice the angle of the facet's:
    :func:`~geostructure.detect.facets.planar_components`' share, counted tile by tile."""
    facet = piece_facets(piece, rank)
    on = facet >= 0
    dot = np.abs(np.einsum("ij,ij->i", cell_normal[on], normal[facet[on]]))
    return np.bincount(facet[on], weights=dot >= np.cos(np.radians(2.0 * thresholds.max_angle)), minlength=len(normal))


def planar_renumbering(joined: JoinedFacets, aligned: np.ndarray, thresholds: FacetThresholds) -> np.ndarray:
    """The facets' new numbers (F + 1,; the last entry for -1): 0, 1, ... for the planar ones
    (:func:`~geostructure.detect.facets.planar_facets`: of three points or more, their RMS
    within twice the offset, four in five points aligned), -2 for the grown groups that are
    not (their points curved), -1 for those of one or two points."""
    _, rms = facet_normals(joined)
    held = np.maximum(joined.count, 1.0)
    spans = joined.count >= 3
    planar = (joined.count > 0) & (rms <= 2.0 * thresholds.max_offset) & (aligned / held >= 0.8) & spans
    renumber = np.full(len(joined) + 1, -1)
    renumber[np.flatnonzero(planar)] = np.arange(int(planar.sum()))
    renumber[:-1][spans & ~planar] = -2
    return renumber


def piece_labels(tile: TilePieces, rank: np.ndarray, renumber: np.ndarray) -> np.ndarray:
    """Each of the tile's own points' facet (its ``point``): its piece's facet renumbered by
    :func:`planar_renumbering` (-1 none, -2 a curved group's)."""
    return renumber[piece_facets(tile.piece, rank)]


def piece_facets(piece: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """Each point's facet from its ``piece`` (-1 none) and the pieces' facets ``rank``.

    Examples
    --------
    >>> piece_facets(np.array([1, -1, 0]), np.array([4, 2])).tolist()
    [2, -1, 4]
    """
    return np.where(piece >= 0, rank[np.maximum(piece, 0)], -1) if len(rank) else np.full(len(piece), -1)


def joined_labels(pieces: list, thresholds: FacetThresholds):
    """Each tile's own points' planar facet (-1 none, -2 a curved group's), one array per
    tile of ``pieces`` in their order: the pieces joined (:func:`join_pieces`), the facets'
    planes from their added moments, the aligned points counted tile by tile, and the
    planar facets numbered 0, 1, ... by size (:func:`planar_renumbering`). In memory, all
    the tiles' pieces at once; a stream does the same with one tile's points at a time."""
    joined = join_pieces(pieces)
    normal, _ = facet_normals(joined)
    aligned = np.zeros(len(joined))
    for piece, rank in zip(pieces, joined.rank):
        aligned += aligned_counts(piece.piece, piece.normal, rank, normal, thresholds)
    renumber = planar_renumbering(joined, aligned, thresholds)
    return [piece_labels(piece, rank, renumber) for piece, rank in zip(pieces, joined.rank)]
