"""The point cloud every stage works on."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.errors import ParameterError

#: Largest coordinate accepted: beyond it float64 no longer resolves a millimetre (UTM northings
#: are 1e7, geocentric ones 6e6), so a larger value is a damaged file, not a survey.
MAX_COORDINATE = 1e12


def as_points(values, name: str = "points") -> np.ndarray:
    """``values`` as an (N, 3) float64 array; anything else is refused, never reshaped.

    Examples
    --------
    >>> as_points([[0, 1, 2]]).dtype
    dtype('float64')
    >>> as_points(np.zeros((5, 4)))
    Traceback (most recent call last):
    ...
    geostructure.errors.ParameterError: points must be an (N, 3) array of x, y, z; got shape (5, 4).
    """
    array = np.asarray(values)
    if array.dtype.kind not in "biuf":
        raise ParameterError(f"{name} must be real numbers; got an array of dtype {array.dtype}.")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ParameterError(f"{name} must be an (N, 3) array of x, y, z; got shape {array.shape}.")
    return np.ascontiguousarray(array, dtype=np.float64)


@dataclass
class Cloud:
    """Points held as float64 offsets from ``offset``, so UTM-sized coordinates keep precision.

    Parameters
    ----------
    local : (N, 3) float64
        Point coordinates minus ``offset``. All arithmetic happens on these.
    offset : (3,) float64
        Added back to ``local`` to give the coordinates of the input file.
    crs : str or None
        Coordinate reference system as WKT when the input file declared one.
    normals : (N, 3) float64 or None
        Normals stored in the input (used only to break the tie for vertical planes).
    source : str
        Where the points came from, for messages and ``run.json``.
    enu_origin : (lat, lon, alt) or None
        Set when the coordinates are local east-north-up metres about this WGS84 point (a
        reconstruction georeferenced from GPS), so outputs can be written in longitude and latitude.
    las_grid : ((3,), (3,)) float64 or None
        The scales and offsets of a LAS/LAZ input's integer coordinates, so ``regions.laz``
        stores its points back on the very integers they were read from.
    left_out : dict or None
        Points the input file held but marked to be left out, by why (``{"withheld": 300,
        "noise": 200}`` for a LAS/LAZ), for ``run.json``; None when there were none.
    grey : (N,) float32 or None
        Each point's brightness from its colour, 0 (black) to 1 (white): the mean of its red,
        green and blue, where the file has them; the trace detector reads dark lines in it.
    vegetation : (N,) bool or None
        The points the input file classifies as vegetation (LAS classes 3 to 5): clutter on a
        rock face, not rock (:func:`~geostructure.rockmass.face.face_parts`); None when it classifies none so.

    Examples
    --------
    >>> cloud = Cloud.from_points([[500000.25, 4600000.5, 10.0], [500001.25, 4600000.5, 10.0]])
    >>> cloud.offset.tolist(), cloud.local[0].tolist()
    ([500001.0, 4600000.0, 10.0], [-0.75, 0.5, 0.0])
    >>> bool((cloud.points == [[500000.25, 4600000.5, 10.0], [500001.25, 4600000.5, 10.0]]).all())
    True
    """

    local: np.ndarray
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    crs: str | None = None
    normals: np.ndarray | None = None
    source: str = "<memory>"
    enu_origin: tuple | None = None
    las_grid: tuple | None = None
    left_out: dict | None = None
    vegetation: np.ndarray | None = None
    grey: np.ndarray | None = None

    def __post_init__(self):
        self.local = as_points(self.local, "local")
        offset = np.asarray(self.offset, dtype=np.float64)
        if offset.shape != (3,) or not np.isfinite(offset).all():
            raise ParameterError(f"offset must be three finite numbers; got {offset.tolist()}.")
        self.offset = offset
        if self.vegetation is not None:
            self.vegetation = np.asarray(self.vegetation, dtype=bool)
            if self.vegetation.shape != (len(self.local),):
                raise ParameterError(
                    f"vegetation must have one flag per point: {len(self.vegetation)} for {len(self.local)} points."
                )
        if self.grey is not None:
            self.grey = np.asarray(self.grey, dtype=np.float32)
            if self.grey.shape != (len(self.local),):
                raise ParameterError(
                    f"grey must have one value per point: {len(self.grey)} for {len(self.local)} points."
                )
        if self.normals is not None:
            self.normals = as_points(self.normals, "normals")
            if len(self.normals) != len(self.local):
                raise ParameterError(
                    f"normals must have one row per point: {len(self.normals)} rows for {len(self.local)} points."
                )

    @classmethod
    def from_points(
        cls,
        points,
        *,
        source="<memory>",
        crs=None,
        normals=None,
        enu_origin=None,
        las_grid=None,
        left_out=None,
        vegetation=None,
        grey=None,
    ) -> "Cloud":
        """Build a cloud from absolute coordinates, centring them on the bounding-box centre."""
        points = as_points(points)
        # Readers report NaN/inf rows by count; the copy is made only when there are some.
        finite = points if np.isfinite(points).all() else points[np.isfinite(points).all(axis=1)]
        offset = (column_min(finite) + column_max(finite)) / 2 if len(finite) else np.zeros(3)
        # Round the offset so it prints cleanly and survives float32 writers (E57, LAS scale).
        offset = np.round(offset, 0) + 0.0  # + 0.0 turns -0.0 into 0.0
        return cls(
            points - offset,
            offset,
            crs=crs,
            normals=normals,
            source=str(source),
            enu_origin=enu_origin,
            las_grid=las_grid,
            left_out=left_out,
            vegetation=vegetation,
            grey=grey,
        )

    @property
    def points(self) -> np.ndarray:
        """Absolute coordinates (``local + offset``)."""
        return self.local + self.offset

    def __len__(self) -> int:
        return len(self.local)

    def subset(self, mask: np.ndarray) -> "Cloud":
        """The cloud restricted to ``mask`` (boolean or index array)."""
        normals = None if self.normals is None else self.normals[mask]
        vegetation = None if self.vegetation is None else self.vegetation[mask]
        grey = None if self.grey is None else self.grey[mask]
        return Cloud(
            self.local[mask],
            self.offset,
            self.crs,
            normals,
            self.source,
            self.enu_origin,
            self.las_grid,
            self.left_out,
            vegetation,
            grey,
        )

    @property
    def name(self) -> str:
        """The file's name, or the files' (tiles read as one cloud name theirs, comma-separated)."""
        return ", ".join(Path(part).name for part in str(self.source).split(", "))
