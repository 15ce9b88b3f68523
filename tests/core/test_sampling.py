"""Samples drawn by the points' coordinates (`geostructure.core.sampling`)."""

import warnings

import numpy as np

from geostructure.core.sampling import order_free_sample


def test_any_seed_draws_the_same_points_whatever_their_order_and_without_a_warning():
    """The hash wraps by design; from seed 5 its start wrapped outside numpy's errstate and
    printed a raw RuntimeWarning."""
    points = np.random.default_rng(0).random((5000, 3))
    order = np.random.default_rng(1).permutation(len(points))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for seed in range(10):
            drawn = points[order_free_sample(points, 200, seed)]
            again = points[order][order_free_sample(points[order], 200, seed)]
            assert np.array_equal(drawn, again)
