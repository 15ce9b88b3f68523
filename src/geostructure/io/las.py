"""LAS and LAZ clouds (laspy): read whole or chunk by chunk, the points a survey marks
withheld or noise left out, vegetation and colour read per point, the CRS the header declares."""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from geostructure.core.cloud import MAX_COORDINATE, Cloud
from geostructure.errors import GeoStructureNote, InputError
from geostructure.io.checks import check_coordinate_step, check_step_once, las_step
from geostructure.io.crs import check_cloud_crs
from geostructure.io.failures import check_laz_chunks, laz_readers

#: Points read from a LAS/LAZ file at a time.
LAS_CHUNK = 2_000_000


#: LAS classes of the points a survey marks as noise: 7, low point (noise), and 18, high
#: noise (LAS 1.4). They are left out, as the withheld points are, which the LAS
#: specification says are to be treated as deleted.
NOISE_CLASSES = (7, 18)


def las_chunk_points(chunk) -> tuple[np.ndarray, np.ndarray]:
    """A laspy chunk's points (N, 3) float64, without those the file marks withheld or
    classifies as noise (:data:`NOISE_CLASSES`); and how many of each were left out (2,)."""
    # A damaged scale or offset (1e307) overflows laspy's scaling to infinity: the coordinate
    # checks refuse those points in a sentence, without numpy's raw warning first.
    with np.errstate(over="ignore", invalid="ignore"):
        points = np.column_stack([np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)])
    withheld = np.asarray(chunk.withheld, dtype=bool)
    noise = np.isin(np.asarray(chunk.classification), NOISE_CLASSES) & ~withheld
    left_out = np.array([np.count_nonzero(withheld), np.count_nonzero(noise)])
    return (points[~(withheld | noise)] if left_out.any() else points), left_out


#: LAS classes of vegetation (ASPRS: low, medium and high vegetation): clutter before a rock
#: face, kept and labelled as every point is, but no part of the face (:mod:`~geostructure.rockmass.face`).
VEGETATION_CLASSES = (3, 4, 5)


def las_chunk_vegetation(chunk) -> np.ndarray:
    """Whether each point :func:`las_chunk_points` keeps of a laspy chunk is classified as
    vegetation (:data:`VEGETATION_CLASSES`)."""
    classes = np.asarray(chunk.classification)
    kept = ~(np.asarray(chunk.withheld, dtype=bool) | np.isin(classes, NOISE_CLASSES))
    return np.isin(classes[kept], VEGETATION_CLASSES)


def las_chunk_grey(chunk) -> np.ndarray | None:
    """The brightness (:func:`~.io.text.grey_of`) of each point :func:`las_chunk_points`
    keeps of a laspy chunk, from its red, green and blue; None for a point format without them."""
    names = set(chunk.point_format.dimension_names)
    if not {"red", "green", "blue"} <= names:
        return None
    classes = np.asarray(chunk.classification)
    kept = ~(np.asarray(chunk.withheld, dtype=bool) | np.isin(classes, NOISE_CLASSES))
    rgb = np.column_stack([np.asarray(chunk.red), np.asarray(chunk.green), np.asarray(chunk.blue)])[kept]
    # LAS holds 16-bit colour; many writers put 8-bit values in it: scale by what the file holds
    return (rgb.mean(axis=1) / (65535.0 if rgb.size and rgb.max() > 255 else 255.0)).astype(np.float32)


def left_out_record(left_out) -> dict | None:
    """``run.json``'s record of the points left out (:func:`las_chunk_points`'s counts), or None."""
    record = {why: int(n) for why, n in zip(("withheld", "noise"), left_out) if n}
    return record or None


def merged_left_out(records) -> dict | None:
    """Several files' :func:`left_out_record` as one."""
    total: dict = {}
    for record in records:
        for why, n in (record or {}).items():
            total[why] = total.get(why, 0) + n
    return total or None


def note_left_out(path, kept: int, left_out) -> None:
    """Say which points of a LAS file were left out (:func:`las_chunk_points`), and refuse a
    file left with none; ``kept``: the points kept."""
    withheld, noise = (int(n) for n in left_out)
    if not withheld + noise:
        return
    parts = ", ".join(
        f"{n:,} {what}" for n, what in ((withheld, "withheld"), (noise, "noise (LAS classes 7 and 18)")) if n
    )
    if not kept:
        raise InputError(f"{path}: every point is marked withheld or noise ({parts}); none is left to measure.")
    warnings.warn(
        f"{path}: {withheld + noise:,} point(s) left out, as the file marks them: {parts}.",
        GeoStructureNote,
        stacklevel=2,
    )


class LasTally:
    """What reading a LAS/LAZ file chunk by chunk found (:func:`las_chunk_points`): the
    records read, the points kept and those left out; :meth:`finish` checks the header's
    count, says what was left out and gives ``run.json``'s record of it."""

    def __init__(self) -> None:
        self.read, self.kept, self.left_out = 0, 0, np.zeros(2, dtype=np.int64)

    def add(self, points: np.ndarray, left_out: np.ndarray) -> np.ndarray:
        """Count a chunk's kept ``points`` and ``left_out`` (as :func:`las_chunk_points`
        gives them); the points back."""
        self.read += len(points) + int(left_out.sum())
        self.kept += len(points)
        self.left_out += left_out
        return points

    def finish(self, path, expected: int) -> dict | None:
        if self.read < expected:
            raise InputError(f"{path}: the header promises {expected} points, the file holds {self.read}.")
        note_left_out(path, self.kept, self.left_out)
        return left_out_record(self.left_out)


@contextmanager
def open_las(path, *, points: bool = True):
    """laspy's reader of a LAS/LAZ file, opened once its header's counts are checked
    (:func:`check_las_header`: a damaged count had laspy read records until memory ran out);
    with ``points`` (to read them, not the header alone), its LAZ chunks are checked too
    (:func:`~.failures.check_laz_chunks`: lazrs aborts the process on a damaged one). Points
    are read by lazrs alone (:func:`~.failures.laz_readers`)."""
    import laspy

    check_las_header(path)
    with laspy.open(str(path), laz_backend=laz_readers()) as reader:
        if points:
            check_laz_chunks(path, reader.header)
        yield reader


def read_las(path: Path) -> Cloud:
    """LAS or LAZ (laspy with lazrs); scaled coordinates as float64; CRS kept when declared;
    points marked withheld or noise left out (:func:`las_chunk_points`); those classified as
    vegetation marked (``Cloud.vegetation``)."""
    with open_las(path) as reader:
        header = reader.header
        crs = las_crs(header, path)  # refused before the points are read
        expected = header.point_count
        # Chunks: memory follows the points actually in the file, not what a header claims.
        tally = LasTally()
        parts, vegetation, grey = [], [], []
        for chunk in reader.chunk_iterator(LAS_CHUNK):
            parts.append(tally.add(*las_chunk_points(chunk)))
            vegetation.append(las_chunk_vegetation(chunk))
            grey.append(las_chunk_grey(chunk))
    points = np.vstack(parts) if parts else np.empty((0, 3))
    vegetation = np.concatenate(vegetation) if vegetation else np.zeros(0, dtype=bool)
    grey = np.concatenate(grey) if grey and all(g is not None for g in grey) else None
    if grey is not None and not np.any(grey):  # a format with colour, none recorded
        grey = None
    left_out = tally.finish(path, expected)
    grid = (np.array(header.scales, dtype=np.float64), np.array(header.offsets, dtype=np.float64))
    check_coordinate_step(points, las_step(grid[0]), path)
    return Cloud.from_points(points, source=str(path), crs=crs, las_grid=grid, left_out=left_out,
                             vegetation=vegetation if vegetation.any() else None, grey=grey)  # fmt: skip


def check_las_header(path: Path) -> None:
    """Catch a header whose counts cannot be true before laspy loops over them (a flipped
    byte in the VLR count would have it read four billion records), and one with a scale of
    0 or not a number (every coordinate on that axis would read its offset, or NaN) or an
    offset that is not finite."""
    import struct

    with open(path, "rb") as fh:
        head = fh.read(179)
    if len(head) < 179 or head[:4] != b"LASF":
        raise InputError(f"{path}: not a LAS/LAZ file (no 'LASF' signature).")
    scales = struct.unpack_from("<3d", head, 131)
    # Past a scale of 100 (steps of 100 units, which no survey stores), its 32-bit integers reach MAX_COORDINATE.
    bad = next((axis for axis, scale in zip("xyz", scales) if not (np.isfinite(scale) and 0 < abs(scale) <= 100)), None)
    if bad is not None:
        raise InputError(
            f"{path}: the header is damaged: the {bad} scale is {scales['xyz'.index(bad)]:g}, where a LAS "
            f"file's coordinates are integers times a scale that is not 0 (nor past 100)."
        )
    offsets = struct.unpack_from("<3d", head, 155)
    bad = next((axis for axis, offset in zip("xyz", offsets) if not abs(offset) <= MAX_COORDINATE), None)
    if bad is not None:  # 1e308 overflowed every coordinate, with numpy's warnings beside the error
        raise InputError(
            f"{path}: the header is damaged: the {bad} offset is {offsets['xyz'.index(bad)]:g}, where a LAS "
            f"file's coordinates are integers times a scale plus an offset within {MAX_COORDINATE:.0e}."
        )
    header_size, point_offset, n_vlrs = struct.unpack_from("<HII", head, 94)
    size = path.stat().st_size
    if not header_size <= point_offset <= size or n_vlrs * 54 > point_offset - header_size:
        raise InputError(
            f"{path}: the header is damaged ({n_vlrs} variable-length records and point "
            f"data at byte {point_offset} in a file of {size} bytes)."
        )


def las_crs(header, path=None) -> str | None:
    """The CRS a LAS header declares (WKT, or ``EPSG:n`` from its GeoTIFF keys), or None;
    given the file's ``path``, a geographic one is refused (:func:`~.crs.check_cloud_crs`)."""
    crs = _declared_crs(header)
    if path is not None:
        check_cloud_crs(crs, str(path))
    return crs


def _declared_crs(header) -> str | None:
    for vlr in header.vlrs:
        text = getattr(vlr, "string", None)
        if isinstance(text, str) and text.strip().startswith(("PROJCS", "GEOGCS", "COMPD", "PROJCRS", "GEOGCRS")):
            return text.strip("\x00 ")
    for vlr in header.vlrs:
        for key in getattr(vlr, "geo_keys", []) or []:
            if key.id in (3072, 2048) and 0 < key.value_offset < 32767:  # projected / geographic EPSG
                return f"EPSG:{key.value_offset}"
    return None


def las_chunks(path: Path, rows: int, steps_checked: set):
    """A LAS/LAZ file's (points, normals, vegetation, grey, meta) chunks of ``rows`` records
    (laspy's chunked reader); ``meta`` carries a Cloud with its CRS and the file's grid."""
    with open_las(path) as reader:
        header = reader.header
        grid = (np.array(header.scales, dtype=np.float64), np.array(header.offsets, dtype=np.float64))
        meta = {"cloud": Cloud(np.zeros((0, 3)), crs=las_crs(header, path), source=str(path)), "grid": grid}
        tally = LasTally()
        for chunk in reader.chunk_iterator(rows):
            first = not tally.read
            points = tally.add(*las_chunk_points(chunk))
            if first:
                check_step_once(points, las_step(header.scales), path, steps_checked)
            yield points, None, las_chunk_vegetation(chunk), las_chunk_grey(chunk), meta
        meta["cloud"].left_out = tally.finish(path, header.point_count)
        if not tally.read:
            yield np.zeros((0, 3)), None, None, None, meta


def las_point_count(path: Path, mesh_samples=None) -> int:
    """The records a LAS/LAZ header declares."""
    with open_las(path, points=False) as reader:
        return int(reader.header.point_count)


def las_header_crs(path: Path) -> str | None:
    """The CRS a LAS/LAZ header declares, read without the points."""
    with open_las(path, points=False) as reader:
        return las_crs(reader.header)
