"""Standard errors of plane normals that one can use: calibrated, and honest about
correlated noise.

A least-squares plane's normal tilts when its points' errors do. With independent errors of
variance s^2 on N points, the tilt about each in-plane axis has variance s^2 / sum(u_i^2);
but the errors of an SfM cloud, and the rock's own roughness, are correlated over
centimetres to metres, and a normal fitted to a thousand points is then far less certain
than that formula says. So each plane is cut into :data:`BLOCKS` x :data:`BLOCKS` blocks
along its rectangle's axes, and the tilt's variance is that of a regression on the blocks'
mean offsets from the plane: Var(slope_u) = s_b^2 / sum_b (u_b - u_mean)^2, with s_b^2 the
blocks' residual variance after the plane (B - 3 degrees of freedom). Errors correlated
over less than a block average down within it and those over more show between blocks;
the blocks are the effective sample size. Noise correlated over much more than the plane
tilts it as a whole and no fit to the plane alone can see it: that part of the error is
not in the figure, and ``docs/rockmass.md`` gives how much it is on the synthetic outcrops.

The normal's standard error (``normal_uncertainty_deg``) is sqrt(Var_u + Var_v), the RMS
angle between the fitted and the true normal; it is carried into dip (the tilt along the
dip line) and dip direction (the tilt along strike, over sin(dip)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.eigen import smallest_eigenpair
from geostructure.core.threads import run_blocks

#: Blocks along each of a plane's two axes for the regression on block means.
BLOCKS = 3


def normal_standard_errors(points, labels, normals, centroids, axes_u, up=(0.0, 0.0, 1.0)) -> dict:
    """Standard errors (degrees) of each plane's normal, dip and dip direction.

    Parameters
    ----------
    points : (N, 3) array
        The points, local coordinates.
    labels : (N,) int array
        Each point's plane, -1 for none.
    normals, centroids, axes_u : (P, 3) array
        Each plane's unit normal, centroid and first in-plane axis (its rectangle's).
    up : (3,) array
        The frame's up, for dip and dip direction.

    Returns
    -------
    dict
        ``normal``, ``dip`` and ``dip_direction``: (P,) arrays of degrees, NaN where a plane
        has fewer than four blocks with points; ``planarity``, 1 - sqrt(lambda_3 / lambda_2)
        of its points' covariance: 1 for a flat patch, 0 for a blob, whatever its outline.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> uv = rng.uniform(-1, 1, (4000, 2))
    >>> points = np.column_stack([uv, 0.01 * rng.standard_normal(4000)])  # 1 cm noise on a 2 m square
    >>> se = normal_standard_errors(points, np.zeros(4000, int), [[0, 0, 1.0]], [[0, 0, 0.0]], [[1.0, 0, 0]])
    >>> theory = np.degrees(0.01 * np.sqrt(2 / (4000 / 3)))  # s sqrt(1/Suu + 1/Svv), Suu = N var(u)
    >>> bool(0.7 < se["normal"][0] / theory < 1.5)
    True
    """
    axes = plane_axes(normals, axes_u)
    coords = plane_coordinates(points, labels, centroids, axes)
    return errors_from_sums(block_sums(coords, coordinate_ranges(coords, len(axes[0])), len(axes[0])), axes, up)


def plane_axes(normals, axes_u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each plane's (normal, u, v): ``axes_u`` made orthogonal to the normal, v = n x u."""
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    u_axis = np.asarray(axes_u, dtype=np.float64).reshape(-1, 3)
    u_axis = u_axis - np.einsum("ij,ij->i", u_axis, normals)[:, None] * normals
    u_axis /= np.maximum(np.linalg.norm(u_axis, axis=1, keepdims=True), 1e-12)
    return normals, u_axis, np.cross(normals, u_axis)


def plane_coordinates(points, labels, centroids, axes) -> tuple[np.ndarray, ...]:
    """The labelled points' plane, and their (u, v, h) about its centroid along its axes."""
    points = np.asarray(points, dtype=np.float64)
    labels = np.asarray(labels)
    centroids = np.asarray(centroids, dtype=np.float64).reshape(-1, 3)
    normals, u_axis, v_axis = axes
    mine = np.flatnonzero(labels >= 0)
    lab = labels[mine]
    # Axis by axis, each gather into one of two buffers: no (M, 3) temporary, of which the
    # row-wise form made six, and no fresh array a gather (each fresh megabyte's pages cost
    # their first touch: at 7M labelled points the row-wise form touched 1 GB).
    u, v, h = (np.zeros(len(lab)) for _ in range(3))
    offset, gathered = np.empty(len(lab)), np.empty(len(lab))
    columns = [[np.ascontiguousarray(np.asarray(along, dtype=np.float64)[:, axis]) for along in (u_axis, v_axis, normals)]
               for axis in range(3)]  # fmt: skip

    def coordinate_rows(rows: slice) -> None:  # elementwise: split over the cores, the same bits
        o, g, at, of = offset[rows], gathered[rows], mine[rows], lab[rows]
        for axis in range(3):
            np.take(points[:, axis], at, out=o, mode="clip")  # "raise" buffers a copy
            o -= np.take(centroids[:, axis], of, out=g, mode="clip")
            for total, along in zip((u[rows], v[rows], h[rows]), columns[axis]):
                np.take(along, of, out=g, mode="clip")
                g *= o
                total += g

    run_blocks(coordinate_rows, len(lab))
    return lab, u, v, h


def coordinate_ranges(coords, n: int) -> np.ndarray:
    """(n, 4) least and greatest u, then v, of each plane's points (inf, -inf for none):
    the extent its blocks divide. Of parts of a cloud, the element-wise min and max."""
    lab, u, v, _ = coords
    out = np.column_stack([np.full(n, np.inf), np.full(n, -np.inf), np.full(n, np.inf), np.full(n, -np.inf)])
    for column, coord in ((0, u), (2, v)):
        np.minimum.at(out[:, column], lab, coord)
        np.maximum.at(out[:, column + 1], lab, coord)
    return out


@dataclass
class BlockSums:
    """Sums that add over parts of a cloud given each plane's extent: per plane and block,
    ``blocks`` (n, BLOCKS^2, 4) holds the count and the sums of u, v, h; per plane,
    ``points`` (n,) the count and ``squares`` (n, 3) the sums of u^2, v^2, h^2 (the planarity)."""

    blocks: np.ndarray
    points: np.ndarray
    squares: np.ndarray

    def __add__(self, other: BlockSums) -> BlockSums:
        return BlockSums(self.blocks + other.blocks, self.points + other.points, self.squares + other.squares)

    def __radd__(self, other):  # sum() starts from 0
        return self if isinstance(other, int) and other == 0 else NotImplemented


def block_sums(coords, ranges: np.ndarray, n: int) -> BlockSums:
    """The :class:`BlockSums` of points in :func:`plane_coordinates` over the blocks that
    ``ranges`` (:func:`coordinate_ranges`) cut each plane's extent into."""
    lab, u, v, h = coords
    blocks = BLOCKS * BLOCKS
    key = lab.astype(np.int64) * blocks
    # Each point's block through two buffers, the same arithmetic as
    # clip(int(BLOCKS * (coord - lo) / width)): no fresh array the points' length a step.
    scaled, width, index = np.empty(len(lab)), np.empty(len(lab)), np.empty(len(lab), dtype=np.int64)
    for coord, stride, column in ((u, BLOCKS, 0), (v, 1, 2)):
        lo, hi = ranges[:, column], ranges[:, column + 1]
        np.take(np.maximum(hi - lo, 1e-12), lab, out=width, mode="clip")  # "raise" buffers a copy
        np.subtract(coord, np.take(lo, lab, out=scaled, mode="clip"), out=scaled)
        scaled *= BLOCKS
        scaled /= width
        np.copyto(index, scaled, casting="unsafe")  # as astype(np.int64): toward zero
        np.clip(index, 0, BLOCKS - 1, out=index)
        index *= stride
        key += index
    size = n * blocks
    per_block: list[np.ndarray] = [np.bincount(key, minlength=size).astype(np.float64)]
    per_block += [np.bincount(key, x, size) for x in (u, v, h)]
    squares = np.column_stack([np.bincount(lab, np.multiply(x, x, out=scaled), n) for x in (u, v, h)]).reshape(n, 3)
    return BlockSums(
        np.stack(per_block, axis=1).reshape(n, blocks, 4), np.bincount(lab, minlength=n).astype(np.float64), squares
    )


def errors_from_sums(sums: BlockSums, axes, up=(0.0, 0.0, 1.0)) -> dict:
    """The standard errors and planarity (:func:`normal_standard_errors`) from
    :func:`block_sums`."""
    normals, u_axis, v_axis = axes
    n = len(normals)
    blocks = BLOCKS * BLOCKS
    count = sums.blocks[:, :, 0].ravel()
    filled = count > 0
    mean = {name: sums.blocks[:, :, c].ravel()[filled] / count[filled] for name, c in (("u", 1), ("v", 2), ("h", 3))}
    owner = np.flatnonzero(filled) // blocks
    b = np.bincount(owner, minlength=n).astype(np.float64)
    # Regress block means h_b on (1, u_b, v_b) per plane: centre u_b, v_b, then solve 2 x 2.
    mu = {k: np.bincount(owner, mean[k], n) / np.maximum(b, 1) for k in ("u", "v", "h")}
    du, dv, dh = (mean[k] - mu[k][owner] for k in ("u", "v", "h"))
    suu, svv, suv = (np.bincount(owner, x, n) for x in (du * du, dv * dv, du * dv))
    suh, svh = np.bincount(owner, du * dh, n), np.bincount(owner, dv * dh, n)
    det = suu * svv - suv**2
    ok = (b >= 4) & (det > 1e-18)
    safe = np.where(ok, det, 1.0)
    slope_u = (svv * suh - suv * svh) / safe
    slope_v = (suu * svh - suv * suh) / safe
    residual = dh - slope_u[owner] * du - slope_v[owner] * dv
    s2 = np.bincount(owner, residual**2, n) / np.maximum(b - 3, 1)
    var_u, var_v = s2 * svv / safe, s2 * suu / safe  # the diagonal of s2 (X^T X)^-1
    cov_uv = -s2 * suv / safe
    normal = np.degrees(np.sqrt(np.maximum(var_u + var_v, 0.0)))
    # Tilt along the dip line changes the dip; along strike, the dip direction.
    up = np.asarray(up, dtype=np.float64)
    strike = np.cross(up, normals)
    flat = np.linalg.norm(strike, axis=1) < 1e-9
    strike[flat] = u_axis[flat]
    strike /= np.linalg.norm(strike, axis=1, keepdims=True)
    dip_line = np.cross(normals, strike)

    def along(e):
        a, c = np.einsum("ij,ij->i", e, u_axis), np.einsum("ij,ij->i", e, v_axis)
        return a * a * var_u + c * c * var_v + 2 * a * c * cov_uv

    sin_dip = np.sqrt(np.clip(1.0 - (normals @ up) ** 2, 0.0, 1.0))
    dip = np.degrees(np.sqrt(np.maximum(along(dip_line), 0.0)))
    dip_direction = np.degrees(np.sqrt(np.maximum(along(strike), 0.0)) / np.maximum(sin_dip, 1e-9))
    nan = np.where(ok, 1.0, np.nan)
    # Planarity from the points' variances along the plane's axes (its covariance's eigenvalues
    # Planarity from the points' variances along the plane's axes (its covariance's eigenvalues
    # when the rectangle's axes are the principal ones, as for a least-squares plane).
    n_points = sums.points
    count_p = np.maximum(n_points, 1)
    var = np.sort(sums.squares / count_p[:, None], axis=1)
    planarity = 1.0 - np.sqrt(var[:, 0] / np.maximum(var[:, 1], 1e-300))
    return {
        "normal": normal * nan,
        "dip": dip * nan,
        "dip_direction": np.minimum(dip_direction, 180.0) * nan,
        "planarity": np.where(n_points >= 3, planarity, np.nan),
    }


#: A facet counts in the correlated tilt while its squared angle to its joint's plane is
#: within this many times its expected value (the tilt's variance plus its own); beyond it,
#: it is taken for another joint's. 3 keeps 95% of the angles of an isotropic normal error.
#: On fifteen synthetic faces (planes through the rock mass, joints 1.5 to 10 m across) the
#: calibration ratio read 0.80 to 1.20 for any value from 2.75 to 3.25; 4 let mixed joints
#: through (0.60 on a 12 x 6 m face of 1.5 m joints), 2 cut the tilt to nothing on three.
TILT_KEEP = 3.0
#: The tilt is read from this many facets at least (in joints of three or more). From a few
#: joints it is their waviness as much as the cloud's error, and it is given to every plane:
#: an indoor laser scan read 9.9 degrees from 9 facets of 3 "joints" (a floor and walls that
#: are not one plane), where its planes' own errors are hundredths of a degree. The synthetic
#: outcrops read it from 150 to 860.
MIN_TILT_FACETS = 20


def correlated_tilt(normals, standard_errors, joints, moments, iterations: int = 50) -> tuple[float, int]:
    """The tilt (degrees, RMS) that errors correlated over more than a plane give every
    plane alike, read from the cloud itself: the facets of one joint share its normal, so the
    part of their scatter about it that their own standard errors do not explain is that
    tilt. Returns it and the number of facets it was read from (0: fewer than
    :data:`MIN_TILT_FACETS` lie in joints of three or more, and it is not read).

    Each facet is compared with the plane of its joint's other facets (their points pooled),
    not with the plane it helped fit, which leans towards it. A joint grown on a rough face
    can hold facets of neighbouring joints of its set a few degrees off (on faces of short
    joints, up to a third of its facets): a facet whose squared angle is beyond
    :data:`TILT_KEEP` times its expected value (the tilt's variance plus its own) is left
    out, and the tilt read again from the facets kept until it settles; the mean of the
    squared angles kept is scaled for the cut. A mean over all facets read 2.7 degrees on
    such faces where the truth is 0.9 (docs/rockmass.md, "Honest uncertainty").

    Parameters
    ----------
    normals : (P, 3) array
        The planes' normals.
    standard_errors : (P,) array
        Their standard errors (degrees, :func:`normal_standard_errors`).
    joints : sequence of index arrays
        Each joint's planes (joints of three or more count).
    moments : PlaneMoments
        The planes' point counts, centroids and scatters (:class:`~geostructure.rockmass.joints.PlaneMoments`).

    Examples
    --------
    >>> from geostructure.rockmass.joints import PlaneMoments
    >>> rng = np.random.default_rng(0)
    >>> tilt = np.radians(1.0) * rng.standard_normal((40, 2)) / np.sqrt(2)  # 1 degree RMS
    >>> normals = np.column_stack([tilt, np.ones(40)])
    >>> normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    >>> u = rng.uniform(-1.0, 1.0, (40, 2))  # facets side by side on the plane z = 0
    >>> moments = PlaneMoments(np.full(40, 50.0), np.column_stack([4 * u, np.zeros(40)]), np.tile(np.diag([1.0, 1.0, 1e-4]), (40, 1, 1)))
    >>> value, n = correlated_tilt(normals, np.full(40, 0.2), [np.arange(40)], moments)
    >>> bool(0.8 < value < 1.2), n
    (True, 40)
    """
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    se2 = np.asarray(standard_errors, dtype=np.float64) ** 2
    joints = [np.asarray(j, dtype=np.int64) for j in joints if len(j) >= 3]
    if not joints:
        return 0.0, 0
    member = np.concatenate(joints)
    joint = np.repeat(np.arange(len(joints)), [len(j) for j in joints])
    usable = np.isfinite(se2[member]) & np.isfinite(normals[member]).all(axis=1)
    member, joint = member[usable], joint[usable]
    if len(member) < MIN_TILT_FACETS:
        return 0.0, 0
    n, n_joints = moments.count[member], len(joints)
    # Each facet's first and second moments about its joint's centroid (no cancellation).
    centre: np.ndarray = np.stack(
        [np.bincount(joint, n * moments.centroid[member, a], n_joints) for a in range(3)], axis=1
    )
    centre /= np.maximum(np.bincount(joint, n, n_joints), 1.0)[:, None]
    d = moments.centroid[member] - centre[joint]
    first = n[:, None] * d
    second = (moments.scatter[member] + first[:, :, None] * d[:, None, :]).reshape(-1, 9)
    sums = np.column_stack([n, first, second])  # (M, 13): what each facet adds to its joint's plane
    own = normals[member]

    def angles_to_the_others(kept):
        """Each facet's angle (degrees) to the plane of its joint's kept facets, itself left out."""
        mine = sums * kept[:, None]
        total = np.column_stack([np.bincount(joint, column, n_joints) for column in mine.T])[joint]
        other = total - mine
        count = np.maximum(other[:, 0], 1e-12)
        scatter = other[:, 4:].reshape(-1, 3, 3) - other[:, 1:4, None] * other[:, None, 1:4] / count[:, None, None]
        plane = smallest_eigenpair(scatter)[1]
        cosine = np.abs(np.einsum("ij,ij->i", own, plane))
        return np.degrees(np.arccos(np.clip(cosine, 0.0, 1.0)))

    kept = np.ones(len(member), dtype=bool)
    angle2 = angles_to_the_others(kept) ** 2
    # A start robust to the other joints' facets: the median of an exponential is ln 2 its mean.
    tilt2 = max(float(np.median(angle2) / np.log(2) - np.median(se2[member])), 1e-4)
    truncation = 1.0 - TILT_KEEP * np.exp(-TILT_KEEP) / (1.0 - np.exp(-TILT_KEEP))  # mean kept of Exp(1)
    counted = np.zeros(len(member), dtype=bool)
    for _ in range(iterations):
        kept = angle2 <= TILT_KEEP * (tilt2 + se2[member])
        kept &= (np.bincount(joint, kept, n_joints) >= 3)[joint]  # a plane of two others at least
        if not kept.any():
            return 0.0, 0
        angle2 = angles_to_the_others(kept) ** 2
        counted = kept & (angle2 <= TILT_KEEP * (tilt2 + se2[member]))
        new = max(float(np.mean(angle2[counted] / truncation - se2[member][counted])), 0.0) if counted.any() else 0.0
        settled = abs(new - tilt2) <= 1e-4 * max(tilt2, 1e-6)
        tilt2 = new
        if settled:
            break
    return float(np.sqrt(tilt2)), int(counted.sum())


def with_correlated_tilt(errors: dict, tilt: float, normals, up=(0.0, 0.0, 1.0)) -> dict:
    """Standard errors with a correlated ``tilt`` (degrees RMS, isotropic) added in quadrature:
    all of it to the normal's, half its variance each to dip and to dip direction's tilt."""
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    sin_dip = np.sqrt(np.clip(1.0 - (normals @ np.asarray(up, dtype=np.float64)) ** 2, 1e-18, 1.0))
    half = tilt**2 / 2.0
    return {
        **errors,
        "normal": np.sqrt(errors["normal"] ** 2 + tilt**2),
        "dip": np.sqrt(errors["dip"] ** 2 + half),
        "dip_direction": np.minimum(np.sqrt(errors["dip_direction"] ** 2 + half / sin_dip**2), 180.0),
    }
