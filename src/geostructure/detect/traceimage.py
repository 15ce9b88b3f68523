"""Dark lines on a patch of surface, as a geologist sees fracture traces on a photograph of it.

A patch of the cloud is laid flat on its own mean plane and sampled as an image half a point
spacing per pixel (:meth:`PatchGrid.image`): each pixel the points' values around it, weighted by a
Gaussian one spacing wide (normalised convolution, so that holes stay holes). A trace is a
line darker than the rock either side of it: where the image's Hessian, at a scale of one
spacing, has a large positive eigenvalue (the value curves up across the line), thinned to
the pixels that are the strongest across it (non-maximum suppression, as Canny and Steger
thin edges and lines), kept where a chain of them reaches a strong pixel (hysteresis). Each
chain is followed along its longest path (:func:`pixel_chains`), and cut where it turns
(:func:`straight_pieces`): a fracture's trace is straight over the lengths the rule scores.
A piece is kept when it stands out of the patch's noise more than the lines drawn on the
same patch with its values shuffled among its points do (:func:`noise_contrast`).

Every length is in point spacings; the thresholds are robust z-scores of the patch's own
ridge strengths. Nothing reads the patch's extent or where it lies.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from geostructure.core.threads import run_tasks

#: Pixels per point spacing: two, so that a line one spacing wide spans a pixel or two.
PIXELS_PER_SPACING = 2.0
#: The Hessian's scale (spacings): a trace on a 3 cm cloud is one or two points wide.
RIDGE_SCALE = 1.0
#: Robust z-scores of the ridge strength: a chain is kept where it reaches HIGH, followed
#: while above LOW (hysteresis). On the Lastoni SW half LOW 0.5 joined more of each trace
#: (69 mapped fractures traced, against 61 at 1.0) at the same precision (0.24, 0.26).
HIGH_Z, LOW_Z = 2.0, 0.5
#: Chains that turn by more than this (degrees) between straight pieces are cut there.
BEND_DEG = 25.0
#: A straight piece deviates from its chord by at most this many spacings.
STRAIGHT_TOLERANCE = 1.5


def patch_frame(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A patch's mean plane: its centroid and the principal axes (largest, second, normal)."""
    centre = points.mean(axis=0)
    centred = points - centre
    _, vectors = np.linalg.eigh(np.cov(centred.T))
    u, normal = vectors[:, 2], vectors[:, 0]
    # Signs the patch itself fixes, not the axes it lies along (a turned or moved cloud gives
    # the same image): each axis toward its projections' longer tail (third moment); then
    # v completes a right-handed frame.
    u = u if np.mean((centred @ u) ** 3) >= 0 else -u
    normal = normal if np.mean((centred @ normal) ** 3) >= 0 else -normal
    v = np.cross(normal, u)
    return centre, u, v, normal


@dataclass(frozen=True)
class PatchGrid:
    """Where a patch's points fall on its image (``cell``, each point's pixel, flat), the
    points' weight per pixel blurred (``count``), what is trusted (``covered``, ``inside``)
    and the plane: what every image of the patch's values shares (the shuffled nulls too)."""

    cell: np.ndarray
    shape: tuple
    count: np.ndarray
    covered: np.ndarray
    inside: np.ndarray
    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    lower: np.ndarray
    pixel: float

    @classmethod
    def of(cls, points: np.ndarray, spacing: float) -> PatchGrid:
        centre, u, v, _ = patch_frame(points)
        pixel = spacing / PIXELS_PER_SPACING
        flat = np.column_stack([(points - centre) @ u, (points - centre) @ v])
        # Pixels counted from the point nearest the patch's centroid, not from its extreme
        # points nor from the centroid itself: an outlier more or less moves the least corner
        # by centimetres, and with it every pixel's phase (on the Lastoni SW half, 15 points
        # the filter read otherwise turned moved three dark lines in five); the centroid moves
        # by a fraction of a pixel, which still moved 14 of its 159 lines when one of its
        # 38,173 points was left out, and 42 inside a survey of four copies (where the filter
        # reads four points otherwise); the point nearest it stays the same point (5 lines
        # of 153 moved, and 21).
        anchor = flat[np.argmin(np.einsum("ij,ij->i", flat, flat))]
        lower = anchor + np.floor((flat.min(axis=0) - anchor) / pixel) * pixel
        ij = np.floor((flat - lower) / pixel).astype(np.int64)
        shape = tuple(int(n) for n in ij.max(axis=0) + 1)
        cell = ij[:, 0] * shape[1] + ij[:, 1]
        count = np.bincount(cell, minlength=shape[0] * shape[1]).reshape(shape).astype(np.float64)
        count = ndimage.gaussian_filter(count, PIXELS_PER_SPACING)  # one spacing
        covered = count > 0.05 * np.median(count[count > 1e-6])
        margin = int(np.ceil(2 * RIDGE_SCALE * PIXELS_PER_SPACING))
        inside = ndimage.binary_erosion(covered, iterations=margin) if margin else covered
        return cls(cell, shape, count, covered, inside, centre, u, v, lower, pixel)

    def image(self, values: np.ndarray) -> np.ndarray:
        """The points' ``values`` on the grid, (H, W) with NaN where no point lies: each pixel
        their mean around it, weighted by a Gaussian one spacing wide (normalised
        convolution: holes stay holes)."""
        size = self.shape[0] * self.shape[1]
        total = np.bincount(self.cell, weights=values, minlength=size).reshape(self.shape)
        value = ndimage.gaussian_filter(total, PIXELS_PER_SPACING)
        del total
        value /= np.maximum(self.count, 1e-12)  # in place: an image's size in arrays, two at most
        value[~self.covered] = np.nan
        return value


#: Rows of an image squared at once where a whole image's temporary would be one array too many.
ROW_BLOCK = 64


def ridge_strength(value: np.ndarray, inside: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The dark-line strength of each pixel of an image's ``value`` (the Hessian's larger
    eigenvalue, scale-normalised; 0 off ``inside``), and the Hessian's ``hxx - hyy`` and
    ``2 hxy``, whose half angle is the direction across the line (:func:`across_line`), read
    only where a line may pass. ``value`` is overwritten (its holes filled): five arrays of
    the image's size at most alive at once, for five images a patch may find lines on side
    by side."""
    sigma = RIDGE_SCALE * PIXELS_PER_SPACING
    holes = ~np.isfinite(value)
    value[holes] = np.median(value[~holes], overwrite_input=True) if (~holes).any() else np.nan
    hxx = ndimage.gaussian_filter(value, sigma, order=(2, 0))
    hyy = ndimage.gaussian_filter(value, sigma, order=(0, 2))
    # (hxx + hyy) / 2 + sqrt(((hxx - hyy) / 2)^2 + hxy^2), in place
    strength = hxx + hyy
    difference = np.subtract(hxx, hyy, out=hxx)
    del hyy
    hxy = ndimage.gaussian_filter(value, sigma, order=(1, 1))
    gap = np.divide(difference, 2, out=value)  # the image's array, no longer read
    np.square(gap, out=gap)
    for rows in range(0, len(gap), ROW_BLOCK):  # hxy squared a block of rows at a time: no fifth array
        gap[rows : rows + ROW_BLOCK] += np.square(hxy[rows : rows + ROW_BLOCK])
    np.sqrt(gap, out=gap)
    strength /= 2
    strength += gap
    del gap
    strength *= sigma**2
    strength[~inside] = 0.0
    twice_hxy = np.multiply(hxy, 2, out=hxy)
    return strength, difference, twice_hxy


def across_line(difference: np.ndarray, twice_hxy: np.ndarray) -> np.ndarray:
    """The angle across a line (radians, in pixel axes) from the Hessian's ``hxx - hyy`` and
    ``2 hxy`` (:func:`ridge_strength`).

    Examples
    --------
    >>> float(np.degrees(across_line(np.array([1.0]), np.array([0.0]))[0]))  # hxx > hyy: across rows
    0.0
    """
    return 0.5 * np.arctan2(twice_hxy, difference)


def line_candidates(z: np.ndarray, inside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pixels (rows, columns) that may be a line's: inside, above LOW (none where fewer
    than 16 pixels are inside). The strongest across a line is looked for there alone (a
    third of the pixels), each pixel read as it would be in the whole image."""
    if np.count_nonzero(inside) < 16:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    rows, cols = np.nonzero(inside & (z > LOW_Z))
    return rows, cols


def thinned_lines(strength: np.ndarray, z: np.ndarray, rows: np.ndarray, cols: np.ndarray, across) -> np.ndarray:
    """Of the :func:`line_candidates` (``rows``, ``cols``, each with its angle ``across`` the
    line), those the strongest across their line (non-maximum suppression) in a group that
    reaches above HIGH (hysteresis): the lines' pixels, as a mask of the image."""
    dr, dc = np.cos(across), np.sin(across)
    ahead = ndimage.map_coordinates(strength, [rows + dr, cols + dc], order=1, mode="nearest")
    behind = ndimage.map_coordinates(strength, [rows - dr, cols - dc], order=1, mode="nearest")
    here = strength[rows, cols]
    thin = np.zeros(strength.shape, dtype=bool)
    thin[rows, cols] = (here >= ahead) & (here >= behind)
    labels, n = ndimage.label(thin, structure=np.ones((3, 3)))
    strong = np.zeros(n + 1, dtype=bool)
    strong[np.unique(labels[thin & (z > HIGH_Z)])] = True
    strong[0] = False
    return strong[labels]


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


def channel_lines(grid: PatchGrid, channels: list, min_chord: float) -> list:
    """The lines of low values of one patch, per channel (its grey, its depths), on its
    ``grid``: per channel its straight pieces, each an (n, 2) array of coordinates along the
    patch's axes (:class:`PatchGrid`), and their contrasts (:func:`line_contrast`), those
    that stand out more than the channel's values shuffled among the points let a line
    (:func:`noise_contrast`).

    Parameters
    ----------
    grid : PatchGrid
        The patch's points laid flat (:meth:`PatchGrid.of`).
    channels : list of (N,) arrays
        What is low along a trace (the points' grey; their height over the surface around them).
    min_chord : float
        The shortest piece kept (spacings).
    """
    # every channel's lines and first null side by side, each image made in its own task
    # (only those running take memory; each is half numpy filters, which run in threads);
    # then as many further nulls as the lines drawn so far show are needed. A null keeps only
    # its lines' contrasts, and its order is drawn as it is needed (the images' stage took
    # 3.8 MB more at its peak while all four orders and the nulls' pieces were kept).
    shuffles = [np.random.default_rng(0) for _ in channels]  # each channel's orders drawn in turn from its own
    tasks = []
    for values, rng in zip(channels, shuffles):
        tasks += [
            partial(_lines, grid, values, min_chord),
            partial(_null_lines, grid, values, rng.permutation(len(values)), min_chord),
        ]
    found = run_tasks(tasks)
    lines = [found[2 * c] for c in range(len(channels))]
    nulls = [[found[2 * c + 1]] for c in range(len(channels))]
    del found
    while True:
        wanted = [permutations_needed(sum(map(len, drawn)), len(drawn)) - len(drawn) for drawn in nulls]
        if not any(wanted):
            break
        tasks = [partial(_null_lines, grid, values, rng.permutation(len(values)), min_chord)
                 for values, rng, extra in zip(channels, shuffles, wanted) for _ in range(extra)]  # fmt: skip
        more = iter(run_tasks(tasks))
        for drawn, extra in zip(nulls, wanted):
            drawn.extend(next(more) for _ in range(extra))
    out = []
    for (pieces, contrast), drawn in zip(lines, nulls):
        bar = noise_contrast(drawn)
        kept = [k for k, value in enumerate(contrast) if value > bar]
        out.append(([pieces[k] for k in kept], [contrast[k] for k in kept]))
    return out


def _lines(grid: PatchGrid, values: np.ndarray, min_chord: float) -> tuple[list, list]:
    """Every line piece of the points' ``values`` on ``grid``, with its contrast (the
    module's steps)."""
    strength, difference, twice_hxy = ridge_strength(grid.image(values), grid.inside)
    z = robust_z(strength, grid.inside)
    rows, cols = line_candidates(z, grid.inside)
    across = across_line(difference[rows, cols], twice_hxy[rows, cols])
    del difference, twice_hxy  # read where a line may pass: the image's arrays let go first
    mask = thinned_lines(strength, z, rows, cols, across)
    del strength
    pieces = chains_straight_pieces(
        pixel_chains(mask, JOIN_GAP * PIXELS_PER_SPACING), STRAIGHT_TOLERANCE * PIXELS_PER_SPACING
    )
    mean_z = pieces_mean(z, pieces)
    lines, contrast = [], []
    for line, line_z in zip(*joined_collinear(pieces, mean_z, JOIN_GAP * PIXELS_PER_SPACING)):
        length = np.linalg.norm(line[-1] - line[0])
        if length >= min_chord * PIXELS_PER_SPACING:
            lines.append(line * grid.pixel + grid.lower)
            contrast.append(float(line_z * np.sqrt(length / (2.0 * RIDGE_SCALE * PIXELS_PER_SPACING))))
    return lines, contrast


def pieces_mean(image: np.ndarray, pieces: list) -> list[float]:
    """Each piece's mean of ``image`` over its pixels: the pieces of one length at once, each
    its own row, whose mean numpy sums as it would the piece alone (the same to the bit).

    Examples
    --------
    >>> pieces_mean(np.arange(9.0).reshape(3, 3), [np.array([[0, 0], [1, 1]]), np.array([[2, 2]])])
    [2.0, 8.0]
    """
    out = np.zeros(len(pieces))
    lengths = np.array([len(piece) for piece in pieces], dtype=np.int64)
    for length in np.unique(lengths):
        same = np.flatnonzero(lengths == length)
        pixels = np.stack([pieces[k] for k in same]).astype(np.int64)
        out[same] = image[pixels[..., 0], pixels[..., 1]].mean(axis=1)
    return out.tolist()


#: Straight pieces whose near ends lie this many spacings apart or less, running on one line
#: (within :data:`JOIN_ANGLE_DEG` and :data:`STRAIGHT_TOLERANCE` of it), are one trace broken
#: by noise, a crossing or a blurred stretch: a geologist draws it through.
JOIN_GAP = 4.0
JOIN_ANGLE_DEG = 10.0


def joined_collinear(pieces: list, mean_z: list, gap: float) -> tuple[list, list]:
    """Pieces (each (n, 2), pixels) joined end to end where they run on one line (see
    :data:`JOIN_GAP`): each end joins the nearest end of another piece within ``gap`` whose
    piece runs within :data:`JOIN_ANGLE_DEG` and :data:`STRAIGHT_TOLERANCE` of its own line,
    when each is the other's nearest; each joined line with its pieces' length-weighted mean
    z-score.

    Examples
    --------
    >>> a = np.array([[0.0, 0], [10, 0]]); b = np.array([[13.0, 0.5], [30, 0.5]]); c = np.array([[0.0, 5], [0, 20]])
    >>> lines, z = joined_collinear([a, b, c], [1.0, 3.0, 2.0], 4.0)
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
    tolerance = STRAIGHT_TOLERANCE * PIXELS_PER_SPACING
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


#: The null that sets how much contrast a line needs: the patch's grey shuffled among its
#: points, its lines found the same way; a line is kept when it stands out more than this
#: share of the null's lines (a contrario, as LSD keeps a segment that noise would give less
#: than once). The cloud's own noise sets the bar, no constant: on the Lastoni SW half it
#: came to a contrast of about 5.4.
NULL_QUANTILE = 0.99
#: Seeded permutations drawn, at most: on the Lastoni SW half one alone (some 320 lines)
#: moved its bar by 10%.
NULL_PERMUTATIONS = 4
#: The bar, a tail quantile, is read from at least this many null lines beyond it: as many
#: permutations as give NULL_TAIL_LINES / (1 - NULL_QUANTILE) lines (a thousand), at most
#: :data:`NULL_PERMUTATIONS`. A large patch's first shuffle alone draws that many (on the
#: ODM Brighton survey's largest, 2,000), and its other three were half the traces' time.
NULL_TAIL_LINES = 10


def permutations_needed(lines_drawn: int, shuffles: int) -> int:
    """How many shuffles a patch's null needs, from the ``lines_drawn`` by its first
    ``shuffles`` (see :data:`NULL_TAIL_LINES`): as many as, drawing lines at that rate, give
    a thousand, at most :data:`NULL_PERMUTATIONS`.

    Examples
    --------
    >>> permutations_needed(2000, 1), permutations_needed(600, 1), permutations_needed(320, 1), permutations_needed(0, 1)
    (1, 2, 4, 4)
    >>> permutations_needed(996, 3)  # three short of a thousand: a fourth
    4
    """
    lines_needed = int(round(NULL_TAIL_LINES / (1.0 - NULL_QUANTILE)))
    if lines_drawn >= lines_needed:
        return shuffles
    if lines_drawn <= 0:
        return NULL_PERMUTATIONS
    return int(min(NULL_PERMUTATIONS, max(shuffles + 1, -(-lines_needed * shuffles // lines_drawn))))


def _null_lines(grid: PatchGrid, values: np.ndarray, order: np.ndarray, min_chord: float) -> list:
    """The contrasts of the lines :func:`_lines` draws on ``values`` shuffled by ``order``
    (what the null keeps of them)."""
    return _lines(grid, values[order], min_chord)[1]


def noise_contrast(found: list) -> float:
    """The contrast a line must pass on a patch: :data:`NULL_QUANTILE` of the contrasts of
    the lines found on its values shuffled among its points (``found``: one list per
    seeded shuffle, as many as :func:`permutations_needed` asks); 0 where the shuffles draw no
    line."""
    contrasts = [contrast for lines in found for contrast in lines]
    return float(np.quantile(contrasts, NULL_QUANTILE)) if contrasts else 0.0


def robust_z(strength: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """The ridge strength as robust z-scores of the patch's own (median, 1.4826 MAD)."""
    values = strength[inside]  # a copy, reordered and overwritten by the medians below
    median = np.median(values, overwrite_input=True) if values.size else 0.0
    values -= median
    spread = 1.4826 * np.median(np.abs(values, out=values), overwrite_input=True) if values.size else 0.0
    del values
    if not spread > 0:
        return np.zeros_like(strength)
    z = strength - median
    z /= spread
    return z


def line_contrast(z: np.ndarray, piece: np.ndarray, length: float) -> float:
    """How far a line stands out of the patch's noise: its pixels' mean z-score times the
    root of the independent samples along it (one per two ridge scales), as a line's mean
    of that many noisy samples would. On the Lastoni SW half the dark lines of 6 or more
    traced mapped fractures at a precision of 0.40, all of them at 0.24."""
    along = z[piece[:, 0].astype(np.int64), piece[:, 1].astype(np.int64)]
    return float(along.mean() * np.sqrt(length / (2.0 * RIDGE_SCALE * PIXELS_PER_SPACING)))
