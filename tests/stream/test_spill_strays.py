"""A stray point streamed (issue 53, item 2): left out of the spill as in memory, so the
streamed planes are those of the survey without it, and said."""

import numpy as np
from helpers import run_cli, scene_points, write_xyz

from geostructure.io.results import read_run


def test_a_stray_point_changes_no_streamed_plane(tmp_path, capsys):
    points = scene_points(30_000)
    clean = write_xyz(tmp_path / "clean.xyz", points)
    stray = write_xyz(tmp_path / "stray.xyz", np.vstack([points, points[:1] - [0.0, 0.0, 2_000.0]]))
    for cloud in (clean, stray):
        code, _, err = run_cli(capsys, "measure", cloud, "-o", tmp_path / cloud.stem, "--engine", "stream", "-q")
        assert code == 0, err
    # the same planes; the text reader's offset moves with the stray, and with it the last bits
    found, clean_planes = (
        np.genfromtxt(tmp_path / name / "planes.csv", delimiter=",", names=True) for name in ("stray", "clean")
    )
    assert len(found) == len(clean_planes) > 5
    for column in ("n_points", "centroid_x", "centroid_y", "centroid_z", "dip", "dip_direction"):
        assert np.allclose(found[column], clean_planes[column], rtol=1e-9, atol=1e-9, equal_nan=True), column
    assert "stray point" in err and "30,001" in err
    assert (read_run(tmp_path / "stray").get("left_out") or {}).get("strays") == 1
    assert "strays" not in (read_run(tmp_path / "clean").get("left_out") or {})
