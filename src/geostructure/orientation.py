"""Direction cosines to strike, dip and dip direction (conventions of ``ORIENTATION.md``).

A :class:`Frame` says which way east, north and up point in the cloud's coordinates. A
normal is expressed in (east, north, up), turned upward, and then

- dip = arccos(up), in [0, 90];
- dip direction = atan2(east, north) mod 360, the azimuth of steepest descent;
- strike = (dip direction - 90) mod 360 (right-hand rule).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import GeoStructureError

#: Below this |up| component (about 0.06 degrees from vertical) a plane counts as vertical
#: and its dip direction is settled by the face's outward side instead of by up >= 0.
VERTICAL_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Frame:
    """Rows are the unit east, north and up vectors written in the cloud's coordinates.

    ``declination`` (degrees, east positive) makes azimuths read against magnetic north,
    as a compass does: azimuth_magnetic = azimuth_true - declination.
    """

    rotation: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    declination: float = 0.0
    name: str = "enu"

    @property
    def matrix(self) -> np.ndarray:
        return np.asarray(self.rotation, dtype=np.float64)

    @classmethod
    def named(cls, name: str, declination: float = 0.0) -> "Frame":
        """``enu`` (x=E, y=N, z=Up) or ``paper`` (x=N, y=W, z=Up)."""
        if name == "enu":
            return cls(declination=declination, name="enu")
        if name == "paper":
            return cls(((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)), declination, "paper")
        raise GeoStructureError(f"unknown frame '{name}'; use 'enu', 'paper' or give --up and --north.")

    @classmethod
    def from_up_north(cls, up, north, declination: float = 0.0) -> "Frame":
        """A frame from an up vector and a (roughly horizontal) north vector, both in cloud axes.

        North is made orthogonal to up (Gram-Schmidt); east = north x up.
        """
        up = np.asarray(up, dtype=np.float64)
        north = np.asarray(north, dtype=np.float64)
        if up.shape != (3,) or north.shape != (3,) or np.linalg.norm(up) == 0:
            raise GeoStructureError("--up and --north each need three numbers, and up must not be zero.")
        up = up / np.linalg.norm(up)
        north = north - (north @ up) * up
        if np.linalg.norm(north) < 1e-6:
            raise GeoStructureError("--north must not be parallel to --up.")
        north = north / np.linalg.norm(north)
        east = np.cross(north, up)
        return cls(tuple(map(tuple, np.vstack([east, north, up]).tolist())), declination, "custom")

    def to_enu(self, vectors: np.ndarray) -> np.ndarray:
        """Express cloud-axis vectors (N, 3) in (east, north, up)."""
        return np.asarray(vectors, dtype=np.float64) @ self.matrix.T


@dataclass(frozen=True)
class Orientation:
    """Angles in degrees; arrays when computed for many normals at once."""

    strike: np.ndarray
    dip: np.ndarray
    dip_direction: np.ndarray


def upward(normals_enu: np.ndarray, outward_enu: np.ndarray | None = None) -> np.ndarray:
    """Turn normals (in ENU) to point up; a vertical one points along ``outward_enu`` instead.

    For a vertical face both normals are upward, so the dip direction is only defined modulo
    180; the side the face is seen from (the input's own normals, when it has them) decides.
    """
    n = np.atleast_2d(np.asarray(normals_enu, dtype=np.float64))
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    sign = np.where(n[:, 2] < 0, -1.0, 1.0)
    vertical = np.abs(n[:, 2]) < VERTICAL_TOLERANCE
    if vertical.any():
        if outward_enu is not None:
            facing = np.einsum("ij,ij->i", n, np.atleast_2d(outward_enu))
        else:  # no side known: settle on dip directions in [0, 180) so runs agree
            facing = np.where(np.abs(n[:, 0]) > 1e-12, n[:, 0], n[:, 1])
        sign[vertical] = np.where(facing[vertical] < 0, -1.0, 1.0)
    return n * sign[:, None]


def orientation_from_normals(normals, frame: Frame = Frame(), outward=None) -> Orientation:
    """Strike, dip and dip direction (degrees) of planes with the given normals.

    Parameters
    ----------
    normals : (N, 3) or (3,) array
        Plane normals in the cloud's axes; length and sign do not matter.
    frame : Frame
        Which way east, north and up point in the cloud.
    outward : (N, 3) array, optional
        The side each face is seen from, in cloud axes; settles vertical planes.

    Examples
    --------
    >>> o = orientation_from_normals([0.0112, -0.6427, 0.7660], Frame.named("paper"))
    >>> [int(round(float(v))) for v in (o.strike[0], o.dip[0], o.dip_direction[0])]
    [359, 40, 89]
    """
    enu = frame.to_enu(np.atleast_2d(normals))
    out = None if outward is None else frame.to_enu(np.atleast_2d(outward))
    n = upward(enu, out)
    dip = np.degrees(np.arccos(np.clip(n[:, 2], -1.0, 1.0)))
    dip_direction = (np.degrees(np.arctan2(n[:, 0], n[:, 1])) - frame.declination) % 360.0
    strike = (dip_direction - 90.0) % 360.0
    return Orientation(strike=strike, dip=dip, dip_direction=dip_direction)


def normal_from_orientation(dip_direction, dip, frame: Frame = Frame()) -> np.ndarray:
    """The upward unit normal, in cloud axes, of planes with the given dip direction and dip."""
    dd = np.radians(np.asarray(dip_direction, dtype=np.float64) + frame.declination)
    d = np.radians(np.asarray(dip, dtype=np.float64))
    enu = np.stack([np.sin(d) * np.sin(dd), np.sin(d) * np.cos(dd), np.cos(d)], axis=-1)
    return enu @ frame.matrix  # rows of the matrix are E, N, U in cloud axes


def azimuth_difference(a, b) -> np.ndarray:
    """Smallest difference between azimuths in degrees, in [0, 180]: 359 and 1 are 2 apart."""
    d = np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) % 360.0
    return np.minimum(d, 360.0 - d)


def angle_between_normals(n1, n2) -> np.ndarray:
    """Angle between planes in degrees, arccos(|n1 . n2|): the sign of a normal does not matter."""
    a = np.atleast_2d(np.asarray(n1, dtype=np.float64))
    b = np.atleast_2d(np.asarray(n2, dtype=np.float64))
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    cos = np.abs(np.einsum("ij,ij->i", a, b))
    return np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))
