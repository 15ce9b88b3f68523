"""The point-cloud formats, by extension: the one place a new reader is added.

Each :class:`Format` says how a file of it is read whole (a function returning a
:class:`~geostructure.core.cloud.Cloud`), how it is read chunk by chunk for a streamed survey
(or None: read whole, one file at a time), how many points its header declares (or None:
about so many bytes a point), whether the format declares its coordinates' step (checked as
it is read) and the CRS its header declares (tiles checked against each other before
any is read). :func:`read_cloud`, the stream (:func:`file_chunks`, :func:`estimate_points`)
and the tiles' checks (:mod:`geostructure.io.survey_files`) read this table.

Every reader turns a library's exception into a :class:`GeoStructureError` that names the
file and what is wrong, and checks the points are finite and numerous enough to measure.

Examples
--------
>>> format_of("survey.LAZ").name, format_of("scan.e57").chunks is None
('LAS', True)
>>> ", ".join(SUFFIXES)
'.ply, .las, .laz, .e57, .xyz, .txt, .csv, .pts, .asc'
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from geostructure.core.cloud import Cloud
from geostructure.core.duplicates import without_copies
from geostructure.errors import InputError
from geostructure.io.checks import check_coordinate_step, check_points, observed_step
from geostructure.io.e57 import read_e57
from geostructure.io.failures import translated_read_errors
from geostructure.io.las import las_chunks, las_header_crs, las_point_count, read_las
from geostructure.io.ply import (
    DEFAULT_MESH_SAMPLES,
    MAX_MESH_SAMPLES,
    ply_chunks,
    ply_has_faces,
    ply_point_count,
    read_ply,
)
from geostructure.io.text import read_text

__all__ = ["DEFAULT_MESH_SAMPLES", "FORMATS", "Format", "MAX_MESH_SAMPLES", "SUFFIXES", "read_cloud"]


@dataclass(frozen=True)
class Format:
    """One point-cloud format.

    Parameters
    ----------
    name : str
        Its name, in messages.
    suffixes : tuple of str
        Its extensions, lower case, with the dot.
    read : callable
        ``read(path, mesh_samples, seed) -> Cloud``: the whole file.
    chunks : callable or None
        ``chunks(path, rows, mesh_samples, steps_checked)``, yielding (points, normals,
        vegetation, grey, meta) chunks; None: read whole, then cut in chunks.
    point_count : callable or None
        ``point_count(path, mesh_samples) -> int`` from the header; None: from the size.
    bytes_per_point : int
        About how many bytes a point takes, for the estimate from the size.
    declares_step : bool
        Whether the format declares its coordinates' step, checked as it is read; else the
        step is read off the values.
    header_crs : callable or None
        ``header_crs(path) -> str or None``: the CRS its header declares, read without the
        points; None for a format that declares none.
    """

    name: str
    suffixes: tuple[str, ...]
    read: Callable[[Path, int | None, int], Cloud]
    chunks: Callable | None = None
    point_count: Callable[[Path, int | None], int] | None = None
    bytes_per_point: int = 30
    declares_step: bool = False
    header_crs: Callable[[Path], str | None] | None = None


def _ply_chunks_unless_mesh(path: Path, rows: int, mesh_samples, steps_checked: set):
    """A PLY cloud chunk by chunk; a mesh to sample, read whole."""
    if ply_has_faces(path, mesh_samples):
        yield from _whole_in_chunks(path, rows, mesh_samples)
    else:
        yield from ply_chunks(path, rows, steps_checked)


FORMATS: tuple[Format, ...] = (
    Format("PLY", (".ply",), lambda path, mesh_samples, seed: read_ply(path, mesh_samples=mesh_samples, seed=seed),
           chunks=_ply_chunks_unless_mesh, point_count=ply_point_count, declares_step=True),
    Format("LAS", (".las", ".laz"), lambda path, mesh_samples, seed: read_las(path),
           chunks=lambda path, rows, mesh_samples, steps_checked: las_chunks(path, rows, steps_checked),
           point_count=las_point_count, declares_step=True, header_crs=las_header_crs),
    Format("E57", (".e57",), lambda path, mesh_samples, seed: read_e57(path), bytes_per_point=24),
    Format("text", (".xyz", ".txt", ".csv", ".pts", ".asc"), lambda path, mesh_samples, seed: read_text(path)),
)  # fmt: skip
#: Every extension a cloud may have, in the table's order.
SUFFIXES = tuple(suffix for spec in FORMATS for suffix in spec.suffixes)
_BY_SUFFIX = {suffix: spec for spec in FORMATS for suffix in spec.suffixes}


def format_of(path) -> Format:
    """The format of ``path`` by its extension; an extension no format has is refused."""
    path = Path(path)
    try:
        return _BY_SUFFIX[path.suffix.lower()]
    except KeyError:
        raise InputError(f"{path}: unknown extension '{path.suffix}'; expected one of {', '.join(SUFFIXES)}.") from None


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
    spec = format_of(path)
    if not path.is_file():  # a FIFO, a device: reading it waits for a writer, or for ever
        raise InputError(f"{path}: is not a regular file (a pipe or a device); save the cloud to a file first.")
    if path.stat().st_size == 0:
        raise InputError(f"{path}: the file is empty.")
    with translated_read_errors(path):  # a library's parse error: the user's file is at fault
        cloud = spec.read(path, mesh_samples, seed)
    check_points(cloud.local, path, offset=cloud.offset)  # no absolute copy: 192 MB at 8M points
    if not spec.declares_step:  # the step a format declares is checked as it is read
        check_coordinate_step(cloud.local, observed_step(cloud.local), path)
    return without_copies(cloud, path)


def file_chunks(path: Path, rows: int, mesh_samples, steps_checked: set):
    """(points, normals, vegetation, grey, meta) chunks of one file (``vegetation``: a LAS/LAZ
    file's vegetation classes, :func:`~.io.las.las_chunk_vegetation`; ``grey``: each
    point's brightness where the file has colour, else None); ``meta`` carries
    a Cloud with its CRS and, for LAS/LAZ, the file's grid.

    A file whose coordinates are stored coarser than its points lie (32-bit floats far from
    the origin, a coarse LAS scale) is refused or warned of as in memory
    (:func:`~.checks.check_coordinate_step`), judged on its first chunk: the spacing a
    chunk reads is the file's where a chunk is a patch of it (a tile's points in their scan
    order) and reads wider, so errs towards measuring, where a chunk is thinned evenly. A
    step is judged once (``steps_checked``): a survey's tiles share it, and each judgement
    reads a spacing."""
    spec = format_of(path)
    if spec.chunks is None:
        yield from _whole_in_chunks(path, rows, mesh_samples)
    else:
        yield from spec.chunks(path, rows, mesh_samples, steps_checked)


def _whole_in_chunks(path: Path, rows: int, mesh_samples):
    """A file read whole (text, E57, a mesh to sample), cut in chunks of ``rows`` points."""
    cloud = read_cloud(path, mesh_samples=mesh_samples)
    points = cloud.points
    meta = {"cloud": cloud}
    for a in range(0, max(len(points), 1), rows):
        normals = None if cloud.normals is None else cloud.normals[a : a + rows]
        grey = None if cloud.grey is None else cloud.grey[a : a + rows]
        yield points[a : a + rows], normals, None, grey, meta


def estimate_points(paths, mesh_samples: int | None = DEFAULT_MESH_SAMPLES) -> int:
    """The points ``paths`` hold, from their headers (LAS/LAZ, PLY) or their size (about 30
    bytes a point of text, 24 of E57), without reading them: what decides the engine."""
    total = 0
    for path in (Path(p) for p in paths):
        spec = format_of(path)
        if spec.point_count is not None:
            try:
                total += spec.point_count(path, mesh_samples)
                continue
            except Exception:  # a damaged header: the reader says what is wrong with it
                pass
        total += path.stat().st_size // spec.bytes_per_point
    return total
