"""A survey measured with its facets found on every point in tiles with halos (issue 46's
first criterion): on a cloud that fits, with tiles small enough to cut most facets, the
planes, sets and joints are the in-memory ones, here and on two Dask workers."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from geostructure.io.laz import write_laz
from geostructure.stream import SerialExecutor, spill_inputs
from geostructure.stream.thin import thin_spill
from geostructure.stream.thinnedsurvey import ThinnedSurvey
from geostructure.synthetic import outcrop_scene
from geostructure.workflows.outcrop import measure_outcrop


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    """The 8 x 5 m outcrop (about 160 facets, 0.2 to 2 m across) as a spilled LAZ that fits:
    nothing thinned; and what it gives in memory with ``--sets``."""
    folder = tmp_path_factory.mktemp("survey")
    cloud = outcrop_scene(width=8.0, height=5.0, seed=5).cloud
    write_laz(folder / "outcrop.laz", cloud.points, {}, offset=cloud.offset)
    spill = spill_inputs([folder / "outcrop.laz"], 10_000)
    thinned = thin_spill(spill, spill.n_points, 10_000)
    whole = ThinnedSurvey(spill, thinned, SerialExecutor(), 10_000)
    yield spill, thinned, measure_outcrop(whole.cloud(), sets=True)
    spill.close()


def same_measure(memory, tiled):
    """Issue 46: 99% of the planes matched (centroid within a point spacing, normal within 0.1
    degree), the same set count, set means within 0.1 degree; here the same joints too."""
    a, b = memory.planes, tiled.planes
    spacing = memory.result.detection["facet_thresholds"]["spacing"]
    assert len(a) > 50 and abs(len(a) - len(b)) <= 0.01 * len(a)
    distance, nearest = cKDTree(b.local_centroid).query(a.local_centroid)
    angle = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", a.normal, b.normal[nearest])), 0, 1)))
    assert ((distance < spacing) & (angle < 0.1)).mean() >= 0.99
    assert len(memory.sets) == len(tiled.sets) == 3
    means = np.abs(np.einsum("ij,ij->i", memory.sets.mean_normal, tiled.sets.mean_normal))
    assert np.degrees(np.arccos(np.clip(means, 0, 1))).max() < 0.1
    assert len(memory.rock.joints) == len(tiled.rock.joints)


def test_facets_found_in_small_tiles_give_the_in_memory_planes_sets_and_joints(survey):
    spill, thinned, memory = survey
    tiled = ThinnedSurvey(spill, thinned, SerialExecutor(), 10_000, tile_cells=10)
    run = measure_outcrop(tiled.cloud(), sets=True, facets=tiled.full_resolution_facets)
    record = run.result.detection["full_resolution"]
    assert record["tiles"] > 100 and record["tile_cells"] == 10  # 50 cm tiles: most facets cut
    assert record["planar_facets"] == memory.result.detection["planar_facets"]
    same_measure(memory, run)


def test_the_tiles_on_two_dask_workers_give_the_same(survey):
    pytest.importorskip("distributed")
    from geostructure.stream import DaskExecutor

    spill, thinned, memory = survey
    executor = DaskExecutor(workers=2)
    try:
        tiled = ThinnedSurvey(spill, thinned, executor, 10_000, tile_cells=20)
        run = measure_outcrop(tiled.cloud(), sets=True, facets=tiled.full_resolution_facets)
    finally:
        executor.close()
    assert run.result.detection["full_resolution"]["tiles"] > 20
    same_measure(memory, run)
