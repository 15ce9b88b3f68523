"""Helpers the reliability, fuzz and kill tests share: small clouds on disk, a CLI runner,
and the checks of the error contract (one sentence, exit 2, the input untouched)."""

from __future__ import annotations

import csv
import hashlib
import re
from pathlib import Path

import numpy as np

from geostructure.cli import main
from geostructure.synthetic import observatory_scene, outcrop_scene

#: The tests' folder, for the data files beside them (tests/data).
TESTS_DIR = Path(__file__).resolve().parent

#: An error line: the prefix, then one sentence (ending in a full stop; no second line).
ERROR_LINE = re.compile(r"^geostructure: error: .+[.)]$")


def digest(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def folder_digests(folder) -> dict[str, str]:
    """Name -> SHA-256 of every file in a folder, hidden ones included (what a run left)."""
    folder = Path(folder)
    if not folder.is_dir():
        return {}
    return {
        str(p.relative_to(folder)): digest(p)
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != ".geostructure-lock"
    }


def scene_points(n: int = 20_000, seed: int = 0, offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    return observatory_scene(n, seed=seed).cloud.points + np.asarray(offset, dtype=np.float64)


def write_xyz(path, points, *, header: str | None = None, delimiter: str = " ", bom: bool = False) -> Path:
    """A text cloud written with 17 significant digits, so it reads back bit for bit."""
    lines = [delimiter.join(repr(float(v)) for v in row) for row in points]
    text = ((header + "\n") if header else "") + "\n".join(lines) + "\n"
    Path(path).write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    return Path(path)


#: Where the LAS files the tests write lie (a UTM-sized offset), and their grid.
LAS_ORIGIN = (500_000.0, 5_000_000.0, 100.0)


def write_classified_las(path, points, classification, origin=LAS_ORIGIN):
    """``points`` (local, metres) as a LAS 1.4 file at ``origin`` on a millimetre grid, each
    with its ASPRS ``classification``; returns the path."""
    import laspy
    import numpy as np

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [0.001] * 3, [origin[0], origin[1], 0.0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = (np.asarray(points) + origin).T
    las.classification = np.asarray(classification, dtype=np.uint8)
    las.write(str(path))
    return Path(path)


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    """Run the command line in this process; returns (exit status, stdout, stderr)."""
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_sentence(err: str, *names) -> None:
    """The whole of stderr is one error line, naming each of ``names``; no traceback, no
    library's warning (raw or labelled as ours to fix)."""
    lines = [line for line in err.strip().splitlines() if not line.startswith("geostructure: warning:")]
    assert "Traceback" not in err and "internal warning" not in err, err
    assert len(lines) == 1 and ERROR_LINE.match(lines[0]), err
    for name in names:
        assert str(name) in lines[0], (name, err)


def lidar_outcrop(width: float, height: float):
    """The LiDAR-like outcrop the tests share: 1 cm spacing, little noise, at a UTM offset."""
    return outcrop_scene(
        width=width,
        height=height,
        point_spacing=0.01,
        noise=0.002,
        correlated_noise=0.001,
        facet_size=0.4,
        seed=6,
        offset=(662_000.0, 5_103_000.0, 800.0),
    )


def write_ply(path, points, *, text, dtype="f8", extra=True, faces=None):
    from plyfile import PlyData, PlyElement

    fields = [("x", dtype), ("y", dtype), ("z", dtype)] + ([("red", "u1"), ("intensity", "f4")] if extra else [])
    v = np.zeros(len(points), dtype=fields)
    v["x"], v["y"], v["z"] = points.T
    elements = [PlyElement.describe(v, "vertex")]
    if faces is not None:
        f = np.empty(len(faces), dtype=[("vertex_indices", "i4", (3,))])
        f["vertex_indices"] = faces
        elements.append(PlyElement.describe(f, "face"))
    PlyData(elements, text=text).write(str(path))


UTM = (500_000.0, 4_600_000.0, 300.0)


def write_laz(path, points, crs="EPSG:32633"):
    import laspy
    import pyproj

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = [0.001] * 3, list(UTM)
    if crs:
        header.add_crs(pyproj.CRS(crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    las.write(str(path))


def tile_index(points, n=4, axes=(0, 2)):
    """Each point's tile on an n x n grid over two axes of the bounding box."""
    lower, upper = points.min(axis=0), points.max(axis=0)
    index = [np.minimum(((points[:, a] - lower[a]) / (upper[a] - lower[a]) * n).astype(int), n - 1) for a in axes]
    return index[0] * n + index[1]


def planes_of(out):
    with open(out / "planes.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    centroid = np.array([[float(r[f"centroid_{a}"]) for a in "xyz"] for r in rows]).reshape(-1, 3)
    normal = np.array([[float(r[f"normal_{a}"]) for a in "xyz"] for r in rows]).reshape(-1, 3)
    return centroid, normal


def turned_faces(turn: float, seed: int = 4) -> np.ndarray:
    """Two 12 x 6 m faces side by side along x, the second turned ``turn`` degrees about the
    vertical at their shared edge (as two generated outcrops, each with its own joints)."""
    first = outcrop_scene(width=12.0, height=6.0, seed=seed, face_dip_direction=180.0)
    second = outcrop_scene(width=12.0, height=6.0, seed=seed + 50, face_dip_direction=180.0 + turn,
                           offset=(12.0, 0.0, 0.0))  # fmt: skip
    return np.vstack([first.cloud.points, second.cloud.points])
