"""What a run says after it measured: no plane found (and what to try, by detector), few
points in planes, no GIS file for a cloud without a place. In memory and streamed alike."""

from __future__ import annotations

import warnings

from geostructure.detect.registry import detector_spec
from geostructure.errors import GeoStructureNote, GeoStructureWarning
from geostructure.io.gis import NO_CRS_NOTE

#: Below this share of the filtered points in a plane, a run says how few are.
FEW_IN_PLANES = 0.5


def say_what_was_left(
    n_planes: int, detector: str, has_place: bool, min_points: int | None = None, counts: dict | None = None
) -> None:
    """After a run: the advice when no plane was found (a warning), a note when planes hold
    fewer than :data:`FEW_IN_PLANES` of the filtered points (``counts``, the run's), and the
    note that no GIS file was written when the cloud has no CRS (notes, which ``-q``
    silences). In memory and streamed alike. ``min_points``: the user's ``--min-points``,
    when given."""
    if not n_planes:
        warnings.warn(no_plane_advice(detector, min_points), GeoStructureWarning, stacklevel=2)
    counts = counts or {}
    kept, held = counts.get("filtered", 0), counts.get("labelled_points", 0)
    if n_planes and kept and held < FEW_IN_PLANES * kept:
        warnings.warn(
            f"only {held:,} of the {kept:,} points ({held / kept:.0%}) lie in a plane: the rest are on surfaces too "
            f"rough, curved or small to measure as one (planes.csv lists what was measured; regions.ply marks the "
            f"rest -1).",
            GeoStructureNote,
            stacklevel=2,
        )
    if not has_place:
        warnings.warn(NO_CRS_NOTE, GeoStructureNote, stacklevel=2)


def no_plane_advice(detector: str, min_points: int | None = None) -> str:
    """What to try when a run finds no plane, for the detector it ran; with the user's
    ``--min-points``, that first (a plane smaller than it is not reported, however flat).

    Examples
    --------
    >>> no_plane_advice("facets", 100_000)
    'no plane found of 100,000 points or more (--min-points): a smaller --min-points reports smaller planes.'
    """
    if min_points is not None:
        return f"no plane found of {min_points:,} points or more (--min-points): a smaller --min-points reports smaller planes."
    return detector_spec(detector).no_plane_advice


def say_after(result) -> None:
    """:func:`say_what_was_left` of a measure's result (in memory or streamed): its
    detector, whether its cloud has a place on the map, the user's ``min_points``."""
    cloud = result.cloud
    has_place = cloud.crs is not None or getattr(cloud, "enu_origin", None) is not None
    say_what_was_left(len(result), result.params.detector, has_place, result.params.min_points, result.counts)
