"""Readers: one function per format, each returning a :class:`~geostructure.core.cloud.Cloud`.

Every reader turns a library's exception into a :class:`GeoStructureError` that names the
file and what is wrong, and checks the points are finite and numerous enough to measure.
"""

from __future__ import annotations

import re
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from geostructure.core.cloud import MAX_COORDINATE, Cloud
from geostructure.core.duplicates import without_copies
from geostructure.errors import GeoStructureNote, InputError, ParameterError
from geostructure.io.checks import (
    check_coordinate_step,
    check_coordinates,
    check_points,
    las_step,
    observed_step,
    ply_step,
)
from geostructure.io.crs import check_cloud_crs
from geostructure.io.failures import check_laz_chunks, laz_readers, translated_read_errors
from geostructure.io.text import grey_of, read_text

TEXT_SUFFIXES = (".xyz", ".txt", ".csv", ".pts", ".asc")
SUFFIXES = (".ply", ".las", ".laz", ".e57") + TEXT_SUFFIXES

#: Points read from a LAS/LAZ file at a time.
LAS_CHUNK = 2_000_000
#: Points sampled on a mesh's faces when a PLY carries triangles (see :func:`sample_mesh`).
DEFAULT_MESH_SAMPLES = 200_000
#: The most points sampled on a mesh: 100 million samples already take 4.8 GB with their normals,
#: more than a mesh's own vertices ever justify.
MAX_MESH_SAMPLES = 100_000_000


def read_cloud(path, *, mesh_samples: int | None = DEFAULT_MESH_SAMPLES, seed: int = 0) -> Cloud:
    """Read a point cloud from PLY, LAS/LAZ, E57 or text (XYZ/TXT/CSV).

    Parameters
    ----------
    path : str or Path
        The file; its extension picks the reader.
    mesh_samples : int or None
        For a PLY with faces (a Poisson surface, say): how many points to sample on the
        faces, area-weighted, as the paper samples its surface back to points. ``None``
        keeps only the vertices.
    seed : int
        Seed of the mesh sampling, so a run is repeatable.

    Returns
    -------
    Cloud

    Examples
    --------
    >>> cloud = read_cloud("outcrop.laz")  # doctest: +SKIP
    >>> cloud.points.shape  # doctest: +SKIP
    (110000, 3)
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file.")
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a point-cloud file.")
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise InputError(f"{path}: unknown extension '{path.suffix}'; expected one of {', '.join(SUFFIXES)}.")
    if not path.is_file():  # a FIFO, a device: reading it waits for a writer, or for ever
        raise InputError(f"{path}: is not a regular file (a pipe or a device); save the cloud to a file first.")
    if path.stat().st_size == 0:
        raise InputError(f"{path}: the file is empty.")
    with translated_read_errors(path):  # a library's parse error: the user's file is at fault
        if suffix == ".ply":
            cloud = read_ply(path, mesh_samples=mesh_samples, seed=seed)
        elif suffix in (".las", ".laz"):
            cloud = read_las(path)
        elif suffix == ".e57":
            cloud = read_e57(path)
        else:
            cloud = read_text(path)
    check_points(cloud.local, path, offset=cloud.offset)  # no absolute copy: 192 MB at 8M points
    if suffix not in (".ply", ".las", ".laz"):  # the step those formats declare is checked as they are read
        check_coordinate_step(cloud.local, observed_step(cloud.local), path)
    return without_copies(cloud, path)


def read_ply(path: Path, *, mesh_samples: int | None = DEFAULT_MESH_SAMPLES, seed: int = 0) -> Cloud:
    """PLY, ASCII or binary, float or double; red, green and blue give each point's ``grey``;
    other vertex properties are ignored."""
    if mesh_samples is not None and not 0 <= mesh_samples <= MAX_MESH_SAMPLES:
        raise ParameterError(f"mesh samples must lie between 0 and {MAX_MESH_SAMPLES:,}, not {mesh_samples}.")
    data, vertex = ply_vertices(path)
    names = vertex.dtype.names
    points = vertex_columns(vertex, "xyz")
    check_coordinates(points, path)  # first: random bytes' NaN gave numpy's warnings in the step's check
    check_coordinate_step(points, ply_step(points, vertex.dtype), path)
    normals = None
    if all(n in names for n in ("nx", "ny", "nz")):
        normals = np.array(vertex_columns(vertex, ("nx", "ny", "nz")))
    grey = None
    colour = next((c for c in (("red", "green", "blue"), ("diffuse_red", "diffuse_green", "diffuse_blue"))
                   if all(n in names for n in c)), None)  # fmt: skip
    if colour is not None:
        grey = grey_of(vertex_columns(vertex, colour))
    faces = _ply_faces(data, len(points), path)
    if mesh_samples and faces is not None and len(faces):
        grey = None  # samples on the faces carry no colour
        check_points(points, path)
        with np.errstate(all="ignore"):  # coordinates near float64's limit overflow: said below
            try:
                points, normals = sample_mesh(points, faces, mesh_samples, seed=seed)
            except OverflowError:
                raise InputError(f"{path}: the mesh's coordinates are too large to sample its faces.") from None
    return Cloud.from_points(points, source=str(path), normals=normals, grey=grey)


def vertex_columns(vertex: np.ndarray, names) -> np.ndarray:
    """Three properties of PLY vertex records as an (N, 3) float64 array: a view of the
    memory-mapped file where they are native doubles side by side (a file of x, y and z
    only: no copy, where stacking the columns took 0.1 s at 8M points), a copy otherwise.

    Examples
    --------
    >>> v = np.zeros(2, dtype=[("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("id", "<i4")])
    >>> v["y"] = [1.0, 2.0]
    >>> vertex_columns(v, "xyz").tolist(), np.shares_memory(vertex_columns(v, "xyz"), v)
    ([[0.0, 1.0, 0.0], [0.0, 2.0, 0.0]], True)
    """
    from numpy.lib.recfunctions import structured_to_unstructured  # lazy: numpy's own, PLY only

    # A damaged file's NaN and infinities are refused by the checks that follow, in words;
    # numpy's cast would only have warned of them first.
    with np.errstate(invalid="ignore", over="ignore"):
        return structured_to_unstructured(vertex[list(names)], dtype=np.float64, copy=False)


def ply_vertices(path: Path):
    """A PLY file's data and its vertex records (x, y and z checked present), memory-mapped
    read-only: a binary vertex block is read at the disk's speed (plyfile without a map reads
    it row by row, 30 times slower), and the file cannot be written."""
    from plyfile import PlyData

    check_ply_size(path)
    data = PlyData.read(str(path), mmap="r")
    if "vertex" not in data:
        raise InputError(f"{path}: has no 'vertex' element.")
    vertex = data["vertex"].data
    missing = [axis for axis in "xyz" if axis not in (vertex.dtype.names or ())]
    if missing:
        present = ", ".join(vertex.dtype.names or ()) or "none"
        raise InputError(f"{path}: vertex has no '{missing[0]}' property (it has: {present}).")
    return data, vertex


def check_ply_size(path: Path) -> None:
    """Refuse a PLY whose header promises more rows than the file can hold, before plyfile
    allocates for them: binary rows need their fixed-size properties' bytes (a list at least
    its count), ASCII rows two bytes a property (a digit and a separator). A header claiming
    10^9 faces ran to the memory cap; 3e8 reached 2.4 GB."""
    with open(path, "rb") as fh:
        head = fh.read(65536)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        raise InputError(f"{path}: not a PLY file (no 'ply' magic line or no 'end_header').")
    header = head[:end].decode("ascii", errors="replace")
    fmt = re.search(r"^format\s+(\S+)", header, re.M)
    ascii_rows = not fmt or fmt.group(1) == "ascii"
    elements = []  # [name, count, least bytes a row]
    for line in header.splitlines():
        parts = line.split()
        if parts[:1] == ["element"] and len(parts) >= 3:
            try:
                elements.append([parts[1], int(parts[2]), 0])
            except ValueError:
                raise InputError(f"{path}: not a PLY file (element {parts[1]}'s count '{parts[2]}').") from None
        elif parts[:1] == ["property"] and elements:
            if ascii_rows:
                elements[-1][2] += 2
            elif parts[1:2] == ["list"]:
                elements[-1][2] += PLY_SIZES.get(parts[2], 1) if len(parts) > 2 else 1
            else:
                elements[-1][2] += PLY_SIZES.get(parts[1], 0) if len(parts) > 1 else 0
    body = path.stat().st_size - (end + len(b"end_header\n"))
    need = sum(count * least for _, count, least in elements)
    if any(count < 0 for _, count, _ in elements) or body < need:
        claims = ", ".join(f"{count:,} {name}" for name, count, _ in elements)
        raise InputError(
            f"{path}: truncated or damaged: its header promises {claims}, at least {need:,} bytes, and the file "
            f"holds {max(body, 0):,}."
        )


#: Bytes of each PLY property type.
PLY_SIZES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8,
}  # fmt: skip


def _ply_faces(data, n_vertices: int, path) -> np.ndarray | None:
    if "face" not in data or data["face"].count == 0:
        return None
    face = data["face"].data
    key = next((k for k in ("vertex_indices", "vertex_index") if k in face.dtype.names), None)
    if key is None:
        return None
    lists = face[key]
    lengths = np.fromiter((len(f) for f in lists), dtype=np.int64, count=len(lists))
    # Polygons of n corners as fans of n - 2 triangles from their first corner (a quad mesh's
    # faces were all dropped, and the mesh measured on its vertices alone).
    tris = [np.empty((0, 3), np.int64)]
    for n in np.unique(lengths[lengths >= 3]):
        corners = np.array([f for f, m in zip(lists, lengths) if m == n], dtype=np.int64).reshape(-1, n)
        tris += [corners[:, [0, i, i + 1]] for i in range(1, n - 1)]
    tris = np.vstack(tris)
    if len(tris) and (tris.min() < 0 or tris.max() >= n_vertices):
        raise InputError(f"{path}: a face refers to a vertex that does not exist.")
    return tris


def sample_mesh(vertices: np.ndarray, faces: np.ndarray, n: int, *, seed: int = 0):
    """Sample ``n`` points uniformly over a triangle mesh; returns points and face normals.

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    >>> p, nrm = sample_mesh(v, np.array([[0, 1, 2]]), 100)
    >>> bool(np.allclose(p[:, 2], 0)), nrm[0].tolist()
    (True, [0.0, 0.0, 1.0])
    """
    rng = np.random.default_rng(seed)
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    cross = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    if not np.isfinite(area.sum()):
        raise OverflowError("a face's area is not a finite number")
    if area.sum() <= 0:
        return vertices, None
    chosen = rng.choice(len(faces), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    flip = r1 + r2 > 1  # fold the unit square onto the triangle
    r1[flip], r2[flip] = 1 - r1[flip], 1 - r2[flip]
    points = a[chosen] + r1[:, None] * (b - a)[chosen] + r2[:, None] * (c - a)[chosen]
    normals = cross[chosen] / np.maximum(2 * area[chosen], 1e-300)[:, None]
    return points, normals


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


def read_e57(path: Path) -> Cloud:
    """E57 (pye57): all scans, each moved by its pose into the file's common frame."""
    import pye57

    e57 = pye57.E57(str(path))
    claimed = sum(int(e57.get_header(i).point_count) for i in range(e57.scan_count))
    if claimed > 8 * path.stat().st_size:  # a point's coordinates take a bit at the least, packed
        raise InputError(
            f"{path}: its scans claim {claimed:,} points, more than its {path.stat().st_size:,} bytes can hold; "
            f"the file is damaged."
        )
    parts = []
    for i in range(e57.scan_count):
        scan = e57.read_scan(i, ignore_missing_fields=True, transform=True)
        parts.append(np.column_stack([scan["cartesianX"], scan["cartesianY"], scan["cartesianZ"]]))
    points = np.vstack(parts) if parts else np.empty((0, 3))
    return Cloud.from_points(points.astype(np.float64), source=str(path))
