"""The detectors, by name: the one place a new detector is added.

Each entry says how it grows its regions (:mod:`geostructure.detect.growing`), whether a
streamed run can use it chunk by chunk, whether it finds the small joints of rough rock (the
sets' rock mass notes when it does not), the smallest region it reports by default, and what
to try when it finds no plane. The command line's ``--detector`` choices, the stream engine,
the automatic engine and the notes all read this table; ``Params.detector`` is checked
against the same names (:data:`geostructure.core.params.DETECTORS`).

Examples
--------
>>> sorted(DETECTORS), STREAMED_DETECTOR
(['facets', 'voxel'], 'voxel')
>>> detector_spec("facets").streams, detector_spec("voxel").default_min_points(1_000_000)
(False, 1000)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from geostructure.core import params as core_params
from geostructure.detect.growing import Growth, grow_facets_then_voxels, grow_voxel_regions
from geostructure.errors import ParameterError


def facet_min_points(n_points: int) -> int:
    """Facets grown on the points, and the regions the facet detector grows over voxel
    planes beside them: 30 whatever the cloud's size (a facet some 6 point spacings across,
    so joints down to 10 spacings are found), so that an outcrop measures the same alone or
    inside a larger survey."""
    return 30


def voxel_min_points(n_points: int) -> int:
    """Regions grown over voxel planes: 0.1% of the points, at least 30."""
    return max(30, int(0.001 * n_points))


@dataclass(frozen=True)
class Detector:
    """One detector.

    Parameters
    ----------
    name : str
        What ``--detector`` and ``Params.detector`` call it.
    help : str
        One line for ``--detector``'s help.
    grow : callable
        ``grow(filtered, voxels, params, report, counts, facets, keep) -> Growth``.
    streams : bool
        Whether a streamed run measures with it chunk by chunk; one that does not is run on
        a survey thinned to what fits in memory.
    finds_small_joints : bool
        Whether it finds the joint faces of rough rock a few voxels across; the sets' rock
        mass notes when it does not.
    default_min_points : callable
        ``default_min_points(n_points)``: the smallest region reported when none is given.
    no_plane_advice : str
        What to try when it finds no plane.
    """

    name: str
    help: str
    grow: Callable[..., Growth]
    streams: bool
    finds_small_joints: bool
    default_min_points: Callable[[int], int]
    no_plane_advice: str


DETECTORS: dict[str, Detector] = {
    spec.name: spec
    for spec in (
        Detector(
            "facets",
            "grown on per-point planes, down to small joints on rough rock, with the paper's voxel growing where "
            "a facet is curved",
            grow_facets_then_voxels,
            streams=False,
            finds_small_joints=True,
            default_min_points=facet_min_points,
            no_plane_advice="no plane found: no part of the cloud is flat over a few point spacings (vegetation, "
            "scatter, or noise as large as the spacing); --detector voxel fits coarser planes, and a larger --zeta "
            "coarser still.",
        ),
        Detector(
            "voxel",
            "the paper's region growing alone",
            grow_voxel_regions,
            streams=True,
            finds_small_joints=False,
            default_min_points=voxel_min_points,
            no_plane_advice="no plane found; if the cloud is sparse, try a larger --zeta (voxels need at least 5 "
            "points each to fit a plane).",
        ),
    )
}
#: The detector a streamed run measures with.
STREAMED_DETECTOR = next(name for name, spec in DETECTORS.items() if spec.streams)
if tuple(DETECTORS) != core_params.DETECTORS:  # pragma: no cover - a name added in one place only
    raise ImportError(f"core.params.DETECTORS {core_params.DETECTORS} differs from the registry's {tuple(DETECTORS)}")


def detector_spec(name: str) -> Detector:
    """The detector called ``name``; a name no detector has is refused, naming the choices."""
    try:
        return DETECTORS[name]
    except KeyError:
        raise ParameterError(f"--detector must be one of {', '.join(DETECTORS)}, not {name!r}.") from None
