"""The slope face the kinematic tests are made against: fitted to an outcrop cloud
(:func:`fit_slope`), and on a face that turns, one slope per section (:func:`fit_face`).
The tests are :mod:`.modes`; running them on a measured folder is
:mod:`geostructure.workflows.kinematics`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geostructure.core.orientation import Frame, orientation_from_normals
from geostructure.detect.uncertainty import normal_standard_errors
from geostructure.kinematics.modes import Slope
from geostructure.rockmass.exposure import face_bend, face_plane
from geostructure.rockmass.sections import FaceSections, face_sections


@dataclass(frozen=True)
class FittedFace:
    """A slope fitted to a cloud: the whole face's plane (``slope``), and for a face that
    turns its ``sections`` (:mod:`.sections`) with each one's own fitted slope (``slopes``,
    in the sections' order; the whole face's alone for a face that does not turn).
    ``offset``: what the fitted points were relative to (a cloud's ``offset``)."""

    slope: Slope
    sections: FaceSections | None
    slopes: tuple[Slope, ...]
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def plane_sections(self, planes) -> np.ndarray:
        """The section each plane of a table lies in (its centroid's)."""
        if self.sections is None or len(self.slopes) == 1:
            return np.zeros(len(planes), dtype=np.int64)
        return self.sections.of(planes.centroid - np.asarray(self.offset))


def fit_face(
    points, frame: Frame = Frame(), members=None, bend: float | None = None, offset=None, sections=None
) -> FittedFace:
    """The slope of an outcrop cloud (:func:`fit_slope`), and for a face that turns, the
    slope of each of its sections (:func:`~geostructure.rockmass.sections.face_sections`), each fitted to the
    points of its own section.

    Parameters
    ----------
    points, frame, members, bend
        As :func:`fit_slope` takes them.
    offset : (3,) array, optional
        What ``points`` are relative to (the cloud's), for the planes' sections.
    sections : FaceSections, optional
        The face's sections, when the rock mass cut them already.

    Returns
    -------
    FittedFace
        The whole face's slope (``slope``) and, for a face that turns, each section's
        (``slopes``) with the section each point lies in.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, v = rng.random((2, 40_000)) * [[24.0], [6.0]]
    >>> arm = u > 12  # a cut dipping 70 degrees that turns a right angle half way along
    >>> x = np.where(arm, 12.0 + v * np.cos(np.radians(70)), u)
    >>> y = np.where(arm, 12.0 - u, v * np.cos(np.radians(70)))
    >>> face = fit_face(np.column_stack([x, y, v * np.sin(np.radians(70))]))
    >>> round(face.slope.dip), [(round(s.dip), round(s.dip_direction)) for s in face.slopes]
    (10, [(70, 180), (70, 270)])
    """
    points = np.asarray(points, dtype=np.float64)
    if members is not None:
        points = points[members]
    offset = tuple(np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64).reshape(3))
    slope = fit_slope(points, frame, bend=bend)
    if sections is None:
        sections = face_sections(points, frame.matrix[2], bend=slope.face_bend)
    if len(sections) == 1:
        return FittedFace(slope, sections, (slope,), offset)
    label = sections.of(points)
    slopes = tuple(fit_slope(points[label == k], frame) for k in range(len(sections)))
    return FittedFace(slope, sections, slopes, offset)


def fit_slope(points, frame: Frame = Frame(), members=None, bend: float | None = None) -> Slope:
    """The overall face of an outcrop cloud: the least-squares plane of all its points (not
    its largest joint), with the standard errors of its dip and dip direction from a block
    regression over the whole face (:func:`~geostructure.detect.uncertainty.normal_standard_errors`).
    ``members`` (:func:`~geostructure.rockmass.face.face_members`) leaves the ground before or above the face and
    the clutter on it out (see :func:`~geostructure.rockmass.exposure.exposure`). ``bend``: how far those points
    turn (:func:`~geostructure.rockmass.exposure.face_bend`), when the sets' exposure measured it already.

    Parameters
    ----------
    points : (N, 3) array
        The cloud's points (local coordinates).
    frame : Frame
        Which way east, north and up point in the cloud.
    members : (N,) bool array, optional
        The points of the face (:func:`~geostructure.rockmass.face.face_members`); all by default.
    bend : float, optional
        How far the face turns along its strike (degrees); measured here when not given.

    Returns
    -------
    Slope
        The face's dip and dip direction with their standard errors, ``source`` "fitted".

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ab = rng.random((20_000, 2)) * [10.0, 5.0]
    >>> face = np.column_stack([ab[:, 0], ab[:, 1] * np.cos(np.radians(70)), ab[:, 1] * np.sin(np.radians(70))])  # rising north
    >>> slope = fit_slope(face + 0.01 * rng.standard_normal(face.shape))
    >>> round(slope.dip), round(slope.dip_direction), slope.source
    (70, 180, 'fitted')
    """
    points = np.asarray(points, dtype=np.float64)
    up = frame.matrix[2]
    if members is not None:
        points = points[members]
    # The plane alone: the exposure's occupancy grid (and the density read for it) is not needed.
    origin, normal, axes = face_plane(points, up)
    labels = np.zeros(len(points), dtype=np.int64)
    errors = normal_standard_errors(points, labels, normal[None, :], origin[None, :], axes[:1], up)
    o = orientation_from_normals(normal, frame)
    return Slope(
        float(o.dip[0]),
        float(o.dip_direction[0]),
        float(errors["dip"][0]),
        float(errors["dip_direction"][0]),
        "fitted",
        face_bend(points, up) if bend is None else float(bend),
    )
