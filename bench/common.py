"""What the benchmark scripts share: writing the cloud they time, the package's bytecode
compiled before any timed process starts, and the command's own memory settings given to
every method."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np


def the_commands_memory_settings() -> None:
    """Every timed process (this one's children) with the memory settings the ``geostructure``
    command gives itself: numpy's small pages (``NUMPY_MADVISE_HUGEPAGE=0``) and, on glibc,
    freed memory reused (``MALLOC_ARENA_MAX=1``, ``MALLOC_MMAP_MAX_=0``, a high trim
    threshold: docs/design.md, "Reused memory"), so that the ratios compare the methods,
    not the allocators. Set in this process's environment, which the children inherit."""
    from geostructure.__main__ import reuse_freed_memory

    os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", "0")
    reuse_freed_memory()


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
