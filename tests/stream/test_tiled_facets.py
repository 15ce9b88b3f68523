"""The facet detector over a spilled survey in tiles with halos (issue 46, docs/tiles.md
step 4): on a cloud that fits, every point's facet is the one the in-memory detector gives,
with tiles small enough to cut most facets, here and on a Dask local cluster; the tile files
are gone after."""

import numpy as np
import pytest

from geostructure.detect.facets import detect_facets
from geostructure.io.laz import write_laz
from geostructure.stream import spill_inputs
from geostructure.stream.tiledfacets import detect_facets_spilled
from geostructure.synthetic import outcrop_scene


@pytest.fixture(scope="module")
def spilled(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tiled")
    cloud = outcrop_scene(width=8.0, height=5.0, seed=5).cloud
    write_laz(folder / "outcrop.laz", cloud.points, {}, offset=cloud.offset)
    spill = spill_inputs([folder / "outcrop.laz"], 10_000)
    local = np.fromfile(spill.points_path).reshape(-1, 3) - spill.offset
    yield spill, detect_facets(local)
    spill.close()


def check_same_facets(found, whole):
    labels = found.labels()
    assert whole.labels.max() + 1 > 100  # an outcrop of many facets
    assert found.n_facets == whole.labels.max() + 1
    # Facet by facet, each point's: the issue asks 99% of the facets, this gives them all.
    assert (np.maximum(labels, -1) == whole.labels).mean() > 0.999
    assert ((labels == -2) == whole.curved).mean() > 0.999
    # The medians read from counts in bins that add over the tiles: within half a bin.
    assert found.thresholds.max_angle == pytest.approx(whole.thresholds.max_angle, abs=1e-3)
    assert found.thresholds.max_offset == pytest.approx(whole.thresholds.max_offset, rel=1e-3)


@pytest.mark.parametrize("tile_cells", [6, 20])
def test_tiles_of_a_spill_give_every_points_in_memory_facet(spilled, tile_cells):
    """Tiles of 6 cells (30 cm, 3,800 tiles: the halo is wider than half a tile, so a point
    lies in up to three tiles along an axis) and of 20 (1 m, 300 tiles) on an 8 x 5 m face
    whose facets are 0.2 to 2 m across."""
    spill, whole = spilled
    found = detect_facets_spilled(spill, 10_000, tile_cells=tile_cells)
    assert found.n_tiles > 100
    check_same_facets(found, whole)
    assert not (spill.folder / "tiles").exists()


def test_tiles_on_two_dask_workers_give_the_same_facets(spilled):
    pytest.importorskip("distributed")
    from geostructure.stream import DaskExecutor

    spill, whole = spilled
    executor = DaskExecutor(workers=2)
    try:
        found = detect_facets_spilled(spill, 10_000, executor, tile_cells=40)
    finally:
        executor.close()
    assert found.n_tiles > 20
    check_same_facets(found, whole)


def test_the_default_tile_holds_about_a_chunk(spilled):
    """Without a tile size, a tile's core is as wide as a chunk of points on a surface facing
    it, and at least eight halos across."""
    spill, whole = spilled
    found = detect_facets_spilled(spill, 4_000)
    assert found.tile_cells >= 40
    check_same_facets(found, whole)


@pytest.mark.real_data
def test_real_rock_in_tiles_gives_every_points_in_memory_rough_facet():
    """The real outcrop (7 x 10 m, rough at every scale the grid tries: rough rock's facets)
    in 35 tiles of 1.7 m: every point's facet is the one the whole cloud gives, the medians
    read on the tiles' counts."""
    from conftest import shared_file

    spill = spill_inputs([shared_file("dice_lastoni_sw/Lastoni_SW_3cm.txt")], 10_000)
    try:
        whole = detect_facets(np.fromfile(spill.points_path).reshape(-1, 3) - spill.offset)
        found = detect_facets_spilled(spill, 10_000, tile_cells=4)
        labels = found.labels()
    finally:
        spill.close()
    assert whole.rough is not None and found.rough is not None
    assert found.n_tiles > 25
    assert found.n_facets == whole.labels.max() + 1 > 200
    assert (labels == whole.labels).mean() > 0.999
    assert found.rough["rough_join_angle_deg"] == pytest.approx(whole.rough.join_angle, abs=1e-3)
    assert found.rough["face_points"] == whole.rough.on_face.sum()
    assert found.rough["points_past_halo"] == 0
