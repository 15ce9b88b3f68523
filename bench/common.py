"""What the benchmark scripts share: writing the cloud they time, and the package's
bytecode compiled before any timed process starts."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_ply(points: np.ndarray, path: Path) -> None:
    """``points`` (N, 3) as a binary PLY of doubles: the file each method reads."""
    from plyfile import PlyData, PlyElement

    vertex = np.empty(len(points), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    vertex["x"], vertex["y"], vertex["z"] = points.T
    PlyData([PlyElement.describe(vertex, "vertex")], text=False).write(str(path))


def compile_package() -> None:
    """The package's modules compiled to bytecode (not timed), as installing it does: run
    from a source tree with PYTHONDONTWRITEBYTECODE set, every timed process compiled them."""
    import compileall

    import geostructure

    compileall.compile_dir(Path(geostructure.__file__).parent, quiet=1)
