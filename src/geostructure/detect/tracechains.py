"""Lines of pixels followed and cut: a thinned image's pixels chained along their longest
paths (:func:`pixel_chains`), each chain cut into straight pieces where it turns
(:func:`straight_pieces`), and the pieces that run on one line joined across short gaps
(:func:`joined_collinear`): what :mod:`.traceimage` draws its dark lines with. Every length
here is in pixels.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

#: Chains that turn by more than this (degrees) between straight pieces are cut there.
BEND_DEG = 25.0


def pixel_chains(mask: np.ndarray, min_pixels: float) -> list[np.ndarray]:
    """Paths through the 8-connected pixels of ``mask``: in each group, its longest path
    (between the two pixels farthest apart along the group), then the longest of what is
    left once that path and the pixels touching it are taken, while it spans ``min_pixels``.
    Every group at once: one shortest-path pass from a pixel of each group, one from the
    farthest pixel each reached (groups share no edge, so each pixel's nearest source is its
    own group's)."""
    where = np.argwhere(mask)
    n = len(where)
    if n < 2:
        return []
    lookup = np.full(mask.shape, -1, dtype=np.int32)  # a tile holds fewer than 2^31 pixels
    lookup[where[:, 0], where[:, 1]] = np.arange(n)
    row_parts: list[np.ndarray] = []
    col_parts: list[np.ndarray] = []
    weight_parts: list[np.ndarray] = []
    for dr, dc in ((1, 0), (0, 1), (1, 1), (1, -1)):
        step = where + (dr, dc)
        ok = (step[:, 0] < mask.shape[0]) & (step[:, 1] >= 0) & (step[:, 1] < mask.shape[1])
        other = np.full(n, -1)
        other[ok] = lookup[step[ok, 0], step[ok, 1]]
        linked = other >= 0
        row_parts.append(np.flatnonzero(linked))
        col_parts.append(other[linked])
        weight_parts.append(np.full(int(linked.sum()), np.hypot(dr, dc)))
    rows, cols, weights = np.concatenate(row_parts), np.concatenate(col_parts), np.concatenate(weight_parts)
    alive = np.ones(n, dtype=bool)
    chains: list[np.ndarray] = []
    while True:
        keep = alive[rows] & alive[cols]
        graph = coo_matrix((weights[keep], (rows[keep], cols[keep])), shape=(n, n)).tocsr()
        graph = graph + graph.T
        found = _longest_path_per_group(graph, alive, min_pixels)
        if not found:
            return chains
        chains.extend(where[path] for path in found)
        # the paths and the pixels touching them: their 8 neighbours in the mask (those dead
        # already stay so), read from the lookup, not the sparse graph's rows
        taken = np.concatenate(found)
        alive[taken] = False
        alive[_touching(where[taken], lookup)] = False


#: A pixel's 8 neighbours.
_NEIGHBOURS = np.array([(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc])


def _touching(pixels: np.ndarray, lookup: np.ndarray) -> np.ndarray:
    """The mask's pixels (indices in ``lookup``, -1 off the mask) 8-connected to ``pixels``."""
    near = (pixels[:, None, :] + _NEIGHBOURS).reshape(-1, 2)
    inside = (near[:, 0] >= 0) & (near[:, 0] < lookup.shape[0]) & (near[:, 1] >= 0) & (near[:, 1] < lookup.shape[1])
    index = lookup[near[inside, 0], near[inside, 1]]
    return index[index >= 0]


def _longest_path_per_group(graph, alive: np.ndarray, min_pixels: float) -> list[np.ndarray]:
    """Each group's longest path of the ``alive`` pixels (indices), where it spans ``min_pixels``."""
    _, group = connected_components(graph, directed=False)
    nodes = np.flatnonzero(alive)
    if not len(nodes):
        return []
    size = np.bincount(group[nodes], minlength=group.max() + 1)
    big = size * np.sqrt(2.0) >= min_pixels
    nodes = nodes[big[group[nodes]]]
    if not len(nodes):
        return []
    order = nodes[np.argsort(group[nodes], kind="stable")]
    first = order[np.r_[True, group[order][1:] != group[order][:-1]]]
    reach = dijkstra(graph, indices=first, directed=False, min_only=True)
    start = _farthest(reach, group, order)
    reach, before, _ = dijkstra(graph, indices=start, directed=False, min_only=True, return_predecessors=True)
    end = _farthest(reach, group, order)
    paths = []
    previous = before.tolist()  # walked a pixel at a time: a list reads faster than an array
    for a, z in zip(start.tolist(), end.tolist()):
        if reach[z] < min_pixels:
            continue
        path = [z]
        while path[-1] != a:
            path.append(previous[path[-1]])
        paths.append(np.asarray(path, dtype=np.int64))
    return paths


def _farthest(reach: np.ndarray, group: np.ndarray, order: np.ndarray) -> np.ndarray:
    """Per group (``order``: its alive pixels, grouped), the pixel farthest along ``reach``."""
    value = np.where(np.isfinite(reach[order]), reach[order], -1.0)
    sorted_group = group[order]
    cuts = np.flatnonzero(np.r_[True, sorted_group[1:] != sorted_group[:-1]])
    most = np.maximum.reduceat(value, cuts)
    at_most = np.flatnonzero(value == np.repeat(most, np.diff(np.r_[cuts, len(order)])))
    _, first = np.unique(sorted_group[at_most], return_index=True)  # the first, as argmax
    return order[at_most[first]].astype(np.int64)


def straight_pieces(chain: np.ndarray, tolerance: float, bend_deg: float = BEND_DEG) -> list[np.ndarray]:
    """A chain of pixels (n, 2) cut into straight pieces: its Douglas-Peucker vertices at
    ``tolerance`` pixels, cut where it turns by more than ``bend_deg``.

    Examples
    --------
    >>> chain = np.array([[i, 0] for i in range(10)] + [[9, j] for j in range(1, 10)], dtype=float)
    >>> [len(p) for p in straight_pieces(chain, 1.0)]
    [10, 10]
    """
    return chains_straight_pieces([chain], tolerance, bend_deg)


def chains_straight_pieces(chains: list, tolerance: float, bend_deg: float = BEND_DEG) -> list[np.ndarray]:
    """Every chain's :func:`straight_pieces`, in order: all chains at once, one pass per
    level of Douglas-Peucker's splits (an image's few hundred short chains, each its own
    loop of small numpy calls, took a fifth of the dark lines' time)."""
    if not len(chains):
        return []
    points = np.vstack([np.asarray(c, dtype=np.float64).reshape(-1, 2) for c in chains])
    sizes = np.array([len(c) for c in chains], dtype=np.int64)
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    keep = np.zeros(len(points), dtype=bool)
    keep[first] = keep[first + sizes - 1] = True
    _split_until_within(points, first, first + sizes - 1, tolerance, keep)
    vertex = np.flatnonzero(keep)
    chain_of = np.searchsorted(first, vertex, side="right") - 1
    # the turn at each vertex between two others of its chain
    steps = np.diff(points[vertex], axis=0)
    norms = np.linalg.norm(steps, axis=1)
    cosine = np.einsum("ij,ij->i", steps[:-1], steps[1:]) / np.maximum(norms[:-1] * norms[1:], 1e-12)
    inner = (chain_of[1:-1] == chain_of[:-2]) & (chain_of[1:-1] == chain_of[2:])
    turns = np.zeros(len(vertex), dtype=bool)
    turns[1:-1] = inner & (np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))) > bend_deg)
    ends = np.r_[True, chain_of[1:] != chain_of[:-1]]  # each chain's first vertex
    pieces = []
    for start, stop in zip(*_piece_bounds(vertex, ends, turns)):
        pieces.append(points[start : stop + 1])
    return pieces


def _piece_bounds(vertex: np.ndarray, first: np.ndarray, turns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each piece's first and last point: from a chain's first vertex or a turn to the next
    turn or the chain's last vertex (a chain of one point is one piece of one point)."""
    last = np.r_[first[1:], True]
    opens = first | turns
    closes = (turns | last) & ~(first & ~last)  # a chain's first vertex closes nothing, unless alone
    return vertex[opens & ~(last & ~first)], vertex[closes]


def _split_until_within(points, start, stop, tolerance: float, keep: np.ndarray) -> None:
    """Douglas-Peucker over every segment ``start[i]`` to ``stop[i]`` at once: each segment's
    interior point farthest from its chord (the first such) is kept and splits it, while
    that farthest lies beyond ``tolerance``."""
    while len(start):
        wide = stop - start >= 2
        start, stop = start[wide], stop[wide]
        if not len(start):
            return
        inner = stop - start - 1
        segment = np.repeat(np.arange(len(start)), inner)
        offset = np.arange(len(segment)) - np.repeat(np.cumsum(inner) - inner, inner)
        at = start[segment] + 1 + offset
        chord = points[stop] - points[start]
        along, across = chord[:, 0], chord[:, 1]
        length = np.sqrt(along * along + across * across)
        off = points[at] - points[start[segment]]
        lengths = length[segment]
        cross = np.abs(along[segment] * off[:, 1] - across[segment] * off[:, 0]) / np.where(lengths > 0, lengths, 1.0)
        distance = np.where(lengths > 0, cross, np.sqrt(off[:, 0] * off[:, 0] + off[:, 1] * off[:, 1]))
        bounds = np.cumsum(inner) - inner
        farthest = np.maximum.reduceat(distance, bounds)
        is_max = distance == farthest[segment]
        first_max = np.flatnonzero(is_max)
        _, pick = np.unique(segment[first_max], return_index=True)
        split = at[first_max[pick]]
        beyond = farthest > tolerance
        split, left, right = split[beyond], start[beyond], stop[beyond]
        keep[split] = True
        start, stop = np.concatenate([left, split]), np.concatenate([split, right])


#: Pieces joined end to end run within this of one line (degrees).
JOIN_ANGLE_DEG = 10.0


def joined_collinear(pieces: list, mean_z: list, gap: float, tolerance: float) -> tuple[list, list]:
    """Pieces (each (n, 2), pixels) joined end to end where they run on one line (see
    :data:`~.traceimage.JOIN_GAP`): each end joins the nearest end of another piece within
    ``gap`` whose piece runs within :data:`JOIN_ANGLE_DEG` and ``tolerance`` of its own line,
    when each is the other's nearest; each joined line with its pieces' length-weighted mean
    z-score.

    Examples
    --------
    >>> a = np.array([[0.0, 0], [10, 0]]); b = np.array([[13.0, 0.5], [30, 0.5]]); c = np.array([[0.0, 5], [0, 20]])
    >>> lines, z = joined_collinear([a, b, c], [1.0, 3.0, 2.0], 4.0, 3.0)
    >>> [len(line) for line in lines], [round(v, 2) for v in z]
    ([4, 2], [2.26, 2.0])
    """
    n = len(pieces)
    if n < 2:
        return [np.asarray(p, dtype=np.float64) for p in pieces], list(mean_z)
    pieces = [np.asarray(p, dtype=np.float64) for p in pieces]
    ends = np.array([p[k] for p in pieces for k in (0, -1)])  # end 2i: piece i's start, 2i + 1: its end
    direction = np.array([p[-1] - p[0] for p in pieces])
    length = np.linalg.norm(direction, axis=1)
    unit = direction / np.maximum(length, 1e-12)[:, None]
    pairs = cKDTree(ends).query_pairs(gap, output_type="ndarray")
    pairs = pairs[pairs[:, 0] // 2 != pairs[:, 1] // 2]
    i, j = pairs[:, 0] // 2, pairs[:, 1] // 2
    parallel = np.abs(np.einsum("ij,ij->i", unit[i], unit[j])) >= np.cos(np.radians(JOIN_ANGLE_DEG))
    # each end within the tolerance of the other piece's line
    cross = lambda d, e: np.abs(d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0])  # noqa: E731
    aligned = (cross(unit[i], ends[pairs[:, 1]] - pieces_start(pieces, i)) <= tolerance) & (
        cross(unit[j], ends[pairs[:, 0]] - pieces_start(pieces, j)) <= tolerance
    )
    pairs = pairs[parallel & aligned]
    distance = np.linalg.norm(ends[pairs[:, 0]] - ends[pairs[:, 1]], axis=1)
    partner = np.full(len(ends), -1)
    for k in np.argsort(distance, kind="stable"):  # nearest first, each end once
        e, f = pairs[k]
        if partner[e] < 0 and partner[f] < 0:
            partner[e], partner[f] = f, e
    lines, z = [], []
    used = np.zeros(n, dtype=bool)
    for start in range(n):
        if used[start] or (partner[2 * start] >= 0 and partner[2 * start + 1] >= 0):
            continue  # a piece inside a run is reached from the run's first piece
        lines_z = _follow(start, partner, pieces, mean_z, length, used)
        lines.append(lines_z[0])
        z.append(lines_z[1])
    for loop_start in np.flatnonzero(~used):  # closed loops of pieces: none on a line, but kept whole
        lines_z = _follow(int(loop_start), partner, pieces, mean_z, length, used)
        lines.append(lines_z[0])
        z.append(lines_z[1])
    return lines, z


def pieces_start(pieces: list, index: np.ndarray) -> np.ndarray:
    return np.array([pieces[k][0] for k in index]).reshape(-1, 2)


def _follow(start: int, partner: np.ndarray, pieces: list, mean_z: list, length: np.ndarray, used: np.ndarray):
    """The run of joined pieces from ``start`` (an end of a run, or any piece of a loop)."""
    # leave by the end that has a partner (or the end, for a piece alone)
    forward = partner[2 * start + 1] >= 0 or partner[2 * start] < 0
    parts, weights, zs = [], [], []
    piece, out_end = start, (2 * start + 1 if forward else 2 * start)
    while True:
        used[piece] = True
        line = pieces[piece] if out_end == 2 * piece + 1 else pieces[piece][::-1]
        parts.append(line)
        weights.append(length[piece])
        zs.append(mean_z[piece] * length[piece])
        nxt = partner[out_end]
        if nxt < 0 or used[nxt // 2]:
            break
        piece = nxt // 2
        out_end = 2 * piece + 1 if nxt == 2 * piece else 2 * piece
    return np.vstack(parts), float(sum(zs) / max(sum(weights), 1e-12))
