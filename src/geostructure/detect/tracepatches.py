"""The face cut into patches, each laid flat as an image and its lines drawn: the dark lines
of its grey and the valleys of its relief (:mod:`.tracechannels`, :mod:`.traceimage`), as
3D polylines on its points.

A patch is a group of points no gap of :data:`PATCH_GAP` spacings splits, so that an outcrop
measured inside a larger survey gives the same patch, laid on the same plane, as alone; a
patch too large for one image is cut into tiles along its own axes. Every length is in point
spacings.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from geostructure.core.threads import tree_query
from geostructure.detect.tracechannels import DARK_LINE, VALLEY, local_planes, patch_recess
from geostructure.detect.traceimage import PIXELS_PER_SPACING, PatchGrid, channel_lines, patch_frame

#: Two groups of points this many spacings apart are separate patches (each point linked to
#: its PATCH_NEIGHBOURS nearest within it).
PATCH_GAP = 4.0
PATCH_NEIGHBOURS = 8
#: The largest patch laid flat as one image (spacings along its longer axis); larger ones
#: are cut into tiles of this size, with halos of :data:`TILE_HALO`.
MAX_PATCH = 768.0
TILE_HALO = 16.0
#: The shortest trace kept (spacings): six spacings, the scale below which a line of points
#: is noise as often as rock.
MIN_CHORD = 6.0
#: Vertices along a trace every this many spacings.
VERTEX_STEP = 2.0
#: A valley within this many spacings of a dark line of its patch, along half its length, is
#: that dark line seen again.
SAME_LINE_SPACINGS = 2.0
#: ... and whose chord runs within this of the dark line's (degrees: a trace's set's tolerance).
SAME_LINE_DEG = 15.0

#: Points a patch's own spacing is read over, at most (its image's pixel): every point of a
#: patch this size or smaller. A sample drawn again from a few points more or less is another
#: sample, whose median moved the pixel, and so the lines, where the median over all barely
#: moves (on the Lastoni SW half, 0.02% against 0.003%).
PATCH_SPACING_SAMPLE = 200_000


def nearest_spacing(points: np.ndarray, tree: cKDTree, sample: int = 50_000) -> float:
    """The median distance from a point to its nearest neighbour (a seeded sample of at most
    ``sample`` points; every point of a cloud that size or smaller)."""
    distance, _ = tree.query(_seeded_sample(points, sample), 2)
    return float(np.median(distance[:, 1]))


def median_nearest(nearest: np.ndarray, sample: int = 50_000) -> float:
    """:func:`nearest_spacing` from each point's distance to its nearest neighbour, when a
    query already holds them (the same seeded sample, so the same value)."""
    return float(np.median(_seeded_sample(nearest, sample)))


def _seeded_sample(rows: np.ndarray, sample: int) -> np.ndarray:
    """At most ``sample`` of ``rows``, drawn with seed 0 (all of them when that many or fewer)."""
    if len(rows) <= sample:
        return rows
    return rows[np.random.default_rng(0).choice(len(rows), sample, replace=False)]


def neighbours(points: np.ndarray, tree: cKDTree) -> tuple[np.ndarray, np.ndarray]:
    """Each point's :data:`PATCH_NEIGHBOURS` nearest (distances, indices; itself first), one
    query that gives the patches and every spacing the traces read."""
    distance, index = tree_query(tree, points, min(PATCH_NEIGHBOURS, len(points)))
    return distance.reshape(len(points), -1), index.reshape(len(points), -1)


def patches(points: np.ndarray, spacing: float, tree: cKDTree | None = None, near_points=None) -> list:
    """Groups of points no gap of :data:`PATCH_GAP` spacings splits (each point linked to its
    nearest neighbours that close, so that neither the cloud's axes nor its origin matter),
    each cut into tiles along its own axes where larger than :data:`MAX_PATCH`: (indices
    with halos, the core each tile answers for) per tile. ``near_points``: the points'
    :func:`neighbours`, when the caller holds them."""
    tree = cKDTree(points) if tree is None else tree
    distance, neighbour = neighbours(points, tree) if near_points is None else near_points
    k = distance.shape[1]
    near = distance[:, 1:] <= PATCH_GAP * spacing
    rows = np.repeat(np.arange(len(points)), k - 1)[near.ravel()]
    graph = coo_matrix((np.ones(len(rows)), (rows, neighbour[:, 1:][near])), shape=(len(points),) * 2)
    _, group = connected_components(graph, directed=False)
    order = np.argsort(group, kind="stable")
    tiles = []
    for members in np.split(order, np.flatnonzero(np.diff(group[order])) + 1):
        tiles.extend(_tiles(points, members, spacing))
    return tiles


def _tiles(points, members, spacing):
    if len(members) < 3:
        return []
    centre, u, v, _ = patch_frame(points[members])
    flat = np.column_stack([(points[members] - centre) @ u, (points[members] - centre) @ v])
    size = MAX_PATCH * spacing
    if np.ptp(flat[:, 0]) <= size and np.ptp(flat[:, 1]) <= size:
        return [(members, np.ones(len(members), dtype=bool))]
    lower, halo = flat.min(axis=0), TILE_HALO * spacing
    out = []
    tile = np.floor((flat - lower) / size).astype(np.int64)
    for t in np.unique(tile, axis=0):
        low, high = lower + t * size, lower + (t + 1) * size
        near = np.all((flat >= low - halo) & (flat < high + halo), axis=1)
        core = np.all((flat[near] >= low) & (flat[near] < high), axis=1)
        out.append((members[near], core))
    return out


def patch_tiles(points: np.ndarray, tree: cKDTree, spacing: float | None = None) -> tuple[float, list, np.ndarray]:
    """From one neighbour query (:func:`neighbours`): the points' spacing (``spacing`` when
    given), their patches' tiles (:func:`patches`) and each point's distance to its nearest
    neighbour; the query's other columns are let go before the images take their memory."""
    distance, index = neighbours(points, tree)
    spacing = median_nearest(distance[:, 1]) if spacing is None else spacing
    return spacing, patches(points, spacing, tree, (distance, index)), distance[:, 1].copy()


def dark_line_traces(
    points: np.ndarray, grey: np.ndarray, spacing: float, tree: cKDTree | None = None, tiles=None, nearest=None
) -> list:
    """The dark lines of every patch (:func:`patches`) as 3D polylines on the surface, each
    with its contrast and its kind: :data:`DARK_LINE` on the grey, :data:`VALLEY` on the
    recess (:mod:`.tracechannels`), a valley along a dark line of its patch dropped.
    ``tiles`` and ``nearest``: the points' :func:`patch_tiles`, when the caller holds them."""
    tree = cKDTree(points) if tree is None else tree
    if tiles is None or nearest is None:
        _, tiles, nearest = patch_tiles(points, tree, spacing)
    out: list = []
    for members, core in tiles:
        if len(members) < 50:
            continue
        mine = points[members]
        # the patch's own spacing: a survey around it, or its sample, must not change its image
        own = median_nearest(nearest[members], PATCH_SPACING_SAMPLE)
        # each point's plane of its nearest in the whole cloud, read a tile at a time: memory
        # the tile's, not the survey's
        centres, normals = local_planes(points, tree, at=members)
        grid = PatchGrid.of(mine, own)
        recess = patch_recess(mine, centres, normals, grey[members], np.cross(grid.u, grid.v))
        channels = [grey[members]] if recess is None else [grey[members], -recess]
        found = _patch_lines(mine, core, channels, grid)
        (dark, dark_contrast), (valley, valley_contrast) = found[0], found[1] if len(found) > 1 else ([], [])
        again = _along(valley, dark, own)
        out.extend((line, contrast, DARK_LINE) for line, contrast in zip(dark, dark_contrast))
        out.extend((line, contrast, VALLEY) for line, contrast, seen in zip(valley, valley_contrast, again) if not seen)
    return out


def _patch_lines(mine: np.ndarray, core: np.ndarray, channels: list, grid: PatchGrid) -> list:
    """One patch's lines of low values in each of ``channels`` (:func:`~.traceimage.channel_lines`)
    whose middle is in the tile's ``core``: per channel, 3D polylines on its points and their
    contrasts."""
    found = channel_lines(grid, channels, MIN_CHORD)
    if not any(pieces for pieces, _ in found):
        return [([], []) for _ in channels]
    flat = np.column_stack([(mine - grid.origin) @ grid.u, (mine - grid.origin) @ grid.v])
    flat_tree = cKDTree(flat)
    core_tree = cKDTree(flat[core]) if not core.all() else None
    step = max(1, int(round(VERTEX_STEP * PIXELS_PER_SPACING)))  # pixels: the patch's spacings
    out = []
    for pieces, contrasts in found:
        lines, kept = [], []
        for piece, contrast in zip(pieces, contrasts):
            mid = piece[len(piece) // 2]
            if core_tree is not None and core_tree.query(mid)[0] > flat_tree.query(mid)[0] + 1e-9:
                continue  # its middle lies in the halo: the neighbouring tile answers for it
            at = np.vstack([piece[::step], piece[-1:]]) if (len(piece) - 1) % step else piece[::step]
            _, idx = flat_tree.query(at, 3)
            lines.append(mine[idx].mean(axis=1))  # on the surface: the nearest points, in 3D
            kept.append(contrast)
        out.append((lines, kept))
    return out


def _along(lines: list, drawn: list, spacing: float) -> np.ndarray:
    """Which of ``lines`` run along one of the lines ``drawn`` already: half its vertices or
    more within :data:`SAME_LINE_SPACINGS` of that line's, its chord within
    :data:`SAME_LINE_DEG` of that line's (the same trace seen again; one crossing it is not)."""
    again = np.zeros(len(lines), dtype=bool)
    if not lines or not drawn:
        return again
    owner = np.repeat(np.arange(len(drawn)), [len(line) for line in drawn])
    vertices = cKDTree(np.vstack(drawn))
    chords = np.array([line[-1] - line[0] for line in drawn])
    chords /= np.maximum(np.linalg.norm(chords, axis=1, keepdims=True), 1e-12)
    parallel = np.cos(np.radians(SAME_LINE_DEG))
    for k, line in enumerate(lines):
        near = vertices.query_ball_point(line, SAME_LINE_SPACINGS * spacing)
        # per line drawn, how many of this line's vertices lie near it
        hits = np.concatenate([np.unique(owner[found]) for found in near if found] or [np.zeros(0, dtype=np.int64)])
        close = np.flatnonzero(np.bincount(hits, minlength=len(drawn)) >= 0.5 * len(line))
        if len(close):
            chord = (line[-1] - line[0]) / max(np.linalg.norm(line[-1] - line[0]), 1e-12)
            again[k] = bool(np.any(np.abs(chords[close] @ chord) >= parallel))
    return again
