"""A wedge's block and its factor of safety (Hoek & Bray 1981, chapter 8; Hocking 1976).

Two joints a and b cut a tetrahedral block out of a slope: its faces are the two joints, the
slope face and the level ground above it. Its corners are the toe O, where the joints' line
of intersection comes out of the face; P, where that line meets the upper surface; and Q, R,
where each joint meets the face's crest. The block weighs W = unit weight x volume. Per unit
of weight the joints push back with normal forces N_a and N_b, from equilibrium across the
line (:func:`normal_forces`). The factor of safety is

    FS = (c_a S_a + c_b S_b + W (N_a tan(phi_a) + N_b tan(phi_b))) / (W sin(plunge)),

where S_a and S_b are the block's faces on each joint. Without cohesion the block's size
cancels and FS = A tan(phi_a) + B tan(phi_b), Hoek & Bray's wedge factors. With cohesion this
is their "short solution" for a dry slope,
FS = 3 (c_a X + c_b Y) / (gamma H) + A tan(phi_a) + B tan(phi_b), H being the block's height
from O to P. When one normal force comes out negative, the block lifts off that joint
(Hocking 1976) and slides down the other's dip, as a planar block does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.errors import ParameterError

#: Unit weight of rock (kN/m3) when none is given: granite, limestone and sandstone lie
#: between about 23 and 28.
UNIT_WEIGHT = 26.0


@dataclass
class WedgeBlocks:
    """Per pair of joints: the block's ``volume`` (m3), its faces ``area_a`` and ``area_b`` on
    each joint (m2), its ``height`` from toe to top (m), and whether such a block exists
    (``formed``: the line comes out of the face, below the upper surface)."""

    volume: np.ndarray
    area_a: np.ndarray
    area_b: np.ndarray
    height: np.ndarray
    formed: np.ndarray


def wedge_blocks(normal_a, normal_b, face_normal, face_height: float, upper_normal=(0.0, 0.0, 1.0)) -> WedgeBlocks:
    """The tetrahedral blocks that pairs of joints (upward unit normals, (n, 3)) cut under a
    face (upward unit normal) of ``face_height`` m, its crest on an upper surface
    (``upper_normal``; level by default).

    Examples
    --------
    A symmetric wedge under a vertical face 10 m high, with a level top:

    >>> from geostructure.core.orientation import normal_from_orientation
    >>> a, b = normal_from_orientation([150, 210], [60, 60])
    >>> block = wedge_blocks(a, b, normal_from_orientation(180, 90), 10.0)
    >>> bool(block.formed[0]), round(float(block.height[0]), 6), bool(np.isclose(block.area_a, block.area_b)[0])
    (True, 10.0, True)
    """
    na, nb = (
        np.atleast_2d(np.asarray(normal_a, dtype=np.float64)),
        np.atleast_2d(np.asarray(normal_b, dtype=np.float64)),
    )
    face, upper = np.asarray(face_normal, dtype=np.float64), np.asarray(upper_normal, dtype=np.float64)
    # The crest lies up the face's dip line from the toe, face_height above it.
    horizontal = np.hypot(face[0], face[1])
    up_dip = np.array(
        [-face[0] * face[2] / max(horizontal, 1e-12), -face[1] * face[2] / max(horizontal, 1e-12), horizontal]
    )
    crest = up_dip * face_height / max(up_dip[2], 1e-12)
    top = float(upper @ crest)
    n = len(na)
    faces = np.broadcast_to(face, (n, 3))
    uppers = np.broadcast_to(upper, (n, 3))

    def corner(m1, m2, rhs3):
        system = np.stack([m1, m2, uppers], axis=1)
        ok = np.abs(np.linalg.det(system)) > 1e-12
        out = np.full((n, 3), np.nan)
        if ok.any():
            rhs = np.zeros((int(ok.sum()), 3))
            rhs[:, 2] = rhs3
            out[ok] = np.linalg.solve(system[ok], rhs[..., None])[..., 0]
        return out

    p, q, r = corner(na, nb, top), corner(na, faces, top), corner(nb, faces, top)
    volume = np.abs(np.einsum("ij,ij->i", p, np.cross(q, r))) / 6.0
    area_a = 0.5 * np.linalg.norm(np.cross(p, q), axis=1)
    area_b = 0.5 * np.linalg.norm(np.cross(p, r), axis=1)
    # A block: P, the line's top, lies above the toe and behind the face.
    formed = np.isfinite(p).all(axis=1) & (p[:, 2] > 0) & (p @ face < 0) & (volume > 0)
    return WedgeBlocks(volume, area_a, area_b, p[:, 2], formed)


def normal_forces(normal_a, normal_b) -> tuple[np.ndarray, np.ndarray]:
    """The joints' normal forces on a block of unit weight (Hoek & Bray's A and B times
    sin(plunge)). The upward normals push on the block from below; solving
    N_a n_a + N_b n_b = the weight's part across the line (n_a and n_b both lie across it)
    gives N_a + N_b cos t = cos(dip_a) and N_a cos t + N_b = cos(dip_b), t the angle between
    the normals."""
    na, nb = np.atleast_2d(normal_a), np.atleast_2d(normal_b)
    cos_t = np.einsum("ij,ij->i", na, nb)
    sin2 = np.maximum(1.0 - cos_t**2, 1e-12)
    ca, cb = na[:, 2], nb[:, 2]
    return (ca - cb * cos_t) / sin2, (cb - ca * cos_t) / sin2


def wedge_factor_of_safety(
    normal_a, normal_b, friction_a, friction_b=None, *, cohesion_a: float = 0.0, cohesion_b: float | None = None,
    blocks: WedgeBlocks | None = None, unit_weight: float = UNIT_WEIGHT,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Factor of safety of the wedges on pairs of joints (upward unit normals), dry, and which
    joint each rides on (0: a, 1: b, -1: both); see the module's description. Cohesion (kPa)
    needs the ``blocks`` (:func:`wedge_blocks`); without it the factor is frictional and the
    block's size does not count. A pair that cuts no block gets NaN with cohesion.

    Examples
    --------
    Hoek & Bray's (1981) worked wedge: joints 45/105 (friction 20) and 70/235 (friction 30).
    Frictional, FS = A tan(20) + B tan(30), which their rounded angles give as 1.548 x 0.364 +
    0.956 x 0.577 = 1.12:

    >>> from geostructure.core.orientation import normal_from_orientation
    >>> a, b = normal_from_orientation([105, 235], [45, 70])
    >>> fs, rides = wedge_factor_of_safety(a[None], b[None], 20.0, 30.0)
    >>> round(float(fs[0]), 3), int(rides[0])
    (1.107, -1)
    """
    na, nb = np.atleast_2d(normal_a), np.atleast_2d(normal_b)
    friction_b = friction_a if friction_b is None else friction_b
    cohesion_b = cohesion_a if cohesion_b is None else cohesion_b
    tan_a, tan_b = np.tan(np.radians(friction_a)), np.tan(np.radians(friction_b))
    force_a, force_b = normal_forces(na, nb)
    line = np.cross(na, nb)
    sin_plunge = np.abs(line[:, 2]) / np.maximum(np.linalg.norm(line, axis=1), 1e-300)
    both = (force_a >= 0) & (force_b >= 0)
    alone = np.where(force_a < 0, 1, 0)  # lifted off a: it rides on b
    cohesive = bool(cohesion_a or cohesion_b)
    if cohesive:
        if blocks is None:
            raise ParameterError("a wedge's factor of safety with cohesion needs its block (wedge_blocks).")
        weight = unit_weight * blocks.volume
        with np.errstate(divide="ignore", invalid="ignore"):
            hold_a, hold_b = cohesion_a * blocks.area_a / weight, cohesion_b * blocks.area_b / weight
    else:
        hold_a = hold_b = np.zeros(len(na))
    with np.errstate(divide="ignore", invalid="ignore"):
        riding = (hold_a + hold_b + force_a * tan_a + force_b * tan_b) / sin_plunge
        cos_a, cos_b = na[:, 2], nb[:, 2]
        sin_a, sin_b = np.sqrt(np.maximum(1 - cos_a**2, 0)), np.sqrt(np.maximum(1 - cos_b**2, 0))
        on_a, on_b = (hold_a + cos_a * tan_a) / sin_a, (hold_b + cos_b * tan_b) / sin_b
    fs = np.where(both, riding, np.where(alone == 1, on_b, on_a))
    if cohesive:
        fs = np.where(blocks.formed, fs, np.nan)
    return fs, np.where(both, -1, alone)
