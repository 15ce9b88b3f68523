"""What a fracture trace shows at each point, as values whose low lines the dark-line
detector (:mod:`.traceimage`) draws: the points' grey, and how far each point lies below
the surface around it (a valley: an open crack, a recess the fracture weathered out).

Measured on the DICE Lastoni SW half (``docs/rockmass.md``, "What the cloud shows of a
trace"), along the 432 mapped traces against as many random segments: the mean darkness
against each point's 60 nearest tells a trace from a random line with an area under the
curve of 0.69, the recess below each point's 16 nearest 0.70, both together 0.71; the
colour itself (chroma, the balance of red, green and blue) 0.49 to 0.58. The two channels
trace different fractures (of the dark lines drawn on each, 17 traced only on the recess,
24 only on the grey), so both are drawn and a line of the second that lies along one of the
first is dropped.

The recess is signed toward the rock: the side of the patch's surface that is darker
where it is deeper (a crack is shaded). On the SW half every one of its 39 squares of 1 m
with 300 points or more reads the same side so; the skew of the depths, another tell, only
74% of them. Where the cloud has no colour, or its shading tells neither side, no valley
is drawn.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from geostructure.core.eigen import smallest_eigenpair
from geostructure.core.threads import tree_query

#: The kinds of line drawn on a patch: on its grey, and on its recess.
DARK_LINE, VALLEY = "dark line", "valley"
#: The neighbours whose plane a point's recess is read against: as many as a surface's cell
#: holds (a disc some four spacings across), the scale of a crack one or two points wide.
RECESS_NEIGHBOURS = 16
#: Points whose neighbourhoods are gathered at once (each 16 x 3 coordinates).
RECESS_BLOCK = 16_384


def local_planes(
    points: np.ndarray, tree: cKDTree, k: int = RECESS_NEIGHBOURS, at: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The local plane of each point (of ``at``, indices, where given): the centroid of its
    ``k`` nearest points of the cloud (itself among them) and their least axis (unit, its
    sign arbitrary), (N, 3) each.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> flat = np.column_stack([rng.uniform(0, 1, 400), rng.uniform(0, 1, 400), np.zeros(400)])
    >>> _, normals = local_planes(flat, cKDTree(flat), at=np.arange(10))
    >>> normals.shape, bool(np.allclose(np.abs(normals[:, 2]), 1.0))
    ((10, 3), True)
    """
    at = np.arange(len(points)) if at is None else np.asarray(at)
    k = min(k, len(points))
    centres = np.empty((len(at), 3))
    normals = np.empty((len(at), 3))
    for start in range(0, len(at), RECESS_BLOCK):
        rows = slice(start, start + RECESS_BLOCK)
        _, near = tree_query(tree, points[at[rows]], k)
        near = points[np.asarray(near).reshape(-1, k)]
        centres[rows] = near.mean(axis=1)
        near -= centres[rows][:, None, :]
        _, normals[rows] = smallest_eigenpair(np.matmul(near.transpose(0, 2, 1), near))
    return centres, normals


#: The shading must tell the rock's side beyond chance: the correlation between darkness and
#: depth over a patch's n points at least this many times its standard error, 1 / sqrt(n).
SHADING_Z = 3.0


def patch_recess(points: np.ndarray, centres: np.ndarray, normals: np.ndarray, grey: np.ndarray, facing):
    """How far each of a patch's points lies below its local plane (:func:`local_planes`),
    toward the rock: each normal first turned to the patch's side ``facing`` (its mean
    plane's normal), then the side where the patch is darker as it is deeper taken as the
    rock's. Metres, (N,); None where the shading does not tell the side (the correlation of
    darkness and depth within :data:`SHADING_Z` standard errors of none: a face lit
    evenly, a grey that is noise).

    Examples
    --------
    >>> x = np.linspace(0.0, 1.0, 21)
    >>> points = np.column_stack([x, np.zeros(21), np.where(np.abs(x - 0.5) < 0.03, -0.02, 0.0)])
    >>> centres = np.column_stack([x, np.zeros(21), np.zeros(21)])
    >>> normals = np.tile([0.0, 0.0, -1.0], (21, 1))  # turned the wrong way: the patch decides
    >>> grey = np.where(points[:, 2] < 0, 40.0, 100.0)  # the crack is shaded
    >>> recess = patch_recess(points, centres, normals, grey, facing=[0.0, 0.0, 1.0])
    >>> float(recess[10]), float(recess[0])
    (0.02, 0.0)
    >>> patch_recess(points, centres, normals, np.full(21, 80.0), facing=[0.0, 0.0, 1.0]) is None
    True
    """
    side = np.where(normals @ np.asarray(facing, dtype=np.float64) < 0, -1.0, 1.0)
    recess = -np.einsum("ij,ij->i", points - centres, normals) * side
    darkness = -np.asarray(grey, dtype=np.float64)
    spread = recess.std() * darkness.std()
    if not spread > 0:
        return None
    correlation = np.mean((recess - recess.mean()) * (darkness - darkness.mean())) / spread
    if abs(correlation) * np.sqrt(len(recess)) < SHADING_Z:
        return None
    return (recess if correlation > 0 else -recess) + 0.0  # no negative zero where a point lies on its plane
