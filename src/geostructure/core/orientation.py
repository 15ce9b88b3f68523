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

from geostructure.errors import ParameterError

#: Below this |up| component (about 0.06 degrees from vertical) a plane counts as vertical
#: and its dip direction is settled by the face's outward side instead of by up >= 0.
VERTICAL_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Frame:
    """Which way east, north and up point in the cloud's coordinates.

    Parameters
    ----------
    rotation : 3 x 3 tuple
        Rows are the unit east, north and up vectors written in the cloud's axes.
    declination : float
        Magnetic declination in degrees, east positive: azimuths are read against magnetic
        north, as a compass does (azimuth_magnetic = azimuth_true - declination).
    name : str
        For records and messages.

    Examples
    --------
    >>> Frame.named("paper").rotation[1]  # north is the cloud's x axis
    (1.0, 0.0, 0.0)
    >>> Frame(declination=float("nan"))
    Traceback (most recent call last):
    ...
    geostructure.errors.ParameterError: declination must be a finite number of degrees, not nan.
    """

    rotation: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    declination: float = 0.0
    name: str = "enu"

    @property
    def matrix(self) -> np.ndarray:
        return np.asarray(self.rotation, dtype=np.float64)

    def __post_init__(self):
        if not np.isfinite(self.declination):
            raise ParameterError(f"declination must be a finite number of degrees, not {self.declination}.")
        m = np.asarray(self.rotation, dtype=np.float64)
        if m.shape != (3, 3) or not np.isfinite(m).all() or not np.allclose(m @ m.T, np.eye(3), atol=1e-6):
            raise ParameterError(
                "a frame's rotation must be three orthonormal rows of finite numbers (east, north, up)."
            )

    @classmethod
    def named(cls, name: str, declination: float = 0.0) -> "Frame":
        """``enu`` (x=E, y=N, z=Up) or ``paper`` (x=N, y=W, z=Up)."""
        if name == "enu":
            return cls(declination=declination, name="enu")
        if name == "paper":
            return cls(((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)), declination, "paper")
        raise ParameterError(f"unknown frame '{name}'; use 'enu' or 'paper', or give `up` and `north` vectors.")

    @classmethod
    def from_up_north(cls, up, north, declination: float = 0.0) -> "Frame":
        """A frame from an up vector and a (roughly horizontal) north vector, both in cloud axes.

        North is made orthogonal to up (Gram-Schmidt); east = north x up.

        Examples
        --------
        >>> Frame.from_up_north([0, 0, 2], [0, 1, 0.1]).rotation[0]
        (1.0, 0.0, 0.0)
        """
        up = np.asarray(up, dtype=np.float64)
        north = np.asarray(north, dtype=np.float64)
        if up.shape != (3,) or north.shape != (3,):
            raise ParameterError("`up` and `north` each need three numbers.")
        if not (np.isfinite(up).all() and np.isfinite(north).all()):
            raise ParameterError(f"`up` and `north` must be finite numbers, not {up.tolist()} and {north.tolist()}.")
        if not up.any() or not north.any():
            raise ParameterError("`up` and `north` must not be the zero vector.")
        # Scaled to their largest component first: only the directions count, and a norm of
        # (1e308, 0, 0) overflows.
        up, north = up / np.abs(up).max(), north / np.abs(north).max()
        up = up / np.linalg.norm(up)
        north = north - (north @ up) * up
        if np.linalg.norm(north) < 1e-6:
            raise ParameterError("`north` must not be parallel to `up`.")
        north = north / np.linalg.norm(north)
        east = np.cross(north, up)
        return cls(tuple(map(tuple, np.vstack([east, north, up]).tolist())), declination, "custom")

    def turned(self, azimuth: float, name: str) -> "Frame":
        """This frame with its north turned ``azimuth`` degrees west about its up: what was
        north here has that azimuth there. A projected CRS's grid north has the grid
        convergence as its true azimuth (:func:`~.io.crs.grid_convergence`), so turning the
        grid frame by it reads azimuths against true north.

        Examples
        --------
        >>> true = Frame().turned(1.5, "enu, true north")  # a plane dipping to grid north
        >>> round(float(orientation_from_normals([0.0, np.sin(0.5), np.cos(0.5)], true).dip_direction[0]), 6)
        1.5
        """
        east, north, up = self.matrix
        g = np.radians(azimuth)
        rows = np.vstack([np.cos(g) * east + np.sin(g) * north, np.cos(g) * north - np.sin(g) * east, up])
        return Frame(tuple(map(tuple, rows.tolist())), self.declination, name)

    def to_dict(self) -> dict:
        """The frame as ``run.json`` records it.

        Examples
        --------
        >>> Frame.from_dict(Frame.named("paper", 2.5).to_dict()) == Frame.named("paper", 2.5)
        True
        """
        return {"name": self.name, "rotation": [list(r) for r in self.rotation], "declination": self.declination}

    @classmethod
    def from_dict(cls, record: dict) -> "Frame":
        """The frame of a ``run.json`` record; :class:`ParameterError` if it is not one."""
        try:
            rotation = tuple(tuple(float(v) for v in row) for row in record["rotation"])
            return cls(rotation, float(record["declination"]), str(record["name"]))
        except (KeyError, TypeError, ValueError) as exc:
            if isinstance(exc, ParameterError):
                raise
            raise ParameterError("not a frame record (name, rotation, declination).") from None

    def to_enu(self, vectors: np.ndarray) -> np.ndarray:
        """Express cloud-axis vectors (N, 3) in (east, north, up)."""
        return np.asarray(vectors, dtype=np.float64) @ self.matrix.T


@dataclass(frozen=True)
class Orientation:
    """Strike, dip and dip direction in degrees; arrays when computed for many normals at once.

    Parameters
    ----------
    strike : ndarray
        Right-hand-rule strike: dip direction minus 90, in [0, 360).
    dip : ndarray
        In [0, 90].
    dip_direction : ndarray
        Azimuth of the steepest descent, in [0, 360), clockwise from north.

    Examples
    --------
    >>> o = orientation_from_normals([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    >>> o.dip.tolist(), o.dip_direction.tolist()
    ([0.0, 90.0], [0.0, 90.0])
    """

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

    Returns
    -------
    Orientation
        ``strike``, ``dip`` and ``dip_direction`` (N,) in degrees (right-hand rule strike,
        dip 0 to 90, dip direction from north, less the frame's declination).

    Examples
    --------
    >>> o = orientation_from_normals([0.0112, -0.6427, 0.7660], Frame.named("paper"))
    >>> [int(round(float(v))) for v in (o.strike[0], o.dip[0], o.dip_direction[0])]
    [359, 40, 89]
    """
    enu = frame.to_enu(np.atleast_2d(normals))
    out = None if outward is None else frame.to_enu(np.atleast_2d(outward))
    n = upward(enu, out)
    # |up|: a near-vertical normal kept on its face's side may point a little down; the dip
    # is still at most 90 (ORIENTATION.md), the side is in the dip direction.
    dip = np.degrees(np.arccos(np.clip(np.abs(n[:, 2]), 0.0, 1.0)))
    dip_direction = (np.degrees(np.arctan2(n[:, 0], n[:, 1])) - frame.declination) % 360.0
    strike = (dip_direction - 90.0) % 360.0
    return Orientation(strike=strike, dip=dip, dip_direction=dip_direction)


def drawn_azimuth(angle) -> np.ndarray:
    """A strike or dip direction a drawing or a vector can use: a level plane's blank (NaN,
    :func:`level_blanked`) read as 0, the same plane at a dip of 0 whatever its azimuth.

    Examples
    --------
    >>> drawn_azimuth([75.0, float("nan")]).tolist()
    [75.0, 0.0]
    """
    return np.nan_to_num(np.asarray(angle, dtype=np.float64), nan=0.0)


def level_blanked(orientation: Orientation, dip_uncertainty) -> Orientation:
    """``orientation`` with no strike or dip direction where the plane is level within its
    measurement: a dip under two of its standard errors (``dip_uncertainty``, degrees) has
    no direction to give, and a number there (the demo's ground: 75 degrees at a dip of
    0.0007) would be read as one. NaN standard errors leave a plane as it is.

    Examples
    --------
    >>> o = level_blanked(Orientation(np.array([345.2, 0.0]), np.array([0.0007, 40.0]), np.array([75.2, 90.0])),
    ...                   np.array([0.0005, 0.002]))
    >>> o.dip_direction.tolist(), o.strike.tolist()
    ([nan, 90.0], [nan, 0.0])
    """
    dip = np.asarray(orientation.dip, dtype=np.float64)
    se = np.asarray(dip_uncertainty, dtype=np.float64)
    level = np.isfinite(se) & (dip < 2.0 * se)
    if not level.any():
        return orientation
    return Orientation(
        strike=np.where(level, np.nan, orientation.strike),
        dip=dip,
        dip_direction=np.where(level, np.nan, orientation.dip_direction),
    )


def face_side(outward, frame: Frame = Frame()) -> tuple[np.ndarray, np.ndarray]:
    """Which way each exposed face looks: (``facing``, ``overhang``).

    ``facing`` is the azimuth (degrees, as dip directions are read) of the face's outward
    normal, the side it was seen from; ``overhang`` is 1.0 where that normal points below
    the horizon (the face is the underside of its plane) and 0.0 where above. The dip and
    dip direction never carry this side (dip stays in [0, 90], ORIENTATION.md): a plane
    dipping 80 east seen from the east and one seen from the west share them. NaN where
    the side is unknown (a zero or NaN row, or no azimuth for a face looking straight up).

    Examples
    --------
    >>> facing, overhang = face_side([[0.0, -1.0, -0.2], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    >>> facing.round(3).tolist(), overhang.tolist()
    ([180.0, 90.0, nan], [1.0, 0.0, 0.0])
    """
    enu = frame.to_enu(np.atleast_2d(np.asarray(outward, dtype=np.float64)))
    horizontal = np.hypot(enu[:, 0], enu[:, 1])
    known = np.isfinite(enu).all(axis=1) & (np.abs(enu).max(axis=1) > 0)
    with np.errstate(invalid="ignore"):
        facing = (np.degrees(np.arctan2(enu[:, 0], enu[:, 1])) - frame.declination) % 360.0
    facing = np.where(known & (horizontal > 1e-12 * np.abs(enu).max(axis=1, initial=0)), facing, np.nan)
    overhang = np.where(known, (enu[:, 2] < 0).astype(np.float64), np.nan)
    return facing, overhang


def normal_from_orientation(dip_direction, dip, frame: Frame = Frame()) -> np.ndarray:
    """The upward unit normal, in cloud axes, of planes with the given dip direction and dip."""
    dd = np.radians(np.asarray(dip_direction, dtype=np.float64) + frame.declination)
    d = np.radians(np.asarray(dip, dtype=np.float64))
    enu = np.stack([np.sin(d) * np.sin(dd), np.sin(d) * np.cos(dd), np.cos(d)], axis=-1)
    return enu @ frame.matrix  # rows of the matrix are E, N, U in cloud axes


def whole_azimuth(azimuth: float) -> str:
    """An azimuth to the whole degree, three digits, as a compass gives it: 359.7 is 000,
    not 360.

    Examples
    --------
    >>> whole_azimuth(359.7), whole_azimuth(5.2), whole_azimuth(180.0)
    ('000', '005', '180')
    """
    return f"{round(float(azimuth)) % 360:03d}"


def azimuth_difference(a, b) -> np.ndarray:
    """Smallest difference between azimuths in degrees, in [0, 180]: 359 and 1 are 2 apart.

    Parameters
    ----------
    a, b : float or array
        Azimuths in degrees (any range; they are taken modulo 360).

    Returns
    -------
    ndarray
        The differences, in degrees.

    Examples
    --------
    >>> azimuth_difference([359.0, 90.0], [1.0, 270.0]).tolist()
    [2.0, 180.0]
    """
    d = np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) % 360.0
    return np.minimum(d, 360.0 - d)


def angle_between_vectors(v1, v2) -> np.ndarray:
    """Angle between directions in degrees, in [0, 180]; the cosine is clipped to [-1, 1], so
    a dot product that rounds to 1.0000000000000002 gives 0, not NaN.

    Parameters
    ----------
    v1, v2 : (N, 3) or (3,) array
        Directions; their lengths do not matter.

    Returns
    -------
    ndarray
        (N,) angles in degrees.

    Examples
    --------
    >>> a = np.array([0.6, 0.8, 0.0])
    >>> float(angle_between_vectors(a, a)[0]), float(angle_between_vectors(a, -a)[0])
    (0.0, 180.0)
    """
    a = np.atleast_2d(np.asarray(v1, dtype=np.float64))
    b = np.atleast_2d(np.asarray(v2, dtype=np.float64))
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0)))


def angle_between_normals(n1, n2) -> np.ndarray:
    """Angle between planes in degrees, arccos(|n1 . n2|): the sign of a normal does not matter.

    Parameters
    ----------
    n1, n2 : (N, 3) or (3,) array
        Plane normals; their lengths and signs do not matter.

    Returns
    -------
    ndarray
        (N,) angles in degrees, in [0, 90].

    Examples
    --------
    >>> angle_between_normals([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]).tolist()
    [0.0]
    """
    angle = angle_between_vectors(n1, n2)
    return np.minimum(angle, 180.0 - angle)
