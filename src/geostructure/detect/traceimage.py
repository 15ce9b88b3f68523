"""Dark lines on a patch of surface, as a geologist sees fracture traces on a photograph of it.

A patch of the cloud is laid flat on its own mean plane and sampled as an image half a point
spacing per pixel (:meth:`PatchGrid.image`): each pixel the points' values around it, weighted by a
Gaussian one spacing wide (normalised convolution, so that holes stay holes). A trace is a
line darker than the rock either side of it: where the image's Hessian, at a scale of one
spacing, has a large positive eigenvalue (the value curves up across the line), thinned to
the pixels that are the strongest across it (non-maximum suppression, as Canny and Steger
thin edges and lines), kept where a chain of them reaches a strong pixel (hysteresis). Each
chain is followed along its longest path (:func:`~.tracechains.pixel_chains`), and cut where it turns
(:func:`~.tracechains.straight_pieces`): a fracture's trace is straight over the lengths the rule scores.
A piece is kept when it stands out of the patch's noise more than the lines drawn on the
same patch with its values shuffled among its points do (:func:`noise_contrast`).

Every length is in point spacings; the thresholds are robust z-scores of the patch's own
ridge strengths. Nothing reads the patch's extent or where it lies.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any, Callable

import numpy as np
from scipy import ndimage

from geostructure.core.threads import run_tasks
from geostructure.detect.tracechains import chains_straight_pieces, joined_collinear, pixel_chains

#: Pixels per point spacing: two, so that a line one spacing wide spans a pixel or two.
PIXELS_PER_SPACING = 2.0
#: The Hessian's scale (spacings): a trace on a 3 cm cloud is one or two points wide.
RIDGE_SCALE = 1.0
#: Robust z-scores of the ridge strength: a chain is kept where it reaches HIGH, followed
#: while above LOW (hysteresis). On the Lastoni SW half LOW 0.5 joined more of each trace
#: (69 mapped fractures traced, against 61 at 1.0) at the same precision (0.24, 0.26).
HIGH_Z, LOW_Z = 2.0, 0.5
#: A straight piece deviates from its chord by at most this many spacings.
STRAIGHT_TOLERANCE = 1.5
#: Straight pieces whose near ends lie this many spacings apart or less, running on one line
#: (within :data:`~.tracechains.JOIN_ANGLE_DEG` and :data:`STRAIGHT_TOLERANCE` of it), are one
#: trace broken by noise, a crossing or a blurred stretch: a geologist draws it through.
JOIN_GAP = 4.0


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
    tasks: list[Callable[[], object]] = []
    for values, rng in zip(channels, shuffles):
        tasks += [
            partial(_lines, grid, values, min_chord),
            partial(_null_lines, grid, values, rng.permutation(len(values)), min_chord),
        ]
    found: list[Any] = run_tasks(tasks)
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
    for line, line_z in zip(
        *joined_collinear(pieces, mean_z, JOIN_GAP * PIXELS_PER_SPACING, STRAIGHT_TOLERANCE * PIXELS_PER_SPACING)
    ):
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
