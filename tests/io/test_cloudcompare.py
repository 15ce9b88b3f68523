"""CloudCompare's command line (Debian's cloudcompare under xvfb-run) loads regions.ply with
region_id as a scalar field and the coordinates within 1 mm (issue "Outputs")."""

import re
import shutil
import subprocess

import numpy as np
import pytest
from plyfile import PlyData

from geostructure import measure
from geostructure.io.outdir import output_set
from geostructure.io.writers import write_regions_ply
from geostructure.synthetic import outcrop_scene

CLOUDCOMPARE = shutil.which("CloudCompare")
XVFB = shutil.which("xvfb-run")

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        not (CLOUDCOMPARE and XVFB),
        reason="CloudCompare and xvfb-run are not installed (Debian: apt-get install cloudcompare xvfb xauth)",
    ),
]


def test_cloudcompare_loads_region_id_as_a_scalar_field_at_utm_coordinates(tmp_path):
    scene = outcrop_scene(width=4.0, height=3.0, seed=2, offset=(500_000.0, 4_600_000.0, 300.0))
    result = measure(scene.cloud)
    with output_set(tmp_path / "out") as outputs:
        write_regions_ply(result, outputs.path("regions.ply"))
    ply = tmp_path / "out" / "regions.ply"
    exported = tmp_path / "regions.asc"
    command = [XVFB, "-a", CLOUDCOMPARE, "-SILENT", "-AUTO_SAVE", "OFF", "-O", "-GLOBAL_SHIFT", "AUTO", str(ply)]
    command += ["-C_EXPORT_FMT", "ASC", "-PREC", "6", "-ADD_HEADER", "-SAVE_CLOUDS", "FILE", str(exported)]
    subprocess.run(command, check=True, capture_output=True, timeout=120)
    header = exported.read_text().splitlines()[0]
    assert header.split()[-1] == "region_id"  # loaded as a scalar field, named without the prefix
    table = np.loadtxt(exported, comments="//")
    vertex = PlyData.read(str(ply))["vertex"].data
    written = np.column_stack([vertex["x"], vertex["y"], vertex["z"]])
    assert len(table) == len(written)
    assert np.abs(table[:, :3] - written).max() < 1e-3  # within 1 mm of the input, UTM included
    np.testing.assert_array_equal(table[:, 3].astype(int), vertex["scalar_region_id"])


def cloudcompare_table(ply, exported) -> tuple[list[str], np.ndarray]:
    """The cloud CloudCompare's command line reads from ``ply``: its ASC header's names and rows."""
    command = [XVFB, "-a", CLOUDCOMPARE, "-SILENT", "-AUTO_SAVE", "OFF", "-O", "-GLOBAL_SHIFT", "AUTO", str(ply)]
    command += ["-C_EXPORT_FMT", "ASC", "-PREC", "6", "-ADD_HEADER", "-SAVE_CLOUDS", "FILE", str(exported)]
    subprocess.run(command, check=True, capture_output=True, timeout=120)
    header = exported.read_text().splitlines()[0].lstrip("/").split()
    return header, np.loadtxt(exported, comments="//")


@pytest.mark.parametrize("how", ["measure --sets", "sets OUTDIR"])
def test_cloudcompare_colours_the_points_by_set_joint_and_face_part(tmp_path, capsys, how):
    """Issue 45: after --sets only regions.laz carried set, joint and face_part, and Debian's
    CloudCompare (2.11) reads no LAS at all."""
    from helpers import run_cli, write_xyz

    cloud = write_xyz(tmp_path / "outcrop.xyz", outcrop_scene(width=6.0, height=4.0, seed=1).cloud.points)
    out = tmp_path / "out"
    if how == "measure --sets":
        assert run_cli(capsys, "measure", cloud, "-o", out, "-q", "--sets")[0] == 0
    else:
        assert run_cli(capsys, "measure", cloud, "-o", out, "-q")[0] == 0
        assert run_cli(capsys, "sets", out, "-q")[0] == 0
    header, table = cloudcompare_table(out / "regions.ply", tmp_path / "regions.asc")
    names = header[-4:]
    assert names == ["region_id", "set", "face_part", "joint"]
    vertex = PlyData.read(str(out / "regions.ply"))["vertex"].data
    for column, name in enumerate(names, start=len(header) - 4):
        np.testing.assert_array_equal(table[:, column].astype(int), vertex["scalar_" + name])
    sets = table[:, header.index("set")]
    assert len(np.unique(sets[sets >= 0])) >= 3  # the outcrop's three joint sets, on its points


def test_cloudcompare_reads_the_traces_dxf_at_utm_coordinates(tmp_path):
    """Issue 55: the traces as 3D polylines a CloudCompare (or DICE) user opens."""
    from geostructure.io.exports import write_traces_dxf

    lines = [np.array([[276774.0, 5151643.0, 2388.0], [276774.5, 5151643.2, 2387.9], [276775.0, 5151643.5, 2387.7]]),
             np.array([[276770.0, 5151640.0, 2390.0], [276770.2, 5151641.0, 2390.5]])]  # fmt: skip
    dxf = write_traces_dxf(lines, [0, -1], tmp_path / "traces.dxf")
    command = [XVFB, "-a", CLOUDCOMPARE, "-SILENT", "-AUTO_SAVE", "OFF", "-O", "-GLOBAL_SHIFT", "AUTO", str(dxf)]
    command += ["-C_EXPORT_FMT", "ASC", "-SAVE_CLOUDS"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    log = done.stdout + done.stderr
    assert "traces.dxf' loaded successfully" in log, log[-2000:]
    found = re.findall(r"Found one cloud with (\d+) points", log)
    assert sorted(int(n) for n in found) == [2, 3], log[-2000:]  # one polyline each, every vertex
