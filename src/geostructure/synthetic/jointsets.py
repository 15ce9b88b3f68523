"""The joints of the synthetic outcrop's sets: Fisher-distributed normals, planes through
the rock mass or discs (Baecher et al. 1977), and the joint each face cell is exposed on.

``joint`` below is an :class:`~.rock_outcrop.JointSet` (its ``normal``, ``kappa``, ``spacing``
and ``persistence``).
"""

from __future__ import annotations

import numpy as np


def fisher_directions(mean, kappa: float, n: int, rng) -> np.ndarray:
    """``n`` unit vectors from a Fisher distribution about ``mean`` (Wood 1994's method).

    Parameters
    ----------
    mean : (3,) array_like
        The mean direction (need not be unit).
    kappa : float
        Fisher's concentration: the larger, the tighter.
    n : int
        How many directions.
    rng : numpy.random.Generator
        The seeded generator drawing them.

    Returns
    -------
    ndarray
        (n, 3) unit vectors.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> d = fisher_directions([0.0, 0.0, 1.0], 100.0, 20_000, rng)
    >>> round(float(np.degrees(np.arccos(d[:, 2])).mean()), 0)  # mean angle ~ sqrt(pi / 2 kappa)
    7.0
    """
    mean = np.asarray(mean, dtype=np.float64)
    mean = mean / np.linalg.norm(mean)
    u = rng.random(n)
    w = 1.0 + np.log(u + (1.0 - u) * np.exp(-2.0 * kappa)) / kappa  # cosine of the angle to the mean
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(mean[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(mean, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(mean, e1)
    s = np.sqrt(np.clip(1.0 - w**2, 0.0, 1.0))
    return w[:, None] * mean + s[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)


def persistent_planes(joint, reach: float, rng):
    """A set's planes through the whole rock mass: normals, a point on each, radii (inf),
    spaced along the mean normal by exponential gaps of the set's spacing."""
    mean = joint.normal
    positions = -reach + np.cumsum(rng.exponential(joint.spacing, int(4 * reach / joint.spacing) + 10))
    positions = positions[positions < reach]
    normals = fisher_directions(mean, joint.kappa, len(positions), rng)
    return normals, positions[:, None] * mean, np.full(len(positions), np.inf)


#: Spread (standard deviation of the log) of the joint discs' diameters.
DISC_LOG_SPREAD = 0.5


def joint_discs(joint, face_frame, size, rng):
    """A set's joints as discs (Baecher et al. 1977): centres uniform in a slab about the face,
    normals Fisher, lognormal diameters of mean ``joint.persistence``, as many as make P32
    (joint area per rock volume) the reciprocal of the set's spacing. Normals, centres, radii."""
    face_normal, along, up_dip = face_frame
    mean_d = float(joint.persistence)
    mu = np.log(mean_d) - DISC_LOG_SPREAD**2 / 2
    # Discs centred beyond the face's edge, or behind or before it, still reach it: the slab
    # is as deep as the large discs reach, and deep enough that one lies near every point.
    margin = 1.5 * mean_d
    depth = 5.0 * joint.spacing + margin
    volume = (size[0] + 2 * margin) * (size[1] + 2 * margin) * 2 * depth
    mean_area = np.pi / 4 * mean_d**2 * np.exp(DISC_LOG_SPREAD**2)  # E[d^2] of the lognormal
    n = int(rng.poisson(volume / joint.spacing / mean_area))
    a = rng.uniform(-margin, size[0] + margin, n)
    b = rng.uniform(-margin, size[1] + margin, n)
    c = rng.uniform(-depth, depth, n)
    centres = a[:, None] * along + b[:, None] * up_dip + c[:, None] * face_normal
    radii = np.exp(rng.normal(mu, DISC_LOG_SPREAD, n)) / 2
    return fisher_directions(joint.normal, joint.kappa, n, rng), centres, radii


#: Cell-joint pairs :func:`nearest_joint` holds at once (three floats each): 1 m discs on a
#: 40 x 16 m face are 12,000 a set for 1,000 cells.
NEAREST_JOINT_PAIRS = 2_000_000


def nearest_joint(centres, normals, points, radii) -> np.ndarray:
    """For each cell centre, the joint nearest to it along the joint's own normal among those
    reaching it (a disc reaches a point whose foot on its plane lies within its radius); the
    nearest plane of all where none reaches. The planes are not parallel: one is nearest at
    one end of the face, another at the other."""
    step = max(1, NEAREST_JOINT_PAIRS // max(len(points), 1))
    if len(centres) > step:  # in blocks of cells: each cell's choice is its own
        blocks = [nearest_joint(centres[i : i + step], normals, points, radii) for i in range(0, len(centres), step)]
        return np.concatenate(blocks)
    offsets = centres[:, None, :] - points[None, :, :]
    along_own = np.einsum("cpk,pk->cp", offsets, normals)
    if np.isinf(radii).all():
        return np.abs(along_own).argmin(axis=1)
    in_plane = np.einsum("cpk,cpk->cp", offsets, offsets) - along_own**2
    reaching = np.where(in_plane <= radii[None, :] ** 2, np.abs(along_own), np.inf)
    return np.where(np.isfinite(reaching.min(axis=1)), reaching.argmin(axis=1), np.abs(along_own).argmin(axis=1))
