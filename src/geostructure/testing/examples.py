"""Small files for the docstrings' examples: a survey file the streamed examples read."""

from __future__ import annotations

import tempfile
from pathlib import Path

from geostructure.io.laz import write_laz
from geostructure.synthetic import observatory_scene


def scene_laz(n_points: int = 40_000, seed: int = 1) -> Path:
    """A LAZ file of the synthetic observatory (:func:`~geostructure.synthetic.observatory_scene`)
    with ``n_points`` points, in a new temporary folder: the survey the streamed examples read.

    Examples
    --------
    >>> scene_laz(5_000).suffix
    '.laz'
    """
    cloud = observatory_scene(n_points, seed=seed).cloud
    path = Path(tempfile.mkdtemp()) / "scene.laz"
    write_laz(path, cloud.points, {}, offset=cloud.offset)
    return path
