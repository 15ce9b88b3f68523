"""PLY clouds and meshes (plyfile): read whole, a mesh's faces sampled back to points, or
a cloud's vertices chunk by chunk through a memory map (a streamed survey's)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from geostructure.core.cloud import Cloud
from geostructure.errors import InputError, ParameterError
from geostructure.io.checks import check_coordinate_step, check_coordinates, check_points, check_step_once, ply_step
from geostructure.io.text import grey_of

#: Points sampled on a mesh's faces when a PLY carries triangles (see :func:`sample_mesh`).
DEFAULT_MESH_SAMPLES = 200_000
#: The most points sampled on a mesh: 100 million samples already take 4.8 GB with their normals,
#: more than a mesh's own vertices ever justify.
MAX_MESH_SAMPLES = 100_000_000


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


def ply_has_faces(path: Path, mesh_samples) -> bool:
    """Whether a PLY is a mesh whose faces are to be sampled (``mesh_samples`` given)."""
    from plyfile import PlyData

    if not mesh_samples:
        return False
    try:
        header = PlyData.read(str(path), mmap="r")
    except Exception:  # read_cloud says what is wrong with it
        return True
    return "face" in header and len(header["face"].data) > 0


def ply_chunks(path: Path, rows: int, steps_checked: set):
    """A PLY cloud's (points, normals, vegetation, grey, meta) chunks of ``rows`` vertices,
    through a memory map; its coordinate step judged on the first (:func:`~.checks.check_step_once`)."""
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
            check_step_once(points, ply_step(points, vertex.dtype), path, steps_checked)
        normals = (
            np.column_stack([np.asarray(part[c], dtype=np.float64) for c in ("nx", "ny", "nz")])
            if has_normals
            else None
        )
        grey = None if colour is None else grey_of(np.column_stack([np.asarray(part[c]) for c in colour]))
        yield points, normals, None, grey, meta


def ply_point_count(path: Path, mesh_samples) -> int:
    """The points a PLY gives, from its header: its vertices, or the samples on its faces."""
    with open(path, "rb") as fh:
        head = fh.read(65536).decode("ascii", errors="replace")
    vertices = re.search(r"^element\s+vertex\s+(\d+)", head, re.M)
    faces = re.search(r"^element\s+face\s+(\d+)", head, re.M)
    if faces and int(faces.group(1)) and mesh_samples:
        return int(mesh_samples)
    return int(vertices.group(1)) if vertices else path.stat().st_size // 30
