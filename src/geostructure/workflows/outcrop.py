"""One call for what ``geostructure measure --sets --kinematics`` does, in memory.

The command line parses its options, calls :func:`measure_outcrop` and :meth:`OutcropRun.save`,
and prints; a notebook gets the same result from the same two calls. The stages, in order,
as :data:`STAGES` runs them (each calls the library's own functions):

1. the coordinate system and north: a CRS given over the file's own, azimuths turned to
   true north by the grid convergence unless ``grid_north`` (:func:`~.io.crs.true_north_frame`);
2. the parameters: chosen from the cloud (:func:`~geostructure.detect.auto.choose_params`) unless ``auto`` is
   off or every factor is given;
3. the planes (:func:`~geostructure.detect.pipeline.measure`);
4. with ``sets``: the joint sets and the rock mass (:func:`~geostructure.workflows.sets_and_mass.sets_and_rock_mass`), and
   the notes on what the face hides;
5. with ``sets``: the fracture traces (:func:`~geostructure.workflows.sets_and_mass.rock_traces`);
6. with ``kinematics``: the slope fitted to the face (:func:`~geostructure.kinematics.slope.fit_face`)
   unless given, and the tests on the planes and sets held
   (:func:`~geostructure.workflows.kinematics.kinematic_tests`); :meth:`OutcropRun.save` writes
   their files with the rest.

Examples
--------
>>> from geostructure.synthetic import outcrop_scene
>>> run = measure_outcrop(outcrop_scene(width=6.0, height=4.0, seed=1).cloud, sets=True)
>>> len(run.sets), len(run.planes) > 50
(3, True)
"""

from __future__ import annotations

import dataclasses
import functools
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geostructure.core.bounds import column_max, column_min
from geostructure.core.cloud import Cloud
from geostructure.core.density import point_spacing
from geostructure.core.orientation import Frame
from geostructure.core.params import Params
from geostructure.core.strays import MIN_NEIGHBOURS, STRAY_RADIUS_SPACINGS, stray_points
from geostructure.detect.auto import choose_params
from geostructure.detect.pipeline import Measurement, check_measurable, measure
from geostructure.errors import GeoStructureNote, GeoStructureWarning
from geostructure.io.crs import cloud_unit, describe_north, given_crs, note_unstated_unit, true_north_frame
from geostructure.io.survey_files import read_tiles
from geostructure.kinematics.slope import fit_face
from geostructure.kinematics.summary import KinematicResult
from geostructure.rockmass.face import FACE
from geostructure.rockmass.mass import RockMass, with_rock_mass
from geostructure.rockmass.notes import note_bent_face, note_tilt_unread, note_vegetation, note_voxel_planes
from geostructure.rockmass.sets import JointSets
from geostructure.workflows.kinematics import kinematic_tests, write_kinematic_files
from geostructure.workflows.saving import save_measurement
from geostructure.workflows.sets_and_mass import detected_spacing, rock_traces, sets_and_rock_mass

#: The factors the automatic choice sets, unless given.
FACTORS = ("zeta", "theta", "psi", "k")


@dataclass
class OutcropRun:
    """What :func:`measure_outcrop` found: the measure (``result``: planes, labels, the
    parameters and frame used), the joint sets and rock mass when asked, the kinematic
    settings (the fitted slope in them), and what ``run.json`` records of the run beyond the
    measure (``record``: the automatic choice, the unit, north). With the kinematics,
    ``tested`` holds the tests' results and ``kinematics`` their summary; after
    :meth:`save`, ``paths`` holds the files written.

    Parameters
    ----------
    result : Measurement
        The measure.
    sets : JointSets, optional
        The joint sets.
    rock : RockMass, optional
        Their spacing, persistence and intensity.
    kinematic_options : dict, optional
        The kinematic tests' settings, the slope fitted in them.
    record : dict
        What ``run.json`` says of the run beyond the measure.
    kinematics : dict
        The kinematic tests' summary (what ``kinematics.json`` holds).
    tested : KinematicResult, optional
        The kinematic tests' results, which :meth:`save` writes.
    paths : dict
        Output kind -> path of each file written, after :meth:`save`.

    Examples
    --------
    >>> import tempfile
    >>> from geostructure.synthetic import outcrop_scene
    >>> run = measure_outcrop(outcrop_scene(width=6.0, height=4.0, seed=1).cloud, sets=True,
    ...                       kinematics={"friction": 30.0})
    >>> "planar_sliding" in run.kinematics  # tested before anything is written
    True
    >>> paths = run.save(tempfile.mkdtemp())
    >>> sorted(k for k in paths if k.startswith("kin"))
    ['kinematics', 'kinematics_json', 'kinematics_png']
    """

    result: Measurement
    sets: JointSets | None = None
    rock: RockMass | None = None
    kinematic_options: dict | None = None
    record: dict = field(default_factory=dict)
    kinematics: dict = field(default_factory=dict)
    paths: dict = field(default_factory=dict)
    tested: KinematicResult | None = None

    @property
    def planes(self):
        """The plane table, with the sets' and rock mass's columns when measured."""
        return self.result.planes if self.sets is None else with_rock_mass(self.result.planes, self.sets, self.rock)

    def save(
        self, outdir, *, extra: dict | None = None, evaluation=None, report: bool = False, inputs=(),
        point_files=True, progress=None,
    ) -> dict[str, Path]:  # fmt: skip
        """Write the folder as the command does, as one set: the measure's files, the sets',
        the kinematic tests' (run here, on the staged files) and the report; returns output
        kind -> path. ``extra``: more entries for ``run.json``; ``point_files`` as
        :func:`~geostructure.workflows.saving.save_measurement` takes it."""
        report_stage = progress or (lambda stage, done, total: None)
        result = self.result

        def kinematics_into_set(outputs):
            """The kinematic tests' files, in the measure's own set: one command, one commit."""
            return write_kinematic_files(outputs, self.tested, progress)

        report_stage("write", 0, None)
        if callable(point_files) and progress is not None:  # a thinned survey's: its own bar
            point_files = functools.partial(point_files, progress=progress)
        self.paths = save_measurement(
            result,
            outdir,
            extra={"auto": self.record.get("auto"), **(extra or {}), **self.record},  # run.json's order
            evaluation=evaluation,
            report=report,
            inputs=inputs,
            sets=self.sets,
            rock=self.rock,
            point_files=point_files,
            then=kinematics_into_set if self.tested is not None else None,
        )
        return self.paths

    def tables(self) -> dict:
        """The planes, and the sets when measured, as pandas DataFrames (``pip install
        pandas``): one row per plane or set, the columns of ``planes.csv`` and ``sets.csv``."""
        import pandas as pd

        tables = {"planes": pd.DataFrame(self.planes.rows())}
        if self.sets is not None:
            rows = self.sets.rows()
            if self.rock is not None:
                rows = [{**a, **b} for a, b in zip(rows, self.rock.set_rows())]
            tables["sets"] = pd.DataFrame(rows)
        return tables


def measure_outcrop(
    cloud,
    *,
    frame: Frame = Frame(),
    params: Params | None = None,
    auto: bool = True,
    given: dict | None = None,
    crs: str | None = None,
    unit: str | None = None,
    grid_north: bool = False,
    sets: bool = False,
    n_sets: int | None = None,
    kinematics: dict | None = None,
    progress=None,
    seconds: dict | None = None,
    on_choice=None,
    facets=None,
) -> OutcropRun:
    """Measure an outcrop as ``geostructure measure`` does, automatic parameters included.

    Parameters
    ----------
    cloud : Cloud, path or list of paths
        The cloud, or its file(s) (tiles of one survey).
    frame : Frame
        Which way east, north and up point in the cloud's axes.
    params : Params, optional
        The parameters other than the automatic ones (the filter, the detector, ...).
    auto : bool
        Choose zeta, theta, psi and k from the cloud; those in ``given`` still win.
    given : dict, optional
        Factors set by hand (``{"zeta": 0.02}``).
    crs : str, optional
        The cloud's coordinate reference system when its file declares none (``EPSG:32633``).
    unit : str, optional
        The length unit of a cloud without a CRS (``m``, ``cm``, ``mm``, ``ft``, ``us-ft``).
    grid_north : bool
        Read azimuths against the CRS's grid north instead of true north.
    sets : bool
        Also find the joint sets and the rock mass.
    n_sets : int, optional
        How many sets; chosen by BIC when not given.
    kinematics : dict, optional
        The kinematic tests' settings, as :func:`~geostructure.workflows.kinematics.write_kinematics_into` takes
        them (``friction`` at least; ``slope`` None: fitted to the face). Needs ``sets``.
    progress : callable, optional
        ``progress(stage, done, total)``.
    seconds : dict, optional
        Times already spent (reading), for ``run.json``.
    on_choice : callable, optional
        Called with the automatic choice's description, before the measure.
    facets : callable, optional
        The facets found elsewhere, as :func:`~geostructure.detect.pipeline.measure` takes
        them (a thinned survey's, found on every point in tiles).

    Returns
    -------
    OutcropRun

    Raises
    ------
    GeoStructureError
        A cloud that cannot be measured, parameters that mean nothing.

    Examples
    --------
    >>> from geostructure.synthetic import outcrop_scene
    >>> run = measure_outcrop(outcrop_scene(width=6.0, height=4.0, seed=1).cloud)
    >>> sorted(run.record["auto"])[:3], len(run.planes) > 50
    (['k', 'normal_noise_deg', 'offset_noise_voxel_edges'], True)
    """
    if not isinstance(cloud, Cloud):
        paths = [Path(p) for p in ([cloud] if isinstance(cloud, (str, Path)) else cloud)]
        t = time.perf_counter()
        cloud = read_tiles(paths)
        seconds = {"read": time.perf_counter() - t, **(seconds or {})}
    measuring = _Measuring(cloud, frame, params or Params(), crs, unit, dict(seconds or {}), progress,
                           dict(auto=auto, given=dict(given or {}), grid_north=grid_north, sets=sets, n_sets=n_sets,
                                kinematics=kinematics, on_choice=on_choice, facets=facets))  # fmt: skip
    for _, stage in STAGES:
        stage(measuring)
    return measuring.measured


@dataclass
class _Measuring:
    """What each stage of :func:`measure_outcrop` hands on to the next: the cloud and frame as
    placed, the CRS and unit, the times so far, the options, and the run once measured."""

    cloud: Cloud
    frame: Frame
    params: Params
    crs: str | None
    unit: str | None
    seconds: dict
    progress: Callable | None
    options: dict
    record: dict = field(default_factory=dict)
    run: OutcropRun | None = None

    @property
    def measured(self) -> OutcropRun:
        """The run, once the planes' stage made it."""
        if self.run is None:
            raise RuntimeError("a stage after the planes ran before them")  # STAGES' order
        return self.run

    def report(self, stage: str) -> None:
        if self.progress is not None:
            self.progress(stage, 0, None)


def _place(m: _Measuring) -> None:
    """The cloud without its strays, its CRS (a given one over the file's), its azimuths
    turned to true north by the grid convergence unless ``grid_north``, its unit."""
    m.cloud = without_strays(m.cloud)  # before anything reads the cloud's extent
    m.crs = given_crs(m.crs, m.cloud.crs, m.cloud.source)
    if m.crs != m.cloud.crs:
        m.cloud = dataclasses.replace(m.cloud, crs=m.crs)
    cloud, north = m.cloud, None
    if cloud.crs is not None and not m.options["grid_north"] and len(cloud):
        m.frame, north = true_north_frame(m.frame, cloud.crs, cloud.offset + column_min(cloud.local),
                                          cloud.offset + column_max(cloud.local))  # fmt: skip
    if m.crs is not None or m.unit is not None:
        m.record["unit"] = cloud_unit(m.crs, m.unit)
    if north:
        m.record["north"] = north
        warnings.warn(describe_north(north), GeoStructureNote, stacklevel=2)


def _planes(m: _Measuring) -> None:
    """The parameters, chosen from the cloud unless ``auto`` is off or every factor is
    given, and the planes."""
    t = time.perf_counter()
    m.report("auto")
    params, choice, moments = chosen_params(m.cloud, m.params, m.options["auto"], m.options["given"],
                                            m.options["on_choice"])  # fmt: skip
    auto_seconds = time.perf_counter() - t
    result = measure(m.cloud, params, m.frame, m.progress, moments=moments, facets=m.options["facets"])
    del moments
    result.seconds = {**m.seconds, "auto": auto_seconds, **result.seconds}
    m.params, m.run = params, OutcropRun(result, record={"auto": choice, **m.record})


def _sets(m: _Measuring) -> None:
    """With ``sets``: the joint sets and the rock mass, and the notes on what the face hides."""
    if not m.options["sets"]:
        return
    run, cloud = m.measured, m.cloud
    result = run.result
    t = time.perf_counter()
    if m.crs is None and m.unit is None and cloud.enu_origin is None:  # a reconstruction knows its scale
        note_unstated_unit(detected_spacing(result.detection), cloud.source)
    # The traces are the next stage's (_traces).
    run.sets, run.rock = sets_and_rock_mass(result.filtered.local, result.labels, result.planes, result.frame,
                                            m.options["n_sets"], m.report,
                                            errors=result.planes.standard_errors(),  # as measured: no tilt yet
                                            spacing=detected_spacing(result.detection),
                                            metres_per_unit=cloud_unit(m.crs, m.unit)["metres"],
                                            vegetation=result.filtered.vegetation,
                                            traces=False)  # fmt: skip
    rock = run.rock
    note_vegetation(result.filtered.vegetation, rock, cloud.source)
    note_voxel_planes(m.params.detector, cloud.source)
    note_bent_face(rock.face_bend, cloud.source, rock.face_sections)
    note_tilt_unread(rock.tilt_facets_short, cloud.source, rock.tilt_facets_along)
    result.seconds["sets"] = time.perf_counter() - t


def _traces(m: _Measuring) -> None:
    """With ``sets``: the face's fracture traces (the planes' and the dark lines), each in
    its set, which the rock mass's trace columns read."""
    run = m.measured
    if run.sets is None or run.rock is None:  # without sets, no traces
        return
    result = run.result
    m.report("traces")
    t = time.perf_counter()
    run.rock.traces = rock_traces(result.filtered.local, result.labels, result.planes, run.sets, run.rock,
                                  result.filtered.grey)  # fmt: skip
    result.seconds["traces"] = time.perf_counter() - t


def _kinematics(m: _Measuring) -> None:
    """With ``kinematics``: the slope fitted to the face unless given, and the tests on the
    planes and sets held."""
    if m.options["kinematics"] is None:
        return
    run = m.measured
    result = run.result
    kinematics = dict(m.options["kinematics"])
    if kinematics.get("slope") is None and run.rock is not None:
        # The face the sets' rock mass was read on, fitted here, where its points are:
        # the folder's would be read back and told from their ground and clutter again.
        members = None if run.rock.point_part is None else run.rock.point_part == FACE
        kinematics["slope"] = fit_face(result.filtered.local, result.frame, members, bend=run.rock.face_bend,
                                       offset=result.filtered.offset, sections=run.rock.sections)  # fmt: skip
    run.kinematic_options = kinematics
    held = result.filtered.local + (result.filtered.offset - result.planes.offset)  # as the folder holds them
    run.tested = kinematic_tests(
        run.planes, [] if run.sets is None else run.sets.rows(), frame=result.frame, detection=result.detection,
        metres_per_unit=cloud_unit(m.crs, m.unit)["metres"], points=(held, result.labels, result.filtered.vegetation),
        progress=m.progress, **kinematics,
    )  # fmt: skip
    run.kinematics = run.tested.summary


#: The stages of :func:`measure_outcrop`, in order (as MintPy keeps its ``STEP_LIST``): each
#: takes what the ones before it handed on. A new stage goes here.
STAGES = (("place", _place), ("planes", _planes), ("sets", _sets), ("traces", _traces), ("kinematics", _kinematics))


def without_strays(cloud: Cloud) -> Cloud:
    """``cloud`` without its stray points (:func:`~geostructure.core.strays.stray_points`),
    said in a warning and counted in ``run.json``'s ``left_out`` as ``strays``."""
    if len(cloud) < 10:
        return cloud
    spacing = point_spacing(cloud.local)
    strays = stray_points(cloud.local, spacing)
    n = int(np.count_nonzero(strays))
    if not n:
        return cloud
    first = int(np.argmax(strays))
    warnings.warn(
        f"{cloud.source}: left out {n:,} stray point(s), each with at most {MIN_NEIGHBOURS} others within "
        f"{STRAY_RADIUS_SPACINGS:g} point spacings ({STRAY_RADIUS_SPACINGS * spacing:.3g} in the cloud's unit) (the first is "
        f"point number {first + 1:,}, counting from 1): one such point made the cloud's extent, and every "
        f"parameter read from it, many times the rock's.",
        GeoStructureWarning,
        stacklevel=3,
    )
    kept = cloud.subset(~strays)
    return dataclasses.replace(kept, left_out={**(cloud.left_out or {}), "strays": n})


def chosen_params(cloud: Cloud, params: Params, auto: bool, given: dict, on_choice=None):
    """The parameters a run takes: ``params`` with the automatic choice where asked (the
    ``given`` factors still win), the choice's record for ``run.json`` (None without one)
    and the voxel moments it summed (for ``measure(..., moments=)``); ``on_choice`` is
    told the choice in words."""
    if given and any(getattr(params, name) != value for name, value in given.items()):
        params = params.with_(**given)
    if not auto or len(given) == len(FACTORS):
        return params, None, None
    check_measurable(cloud)
    choice = choose_params(cloud.local, params)
    chosen = choice.params.with_(**given) if given else choice.params
    if on_choice is not None:
        on_choice(choice.describe() + (f"; given: {given}" if given else ""))
    return chosen, choice.to_dict(given), choice.moments
