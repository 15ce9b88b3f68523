"""Point outputs for point-cloud tools: ``regions.laz`` and ``voxel_planes.laz`` (LAS 1.4).

LAS stores each coordinate as a 32-bit integer on a grid (``scale`` and ``offset`` per
axis), so UTM-sized coordinates keep their precision in every reader (CloudCompare, PDAL,
LAStools, QGIS) without a global shift; a PLY of doubles keeps them too, but CloudCompare
loads it as float32 unless the user shifts it.

- The grid: a LAS/LAZ input's own scale and offset, so its points are written back on the
  very integers they were read from; otherwise :data:`LAS_QUANTUM` (0.1 mm in the CRS's
  unit) about the cloud's rounded centre, or the first coarser power of ten when the cloud
  spans more than 32-bit integers hold at that step (beyond about 200 km).
- The CRS: a WKT VLR (LAS 1.4 asks WKT for point format 6) when the cloud has one; none for
  a reconstruction's local east-north-up frame, which no registry names.
- Point format 6 (x, y, z, with intensity, returns and classification left at 0) and the
  attributes as extra-bytes dimensions, which readers show as scalar fields: ``region_id``
  (-1 for none) and ``set`` (-1 for none, when the run has sets); for the voxel planes,
  ``nx``, ``ny``, ``nz``, ``count`` and ``region_id``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.planes import plane_rows
from geostructure.io.atomic import atomic_path
from geostructure.io.crs import parse_crs
from geostructure.io.failures import laz_readers

#: The step of the coordinate grid for a cloud that was not read from LAS/LAZ.
LAS_QUANTUM = 1e-4
_INT32_REACH = 2**31 - 2


def las_grid(points: np.ndarray, offset, grid=None) -> tuple[np.ndarray, np.ndarray]:
    """The (scales, offsets) on which ``points`` are stored.

    ``grid`` is a LAS input's own (kept when the points fit it); otherwise the step is
    :data:`LAS_QUANTUM`, coarsened by powers of ten until every point is within reach of
    ``offset`` in 32-bit integers.

    Examples
    --------
    >>> scales, offsets = las_grid(np.array([[500000.0, 4600000.0, 10.0]]), [500000.0, 4600000.0, 10.0])
    >>> scales.tolist(), offsets.tolist()
    ([0.0001, 0.0001, 0.0001], [500000.0, 4600000.0, 10.0])
    """
    points = np.asarray(points, dtype=np.float64)
    # The farthest point from the offset, from the bounds alone (fl(p - o) rises with p, so
    # this is max |p - o| exactly), without two temporaries the size of the cloud.
    lower, upper = (column_min(points), column_max(points)) if len(points) else (np.zeros(3), np.zeros(3))

    def reach_from(offsets):
        return np.maximum(upper - offsets, offsets - lower) if len(points) else np.zeros(3)

    if grid is not None:
        scales, offsets = (np.asarray(g, dtype=np.float64) for g in grid)
        if not len(points) or (reach_from(offsets) / scales <= _INT32_REACH).all():
            return scales, offsets
    offsets = np.asarray(offset, dtype=np.float64)
    reach = reach_from(offsets)
    scales = np.full(3, LAS_QUANTUM)
    while (reach / scales > _INT32_REACH).any():
        scales = np.where(reach / scales > _INT32_REACH, scales * 10, scales)
    return scales, offsets


def point_sets(region, planes) -> np.ndarray:
    """Each point's joint set from its ``region_id`` (-1 for none), through the plane table's
    ``set`` column.

    Examples
    --------
    >>> from geostructure.core.planes import Planes
    >>> planes = Planes(normal=[[0, 0, 1.0], [1.0, 0, 0]], region_id=[4, 7]).with_columns(set=[1, -1])
    >>> point_sets(np.array([7, 4, -1, 4]), planes).tolist()
    [-1, 1, -1, 1]
    """
    return per_point(region, planes, "set", np.int16)


def point_joints(region, planes) -> np.ndarray:
    """Each point's joint (``joints.csv``'s number) from its ``region_id`` (-1 for none, and
    for every point of a plane table without a ``joint`` column)."""
    return per_point(region, planes, "joint", np.int32)


def per_point(region, planes, column: str, dtype) -> np.ndarray:
    """A plane-table column (``planes.extra[column]``) for each point through its region."""
    rows = plane_rows(region, planes.region_id)
    if not len(planes) or column not in planes.extra:  # no plane: no row 0 to index
        return np.full(len(rows), -1, dtype=dtype)
    return np.where(rows >= 0, planes.extra[column][np.maximum(rows, 0)], -1).astype(dtype)


#: The dimensions a run with sets adds to ``regions.laz``: each point's set, its part of the
#: face (:data:`~geostructure.rockmass.face.FACE`, ``GROUND`` or ``CLUTTER``) and its joint.
POINT_SET_DIMENSIONS = (("set", np.int16), ("face_part", np.uint8), ("joint", np.int32))


def write_laz(
    path, points: np.ndarray, fields: dict[str, np.ndarray], *, offset, crs=None, grid=None, origin=None
) -> Path:
    """Write ``points`` (N, 3: absolute, or relative to ``origin`` (3,) when given) with
    ``fields`` (name -> (N,) array) as extra dimensions to a LAS 1.4 file, compressed when
    ``path`` ends in ``.laz``; atomically. With ``origin``, each axis's absolute coordinates
    (``points + origin``, as :attr:`Cloud.points` gives them) are made one at a time in one
    buffer: no absolute copy of the cloud (192 MB at 8M points)."""
    import laspy

    points = np.asarray(points, dtype=np.float64)
    origin = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    header = laspy.LasHeader(point_format=6, version="1.4")
    # fl(p + o) rises with p: the bounds of the absolute points are the relative ones' plus o.
    bounds = np.stack([column_min(points), column_max(points)]) + origin if len(points) else np.zeros((0, 3))
    header.scales, header.offsets = las_grid(bounds, offset, grid)
    header.generating_software = "geostructure"
    for name, values in fields.items():
        header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=np.asarray(values).dtype))
    if crs:
        header.add_crs(parse_crs(crs))
    # The record at its length from the start: laspy grows an empty one by np.append.
    las = laspy.LasData(header, points=laspy.ScaleAwarePointRecord.zeros(len(points), header=header))
    scratch = np.empty(len(points))
    for axis, name in enumerate("XYZ"):
        las.points.array[name] = stored_integers(points[:, axis], origin[axis], header.offsets[axis],
                                                 header.scales[axis], scratch)  # fmt: skip
    for name, values in fields.items():
        setattr(las, name, values)
    return _write(las, path)


def stored_integers(column, origin: float, offset: float, scale: float, scratch: np.ndarray) -> np.ndarray:
    """The LAS integers of one axis, ``round((column + origin - offset) / scale)``, in
    ``scratch``: laspy's own formula (so the same integers), without its three temporaries
    the cloud's length a coordinate.

    Examples
    --------
    >>> stored_integers(np.array([0.12344, 2.0]), 500000.0, 500000.0, 1e-4, np.empty(2)).tolist()
    [1234.0, 20000.0]
    """
    np.add(column, origin, out=scratch)
    scratch -= offset
    scratch /= scale
    np.rint(scratch, out=scratch)
    if len(scratch) and not (-(2**31) <= scratch.min() and scratch.max() <= 2**31 - 1):
        raise OverflowError("Values given do not fit after applying offset and scale")
    return scratch


def _write(las, path) -> Path:
    """``las`` to ``path``, atomically. Compressed in memory first, then written by Python:
    an interrupt or a full disk inside lazrs's own writes came back as its "IoError", with a
    traceback, instead of as the KeyboardInterrupt or OSError the output folder answers."""
    import io

    buffer = io.BytesIO()
    las.write(buffer, do_compress=str(path).endswith(".laz"))
    with atomic_path(path) as tmp:
        tmp.write_bytes(buffer.getbuffer())
    return Path(path)


def write_regions_laz(result, path, point_set=None, face_part=None, point_joint=None) -> Path:
    """``regions.laz``: the filtered points with ``region_id`` and, given each point's set
    (``point_set``), ``set``, ``face_part``, each point's part of the face
    (:data:`~geostructure.rockmass.face.FACE`, ``GROUND`` or ``CLUTTER``; all ``FACE`` when
    ``face_part`` is None) and ``joint`` (``point_joint``; -1 for all when None)."""
    fields = {"region_id": np.asarray(result.labels, dtype=np.int32)}
    if point_set is not None:
        n = len(point_set)
        given = {"set": point_set, "face_part": face_part, "joint": point_joint}
        fallback = {"set": -1, "face_part": 0, "joint": -1}
        for name, kind in POINT_SET_DIMENSIONS:
            value = given[name]
            fields[name] = np.full(n, fallback[name], dtype=kind) if value is None else np.asarray(value, kind)
    cloud = result.cloud
    return write_laz(
        path,
        result.filtered.local,
        fields,
        offset=cloud.offset,
        crs=cloud.crs,
        grid=cloud.las_grid,
        origin=cloud.offset,
    )


def write_voxel_planes_laz(result, path) -> Path:
    """``voxel_planes.laz``: each fitted voxel's centroid with its normal, point count and
    region id, the LAS twin of ``voxel_planes.ply``."""
    voxels, cloud = result.voxels, result.cloud
    fields = {
        "nx": voxels.normal[:, 0].astype(np.float32),
        "ny": voxels.normal[:, 1].astype(np.float32),
        "nz": voxels.normal[:, 2].astype(np.float32),
        "count": np.asarray(voxels.count, dtype=np.int32),
        "region_id": np.asarray(result.voxel_labels, dtype=np.int32),
    }
    return write_laz(
        path, voxels.centroid, fields, offset=cloud.offset, crs=cloud.crs, grid=cloud.las_grid, origin=cloud.offset
    )


def add_point_sets(source, path, planes, face_part=None, rows: int = 1_000_000) -> Path:
    """Write ``source`` (a ``regions.laz``) again to ``path`` with ``set`` and ``joint``
    dimensions (each point's, through its region's row of ``planes``) and a ``face_part`` one
    (as :func:`write_regions_laz`), its points on the same integers, ``rows`` at a time."""
    face_part = None if face_part is None else np.asarray(face_part, dtype=np.uint8)

    def fields_of(chunk, start: int) -> dict:
        region = np.asarray(chunk.region_id)
        parts = np.zeros(len(region), np.uint8) if face_part is None else face_part[start : start + len(region)]
        return {"set": point_sets(region, planes), "face_part": parts, "joint": point_joints(region, planes)}

    return rewrite_point_sets(source, path, fields_of, rows)


class KeptWriteErrors:
    """A file for lazrs to write a LAZ through, chunk by chunk, that keeps what its writes
    raised. lazrs turns an error in a write (a full disk, a file size limit, an interrupt)
    into its own "IoError: Failed to call write", which would reach the user as a traceback;
    :meth:`reraise` gives the caller the OSError or KeyboardInterrupt back, which the output
    folder answers in a sentence (as :func:`_write` does for a file written at once)."""

    def __init__(self, path):
        self.file = open(path, "wb")  # closed by the caller, once laspy is done with it
        self.error: BaseException | None = None

    def write(self, data) -> int:
        try:
            return self.file.write(data)
        except BaseException as exc:
            self.error = exc
            raise

    def reraise(self, exc: BaseException) -> None:
        """Raise the write's own error where lazrs's stands for it; ``exc`` otherwise."""
        if self.error is not None and exc is not self.error:
            raise self.error from None
        raise exc

    def __getattr__(self, name):  # seek, tell, flush, close...: the file's own
        return getattr(self.file, name)


def rewrite_point_sets(source, path, fields_of, rows: int) -> Path:
    """Write ``source`` (a ``regions.laz``) again to ``path`` chunk by chunk (``rows`` points
    each), every point on the same integers with its ``region_id``, and the dimensions of
    :data:`POINT_SET_DIMENSIONS` from ``fields_of(chunk, start)`` (name -> array, for the
    chunk's points from the ``start``-th on). Never the whole file in memory."""
    import copy

    import laspy

    with laspy.open(str(source), laz_backend=laz_readers()) as reader:
        header = copy.deepcopy(reader.header)
        for name, kind in POINT_SET_DIMENSIONS:
            if name not in header.point_format.extra_dimension_names:
                header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=kind))
        dest = KeptWriteErrors(path)
        try:
            with laspy.open(dest, mode="w", header=header, do_compress=Path(path).suffix == ".laz") as writer:
                start = 0
                for chunk in reader.chunk_iterator(rows):
                    fields = fields_of(chunk, start)
                    record = laspy.ScaleAwarePointRecord.zeros(len(chunk), header=header)
                    record.X, record.Y, record.Z = chunk.X, chunk.Y, chunk.Z
                    record.region_id = chunk.region_id
                    for name, kind in POINT_SET_DIMENSIONS:
                        if len(fields[name]) != len(chunk):
                            raise ValueError(
                                f"{source}: {len(chunk)} points where its {name} gives {len(fields[name])}"
                            )
                        record[name] = np.asarray(fields[name], dtype=kind)
                    writer.write_points(record)
                    start += len(chunk)
        except BaseException as exc:
            dest.reraise(exc)
        finally:
            dest.file.close()
    return Path(path)
