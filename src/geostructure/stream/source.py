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
from geostructure.io.checks import check_coordinates
from geostructure.io.failures import translated_read_errors
from geostructure.io.las import merged_left_out
from geostructure.io.readers import DEFAULT_MESH_SAMPLES, file_chunks
from geostructure.io.survey_files import check_headers, check_same_crs, describe
from geostructure.stream.spillstrays import without_spill_strays

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
    centre, as :meth:`~geostructure.core.cloud.Cloud.from_points` takes it) and what its files declared.

    Parameters
    ----------
    folder : Path
        The spill's folder: ``points.f8`` (absolute float64 coordinates, 24 bytes a point)
        and, where the files have them, normals, vegetation marks and grey levels.
    n_points : int
        The points spilled.
    lower, upper : ndarray
        The survey's bounds.
    source : str
        The files, in words.
    crs : str, optional
        The CRS the files declare.
    las_grid : tuple, optional
        The LAS scales and offsets the tiles share.
    has_normals, has_vegetation, has_grey : bool
        Whether every file had normals, some point is classified as vegetation, every point
        has a colour.
    left_out : dict, optional
        The points the files marked withheld or noise, left out.

    Examples
    --------
    >>> from geostructure.testing.examples import scene_laz
    >>> path = scene_laz(20_000)
    >>> spill = spill_inputs([path], rows=5_000)
    >>> spill.n_points, [(c.start, c.stop) for c in spill.chunks(8_000)]
    (20000, [(0, 8000), (8000, 16000), (16000, 20000)])
    >>> spill.close()
    """

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
    tiles must share a CRS (checked from the LAS headers before any is read).

    Parameters
    ----------
    paths : sequence of paths
        The survey's files.
    rows : int
        The most points read at a time.
    mesh_samples : int or None
        Points sampled on a PLY mesh's faces.
    progress : callable, optional
        ``progress("spill", done, total)``.
    folder : path, optional
        Where the spill's own folder is made (``--spill-dir``).

    Returns
    -------
    Spill
        Closed by :meth:`Spill.close`, which removes its folder.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import numpy as np
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "grid.xyz"
    >>> np.savetxt(path, np.c_[np.mgrid[0:10, 0:10].reshape(2, -1).T * 0.1, np.zeros(100)])
    >>> spill = spill_inputs([path], rows=40)
    >>> spill.n_points, spill.upper.round(2).tolist()
    (100, [0.9, 0.9, 0.0])
    >>> spill.close()"""
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
                    path, file_chunks(path, rows, mesh_samples, steps_checked)
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
        without_spill_strays(spill, rows)  # before anything reads the survey's extent
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
