"""A survey in many files: tiles given one by one, as a folder, or as a glob pattern.

A LiDAR survey comes as tiles (LAS/LAZ, often hundreds). ``geostructure measure`` takes
them as one cloud: every file named, every point-cloud file of a folder, or every match of a
pattern the shell left unexpanded (``'tiles/*.laz'``). All of them are checked before any is
read: each must exist and have a known extension, and they must agree on their coordinate
system. They are then read one after another and measured as one cloud, in memory, so a
plane that crosses tile borders is one plane.
"""

from __future__ import annotations

import glob
import warnings
from pathlib import Path

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.cloud import Cloud
from geostructure.core.duplicates import without_copies
from geostructure.errors import GeoStructureError, GeoStructureNote, InputError
from geostructure.io.crs import check_cloud_crs, parse_crs
from geostructure.io.las import merged_left_out
from geostructure.io.readers import DEFAULT_MESH_SAMPLES, SUFFIXES, format_of, read_cloud
from geostructure.io.text import holds_rows_of_numbers

#: Files named in a message before it says how many more there are.
NAMED_FILES = 3
#: Tiles of one survey touch: two files whose bounding boxes, each grown by this share of
#: its own diagonal, do not overlap lie apart (two sites, or a cloud in another frame).
TOUCH_SHARE = 0.05


def expand_inputs(specs) -> list[Path]:
    """The files that ``specs`` (paths, folders or glob patterns) name, in order, each once.

    A folder gives its point-cloud files (by extension; text files only where they hold rows
    of numbers, so that its notes are passed over), sorted; a pattern its matches,
    sorted. Refused, in one sentence naming it: a folder with no point-cloud file, a pattern
    that matches none, a file that does not exist.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("b.laz", "a.laz", "notes.txt.bak"):
    ...     _ = (folder / name).write_bytes(b"x")
    >>> _ = (folder / "README.txt").write_text("Tiles of the 2024 survey.")
    >>> [p.name for p in expand_inputs([folder])]
    ['a.laz', 'b.laz']
    """
    paths: list[Path] = []
    for spec in specs:
        spec = Path(spec)
        if spec.is_dir():
            found = sorted(p for p in spec.iterdir() if p.is_file() and _is_point_file(p))
            if not found:
                raise InputError(f"{spec}: the folder holds no point-cloud file ({', '.join(SUFFIXES)}).")
        elif not spec.exists() and glob.has_magic(str(spec)):
            found = sorted(Path(p) for p in glob.glob(str(spec)) if Path(p).is_file())
            if not found:
                raise InputError(f"{spec}: the pattern matches no file.")
        else:
            found = [spec]
        paths.extend(p for p in found if p not in paths)
    for path in paths:
        if not path.exists():
            raise InputError(f"{path}: no such file.")
        if not path.is_file():  # a FIFO, a device: reading it waits for a writer, or for ever
            raise InputError(f"{path}: is not a regular file (a pipe or a device); save the cloud to a file first.")
        format_of(path)  # an extension no format has is refused
    return paths


def _is_point_file(path: Path) -> bool:
    """A folder's file to read: a point-cloud extension, unless it is a note (a folder's
    PROVENANCE.txt or README.txt shares the extension of an XYZ cloud), passed over with a
    word. A tile that is empty, unreadable or damaged is read, and so refused by name: it
    was passed over as a note, and the survey measured without it, with no word."""
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        return False
    if suffix in NOTE_SUFFIXES and is_note(path):
        warnings.warn(GeoStructureNote(f"{path}: passed over, a note (words, not rows of numbers), not a point cloud."))
        return False
    return True


#: The extensions a folder's notes share with clouds: a file named ``.xyz`` is a tile, whatever it holds.
NOTE_SUFFIXES = (".txt",)
#: Bytes of a text file read to tell a note from a cloud.
NOTE_PROBE = 4096


def is_note(path: Path) -> bool:
    """Whether a text file is prose (a README, a provenance note): it reads as UTF-8, its
    first data line is no row of numbers, and most of its first characters are letters. An
    empty file, one that cannot be read or random bytes are no note.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "README.txt").write_text("Survey of 3 June, 2 stations.\\nSee the report.\\n")
    >>> _ = (folder / "tile.txt").write_text("1.5 2.0 3.25\\n")
    >>> _ = (folder / "noise.txt").write_bytes(bytes(range(256)) * 4)
    >>> _ = (folder / "empty.txt").write_bytes(b"")
    >>> [is_note(folder / n) for n in ("README.txt", "tile.txt", "noise.txt", "empty.txt")]
    [True, False, False, False]
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(NOTE_PROBE)
    except OSError:
        return False
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        return False
    visible = [c for c in text if not c.isspace()]
    if not visible or "\x00" in text or holds_rows_of_numbers(path):
        return False
    return sum(c.isalpha() for c in visible) >= 0.5 * len(visible)


def describe(paths) -> str:
    """How messages and ``run.json`` name a set of files: the file itself, or the first few
    and how many there are."""
    paths = [str(p) for p in paths]
    if len(paths) == 1:
        return paths[0]
    shown = ", ".join(paths[:NAMED_FILES])
    return f"{shown}, ... ({len(paths)} files)" if len(paths) > NAMED_FILES else shown


def read_tiles(paths, *, mesh_samples: int | None = DEFAULT_MESH_SAMPLES, progress=None) -> Cloud:
    """One cloud from several files (:func:`~geostructure.io.readers.read_cloud` each).

    The tiles must agree on their coordinate reference system (all the same, or none
    declared); stored normals are kept only when every tile has them; the LAS grid (scale
    and offset) only when every tile shares it. Points written in two tiles count once, and
    files that do not touch are measured together with a note.

    Parameters
    ----------
    paths : sequence of paths
        The survey's files.
    mesh_samples : int or None
        Points sampled on a PLY mesh's faces (None or 0: its vertices).
    progress : callable, optional
        ``progress(stage, done, total)``, once per file read.

    Returns
    -------
    Cloud
        The tiles' points as one cloud, about one offset.

    Raises
    ------
    InputError
        A file that cannot be read, tiles that declare different CRSs.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> grid = np.mgrid[0:10:0.1, 0:10:0.1].reshape(2, -1).T
    >>> for i, shift in enumerate((0.0, 10.0)):
    ...     _ = np.savetxt(folder / f"tile{i}.xyz", np.c_[grid[:, 0] + shift, grid[:, 1], np.zeros(len(grid))])
    >>> cloud = read_tiles(sorted(folder.glob("*.xyz")))
    >>> len(cloud), cloud.source.count(".xyz")
    (20000, 2)
    """
    paths = [Path(p) for p in paths]
    if len(paths) == 1:
        return read_cloud(paths[0], mesh_samples=mesh_samples)
    report = progress or (lambda stage, done, total: None)
    check_headers(paths)  # before reading any: a LAS header says its CRS
    clouds = []
    for i, path in enumerate(paths):
        cloud = read_cloud(path, mesh_samples=mesh_samples)
        if clouds:
            check_same_crs(clouds[0], cloud, paths[0], path)
        clouds.append(cloud)
        report("read", i + 1, len(paths))
    note_apart(paths, [np.vstack([column_min(c.points), column_max(c.points)]) for c in clouds])
    points = np.vstack([c.points for c in clouds])
    normals = np.vstack([c.normals for c in clouds]) if all(c.normals is not None for c in clouds) else None
    vegetation = (
        np.concatenate([np.zeros(len(c), dtype=bool) if c.vegetation is None else c.vegetation for c in clouds])
        if any(c.vegetation is not None for c in clouds)
        else None
    )
    grey = np.concatenate([c.grey for c in clouds]) if all(c.grey is not None for c in clouds) else None
    grids = [c.las_grid for c in clouds]
    same_grid = all(g is not None for g in grids) and all(
        np.array_equal(g[0], grids[0][0]) and np.array_equal(g[1], grids[0][1]) for g in grids
    )
    merged = Cloud.from_points(
        points,
        source=describe(paths),
        crs=clouds[0].crs,
        normals=normals,
        las_grid=grids[0] if same_grid else None,
        left_out=merged_left_out(c.left_out for c in clouds),
        vegetation=vegetation,
        grey=grey,
    )
    return without_copies(merged)  # overlapping tiles: the copies of one tile's points in another


def touching_groups(boxes) -> list[list[int]]:
    """The files that touch, in groups (indices into ``boxes``, each a (2, 3) lower and
    upper corner): two touch when their boxes, each grown by :data:`TOUCH_SHARE` of its
    diagonal, overlap; a group is every file reached through touching ones.

    Examples
    --------
    >>> a, b, far = ([[0, 0, 0], [10, 10, 5]], [[10.2, 0, 0], [20, 10, 5]], [[0, 0, 160], [5, 5, 167]])
    >>> touching_groups([a, b, far])
    [[0, 1], [2]]
    """
    boxes = np.asarray(boxes, dtype=np.float64)
    grow = TOUCH_SHARE * np.linalg.norm(boxes[:, 1] - boxes[:, 0], axis=1)
    lower, upper = boxes[:, 0] - grow[:, None], boxes[:, 1] + grow[:, None]
    touch = np.all((lower[:, None] <= upper[None]) & (lower[None] <= upper[:, None]), axis=2)
    group = list(range(len(boxes)))

    def root(i: int) -> int:
        while group[i] != i:
            i = group[i]
        return i

    for i, j in zip(*np.nonzero(np.triu(touch, 1))):
        group[root(int(j))] = root(int(i))
    roots = [root(i) for i in range(len(boxes))]
    return [[i for i in range(len(boxes)) if roots[i] == r] for r in dict.fromkeys(roots)]


def note_apart(paths, boxes) -> None:
    """A note when the files given as tiles of one survey fall apart into groups that do not
    touch (:func:`touching_groups`): they are still measured as one cloud, as asked."""
    groups = touching_groups(boxes)
    if len(groups) < 2:
        return
    named = "; ".join(describe([Path(paths[i]).name for i in g]) for g in groups)
    warnings.warn(
        f"the {len(paths)} files fall into {len(groups)} groups that do not touch ({named}): they are measured "
        f"as one cloud, as tiles of one survey; measure each on its own if they are separate sites.",
        GeoStructureNote,
        stacklevel=3,
    )


def check_headers(paths) -> tuple[str, Path] | None:
    """Refuse LAS/LAZ tiles that declare different CRSs from their headers alone; the CRS
    they declare and the first tile declaring it, or None."""
    first = None
    for path in paths:
        header_crs = format_of(path).header_crs
        if header_crs is None:
            continue
        try:
            crs = header_crs(path)
        except GeoStructureError:  # counts that cannot be true: said now, before any tile is read
            raise
        except Exception:  # laspy's own refusal: read_cloud says what is wrong with it
            continue
        check_cloud_crs(crs, str(path))  # a tile in degrees: before any tile is read
        cloud = Cloud(np.zeros((1, 3)), crs=crs, source=str(path))
        if first is None:
            first = (cloud, path)
        else:
            check_same_crs(first[0], cloud, first[1], path)
    return (first[0].crs, first[1]) if first is not None and first[0].crs else None


def check_same_crs(first: Cloud, other: Cloud, first_path: Path, path: Path) -> None:
    if first.crs == other.crs:
        return
    if first.crs and other.crs and parse_crs(first.crs) == parse_crs(other.crs):
        return
    raise InputError(
        f"{path}: its coordinate system ({_crs_name(other)}) is not that of {first_path.name} "
        f"({_crs_name(first)}); tiles measured together must share one."
    )


def _crs_name(cloud: Cloud) -> str:
    return "none declared" if not cloud.crs else parse_crs(cloud.crs).name
