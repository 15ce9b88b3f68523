import csv
import json

import numpy as np
import pytest

from geostructure.cli import main
from geostructure.core.orientation import Frame
from geostructure.errors import GeoStructureError
from geostructure.evaluation.groundtruth import scene_truth
from geostructure.evaluation.sweep import factor_values, plot_sweep, run_sweep
from geostructure.synthetic import observatory_scene


def test_table_1_ranges_are_the_defaults():
    np.testing.assert_allclose(factor_values("zeta"), np.arange(0.01, 0.0701, 0.006))
    assert factor_values("theta").tolist() == list(range(0, 31, 3))
    assert factor_values("k").tolist() == list(range(1, 20, 2))
    assert len(factor_values("psi")) == 10
    assert factor_values("theta", 2, 6, 2).tolist() == [2, 4, 6]
    with pytest.raises(GeoStructureError):
        factor_values("theta", 5, 1, 1)


@pytest.fixture(scope="module")
def small():
    scene = observatory_scene(40_000, seed=5)
    return scene, scene_truth(scene, Frame())


def test_sweep_in_parallel_equals_serial_and_finds_theta_0_worst(small, tmp_path):
    scene, truth = small
    ranges = {"theta": (0, 6, 3)}
    serial = run_sweep(scene.cloud, truth, Frame(), ["theta"], ranges=ranges, workers=1)
    parallel = run_sweep(scene.cloud, truth, Frame(), ["theta"], ranges=ranges, workers=2)
    assert [r.value for r in serial] == [0, 3, 6]
    assert [r.z for r in serial] == [r.z for r in parallel]
    assert serial[0].found == 0 and serial[0].z == pytest.approx(np.sqrt(6) / 6)  # every surface missed
    assert serial[1].found == 6 and serial[1].z < 0.01
    paths = plot_sweep(serial, tmp_path / "fig")
    assert [p.suffix for p in paths] == [".png", ".svg"] and all(p.stat().st_size > 1000 for p in paths)


def test_sweep_command_writes_table_and_figures(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert (
        main(
            [
                "sweep",
                "--demo",
                "--points",
                "30000",
                "--factor",
                "k",
                "--start",
                "3",
                "--end",
                "7",
                "--step",
                "2",
                "-o",
                str(out),
                "--workers",
                "1",
            ]
        )
        == 0
    )
    rows = list(csv.DictReader(open(out / "sweep.csv")))
    assert [float(r["value"]) for r in rows] == [3, 5, 7]
    assert {"regions_s", "total_s", "z", "z_wrapped", "mean_error_deg"} <= set(rows[0])
    assert (out / "sweep_k.png").exists() and (out / "sweep_k.svg").exists()
    assert len(json.loads((out / "sweep.json").read_text())["runs"]) == 3


def test_evaluate_command_and_measure_with_truth(tmp_path, capsys):
    from helpers import write_ply

    scene = observatory_scene(40_000, seed=6)
    cloud_path = tmp_path / "scene.ply"
    write_ply(cloud_path, scene.cloud.points, text=False)
    truth_path = tmp_path / "truth.csv"
    truth = scene_truth(scene, Frame())
    truth_path.write_text(
        "surface,dip,dip_direction,center_x,center_y,center_z\n"
        + "".join(
            f"{n},{d},{dd},{c[0]},{c[1]},{c[2]}\n"
            for n, d, dd, c in zip(truth.names, truth.dip, truth.dip_direction, truth.centres)
        )
    )
    out = tmp_path / "out"
    assert main(["measure", str(cloud_path), "-o", str(out), "--zeta", "0.02", "--truth", str(truth_path)]) == 0
    summary = json.loads((out / "evaluation.json").read_text())
    assert summary["found"] == 6 and summary["mean_normal_error_deg"] < 0.5
    rows = list(csv.DictReader(open(out / "evaluation.csv")))
    assert len(rows) == 6 and float(rows[0]["z_region"]) < 0.01
    (out / "evaluation.csv").unlink()
    assert main(["evaluate", str(out), "--truth", str(truth_path), "-q"]) == 0
    assert (out / "evaluation.csv").exists()
    assert main(["evaluate", str(tmp_path / "nowhere"), "--truth", str(truth_path)]) == 2
    assert "run.json" in capsys.readouterr().err
