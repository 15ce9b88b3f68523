"""A thinned survey's facet measured on all the survey's points (docs/tiles.md): the region
that is one whole facet takes the survey's plane, its rectangle turned into it."""

import numpy as np

from geostructure.detect.rectangle import region_plane
from geostructure.detect.surveyplanes import MIN_THINNED_POINTS, on_survey_planes, survey_min_points, whole_facets
from geostructure.detect.tilejoin import FacetPlanes


def test_a_whole_facet_takes_the_plane_of_all_its_survey_points():
    rng = np.random.default_rng(2)
    normal = np.array([0.0, -0.6, 0.8])
    u = np.array([1.0, 0.0, 0.0])
    v = np.cross(normal, u)
    survey = rng.random((4000, 2)) @ np.vstack([u, v]) * 0.3 + 0.001 * rng.standard_normal((4000, 1)) * normal
    thinned = survey[:6] + 0.004 * rng.standard_normal((6, 3))  # six noisy points of it
    region = region_plane(thinned, "exact")
    planes = FacetPlanes.of([4000], [survey.mean(axis=0)], [np.cov(survey.T, bias=True)])
    [moved] = on_survey_planes([region], np.array([0]), planes)
    assert abs(abs(moved.normal @ normal) - 1) < 1e-5 < abs(abs(region.normal @ normal) - 1)
    assert abs(moved.u @ moved.normal) < 1e-12 and abs(moved.v @ moved.normal) < 1e-12
    assert moved.width == region.width and moved.n_points == region.n_points
    assert abs((moved.center - moved.centroid) @ moved.normal) < 1e-12
    # Kept from three thinned points when the survey holds the rule's points of it.
    kept = survey_min_points(np.array([30, 30]), np.array([0, -1]), planes, 30)
    assert kept.tolist() == [MIN_THINNED_POINTS, 30]


def test_only_a_region_that_is_one_facet_whole_is_one():
    region = np.array([0, 0, 0, 1, 1, 2, 2, 3])
    facet = np.array([4, 4, 4, 5, 6, 7, 7, 7])  # region 2 is part of facet 7: not whole
    assert whole_facets(region, facet, 4).tolist() == [4, -1, -1, -1]
