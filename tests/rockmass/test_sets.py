"""Joint sets: axial clustering, Fisher statistics, the number of sets, the outputs."""

import csv
import warnings

import numpy as np
import pytest
from helpers import run_cli

from geostructure import measure
from geostructure.cli import main
from geostructure.core.orientation import angle_between_normals, normal_from_orientation
from geostructure.errors import GeoStructureWarning
from geostructure.rockmass.sets import find_sets, fisher_statistics
from geostructure.synthetic import fisher_directions, outcrop_scene
from geostructure.workflows.sets_and_mass import plane_sets


def test_steep_planes_whose_poles_straddle_the_horizon():
    # mplstereonet's find_fisher_stats (its issue #39) averages such poles into nonsense
    rng = np.random.default_rng(3)
    mean = normal_from_orientation(120.0, 88.0)
    poles = fisher_directions(mean, 40.0, 500, rng)
    poles *= np.where(poles[:, 2] < 0, -1.0, 1.0)[:, None]  # upward poles: dd flips by 180 across the horizon
    assert (np.abs(((np.degrees(np.arctan2(poles[:, 0], poles[:, 1])) - 300) % 360)) < 90).mean() > 0.2
    naive = poles.mean(axis=0)
    assert angle_between_normals(naive, mean)[0] > 5  # the resultant of upward poles is wrong
    stats = fisher_statistics(poles)
    assert angle_between_normals(stats["mean_normal"], mean)[0] < 1.0
    assert stats["fisher_k"] == pytest.approx(40.0, rel=0.15)
    assert stats["alpha95"] == pytest.approx(140.0 / np.sqrt(40.0 * 500), rel=0.2)  # the classic approximation


def test_fisher_k_and_alpha95_on_known_sets():
    rng = np.random.default_rng(5)
    for kappa in (20.0, 100.0):
        stats = fisher_statistics(fisher_directions([0.3, -0.5, 0.8], kappa, 2000, rng))
        assert stats["fisher_k"] == pytest.approx(kappa, rel=0.1)
        assert stats["spherical_variance"] == pytest.approx(1.0 / kappa, rel=0.15)


def test_the_number_of_sets_is_chosen_and_stray_planes_left_out():
    rng = np.random.default_rng(7)
    means = [normal_from_orientation(dd, dip) for dd, dip in ((180, 45), (0, 70), (235, 65), (90, 20))]
    parts = [fisher_directions(m, 60.0, n, rng) for m, n in zip(means, (120, 90, 70, 50))]
    stray = rng.normal(size=(12, 3))
    sets = find_sets(np.vstack(parts + [stray]), rng.uniform(0.05, 2.0, 342))
    assert len(sets) == 4 and sets.criterion == "bic"
    for m in means:
        assert min(angle_between_normals(np.tile(m, (len(sets), 1)), sets.mean_normal)) < 2.0
    assert (sets.labels[-12:] < 0).sum() >= 6  # most stray planes fit no set
    given = find_sets(np.vstack(parts), n_sets=2)
    assert len(given) == 2 and given.criterion == "given"


def test_asking_for_more_sets_than_the_planes_hold_says_so():
    """--n-sets 10 on three sets of planes once gave fewer sets, or none, without a word."""
    rng = np.random.default_rng(7)
    means = [normal_from_orientation(dd, dip) for dd, dip in ((180, 45), (0, 70), (235, 65))]
    normals = np.vstack([fisher_directions(m, 200.0, 8, rng) for m in means])
    with pytest.warns(GeoStructureWarning, match="of the 8 sets asked for hold 3 planes or more"):
        sets = find_sets(normals, n_sets=8)
    assert len(sets) < 8
    with pytest.warns(GeoStructureWarning, match="24 planes make at most 8 sets of 3 planes, not the 10 asked for"):
        assert len(find_sets(normals, n_sets=10)) == 0


# Seed 5 is left out on purpose: one of its joint planes drawn 25 degrees from its set's mean
# lies nearer the next set's mean, and goes there (docs/rockmass.md has the figures).
@pytest.mark.parametrize("seed", [4, 6])
def test_sets_of_a_measured_outcrop_match_its_truth(seed):
    scene = outcrop_scene(width=12.0, height=6.0, seed=seed)
    result = measure(scene.cloud)
    sets = plane_sets(result.planes, result.frame)  # the number of sets chosen, not given
    assert len(sets) == 3
    # the truth a measurement can reach: the exposed facets of each set (0.3 m and larger)
    for t in scene.exposed_set_statistics(min_diameter=0.3):
        errors = angle_between_normals(np.tile(t["mean_normal"], (3, 1)), sets.mean_normal)
        assert errors.min() < 2.0, errors
        assert sets.fisher_k[errors.argmin()] == pytest.approx(t["fisher_k"], rel=0.25)


def test_measure_sets_and_the_sets_command(tmp_path, capsys):
    scene = outcrop_scene(width=6.0, height=4.0, seed=1, offset=(500_000.0, 4_600_000.0, 0.0))
    cloud = tmp_path / "outcrop.xyz"
    np.savetxt(cloud, scene.cloud.points, fmt="%.4f")
    out = tmp_path / "out"
    assert main(["measure", str(cloud), "-o", str(out), "--sets", "-q"]) == 0
    with open(out / "sets.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 and float(rows[0]["fisher_k"]) > 10
    with open(out / "planes.csv", newline="") as fh:
        planes = list(csv.DictReader(fh))
    assert {int(p["set"]) for p in planes} <= {-1, 0, 1, 2}
    assert open(out / "planes_dips.csv").readline().startswith("Dip Direction,Dip,Set,")
    assert main(["sets", str(out), "--n-sets", "2", "-q"]) == 0
    with open(out / "sets.csv", newline="") as fh:
        assert len(list(csv.DictReader(fh))) == 2
    assert main(["report", str(out), "-q"]) == 0  # the folder verifies as one set
    html = (out / "report.html").read_text()
    assert '<table id="sets">' in html and html.count('<tr><td><span class="swatch"') == 2  # the set table
    assert '"name":"set 1"' in html and '"label":"Set"' in html  # mean great circles; a Set column
    assert main(["sets", str(tmp_path / "none"), "-q"]) == 2
    assert "run 'geostructure measure' first" in capsys.readouterr().err


@pytest.mark.real_data
def test_a_small_real_outcrop_goes_through_sets_and_the_report(tmp_path, capsys):
    from conftest import shared_file

    cloud = shared_file("jfm_outcrop_test/test.txt")
    out = tmp_path / "jfm"
    assert main(["measure", str(cloud), "-o", str(out), "--sets", "--report", "-q"]) == 0
    assert (out / "sets.csv").read_text().startswith("set,n_planes,")
    assert "set" in open(out / "planes.csv").readline().strip().split(",")
    assert (out / "report.html").stat().st_size > 100_000
    # The kinematics never print an empty count of joints ("of the joints' planes, 0 of 0",
    # "0 (—%)"), with joints or without.
    code, printed, _ = run_cli(capsys, "kinematics", out, "--friction", "30")
    assert code == 0 and "Wedges: " in printed and "(—%)" not in printed and "0 of 0" not in printed
    assert "(—%)" not in (out / "report.html").read_text()


def test_sets_among_voxel_planes_say_they_see_only_the_larger_joints(tmp_path):
    """The voxel detector (``--detector voxel``, the stream engine's) finds few of a rough
    face's joint faces: on the 40 x 16 m face of 3 m joints 253 planes to the facets' 1,871,
    and the sets' spacing 2.0 to 2.7 times the facets'. Its sets say so; the default's do not."""
    from geostructure.detect.auto import choose_params
    from geostructure.errors import GeoStructureNote
    from geostructure.workflows.saving import add_sets, save_measurement

    cloud = outcrop_scene(width=8.0, height=4.0, seed=1).cloud
    choice = choose_params(cloud.local)
    for detector in ("voxel", "facets"):
        out = tmp_path / detector
        save_measurement(measure(cloud, choice.params.with_(detector=detector)), out)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            add_sets(out)
        notes = [str(w.message) for w in caught if issubclass(w.category, GeoStructureNote)]
        assert any("voxel detector" in n for n in notes) == (detector == "voxel"), notes
