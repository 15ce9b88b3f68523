"""The point outputs of a streamed run, written chunk by chunk as the label pass goes:
``regions.ply`` and ``regions.laz``, the same files (format, fields, grid) that
:mod:`geostructure.io.writers` and :mod:`geostructure.io.laz` write in memory."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geostructure.io.crs import parse_crs
from geostructure.io.laz import KeptWriteErrors, las_grid, rewrite_point_sets
from geostructure.io.results import SCALAR
from geostructure.io.writers import ply_header, regions_comments, regions_dtype


class RegionsPly:
    """``regions.ply``: the kept points (double) with an int ``scalar_region_id``, a
    ``scalar_vegetation`` flag when the survey classifies any point as vegetation, and with
    ``point_sets`` the sets' fields (:data:`~geostructure.io.writers.POINT_SET_FIELDS`) that
    each chunk's ``fields`` give."""

    def __init__(self, path, point_sets: bool = False):
        self.path = Path(path)
        self.point_sets = point_sets
        self._file = None
        self._dtype = None

    def begin(self, n_points: int, lower, upper, cloud) -> None:
        marked = cloud.vegetation is not None  # the spill's cloud carries an empty mark when any is
        self._dtype = regions_dtype(marked, self.point_sets)
        self._file = open(self.path, "wb")
        self._file.write(ply_header(self._dtype, n_points, regions_comments(cloud.source.split(",")[0])))

    def write(self, points: np.ndarray, labels: np.ndarray, vegetation=None, fields=None) -> None:
        rows = np.empty(len(points), dtype=self._dtype)
        rows["x"], rows["y"], rows["z"] = points.T
        rows[SCALAR + "region_id"] = labels
        if SCALAR + "vegetation" in self._dtype.names:
            rows[SCALAR + "vegetation"] = 0 if vegetation is None else vegetation
        if self.point_sets:
            for name, value in fields.items():
                rows[SCALAR + name] = value
        rows.tofile(self._file)

    def end(self) -> None:
        self._file.close()


class RegionsLaz:
    """``regions.laz`` (LAS 1.4, point format 6): the kept points on the input's grid when
    every tile shares one, with ``region_id`` as an extra dimension and the CRS kept, and
    the ``extra`` dimensions (name -> dtype) that each chunk's ``fields`` give."""

    def __init__(self, path, extra: dict | None = None):
        self.path = Path(path)
        self.extra = dict(extra or {})
        self._writer = None
        self._header = None
        self._dest = None

    def begin(self, n_points: int, lower, upper, cloud) -> None:
        import laspy

        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales, header.offsets = las_grid(np.vstack([lower, upper]), cloud.offset, cloud.las_grid)
        header.generating_software = "geostructure"
        for name, kind in {"region_id": np.int32, **self.extra}.items():
            header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=kind))
        if cloud.crs:
            header.add_crs(parse_crs(cloud.crs))
        self._header = header
        self._dest = KeptWriteErrors(self.path)
        self._writer = laspy.open(self._dest, mode="w", header=header, do_compress=self.path.suffix == ".laz")

    def write(self, points: np.ndarray, labels: np.ndarray, vegetation=None, fields: dict | None = None) -> None:
        import laspy

        record = laspy.ScaleAwarePointRecord.zeros(len(points), header=self._header)
        record.x, record.y, record.z = points[:, 0], points[:, 1], points[:, 2]
        record.region_id = np.asarray(labels, dtype=np.int32)
        for name, kind in self.extra.items():
            record[name] = np.asarray(fields[name], dtype=kind)
        try:
            self._writer.write_points(record)
        except BaseException as exc:
            self._dest.file.close()
            self._dest.reraise(exc)

    def end(self) -> None:
        try:
            self._writer.close()
        except BaseException as exc:
            self._dest.reraise(exc)
        finally:
            self._dest.file.close()


def rewrite_regions_laz(source, path, values, rows: int) -> Path:
    """Write ``source`` (a ``regions.laz``) again to ``path`` chunk by chunk, each point on
    the same integers with its ``region_id``, and the dimensions of
    :data:`~geostructure.io.laz.POINT_SET_DIMENSIONS` from ``values`` (an iterable of dicts,
    name -> array, per ``rows`` points, in the file's order)."""
    values = iter(values)

    def fields_of(chunk, start: int) -> dict:
        fields = next(values, None)
        if fields is None:  # zip would have cut the file short here
            raise ValueError(f"{source}: more points than regions.ply gives ({start:,} there)")
        return fields

    return rewrite_point_sets(source, path, fields_of, rows)
