"""Points written more than once (geostructure.core.duplicates): found exactly, the first of each kept."""

import numpy as np
import pytest

from geostructure import Cloud
from geostructure.core.duplicates import first_of_each, has_copies, without_copies
from geostructure.errors import GeoStructureError, GeoStructureNote


def planted(n: int, copies: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` random points and ``copies`` of them again, shuffled in; and the truth: which
    rows are the first of their point."""
    rng = np.random.default_rng(seed)
    points = rng.random((n, 3)) * 100.0
    rows = np.vstack([points, points[rng.choice(n, copies, replace=True)]])[rng.permutation(n + copies)]
    _, first = np.unique(rows, axis=0, return_index=True)
    truth = np.zeros(len(rows), dtype=bool)
    truth[first] = True
    return rows, truth


@pytest.mark.parametrize("n, copies", [(1_000, 300), (300_000, 30_000), (300_000, 0)])
def test_the_first_of_each_point_is_kept_and_every_copy_found(n, copies):
    rows, truth = planted(n, copies)
    assert has_copies(rows) == (copies > 0)
    assert np.array_equal(first_of_each(rows), truth)  # np.unique's first index: the first in order


def test_a_column_slice_and_points_that_differ_in_the_last_bit():
    rows = np.random.default_rng(1).random((1000, 4))[:, :3]  # not contiguous
    assert not has_copies(rows) and has_copies(np.vstack([rows, rows[:1]]))
    nudged = rows.copy()
    nudged[:, 2] = np.nextafter(nudged[:, 2], 2.0)  # one ulp apart: distinct points
    assert first_of_each(np.vstack([rows, nudged])).all()


def test_a_cloud_without_its_copies_says_how_many_and_a_cloud_of_one_spot_is_refused():
    rows, truth = planted(2_000, 500, seed=2)
    cloud = Cloud.from_points(rows, source="merged.xyz", left_out={"noise": 7})
    with pytest.warns(GeoStructureNote, match=r"merged.xyz: 500 point\(s\) repeat others exactly"):
        kept = without_copies(cloud)
    assert np.array_equal(kept.local, cloud.local[truth]) and kept.left_out == {"noise": 7, "copies": 500}
    assert without_copies(kept) is kept  # nothing left to leave out
    with pytest.raises(GeoStructureError, match="all points lie at one spot"):
        without_copies(Cloud.from_points(np.ones((20, 3)), source="spot.xyz"))
