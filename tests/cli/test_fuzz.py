"""Property-based fuzzing of every reader and of the options: mutated valid files
(truncated, bytes flipped, headers lying about their counts), random text and random
option values. Each case ends in a clean result, or in one sentence naming the file with
exit status 2: never a traceback, a library's warning, or a partial output folder.

Hypothesis is derandomized (the same cases every run, so CI cannot flake) and bounded so
the whole file runs in seconds; ``GEOSTRUCTURE_FUZZ_SCALE=N`` runs N times as many new cases.
"""

from __future__ import annotations

import os
import re
import struct
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from helpers import assert_one_sentence, folder_digests, write_xyz
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geostructure.cli import main
from geostructure.errors import GeoStructureError, GeoStructureWarning
from geostructure.io.outdir import verified_record
from geostructure.io.planetable import read_planes_csv
from geostructure.io.readers import read_cloud
from geostructure.io.truth import read_truth
from geostructure.reconstruct.georef import read_gcp_csv

pytestmark = pytest.mark.slow

#: More cases on request (``GEOSTRUCTURE_FUZZ_SCALE=20 make test``), new ones each time with a seed.
SCALE = int(os.environ.get("GEOSTRUCTURE_FUZZ_SCALE", "1"))
FUZZ = settings(
    max_examples=60,
    deadline=None,
    derandomize=SCALE == 1,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
FORMATS = ("ascii.ply", "binary.ply", "mesh.ply", "c.las", "c.laz", "c.e57", "c.xyz", "c.csv")


@pytest.fixture(scope="module")
def valid(tmp_path_factory) -> dict[str, bytes]:
    """One small valid file per reader (500 points at UTM coordinates), as bytes."""
    import laspy
    import pye57
    from plyfile import PlyData, PlyElement

    folder = tmp_path_factory.mktemp("valid")
    rng = np.random.default_rng(0)
    points = rng.random((500, 3)) * [10, 10, 0.05] + [500_000, 4_600_000, 100]
    vertex = np.zeros(len(points), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    vertex["x"], vertex["y"], vertex["z"] = points.T
    faces = np.empty(100, dtype=[("vertex_indices", "i4", (3,))])
    faces["vertex_indices"] = rng.integers(0, 500, (100, 3))
    PlyData([PlyElement.describe(vertex, "vertex")], text=True).write(str(folder / "ascii.ply"))
    PlyData([PlyElement.describe(vertex, "vertex")], text=False).write(str(folder / "binary.ply"))
    PlyData([PlyElement.describe(vertex, "vertex"), PlyElement.describe(faces, "face")], text=False).write(
        str(folder / "mesh.ply")
    )
    for suffix in ("las", "laz"):
        header = laspy.LasHeader(point_format=3, version="1.2")
        header.scales, header.offsets = [0.001] * 3, [500_000, 4_600_000, 0]
        las = laspy.LasData(header)
        las.x, las.y, las.z = points.T
        las.write(str(folder / f"c.{suffix}"))
    local = points - points.mean(axis=0)
    with pye57.E57(str(folder / "c.e57"), mode="w") as e57:
        e57.write_scan_raw(
            {"cartesianX": local[:, 0], "cartesianY": local[:, 1], "cartesianZ": local[:, 2]},
            translation=points.mean(axis=0),
            rotation=np.array([1.0, 0, 0, 0]),
        )
    write_xyz(folder / "c.xyz", points)
    write_xyz(folder / "c.csv", points, header="x,y,z", delimiter=",")
    return {name: (folder / name).read_bytes() for name in FORMATS}


def lie_about_counts(name: str, data: bytes, count: int) -> bytes:
    """The same file with its header claiming ``count`` points."""
    if name.endswith(".ply"):
        return re.sub(rb"element vertex \d+", b"element vertex %d" % count, data, count=1)
    if name.endswith((".las", ".laz")):
        out = bytearray(data)
        struct.pack_into("<I", out, 107, count % 2**32)  # LAS 1.2 legacy point count
        return bytes(out)
    return data[: len(data) * 2 // 3]  # text and E57 carry no simple count: cut them instead


@st.composite
def mutated(draw, valid_files):
    name = draw(st.sampled_from(FORMATS))
    data = bytearray(valid_files[name])
    kind = draw(st.sampled_from(("truncate", "flip", "flip header", "flip tail", "lie", "random text")))
    if kind == "truncate":
        data = data[: draw(st.integers(0, len(data) - 1))]
    elif kind in ("flip", "flip header", "flip tail"):
        # The tail: where a LAZ file keeps its chunk table, whose damage had lazrs abort the process.
        low, high = {"flip header": (0, min(len(data), 400)), "flip tail": (max(0, len(data) - 64), len(data))}.get(
            kind, (0, len(data))
        )
        for position, value in draw(
            st.lists(st.tuples(st.integers(low, high - 1), st.integers(0, 255)), min_size=1, max_size=12)
        ):
            data[position] = value
    elif kind == "lie":
        data = bytearray(lie_about_counts(name, bytes(data), draw(st.integers(0, 2**31 - 1))))
    else:
        data = bytearray(draw(st.text(max_size=300)).encode("utf-8", "surrogatepass"))
    return name, bytes(data)


def assert_read_or_refused(path: Path) -> str:
    """read_cloud gives finite points, or a GeoStructureError naming the file; no warning.
    Returns which of the two it was."""
    outcome = "read"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            cloud = read_cloud(path)
        except GeoStructureError as exc:
            assert path.name in str(exc), exc
            assert "\n" not in str(exc), exc
            outcome = "refused"
        else:
            assert len(cloud) >= 3 and np.isfinite(cloud.local).all()
    assert not [w for w in caught if not issubclass(w.category, GeoStructureWarning)], [str(w.message) for w in caught]
    return outcome


def test_every_reader_reads_or_refuses_mutated_files(valid):
    folder = Path(tempfile.mkdtemp())
    outcomes = []

    @settings(FUZZ, max_examples=300 * SCALE)
    @given(case=mutated(valid))
    def check(case):
        name, data = case
        path = folder / f"fuzz{Path(name).suffix}"
        path.write_bytes(data)
        outcomes.append((Path(name).suffix, assert_read_or_refused(path)))

    check()
    assert len(outcomes) >= 300 and {o for _, o in outcomes} == {"read", "refused"}
    assert {s for s, _ in outcomes} == {".ply", ".las", ".laz", ".e57", ".xyz", ".csv"}


def test_measure_on_mutated_files_is_complete_or_one_sentence(valid, capsys):
    folder = Path(tempfile.mkdtemp())
    codes = []

    @settings(FUZZ, max_examples=100 * SCALE)
    @given(case=mutated(valid))
    def check(case):
        name, data = case
        path = folder / f"fuzz{Path(name).suffix}"
        path.write_bytes(data)
        out = folder / "out"
        before = folder_digests(out)
        code = main(
            [
                "measure",
                str(path),
                "-o",
                str(out),
                "-q",
                "--no-auto",
                "--zeta",
                "0.1",
                "--min-points",
                "10",
                "--mesh-samples",
                "2000",
            ]
        )
        err = capsys.readouterr().err
        codes.append(code)
        assert code in (0, 2), err
        if code == 2:
            assert_one_sentence(err, path.name)
            assert folder_digests(out) == before  # nothing partial, nothing lost
        else:
            assert "Traceback" not in err and "internal warning" not in err, err
            verified_record(out)

    check()
    assert len(codes) >= 100 and set(codes) == {0, 2}


NUMBER_TEXT = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**6), 10**6).map(str),
    st.sampled_from(["", "x", "1e400", "-0", "0x10"]),
)


def test_random_option_values_exit_0_or_2(tmp_path_factory, capsys):
    cloud = write_xyz(
        tmp_path_factory.mktemp("opt") / "c.xyz", np.random.default_rng(3).random((3000, 3)) * [10, 10, 0.02]
    )
    out = cloud.parent / "out"

    @settings(FUZZ, max_examples=80 * SCALE)
    @given(
        option=st.sampled_from(
            ["--zeta", "--theta", "--psi", "--k", "--sigma", "--min-points", "--declination", "--mesh-samples"]
        ),
        value=NUMBER_TEXT,
    )
    def check(option, value):
        try:
            code = main(["measure", str(cloud), "-o", str(out), "-q", f"{option}={value}"])
        except SystemExit as stop:  # argparse: usage and one error line
            code = stop.code
            assert code == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and "internal warning" not in err, err
        if code not in (0, 2):
            pytest.fail(f"exit {code}: {err}")

    check()


def test_truth_gcp_and_planes_tables_read_or_refuse_random_content(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tables")
    good = {
        "truth.csv": b"surface,strike,dip,dip_direction,center_x\nA,0,40,90,1.5\nB,90,89(E),,\n",
        "gcp.csv": b"name,E,N,Up,x,y,z\nA,1,2,3,4,5,6\nB,7,8,9,1,2,3\nC,4,4,4,0,0,1\n",
        "planes.csv": b"region_id,n_points,centroid_x,centroid_y,centroid_z,normal_x,normal_y,normal_z,strike,dip,"
        b"dip_direction,rect_center_x,rect_center_y,rect_center_z,rect_u_x,rect_u_y,rect_u_z,"
        b"rect_width,rect_height\n0,100,1,2,3,0,0,1,0,0,0,1,2,3,1,0,0,2,1\n",
    }
    readers = {"truth.csv": read_truth, "gcp.csv": read_gcp_csv, "planes.csv": read_planes_csv}

    @settings(FUZZ, max_examples=300 * SCALE)
    @given(
        name=st.sampled_from(sorted(good)),
        edits=st.lists(st.tuples(st.integers(0, 200), st.binary(max_size=3)), max_size=6),
        cut=st.integers(0, 300),
    )
    def check(name, edits, cut):
        data = bytearray(good[name])
        for position, chunk in edits:
            data[position : position + len(chunk)] = chunk
        path = folder / name
        path.write_bytes(bytes(data[:cut] if cut < len(data) else data))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                readers[name](path)
            except GeoStructureError as exc:
                assert name in str(exc) and "\n" not in str(exc), exc
        assert not [w for w in caught if not issubclass(w.category, GeoStructureWarning)]

    check()
