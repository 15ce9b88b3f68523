"""The paper's own cloud (../shared/data/observatory, CC BY-NC-SA: test data, not bundled).

Which six surfaces the authors measured is not published, and the cloud's frame is only
roughly the paper's (x about North, z Up). So the frame is fitted from the ground truth
itself (rotation of the six truth normals onto six of the largest planes, one-to-one), and
the tests state how close the planes come once the frame is known, plus the frame-free
figure: the angles between the six surfaces.
"""

import numpy as np
import pytest
from conftest import shared_file
from helpers import TESTS_DIR

from geostructure.core.orientation import Frame, angle_between_normals
from geostructure.core.params import Params
from geostructure.detect.pipeline import measure
from geostructure.evaluation.framefit import fit_frame_to_truth
from geostructure.io.readers import read_cloud
from geostructure.synthetic import PAPER_NORMALS

pytestmark = pytest.mark.real_data  # every test here reads the paper's cloud


@pytest.fixture(scope="module")
def observatory():
    cloud = read_cloud(shared_file("observatory/dense_poisson_oc_6.ply"))
    return measure(cloud, Params(zeta=0.02), Frame.named("paper"))


def pairwise(normals):
    n = len(normals)
    return angle_between_normals(np.repeat(normals, n, 0), np.tile(normals, (n, 1))).reshape(n, n)[
        np.triu_indices(n, 1)
    ]


def test_six_surfaces_found_once_the_frame_is_fitted(observatory):
    fit = fit_frame_to_truth(observatory.normals, PAPER_NORMALS, candidates=30)
    print(
        f"\nobservatory: {len(observatory)} planes; frame turned {fit.rotation_angle:.1f} deg from the paper's;"
        f" residuals {np.round(fit.residuals, 2)} deg, mean {fit.mean_residual:.2f}"
    )
    assert len(set(fit.matched.tolist())) == 6
    assert fit.rotation_angle < 10.0  # the cloud really is roughly in the paper's frame
    # measured on this cloud: 3.25 deg (2.68 with --no-merge, whose frame turns 6.5 deg, not 3.6)
    assert fit.mean_residual < 3.5
    assert fit.residuals.max() < 6.0


def test_angles_between_the_six_surfaces_need_no_frame(observatory):
    fit = fit_frame_to_truth(observatory.normals, PAPER_NORMALS, candidates=30)
    error = np.abs(pairwise(observatory.normals[fit.matched]) - pairwise(PAPER_NORMALS))
    print(f"\nobservatory: angles between surfaces off by {error.mean():.2f} deg on average, {error.max():.2f} at most")
    assert error.mean() < 2.5  # measured: 1.84 deg (2.88 with --no-merge)


def test_evaluate_fit_frame_on_the_paper_cloud(tmp_path, capsys):
    import json

    from geostructure.cli import main

    truth = TESTS_DIR / "data" / "paper_truth.csv"
    cloud = shared_file("observatory/dense_poisson_oc_6.ply")
    out = tmp_path / "obs"
    # the paper's own method: its voxel detector, fixed parameters and no coplanar merge
    # (2.76 / 3.17 deg; the default facet detector's small facets push a wall's plane out of
    # the frame fit's 30 largest candidates)
    assert (
        main(
            [
                "measure",
                str(cloud),
                "-o",
                str(out),
                "--frame",
                "paper",
                "--no-auto",
                "--zeta",
                "0.02",
                "--no-merge",
                "--detector",
                "voxel",
                "-q",
            ]
        )
        == 0
    )
    assert main(["evaluate", str(out), "--truth", str(truth), "--fit-frame", "-q"]) == 0
    assert "surface '4'" in capsys.readouterr().err
    summary = json.loads((out / "evaluation.json").read_text())
    fit = summary["frame_fit"]
    assert summary["found"] == 6 and fit["rotation_deg"] < 10
    assert fit["mean_residual_deg"] == pytest.approx(summary["mean_normal_error_deg"])
    assert fit["mean_residual_deg"] < 3.5 and fit["pairwise_mean_deg"] < 4.0
