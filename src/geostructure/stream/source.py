"""A streamed survey's points: read once from its files, chunk by chunk, into a spill file
that every later pass reads back in chunks.

A LAS/LAZ tile is read with laspy's chunked reader and a binary PLY through a memory map,
so neither is ever held whole; a text or E57 file, or a PLY mesh to be sampled, is read
whole, one file at a time. The absolute float64 coordinates go to a raw file in a
temporary folder (24 bytes a point, normals 24 more when every file has them): the
passes after the first read it at the disk's speed, where decoding LAZ again would cost
several times that, and a Dask worker on the same machine or a shared disk reads it too.
"""

from __future__ import annotations

import errno
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.cloud import Cloud
from geostructure.errors import InputError
from geostructure.io.checks import check_coordinate_step, check_coordinates, las_step, ply_step
from geostructure.io.failures import translated_read_errors
from geostructure.io.readers import (
    DEFAULT_MESH_SAMPLES,
    LasTally,
    las_chunk_grey,
    las_chunk_points,
    las_chunk_vegetation,
    las_crs,
    merged_left_out,
    open_las,
    ply_vertices,
    read_cloud,
)
from geostructure.io.text import grey_of
from geostructure.io.tiles import check_headers, check_same_crs, describe

#: Bytes of one point in the spill file (x, y, z as float64).
POINT_BYTES = 24


@dataclass(frozen=True)
class Chunk:
    """Rows ``start`` to ``stop`` of a spill file: what one task of a pass reads."""

    path: str
    start: int
    stop: int
    normals_path: str | None = None

    def __len__(self) -> int:
        return self.stop - self.start

    def points(self) -> np.ndarray:
        """The chunk's absolute coordinates (n, 3) float64."""
        return _read_rows(self.path, self.start, self.stop)

    def normals(self) -> np.ndarray | None:
        return None if self.normals_path is None else _read_rows(self.normals_path, self.start, self.stop)


def _read_rows(path: str, start: int, stop: int) -> np.ndarray:
    values = np.fromfile(path, dtype="<f8", count=3 * (stop - start), offset=start * POINT_BYTES)
    return values.reshape(-1, 3)


@dataclass
class Spill:
    """The survey spilled to disk: its point count, bounds, offset (the bounding box's rounded
    centre, as :meth:`~geostructure.core.cloud.Cloud.from_points` takes it) and what its files declared."""

    folder: Path
    n_points: int
    lower: np.ndarray
    upper: np.ndarray
    source: str
    crs: str | None = None
    las_grid: tuple | None = None
    has_normals: bool = False
    left_out: dict | None = None
    has_vegetation: bool = False  # some point is classified as vegetation (LAS classes 3 to 5)
    has_grey: bool = False  # every point has a colour (its brightness in grey.f4)

    @property
    def points_path(self) -> str:
        return str(self.folder / "points.f8")

    @property
    def normals_path(self) -> str | None:
        return str(self.folder / "normals.f8") if self.has_normals else None

    @property
    def vegetation_path(self) -> str | None:
        """One byte a point, 1 where its file classifies it as vegetation; None if none is."""
        return str(self.folder / "vegetation.u1") if self.has_vegetation else None

    @property
    def grey_path(self) -> str | None:
        """One float32 a point, its brightness (0 to 1); None unless every file has colour."""
        return str(self.folder / "grey.f4") if self.has_grey else None

    @property
    def offset(self) -> np.ndarray:
        return np.round((self.lower + self.upper) / 2, 0) + 0.0

    def cloud(self) -> Cloud:
        """A Cloud with no points that carries the survey's offset, CRS and LAS grid, for the
        writers and ``run.json``; its ``vegetation`` is empty, not None, when some point of
        the survey is classified as vegetation."""
        return Cloud(
            np.zeros((0, 3)),
            self.offset,
            crs=self.crs,
            source=self.source,
            las_grid=self.las_grid,
            left_out=self.left_out,
            vegetation=np.zeros(0, dtype=bool) if self.has_vegetation else None,
        )

    def chunks(self, rows: int) -> list[Chunk]:
        """The spill cut into chunks of at most ``rows`` points."""
        edges = list(range(0, self.n_points, max(1, int(rows)))) + [self.n_points]
        return [Chunk(self.points_path, a, b, self.normals_path) for a, b in zip(edges[:-1], edges[1:])]

    def close(self) -> None:
        import shutil

        for name in ("points.f8", "normals.f8", "vegetation.u1", "grey.f4", "labels.i4", "keep.u1", "facets.i4"):
            (self.folder / name).unlink(missing_ok=True)
        shutil.rmtree(self.folder / "tiles", ignore_errors=True)  # the facet tiles' files
        try:
            self.folder.rmdir()
        except OSError:
            pass


#: A spill folder's name: this prefix, the process's id, a dash, a random part.
SPILL_PREFIX = "geostructure-stream-"
#: The Dask workers' scratch folder's name, made as a spill folder's is.
DASK_SCRATCH_PREFIX = "geostructure-dask-"


def remove_stale_spills(folder=None, prefix: str = SPILL_PREFIX) -> list[Path]:
    """Remove the spill folders (or, with ``prefix`` :data:`DASK_SCRATCH_PREFIX`, the Dask
    workers' scratch folders) in ``folder`` (the temporary folder by default) whose process
    is gone: a run killed outright (SIGKILL, a power cut) cannot remove its own, which holds
    24 bytes or more a point of its survey. Returns what was removed."""
    import shutil

    removed = []
    for path in Path(folder or tempfile.gettempdir()).glob(f"{prefix}*-*"):
        pid = path.name[len(prefix) :].split("-")[0]
        if not pid.isdigit() or not path.is_dir():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
        except OSError:  # another user's live process
            continue
    return removed


def spill_inputs(paths, rows: int, *, mesh_samples: int | None = DEFAULT_MESH_SAMPLES, progress=None, folder=None):
    """Read ``paths`` chunk by chunk (at most ``rows`` points at a time for LAS/LAZ and PLY
    vertices) into a :class:`Spill` in ``folder`` (a new temporary folder by default).

    Every file is checked as the in-memory readers check it (:func:`~.io.checks.check_points`);
    tiles must share a CRS (checked from the LAS headers before any is read)."""
    paths = [Path(p) for p in paths]
    check_headers(paths)
    report = progress or (lambda stage, done, total: None)
    remove_stale_spills(folder)
    given_folder = folder
    folder = Path(tempfile.mkdtemp(prefix=f"{SPILL_PREFIX}{os.getpid()}-", dir=folder))
    spill = Spill(folder, 0, np.full(3, np.inf), np.full(3, -np.inf), describe(paths))
    grids, left_outs, first, steps_checked = [], [], None, set()
    try:
        with (
            open(spill.folder / "points.f8", "wb") as out,
            open(spill.folder / "normals.f8", "wb") as out_n,
            open(spill.folder / "vegetation.u1", "wb") as out_v,
            open(spill.folder / "grey.f4", "wb") as out_g,
        ):
            all_normals = all_grey = True
            for i, path in enumerate(paths):
                start = spill.n_points
                for points, normals, vegetation, grey, meta in _read_errors_told(
                    path, _file_chunks(path, rows, mesh_samples, steps_checked)
                ):
                    check_coordinates(points, path, spill.n_points - start)
                    points.astype("<f8", copy=False).tofile(out)
                    if vegetation is not None and vegetation.any() and not spill.has_vegetation:
                        _write_zeros(out_v, spill.n_points)  # the marks start with the first vegetation
                        spill.has_vegetation = True
                    if spill.has_vegetation:
                        flags = np.zeros(len(points), np.uint8) if vegetation is None else vegetation.astype(np.uint8)
                        flags.tofile(out_v)
                    all_normals = all_normals and normals is not None
                    if all_normals:
                        normals.astype("<f8", copy=False).tofile(out_n)
                    all_grey = all_grey and grey is not None  # the traces' dark lines need every point's
                    if all_grey:
                        np.asarray(grey, dtype="<f4").tofile(out_g)
                    spill.n_points += len(points)
                    if len(points):
                        spill.lower = np.minimum(spill.lower, column_min(points))
                        spill.upper = np.maximum(spill.upper, column_max(points))
                if spill.n_points - start < 3:
                    held = spill.n_points - start
                    raise InputError(
                        f"{path}: holds no points."
                        if not held
                        else f"{path}: holds {held} point(s); a plane needs at least 3."
                    )
                if first is None:
                    first = (meta["cloud"], path)
                else:
                    check_same_crs(first[0], meta["cloud"], first[1], path)
                grids.append(meta.get("grid"))
                left_outs.append(meta["cloud"].left_out)
                report("read", i + 1, len(paths))
        spill.has_normals = all_normals and spill.n_points > 0
        spill.has_grey = all_grey and spill.n_points > 0
        if not spill.has_grey:
            os.unlink(spill.folder / "grey.f4")
        spill.left_out = merged_left_out(left_outs)
        spill.crs = first[0].crs if first else None
        same = all(g is not None for g in grids) and all(
            np.array_equal(g[0], grids[0][0]) and np.array_equal(g[1], grids[0][1]) for g in grids
        )
        spill.las_grid = grids[0] if same and grids else None
        if not spill.has_normals:
            os.unlink(spill.folder / "normals.f8")
        if not spill.has_vegetation:
            os.unlink(spill.folder / "vegetation.u1")
    except OSError as exc:
        spill.close()
        if exc.errno not in SPILL_FULL:
            raise
        # the spill's folder, not the output folder, ran out: a full --spill-dir was told as
        # "out: cannot write the outputs"
        where = f"--spill-dir {folder.parent}" if given_folder is not None else f"the temporary folder {folder.parent}"
        raise InputError(
            f"{where}: cannot hold the survey's spill ({exc.strerror}, about {24 * max(spill.n_points, 1):,} bytes "
            f"written); free space there or give --spill-dir a larger disk."
        ) from None
    except BaseException:
        spill.close()
        raise
    return spill


#: The errors of a disk that cannot take more (full, over quota, a file too large, read-only).
SPILL_FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS})


def _write_zeros(out, n: int, block: int = 1 << 24) -> None:
    """``n`` zero bytes to ``out``, a block at a time."""
    for a in range(0, n, block):
        np.zeros(min(block, n - a), dtype=np.uint8).tofile(out)


def _read_errors_told(path: Path, chunks):
    """The ``chunks`` of a file, a library's failure to read it (a damaged LAZ mid-file, a
    PLY cut short) told as in memory (:func:`~.io.failures.translated_read_errors`). Only
    the reading: what the caller does with a chunk (writing the spill: a full disk) is its own."""
    while True:
        with translated_read_errors(path):
            try:
                chunk = next(chunks)
            except StopIteration:
                return
        yield chunk


def _file_chunks(path: Path, rows: int, mesh_samples, steps_checked: set):
    """(points, normals, vegetation, grey, meta) chunks of one file (``vegetation``: a LAS/LAZ
    file's vegetation classes, :func:`~.io.readers.las_chunk_vegetation`; ``grey``: each
    point's brightness where the file has colour, else None); ``meta`` carries
    a Cloud with its CRS and, for LAS/LAZ, the file's grid.

    A file whose coordinates are stored coarser than its points lie (32-bit floats far from
    the origin, a coarse LAS scale) is refused or warned of as in memory
    (:func:`~.io.checks.check_coordinate_step`), judged on its first chunk: the spacing a
    chunk reads is the file's where a chunk is a patch of it (a tile's points in their scan
    order) and reads wider, so errs towards measuring, where a chunk is thinned evenly. A
    step is judged once (``steps_checked``): a survey's tiles share it, and each judgement
    reads a spacing."""
    suffix = path.suffix.lower()
    if suffix in (".las", ".laz"):
        yield from _las_chunks(path, rows, steps_checked)
    elif suffix == ".ply" and not _ply_has_faces(path, mesh_samples):
        yield from _ply_chunks(path, rows, steps_checked)
    else:  # text, E57, a mesh to sample: read whole (one file at a time)
        cloud = read_cloud(path, mesh_samples=mesh_samples)
        points = cloud.points
        meta = {"cloud": cloud}
        for a in range(0, max(len(points), 1), rows):
            normals = None if cloud.normals is None else cloud.normals[a : a + rows]
            grey = None if cloud.grey is None else cloud.grey[a : a + rows]
            yield points[a : a + rows], normals, None, grey, meta


def _check_step(points: np.ndarray, step: tuple[float, str] | None, path: Path, steps_checked: set) -> None:
    """:func:`~.io.checks.check_coordinate_step` on a file's first chunk, unless an earlier
    file stored its coordinates in the same step."""
    if step is not None and step[0] not in steps_checked:
        check_coordinate_step(points, step, path)
        steps_checked.add(step[0])


def _las_chunks(path: Path, rows: int, steps_checked: set):
    with open_las(path) as reader:
        header = reader.header
        grid = (np.array(header.scales, dtype=np.float64), np.array(header.offsets, dtype=np.float64))
        meta = {"cloud": Cloud(np.zeros((0, 3)), crs=las_crs(header, path), source=str(path)), "grid": grid}
        tally = LasTally()
        for chunk in reader.chunk_iterator(rows):
            first = not tally.read
            points = tally.add(*las_chunk_points(chunk))
            if first:
                _check_step(points, las_step(header.scales), path, steps_checked)
            yield points, None, las_chunk_vegetation(chunk), las_chunk_grey(chunk), meta
        meta["cloud"].left_out = tally.finish(path, header.point_count)
        if not tally.read:
            yield np.zeros((0, 3)), None, None, None, meta


def _ply_has_faces(path: Path, mesh_samples) -> bool:
    from plyfile import PlyData

    if not mesh_samples:
        return False
    try:
        header = PlyData.read(str(path), mmap="r")
    except Exception:  # read_cloud says what is wrong with it
        return True
    return "face" in header and len(header["face"].data) > 0


def _ply_chunks(path: Path, rows: int, steps_checked: set):
    _, vertex = ply_vertices(path)
    names = vertex.dtype.names
    has_normals = all(n in names for n in ("nx", "ny", "nz"))
    colour = next((c for c in (("red", "green", "blue"), ("diffuse_red", "diffuse_green", "diffuse_blue"))
                   if all(n in names for n in c)), None)  # fmt: skip
    meta = {"cloud": Cloud(np.zeros((0, 3)), source=str(path))}
    for a in range(0, max(len(vertex), 1), rows):
        part = vertex[a : a + rows]
        points = np.column_stack([np.asarray(part[c], dtype=np.float64) for c in "xyz"])
        if not a:
            _check_step(points, ply_step(points, vertex.dtype), path, steps_checked)
        normals = (
            np.column_stack([np.asarray(part[c], dtype=np.float64) for c in ("nx", "ny", "nz")])
            if has_normals
            else None
        )
        grey = None if colour is None else grey_of(np.column_stack([np.asarray(part[c]) for c in colour]))
        yield points, normals, None, grey, meta


def estimate_points(paths, mesh_samples: int | None = DEFAULT_MESH_SAMPLES) -> int:
    """The points ``paths`` hold, from their headers (LAS/LAZ, PLY) or their size (about 30
    bytes a point of text, 24 of E57), without reading them: what decides the engine."""
    total = 0
    for path in (Path(p) for p in paths):
        suffix = path.suffix.lower()
        try:
            if suffix in (".las", ".laz"):
                with open_las(path, points=False) as reader:
                    total += int(reader.header.point_count)
                continue
            if suffix == ".ply":
                total += _ply_points(path, mesh_samples)
                continue
        except Exception:  # a damaged header: the reader says what is wrong with it
            pass
        total += path.stat().st_size // (24 if suffix == ".e57" else 30)
    return total


def _ply_points(path: Path, mesh_samples) -> int:
    import re

    with open(path, "rb") as fh:
        head = fh.read(65536).decode("ascii", errors="replace")
    vertices = re.search(r"^element\s+vertex\s+(\d+)", head, re.M)
    faces = re.search(r"^element\s+face\s+(\d+)", head, re.M)
    if faces and int(faces.group(1)) and mesh_samples:
        return int(mesh_samples)
    return int(vertices.group(1)) if vertices else path.stat().st_size // 30
