"""The joint sets and rock mass of a measured plane table, as the commands find them: the
sets by area (:func:`plane_sets`), the rock mass read on the cloud's face
(:func:`plane_rock_mass`), both with their standard errors and the notes on what the face
hides (:func:`sets_and_rock_mass`). :mod:`.saving` writes them; :mod:`.outcrop` calls
them in one go.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from geostructure.core.orientation import Frame
from geostructure.core.planes import Planes
from geostructure.core.threads import finished_pool, preload
from geostructure.detect.uncertainty import normal_standard_errors, with_correlated_tilt
from geostructure.io.crs import in_metres
from geostructure.rockmass.exposure import exposure
from geostructure.rockmass.face import face_parts
from geostructure.rockmass.mass import RockMass, rock_mass
from geostructure.rockmass.sets import JointSets, find_sets
from geostructure.rockmass.tracemaps import along_edge, censored_ends, face_traces


def plane_sets(
    planes: Planes,
    frame: Frame = Frame(),
    n_sets: int | None = None,
    *,
    metres_per_unit: float = 1.0,
    leave_out=None,
) -> JointSets:
    """The joint sets of a plane table: poles weighted by area (:func:`~geostructure.rockmass.sets.find_sets`),
    the planes' centroids in metres (``metres_per_unit`` of the table's coordinates, as
    :func:`~.io.crs.metres_per_unit` reads it from the CRS) for the joints' metric tolerances.
    The planes ``leave_out`` marks (a boolean per plane: the ground and the clutter,
    :attr:`~geostructure.rockmass.face.FaceParts.off_face`) are clustered with no set and left in none.

    Examples
    --------
    >>> import numpy as np
    >>> from geostructure.synthetic import fisher_directions
    >>> rng = np.random.default_rng(0)
    >>> normals = np.vstack([fisher_directions(n, 60.0, 40, rng) for n in ([0, -0.7, 0.7], [0.9, 0, 0.4])])
    >>> sets = plane_sets(Planes(normal=normals, area=rng.uniform(0.1, 2.0, 80)))
    >>> len(sets), sets.n_planes.sum()
    (2, np.int64(80))
    """
    rows = np.arange(len(planes)) if leave_out is None else np.flatnonzero(~np.asarray(leave_out, dtype=bool))
    centroids = planes.local_centroid[rows] * metres_per_unit
    sets = find_sets(planes.normal[rows], planes.area[rows], n_sets=n_sets, frame=frame, centroids=centroids)
    if len(rows) < len(planes):
        labels = np.full(len(planes), -1)
        labels[rows] = sets.labels
        sets = replace(sets, labels=labels)
    return sets if metres_per_unit == 1.0 else replace(sets, area=sets.area * metres_per_unit**2)


def plane_rock_mass(
    points,
    labels,
    planes: Planes,
    sets: JointSets,
    frame: Frame = Frame(),
    *,
    face=None,
    parts=None,
    errors=None,
    metres_per_unit: float = 1.0,
    metric=None,
    grey=None,
    traces: bool = True,
) -> RockMass:
    """Spacing, persistence and intensity of the sets of a plane table (:func:`~geostructure.rockmass.mass.rock_mass`).

    Parameters
    ----------
    points : (N, 3) array
        The labelled points, relative to ``planes.offset``.
    labels : (N,) int array
        Each point's plane (its row in ``planes``), -1 for none.
    planes : Planes
    sets : JointSets
        The planes' sets (:func:`plane_sets`).
    frame : Frame
        The run's frame, whose up gives strike and dip.
    face : :class:`~geostructure.rockmass.exposure.Exposure`, optional
        The points' exposure (in metres), when it was made already.
    parts : :class:`~geostructure.rockmass.face.FaceParts`, optional
        The face's ground and clutter (:func:`~geostructure.rockmass.face.face_parts`), with ``face``.
    errors : dict, optional
        The planes' block standard errors as measured (:meth:`~geostructure.core.planes.Planes.standard_errors`
        of a fresh :func:`~geostructure.measure`'s table). Without them they are computed
        again: a folder's table may carry a correlated tilt already, which must not be
        added twice.
    metres_per_unit : float
        Metres in one unit of ``points`` (:func:`~.io.crs.metres_per_unit`): the rock mass's
        lengths, areas and intensities are in metres, whatever the cloud's unit.
    metric : (N, 3) array, optional
        ``points`` in metres, when scaled already (the exposure's caller scales them once).
    grey : (N,) array, optional
        The points' brightness (:attr:`~geostructure.core.cloud.Cloud.grey`): the dark lines
        among the traces (:func:`~geostructure.rockmass.tracemaps.face_traces`); the planes'
        traces alone without it.
    traces : bool
        Draw the fracture traces too (:func:`rock_traces`); without, ``rock.traces`` is None
        until a later stage draws them.
    """
    up = frame.matrix[2]
    if errors is None:
        errors = normal_standard_errors(points, labels, planes.normal, planes.local_centroid, planes.rect_u, up)
    metric = in_metres(points, metres_per_unit) if metric is None else metric
    rock = rock_mass(metric, labels, planes.normal, sets.labels, sets.mean_normal, up, errors["normal"], face=face,
                     parts=parts)  # fmt: skip
    rock.plane_errors = with_correlated_tilt(errors, rock.correlated_tilt, planes.normal, up)
    rock.metres_per_unit = float(metres_per_unit)
    if traces:
        rock.traces = rock_traces(points, labels, planes, sets, rock, grey)
    return rock


def rock_traces(points, labels, planes: Planes, sets: JointSets, rock: RockMass, grey=None):
    """The face's fracture traces (:func:`~geostructure.rockmass.tracemaps.face_traces`) of
    the discontinuities alone (no ground, clutter or face surface, :func:`sets_left_out`),
    the dark lines on the face's own points, each in a set of ``sets``, with the ends that
    reach the exposure's edge (:func:`~geostructure.rockmass.tracemaps.censored_ends`);
    ``points``, ``labels`` and ``grey`` as :func:`plane_rock_mass` takes them."""
    tested = ~sets_left_out(planes, rock)
    traces = face_traces(points, labels, planes, sets, rock.point_part, grey, tested)
    traces.censored_ends = censored_ends(traces, rock.exposures, rock.metres_per_unit)
    rim = along_edge(traces, rock.exposures, rock.metres_per_unit, traces.censored_ends)  # its outline, no fracture's
    return traces.subset(~rim) if rim.any() else traces


def sets_left_out(planes: Planes, rock: RockMass) -> np.ndarray:
    """The planes that are no discontinuity: the ground, the clutter, the face's own surface."""
    n = len(planes)
    out = np.asarray(planes.extra.get("face_surface", np.zeros(n))) > 0
    for flags in (rock.ground, rock.clutter):
        if flags is not None:
            out = out | np.asarray(flags, dtype=bool)
    return out


def sets_and_rock_mass(
    points,
    labels,
    planes: Planes,
    frame: Frame = Frame(),
    n_sets: int | None = None,
    progress=None,
    *,
    errors=None,
    spacing: float | None = None,
    metres_per_unit: float = 1.0,
    vegetation=None,
    grey=None,
    traces: bool = True,
) -> tuple[JointSets, RockMass]:
    """:func:`plane_sets`, then :func:`plane_rock_mass` (``errors`` as it takes them); the
    exposure's grid, which needs the points alone, is made in a thread meanwhile (its
    kd-tree and grid are numpy's and scipy's work, the sets' EM mostly Python's: on the
    0.7M-point outcrop the two overlap). ``progress(stage)`` is told each stage as it starts;
    ``spacing``, the points' spacing as the facet detector read it (:func:`detected_spacing`),
    spares the exposure reading it again. ``metres_per_unit``: as :func:`plane_rock_mass`
    takes it. ``vegetation``: the points the input classifies so, clutter
    (:func:`~geostructure.rockmass.face.face_parts`). ``grey``: the points' brightness, for
    the traces' dark lines; ``traces``: as :func:`plane_rock_mass` takes it.

    Examples
    --------
    >>> from geostructure import measure
    >>> from geostructure.synthetic import outcrop_scene
    >>> result = measure(outcrop_scene(width=6.0, height=4.0, seed=1).cloud)
    >>> sets, rock = sets_and_rock_mass(result.filtered.local, result.labels, result.planes)
    >>> len(sets), len(rock.spacing)
    (3, 3)
    """
    report = progress or (lambda stage: None)
    report("sets")
    preload("scipy.ndimage")  # the exposure's thread imports it (threads.preload says why)
    with finished_pool(1) as pool:  # left only once the exposure is done, error or not
        f, metric = metres_per_unit, in_metres(points, metres_per_unit)  # one copy, for a cloud in feet
        # The face without the ground before it and the clutter (vegetation) on it.
        parts = face_parts(points, labels, planes.normal, frame.matrix[2], spacing=spacing, vegetation=vegetation)
        face = pool.submit(exposure, metric, frame.matrix[2], spacing=spacing and spacing * f, members=parts.members)
        # On rough rock, the planes of the face's own surface are no discontinuity either.
        leave_out = parts.off_face | (np.asarray(planes.extra.get("face_surface", 0)) > 0)
        sets = plane_sets(planes, frame, n_sets, metres_per_unit=f, leave_out=leave_out)
        report("spacing and persistence")
        rock = plane_rock_mass(points, labels, planes, sets, frame, face=face.result(), parts=parts, errors=errors,
                               metres_per_unit=f, metric=metric, grey=grey, traces=traces)  # fmt: skip
    return sets, rock


def detected_spacing(detection: dict | None) -> float | None:
    """The point spacing the facet detector read (a run's ``detection`` record), if it ran.

    Examples
    --------
    >>> detected_spacing({"facet_thresholds": {"spacing": 0.03}}), detected_spacing(None)
    (0.03, None)
    """
    spacing = ((detection or {}).get("facet_thresholds") or {}).get("spacing")
    return float(spacing) if spacing else None
