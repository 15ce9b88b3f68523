"""RQD from the sets' spacing: Palmström's from Jv, and Priest & Hudson's along a line."""

import numpy as np
import pytest

from geostructure.rockmass.notes import rqd_phrase
from geostructure.rockmass.rqd import block_size_class, rqd_from_frequency, rqd_from_jv, rqd_range
from geostructure.rockmass.spacing import spacing_class


def core_rqd(frequency: float, length: float = 20_000.0, seed: int = 0) -> float:
    """RQD of a simulated core: joints at random along it (exponential gaps), the share of
    its length in pieces of 0.1 m or more (Deere 1964)."""
    gaps = np.random.default_rng(seed).exponential(1.0 / frequency, int(frequency * length * 1.2))
    gaps = gaps[np.cumsum(gaps) <= length]
    return 100.0 * gaps[gaps >= 0.1].sum() / gaps.sum()


@pytest.mark.parametrize("frequency", [2.0, 6.0, 15.0, 30.0])
def test_priest_and_hudson_is_the_rqd_of_a_core_with_random_joints(frequency):
    assert rqd_from_frequency(frequency) == pytest.approx(core_rqd(frequency), abs=0.5)


def test_palmstrom_from_jv_is_held_to_0_and_100():
    assert [rqd_from_jv(jv) for jv in (0.0, 4.0, 20.0, 44.0, 60.0)] == [100.0, 100.0, 60.0, 0.0, 0.0]
    assert np.isnan(rqd_from_jv(float("nan")))


def test_the_range_along_a_line_of_three_orthogonal_sets():
    normals, spacing = np.eye(3), np.array([0.2, 0.4, 0.5])
    least, greatest = rqd_range(normals, spacing)
    # most joints along (1/0.2, 1/0.4, 1/0.5), fewest along the widest set's normal alone
    assert least == pytest.approx(rqd_from_frequency(np.linalg.norm(1.0 / spacing)), abs=0.01)
    assert greatest == pytest.approx(rqd_from_frequency(1.0 / 0.5), abs=1e-9)
    # no direction, drawn at random, falls outside it
    d = np.random.default_rng(1).normal(size=(20_000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    drawn = rqd_from_frequency(np.abs(d @ normals.T) @ (1.0 / spacing))
    assert least - 1e-9 <= drawn.min() and drawn.max() <= greatest + 1e-9


def test_a_set_without_a_spacing_is_left_out_of_the_range():
    normals = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    assert rqd_range(normals, np.array([0.2, np.nan])) == pytest.approx(rqd_range(normals[:1], [0.2]))
    assert all(np.isnan(rqd_range(normals, np.array([np.nan, np.nan]))))


def test_the_tables_words():
    assert rqd_phrase(85.0, 80.4, 97.2) == ", RQD 85 (80 to 97 by direction)"
    assert rqd_phrase(85.0, float("nan"), float("nan")) == ", RQD 85"
    assert rqd_phrase(None) == ""


def test_isrm_words_for_spacing_and_block_size():
    spacings = [0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0]
    assert [spacing_class(s) for s in spacings] == [
        "extremely close", "very close", "close", "moderate", "wide", "very wide", "extremely wide"
    ]  # fmt: skip
    jv = [0.5, 2.0, 5.0, 20.0, 40.0, 80.0]
    assert [block_size_class(j) for j in jv] == [
        "very large blocks", "large blocks", "medium-sized blocks", "small blocks", "very small blocks", "crushed rock"
    ]  # fmt: skip
    assert spacing_class(float("nan")) == block_size_class(float("nan")) == ""
