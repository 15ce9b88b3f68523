"""The plane table: every measured plane, one row each, as typed numpy columns.

:class:`Planes` is the one representation of a run's planes. ``measure`` builds it, the
writers, the evaluation, the report and the terminal tables read it, and ``planes.csv`` is
its text form (:mod:`geostructure.io.planetable` writes and reads it), so a table read back from
a folder is the table that was written. Vectors are in the cloud's axes. Positions are held
as a :class:`~geostructure.core.cloud.Cloud` holds its points, relative to ``offset`` (so float arithmetic on
them keeps millimetres at UTM magnitudes), and given absolute by ``centroid``,
``rect_center`` and ``corners``, which is what ``planes.csv`` holds.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from geostructure.core.orientation import Frame, Orientation, face_side, level_blanked, orientation_from_normals
from geostructure.errors import ParameterError

#: Column name(s) of each field in ``planes.csv``, in the file's order. The first twelve
#: columns are the stable contract other tools read (:data:`PLANE_COLUMNS`).
LAYOUT = (
    ("region_id", ("region_id",)),
    ("n_points", ("n_points",)),
    ("area", ("area_m2",)),
    ("local_centroid", ("centroid_x", "centroid_y", "centroid_z")),
    ("normal", ("normal_x", "normal_y", "normal_z")),
    ("strike", ("strike",)),
    ("dip", ("dip",)),
    ("dip_direction", ("dip_direction",)),
    ("rect_width", ("rect_width",)),
    ("rect_height", ("rect_height",)),
    ("fit_residual", ("fit_residual",)),
    ("n_voxels", ("n_voxels",)),
    ("normal_scatter_deg", ("normal_scatter_deg",)),
    ("normal_uncertainty_deg", ("normal_uncertainty_deg",)),
    ("local_rect_center", ("rect_center_x", "rect_center_y", "rect_center_z")),
    ("rect_u", ("rect_u_x", "rect_u_y", "rect_u_z")),
    ("dip_uncertainty_deg", ("dip_uncertainty_deg",)),
    ("dip_direction_uncertainty_deg", ("dip_direction_uncertainty_deg",)),
    ("planarity", ("planarity",)),
    ("facing", ("facing",)),
    ("overhang", ("overhang",)),
)
COLUMNS = tuple(name for _, names in LAYOUT for name in names)
#: The stable contract other tools and issues read; more columns may follow these.
PLANE_COLUMNS = COLUMNS[:12]
EXTRA_COLUMNS = COLUMNS[12:]
#: Columns a ``planes.csv`` written before they existed lacks: read back as NaN.
LATER_COLUMNS = ("dip_uncertainty_deg", "dip_direction_uncertainty_deg", "planarity", "facing", "overhang")
_INTEGER = {"region_id", "n_points", "n_voxels"}


@dataclass(frozen=True, eq=False)
class Planes:
    """Measured planes, largest first: one entry per plane in every column.

    Only ``normal`` is required; a column left out is filled (orientation from the normals
    in the ENU frame, ``region_id`` 0, 1, ..., the rectangle centre at the centroid, NaN for
    the rest). ``local_centroid`` and ``local_rect_center`` are relative to ``offset``.
    ``rect_v``, the rectangle's second axis, is ``normal x rect_u`` unless given. ``extra``
    holds further named per-plane columns (a joint set, a kinematic test), written after the
    standard ones.

    Parameters
    ----------
    normal : (P, 3) array
        Unit normals, upward, in the cloud's axes.
    local_centroid, local_rect_center : (P, 3) array, optional
        Centroid and rectangle centre, relative to ``offset``.
    region_id, n_points, n_voxels : (P,) int array, optional
    area : (P,) array, optional
        Convex-hull area in the plane (``area_m2``).
    strike, dip, dip_direction : (P,) array, optional
        Degrees, in the run's frame.
    rect_width, rect_height : (P,) array, optional
        Sides of the minimum-perimeter rectangle.
    fit_residual : (P,) array, optional
        RMS distance of the points to the plane.
    normal_scatter_deg, normal_uncertainty_deg : (P,) array, optional
        Scatter of the voxel normals and the normal's standard error
        (:func:`~geostructure.detect.uncertainty.normal_standard_errors`).
    rect_u, rect_v : (P, 3) array, optional
        The rectangle's axes (``rect_v`` defaults to ``normal x rect_u``).
    dip_uncertainty_deg, dip_direction_uncertainty_deg : (P,) array, optional
        Standard errors of dip and dip direction.
    planarity : (P,) array, optional
        1 - sqrt(lambda_3 / lambda_2) of the points' covariance: 1 for a flat patch, 0 for
        a blob, whatever its outline.
    facing, overhang : (P,) array, optional
        The side each face was seen from (:func:`~geostructure.core.orientation.face_side`): the azimuth of
        its outward normal, and 1 where that normal points down; NaN where the cloud held
        no normals to tell.
    offset : (3,) array, optional
        Added to the local positions to give the input's own coordinates.
    extra : dict of (P,) arrays, optional
        Further columns.

    Examples
    --------
    >>> planes = Planes(normal=[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], local_centroid=[[0, 0, 5], [2, 0, 0]],
    ...                 offset=[500000.0, 0.0, 0.0])
    >>> len(planes), planes.dip.tolist(), planes.dip_direction.tolist()
    (2, [0.0, 90.0], [0.0, 90.0])
    >>> planes.subset([1]).centroid.tolist()
    [[500002.0, 0.0, 0.0]]
    """

    normal: np.ndarray
    # The columns below may be left out (None): __post_init__ fills each, so a built table
    # holds no None, which the annotations say.
    local_centroid: np.ndarray = None  # type: ignore[assignment]
    region_id: np.ndarray = None  # type: ignore[assignment]
    n_points: np.ndarray = None  # type: ignore[assignment]
    area: np.ndarray = None  # type: ignore[assignment]
    strike: np.ndarray = None  # type: ignore[assignment]
    dip: np.ndarray = None  # type: ignore[assignment]
    dip_direction: np.ndarray = None  # type: ignore[assignment]
    rect_width: np.ndarray = None  # type: ignore[assignment]
    rect_height: np.ndarray = None  # type: ignore[assignment]
    fit_residual: np.ndarray = None  # type: ignore[assignment]
    n_voxels: np.ndarray = None  # type: ignore[assignment]
    normal_scatter_deg: np.ndarray = None  # type: ignore[assignment]
    normal_uncertainty_deg: np.ndarray = None  # type: ignore[assignment]
    local_rect_center: np.ndarray = None  # type: ignore[assignment]
    rect_u: np.ndarray = None  # type: ignore[assignment]
    dip_uncertainty_deg: np.ndarray = None  # type: ignore[assignment]
    dip_direction_uncertainty_deg: np.ndarray = None  # type: ignore[assignment]
    planarity: np.ndarray = None  # type: ignore[assignment]
    facing: np.ndarray = None  # type: ignore[assignment]
    overhang: np.ndarray = None  # type: ignore[assignment]
    rect_v: np.ndarray = None  # type: ignore[assignment]
    offset: np.ndarray = None  # type: ignore[assignment]
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        normal = np.asarray(self.normal, dtype=np.float64).reshape(-1, 3)
        n = len(normal)
        filled = {"normal": normal}
        if self.strike is None or self.dip is None or self.dip_direction is None:
            o = orientation_from_normals(normal) if n else Orientation(np.zeros(0), np.zeros(0), np.zeros(0))
            filled.update(strike=o.strike, dip=o.dip, dip_direction=o.dip_direction)
        defaults = {"local_centroid": np.zeros((n, 3)), "region_id": np.arange(n), "n_points": 0, "n_voxels": 0}
        for name, columns in LAYOUT:
            value = filled.get(name, getattr(self, name))
            if value is None:
                value = defaults.get(name, filled.get("local_centroid") if name == "local_rect_center" else None)
            if value is None:
                value = np.full((n, len(columns)) if len(columns) > 1 else n, np.nan)
            dtype = np.int64 if name in _INTEGER else np.float64
            value = np.asarray(value, dtype=dtype)
            if len(columns) > 1:
                value = value.reshape(-1, len(columns))
            elif value.ndim == 0:
                value = np.full(n, value)
            if value.ndim != (2 if len(columns) > 1 else 1) or len(value) != n:
                raise ParameterError(f"Planes: `{name}` has {len(value)} rows, `normal` has {n}.")
            filled[name] = value
        filled["rect_v"] = (
            np.cross(filled["normal"], filled["rect_u"])
            if self.rect_v is None
            else np.asarray(self.rect_v, dtype=np.float64).reshape(n, 3)
        )
        filled["offset"] = np.zeros(3) if self.offset is None else np.asarray(self.offset, dtype=np.float64).reshape(3)
        extra = {k: np.asarray(v).reshape(n) for k, v in self.extra.items()}
        for name, value in {**filled, "extra": extra}.items():
            object.__setattr__(self, name, value)

    def __len__(self) -> int:
        return len(self.normal)

    @property
    def orientation(self) -> Orientation:
        return Orientation(strike=self.strike, dip=self.dip, dip_direction=self.dip_direction)

    @property
    def centroid(self) -> np.ndarray:
        """(P, 3) centroids in the input's own coordinates."""
        return self.local_centroid + self.offset

    @property
    def rect_center(self) -> np.ndarray:
        """(P, 3) rectangle centres in the input's own coordinates."""
        return self.local_rect_center + self.offset

    @property
    def perimeter(self) -> np.ndarray:
        return 2.0 * (self.rect_width + self.rect_height)

    @property
    def local_corners(self) -> np.ndarray:
        """(P, 4, 3) rectangle corners relative to ``offset``, counter-clockwise about ``rect_u x rect_v``."""
        hu = (self.rect_u * self.rect_width[:, None] / 2)[:, None, :]
        hv = (self.rect_v * self.rect_height[:, None] / 2)[:, None, :]
        return self.local_rect_center[:, None, :] + np.concatenate([-hu - hv, hu - hv, hu + hv, -hu + hv], axis=1)

    @property
    def corners(self) -> np.ndarray:
        """(P, 4, 3) rectangle corners in the input's own coordinates."""
        return self.local_corners + self.offset

    def standard_errors(self) -> dict:
        """The table's standard errors (degrees) and planarity as
        :func:`~geostructure.detect.uncertainty.normal_standard_errors` gives them: ``normal``, ``dip``,
        ``dip_direction`` and ``planarity``."""
        return {
            "normal": self.normal_uncertainty_deg,
            "dip": self.dip_uncertainty_deg,
            "dip_direction": self.dip_direction_uncertainty_deg,
            "planarity": self.planarity,
        }

    def subset(self, index) -> Planes:
        """The planes at ``index`` (integers or a mask), with their columns."""
        taken = {name: getattr(self, name)[index] for name, _ in LAYOUT}
        extra = {k: v[index] for k, v in self.extra.items()}
        return Planes(**taken, rect_v=self.rect_v[index], offset=self.offset, extra=extra)

    def with_columns(self, **columns) -> Planes:
        """The same planes with more (or replaced) ``extra`` columns."""
        return replace(self, extra={**self.extra, **columns})

    def rows(self) -> list[dict]:
        """One dict per plane, keyed by the ``planes.csv`` columns, with Python numbers."""
        flat: list[np.ndarray] = []
        for name, columns in LAYOUT:
            value = getattr(self, name.removeprefix("local_"))
            flat.extend(value.T if len(columns) > 1 else [value])
        flat.extend(self.extra.values())
        keys = COLUMNS + tuple(self.extra)
        return [dict(zip(keys, values)) for values in zip(*(column.tolist() for column in flat))] if len(self) else []

    @classmethod
    def from_columns(cls, column: dict, header, offset=None) -> Planes:
        """The table from ``planes.csv``'s columns by name (float arrays; ``header`` their
        order in the file), positions taken relative to ``offset`` (the run's, from
        ``run.json``); columns after the standard ones come back in ``extra``, those of
        whole numbers (a set label) as integers. :func:`~geostructure.io.planetable.read_planes_csv`
        reads and checks the file.

        Examples
        --------
        >>> planes = Planes(normal=[[0.0, 0.6, 0.8]], local_centroid=[[662000.125, 5103000.5, 400.0]])
        >>> table = {k: np.array([v], dtype=float) for k, v in planes.rows()[0].items()}
        >>> Planes.from_columns(table, list(table)).centroid.tolist()
        [[662000.125, 5103000.5, 400.0]]
        """
        column = dict(column)
        rows = len(next(iter(column.values()))) if column else 0
        for name in LATER_COLUMNS:
            column.setdefault(name, np.full(rows, np.nan))
        values = {name: np.stack([column[c] for c in columns], axis=1) for name, columns in LAYOUT}
        values = {name: v[:, 0] if v.shape[1] == 1 else v for name, v in values.items()}
        offset = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
        values["local_centroid"] = values["local_centroid"] - offset
        values["local_rect_center"] = values["local_rect_center"] - offset
        extra = {name: _whole_or_float(column[name]) for name in header if name not in COLUMNS}
        return cls(**values, offset=offset, extra=extra)

    @classmethod
    def from_regions(
        cls, regions, normals, orientation, *, offset, n_voxels, scatter, uncertainty: dict, face=(None, None)
    ) -> Planes:
        """The table of ``measure``'s region planes (:class:`~geostructure.detect.rectangle.RegionPlane`, in the
        cloud's local coordinates, which ``offset`` moves back) with their oriented normals
        and spread; ``uncertainty`` holds the standard errors and planarity
        (:func:`~geostructure.detect.uncertainty.normal_standard_errors`), ``face`` the (facing, overhang) columns."""

        def stacked(attribute, width=None):
            values = np.array([getattr(r, attribute) for r in regions], dtype=np.float64)
            return values.reshape(-1, width) if width else values

        orientation = level_blanked(orientation, uncertainty["dip"])
        return cls(
            normal=normals,
            local_centroid=stacked("centroid", 3),
            region_id=np.arange(len(regions)),
            n_points=np.array([r.n_points for r in regions], dtype=np.int64),
            area=stacked("area"),
            strike=orientation.strike,
            dip=orientation.dip,
            dip_direction=orientation.dip_direction,
            rect_width=stacked("width"),
            rect_height=stacked("height"),
            fit_residual=stacked("residual"),
            n_voxels=n_voxels,
            # the voxels' normals' spread: a facet grown on points has none to read (blank,
            # not 0: 0 would say "perfectly smooth")
            normal_scatter_deg=np.where(np.asarray(n_voxels) > 0, np.asarray(scatter, dtype=np.float64), np.nan),
            normal_uncertainty_deg=uncertainty["normal"],
            dip_uncertainty_deg=uncertainty["dip"],
            dip_direction_uncertainty_deg=uncertainty["dip_direction"],
            planarity=uncertainty["planarity"],
            facing=face[0],
            overhang=face[1],
            local_rect_center=stacked("center", 3),
            rect_u=stacked("u", 3),
            rect_v=stacked("v", 3),
            offset=offset,
        )


def _whole_or_float(values: np.ndarray) -> np.ndarray:
    whole = (
        np.isfinite(values).all() and np.array_equal(values, np.round(values)) and np.abs(values).max(initial=0) < 2**53
    )
    return values.astype(np.int64) if whole else values


def reoriented(planes: Planes, frame: Frame, previous: Frame = Frame()) -> Planes:
    """The same planes with strike, dip, dip direction and facing read in another ``frame``
    (``previous``: the one they were read in)."""
    o = level_blanked(orientation_from_normals(planes.normal, frame), planes.dip_uncertainty_deg)
    # The outward normal is +-normal: the sign whose azimuth in `previous` is `facing`.
    enu = previous.to_enu(planes.normal)
    azimuth = np.radians(planes.facing + previous.declination)
    along = enu[:, 0] * np.sin(azimuth) + enu[:, 1] * np.cos(azimuth)
    sign = np.where(np.isfinite(along) & (np.abs(along) > 1e-9), np.sign(along), 1 - 2 * planes.overhang)
    facing, overhang = face_side(planes.normal * sign[:, None], frame)
    facing = np.where(np.isfinite(planes.overhang), facing, np.nan)
    overhang = np.where(np.isfinite(planes.overhang), overhang, np.nan)
    return replace(planes, strike=o.strike, dip=o.dip, dip_direction=o.dip_direction, facing=facing, overhang=overhang)


def plane_rows(region, region_ids) -> np.ndarray:
    """Each point's row in a plane table, from its ``region_id`` (-1 where it has none, or
    where its region is not in ``region_ids``).

    Examples
    --------
    >>> plane_rows(np.array([7, 4, -1, 9]), np.array([4, 7])).tolist()
    [1, 0, -1, -1]
    """
    region = np.asarray(region, dtype=np.int64)
    region_ids = np.asarray(region_ids, dtype=np.int64)
    lookup = np.full(int(max(region.max(initial=-1), region_ids.max(initial=-1))) + 2, -1, dtype=np.int64)
    lookup[region_ids + 1] = np.arange(len(region_ids))
    return lookup[np.clip(region, -1, len(lookup) - 2) + 1]
