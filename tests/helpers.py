"""Helpers the reliability, fuzz and kill tests share: small clouds on disk, a CLI runner,
and the checks of the error contract (one sentence, exit 2, the input untouched)."""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import numpy as np

from geostructure.cli import main
from geostructure.synthetic import observatory_scene, outcrop_scene

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


def road_before(scene, depth: float, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    """Level ground ``depth`` m deep at the foot of an outcrop scene's face, as wide as the
    face, at its point spacing on average (drawn at random) and ``noise`` m of white noise:
    the road a rock cut is scanned from, noisier than the rock. The scene's ``offset`` is the
    face's lower corner, so the road runs from there along the foot."""
    strike, _ = scene.face_axes
    width, _ = scene.face_size
    out = np.array([scene.face_normal[0], scene.face_normal[1], 0.0])
    out /= np.linalg.norm(out)
    rng = np.random.default_rng(seed)
    n = int(width * depth / scene.point_spacing**2)
    ab = rng.random((n, 2)) * [width, depth]
    return scene.offset + ab[:, :1] * strike + ab[:, 1:] * out + noise * rng.standard_normal((n, 3))


def crest_above(scene, depth: float, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    """Level ground ``depth`` m deep behind the crest of an outcrop scene's face (its top
    edge), as :func:`road_before` lays the road along its foot."""
    strike, up_dip = scene.face_axes
    width, height = scene.face_size
    back = -np.array([scene.face_normal[0], scene.face_normal[1], 0.0])
    back /= np.linalg.norm(back)
    rng = np.random.default_rng(seed)
    n = int(width * depth / scene.point_spacing**2)
    ab = rng.random((n, 2)) * [width, depth]
    crest = scene.offset + height * up_dip
    return crest + ab[:, :1] * strike + ab[:, 1:] * back + noise * rng.standard_normal((n, 3))


def bushes_on(scene, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` bushes on an outcrop scene's face: half-shells 0.5 to 1.5 m in radius standing
    out of it, at the face's point spacing, each blurred by 1.5 to 5 cm of noise (leaves
    that SfM matches badly): clutter that is a volume, not a surface. Their centres lie on
    the face's mean plane (the scene's ``offset`` is its lower corner). Returns the bushes'
    points and which of the scene's points they hide (within a radius of a centre, seen
    along the face's normal), for the rock behind a bush is not seen."""
    strike, up_dip = scene.face_axes
    width, height = scene.face_size
    normal = scene.face_normal
    rng = np.random.default_rng(seed)
    shells, hidden = [], np.zeros(len(scene.cloud.points), dtype=bool)
    across = (scene.cloud.points - scene.offset) @ np.array([strike, up_dip]).T
    for _ in range(n):
        at = rng.uniform(0, 1, 2) * [width, height]
        radius = rng.uniform(0.5, 1.5)
        m = int(2 * np.pi * radius**2 / scene.point_spacing**2)
        d = rng.normal(size=(m, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        behind = d @ normal < 0
        d[behind] -= 2 * np.outer(d[behind] @ normal, normal)  # the half before the face
        centre = scene.offset + at[0] * strike + at[1] * up_dip
        shells.append(centre + radius * d + rng.uniform(0.015, 0.05) * rng.standard_normal((m, 3)))
        hidden |= np.linalg.norm(across - at, axis=1) < radius
    return np.vstack(shells), hidden
