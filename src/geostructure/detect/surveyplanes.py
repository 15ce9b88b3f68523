"""A thinned survey's facets measured on all the survey's points (docs/tiles.md).

A survey larger than memory is measured on a thinned cloud whose points carry the facets
found on every point of the survey, in tiles (:mod:`geostructure.stream.thinnedsurvey`). A facet
a few thinned cells across holds few thinned points: fitted on them, its plane is rough, and
under the in-memory rule's 30 points it was no plane at all, though the survey holds
hundreds of its points. Here a region that is exactly one facet (:func:`whole_facets`) is
judged by the survey's points (:func:`survey_min_points`) and takes the plane they give
(:func:`on_survey_planes`); its rectangle, from the thinned points, is turned into it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

#: The fewest thinned points of a facet that its survey's points make a plane: a region's
#: rectangle needs three.
MIN_THINNED_POINTS = 3


def whole_facets(point_region: np.ndarray, facet: np.ndarray, n_regions: int) -> np.ndarray:
    """Per region (``n_regions``), the facet it is exactly (every one of its points in that
    facet, and every point of that facet in it), -1 for the rest; ``point_region`` and
    ``facet`` (N,) are each point's region and facet, -1 for none.

    Examples
    --------
    >>> region = np.array([0, 0, 1, 1, 2, 2, -1])
    >>> facet = np.array([5, 5, 6, -1, 7, 7, 7])
    >>> whole_facets(region, facet, 3).tolist()
    [5, -1, -1]
    """
    point_region, facet = np.asarray(point_region), np.asarray(facet)
    out = np.full(n_regions, -1, dtype=np.int64)
    n_facets = int(facet.max(initial=-1)) + 1
    if not n_facets:
        return out
    on = point_region >= 0
    region_size = np.bincount(point_region[on], minlength=n_regions)
    facet_size = np.bincount(facet[facet >= 0], minlength=n_facets)
    both = on & (facet >= 0)
    codes, counts = np.unique(point_region[both].astype(np.int64) * n_facets + facet[both], return_counts=True)
    region, which = codes // n_facets, codes % n_facets
    whole = (counts == region_size[region]) & (counts == facet_size[which])
    out[region[whole]] = which[whole]
    return out


def survey_min_points(min_points, region_facet: np.ndarray, survey, rule: int) -> np.ndarray:
    """``min_points`` (per region) where a region that is one whole facet
    (``region_facet``) is judged by the survey's points of it: kept from
    :data:`MIN_THINNED_POINTS` thinned points when the survey holds ``rule`` of its points."""
    min_points = np.broadcast_to(np.asarray(min_points), region_facet.shape).copy()
    one = region_facet >= 0
    enough = np.zeros(len(region_facet), dtype=bool)
    enough[one] = survey.count[region_facet[one]] >= rule
    min_points[enough] = MIN_THINNED_POINTS
    return min_points


def on_survey_planes(regions: list, plane_facet: np.ndarray, survey) -> list:
    """``regions`` (:class:`~geostructure.detect.rectangle.RegionPlane`, one per plane), each
    that is one whole facet (``plane_facet``, -1 for none) on the plane of all the survey's
    points of it (``survey``, :class:`~geostructure.detect.tilejoin.FacetPlanes`): its
    centroid, normal (the region's sense kept) and residual; its rectangle turned into that
    plane, its size kept."""
    out = []
    for region, facet in zip(regions, np.asarray(plane_facet).tolist()):
        if facet < 0:
            out.append(region)
            continue
        normal = survey.normal[facet] * (1.0 if survey.normal[facet] @ region.normal >= 0 else -1.0)
        u = region.u - (region.u @ normal) * normal
        if np.linalg.norm(u) < 1e-6:  # the thinned plane across the survey's: keep it
            out.append(region)
            continue
        u = u / np.linalg.norm(u)
        v = np.cross(normal, u)
        v = v if v @ region.v >= 0 else -v
        centroid = survey.centroid[facet]
        center = region.center - ((region.center - centroid) @ normal) * normal
        out.append(replace(region, centroid=centroid, normal=normal, u=u, v=v, center=center,
                           residual=float(survey.residual[facet])))  # fmt: skip
    return out
