"""One stray point must not change the answer: the extent every parameter is read from
was set by it (issue 53, item 2)."""

import json
import warnings

import numpy as np
import pytest
from helpers import run_cli, write_xyz

from geostructure import Cloud
from geostructure.core.strays import stray_points
from geostructure.workflows.outcrop import measure_outcrop


@pytest.fixture(scope="module")
def lastoni_cut():
    from conftest import shared_file

    points = np.loadtxt(shared_file("dice_lastoni_sw/Lastoni_SW_3cm.txt"), usecols=(0, 1, 2))
    centre = np.median(points, axis=0)
    return points[np.all(np.abs(points[:, :2] - centre[:2]) < 1.1, axis=1)]  # a 2.2 m square of rock


@pytest.mark.real_data
@pytest.mark.parametrize("below", [100.0, 1e4])
def test_a_stray_point_below_a_cut_of_real_rock_changes_no_plane(lastoni_cut, below):
    clean = measure_outcrop(Cloud.from_points(lastoni_cut))
    stray = np.vstack([lastoni_cut, lastoni_cut.mean(axis=0) - [0.0, 0.0, below]])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = measure_outcrop(Cloud.from_points(stray))
    assert any("left out 1 stray point" in str(w.message) for w in caught)
    assert len(run.planes) == len(clean.planes) > 10
    assert run.result.counts["input"] == len(lastoni_cut)
    np.testing.assert_allclose(run.planes.normal, clean.planes.normal, atol=1e-9)


def test_the_strays_are_counted_in_the_record(tmp_path, capsys):
    g = np.mgrid[0:6:0.05, 0:6:0.05].reshape(2, -1).T
    rock = np.c_[g, 0.2 * g[:, 0] + 0.002 * np.random.default_rng(0).standard_normal(len(g))]
    write_xyz(tmp_path / "rock.xyz", np.vstack([rock, [[3.0, 3.0, 500.0]]]))
    code, _, err = run_cli(capsys, "measure", tmp_path / "rock.xyz", "-o", tmp_path / "out", "-q")
    assert code == 0 and "stray point" in err
    assert json.loads((tmp_path / "out" / "run.json").read_text())["left_out"] == {"strays": 1}


def test_a_tall_thin_structure_is_no_stray():
    """A mast of a few hundred points above a field: far from the box of the field, but each
    of its points has neighbours."""
    g = np.mgrid[0:20:0.1, 0:20:0.1].reshape(2, -1).T
    field = np.c_[g, np.zeros(len(g))]
    mast = np.c_[np.full(300, 10.0), np.full(300, 10.0), np.linspace(0.1, 30.0, 300)]
    assert not stray_points(np.vstack([field, mast]), 0.1).any()
