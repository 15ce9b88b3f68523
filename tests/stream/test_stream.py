"""Streaming larger than memory (issue "Scale"): a survey cut into 16 LAZ tiles and measured
in chunks, here and on a Dask LocalCluster, gives the planes the whole cloud gives in memory;
a plane across four tiles is one region; the point outputs keep every coordinate; a memory
bound far below the cloud's size holds, measured in a subprocess."""

import json
import os
import subprocess
import sys

import laspy
import numpy as np
import pytest
from helpers import UTM, assert_one_sentence, planes_of, run_cli, tile_index, write_classified_las, write_laz

from geostructure import measure
from geostructure.core.params import Params
from geostructure.detect import auto
from geostructure.detect.auto import choose_params
from geostructure.io.survey_files import read_tiles
from geostructure.stream import DaskExecutor, stream_planes
from geostructure.synthetic import observatory_scene

VOXEL = Params(detector="voxel")


def angles(a, b):
    return np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", a, b)), 0.0, 1.0)))


def assert_same_planes(memory, streamed):
    assert len(streamed) == len(memory) > 0
    assert angles(memory.normal, streamed.normal).max() < 0.05
    assert np.abs(memory.centroid - streamed.centroid).max() < 1e-3
    assert (memory.n_points == streamed.n_points).all()


@pytest.fixture(scope="module")
def tiled(tmp_path_factory):
    """The observatory (walls, roofs, a ground) at a UTM offset, in 16 tiles, and what the
    whole of it gives in memory with the parameters chosen from it."""
    tmp = tmp_path_factory.mktemp("stream")
    points = observatory_scene(120_000, seed=4).cloud.points + UTM
    tile = tile_index(points, axes=(0, 1))
    paths = []
    for t in np.unique(tile):
        paths.append(tmp / f"tile_{t:02d}.laz")
        write_laz(paths[-1], points[tile == t])
    cloud = read_tiles(paths)
    params = choose_params(cloud.local, VOXEL).params
    return paths, measure(cloud, params).planes, params


def test_sixteen_tiles_streamed_give_the_planes_of_the_whole_cloud(tiled):
    paths, memory, params = tiled
    assert len(paths) == 16
    streamed = stream_planes(paths, VOXEL, auto={}, chunk_points=9_000)  # about 14 chunks
    assert streamed.params == params  # the automatic choice made from chunks is the same
    assert_same_planes(memory, streamed.planes)


def test_sixteen_tiles_on_a_dask_local_cluster_give_the_same_planes(tiled):
    paths, memory, params = tiled
    executor = DaskExecutor(workers=2)
    try:
        streamed = stream_planes(paths, params, chunk_points=20_000, executor=executor)
    finally:
        executor.close()
    assert streamed.engine == "dask"
    assert_same_planes(memory, streamed.planes)


def test_a_plane_across_four_tiles_is_one_region(tmp_path):
    rng = np.random.default_rng(3)
    uv = rng.uniform(-10, 10, (60_000, 2))
    normal = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    z = -(normal[0] * uv[:, 0] + normal[1] * uv[:, 1]) / normal[2] + 0.005 * rng.standard_normal(len(uv))
    points = np.column_stack([uv, z]) + UTM
    tile = tile_index(points, n=2, axes=(0, 1))
    paths = []
    for t in range(4):
        paths.append(tmp_path / f"quarter_{t}.laz")
        write_laz(paths[-1], points[tile == t])
    result = stream_planes(paths, VOXEL.with_(zeta=0.02), chunk_points=10_000)
    assert len(result) == 1
    assert angles(result.planes.normal, normal[None])[0] < 0.05
    assert result.planes.n_points[0] == measure(read_tiles(paths), VOXEL.with_(zeta=0.02)).planes.n_points[0]
    assert result.planes.n_points[0] > 0.95 * len(points)
    assert result.planes.rect_width[0] > 19  # the whole 20 m square, not a quarter of it


def test_streamed_command_writes_every_point_on_its_own_integers(tiled, tmp_path, capsys):
    paths, memory, _ = tiled
    out = tmp_path / "out"
    code, _, err = run_cli(
        capsys, "measure", str(paths[0].parent), "-o", str(out), "--engine", "stream", "--report", "-q"
    )
    assert code == 0, err
    page = (out / "report.html").read_text()
    assert f'"n_planes":{len(memory)}' in page and '"points_total":' in page  # from a sample of regions.ply
    assert "<title>GeoStructure: tile_00.laz, tile_01.laz, tile_02.laz, ... (16 files)</title>" in page
    centroid, normal = planes_of(out)
    assert len(centroid) == len(memory)
    assert np.abs(centroid - memory.centroid).max() < 1e-3
    record = json.loads((out / "run.json").read_text())
    assert record["engine"] == "stream" and record["params"]["detector"] == "voxel"
    written = laspy.read(str(out / "regions.laz"))
    inputs = np.vstack([np.column_stack([las.X, las.Y, las.Z]) for las in map(laspy.read, map(str, paths))])
    assert set(map(tuple, np.column_stack([written.X, written.Y, written.Z]))) <= set(map(tuple, inputs))
    assert len(written) == record["counts"]["filtered"]
    assert f'"points_total":{len(written)}' in page
    sizes = np.bincount(np.asarray(written.region_id)[np.asarray(written.region_id) >= 0])
    assert (sizes == memory.n_points).all()
    assert written.header.parse_crs().to_epsg() == 32633


@pytest.mark.slow
def test_a_memory_bound_far_below_the_cloud_is_kept(tmp_path):
    """2.5M points, which take about 2.8 GB in memory, measured under --max-memory 700M: the
    automatic engine streams them, and the process's peak resident memory stays below."""
    points = observatory_scene(2_500_000, seed=5).cloud.points + UTM
    write_laz(tmp_path / "big.laz", points)
    probe = (
        "import resource, subprocess, sys; code = subprocess.call(sys.argv[1:]); "
        "print(code, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024)"
    )
    command = [sys.executable, "-m", "geostructure", "measure", str(tmp_path / "big.laz"), "-o", str(tmp_path / "out")]
    done = subprocess.run(
        [sys.executable, "-c", probe, *command, "--max-memory", "700M", "-q"], capture_output=True, text=True
    )
    code, peak = map(int, done.stdout.split())
    assert code == 0, done.stderr
    assert peak < 700 * 2**20, f"peak {peak / 2**20:.0f} MiB"
    record = json.loads((tmp_path / "out" / "run.json").read_text())
    assert record["engine"] == "stream" and record["counts"]["input"] == len(points)


def test_dask_options_without_the_dask_engine_are_refused(tiled, tmp_path, capsys):
    paths, _, _ = tiled
    out = tmp_path / "out"
    code, _, err = run_cli(capsys, "measure", str(paths[0]), "-o", str(out), "--scheduler", "tcp://127.0.0.1:1")
    assert code == 2
    assert_one_sentence(err, "--scheduler", "--engine dask")
    assert not out.exists()


def test_a_binary_ply_with_normals_streams_as_it_measures_in_memory(tmp_path):
    """A PLY is read through a memory map, chunk by chunk, its stored normals kept (they decide
    which side of a vertical plane faces out)."""
    from plyfile import PlyData, PlyElement

    from geostructure import read_cloud

    scene = observatory_scene(60_000, seed=6)
    rng = np.random.default_rng(0)
    normals = rng.normal(size=(len(scene.cloud), 3))
    vertex = np.empty(len(normals), dtype=[(a, "f8") for a in ("x", "y", "z", "nx", "ny", "nz")])
    for i, a in enumerate("xyz"):
        vertex[a], vertex["n" + a] = scene.cloud.points[:, i], normals[:, i]
    path = tmp_path / "scene.ply"
    PlyData([PlyElement.describe(vertex, "vertex")]).write(str(path))
    memory = measure(read_cloud(path), VOXEL.with_(zeta=0.02)).planes
    streamed = stream_planes([path], VOXEL.with_(zeta=0.02), chunk_points=7_000).planes
    assert_same_planes(memory, streamed)
    assert np.allclose(memory.facing, streamed.facing, atol=1e-6)  # the sums of normals, added in another order


def test_a_killed_runs_spill_is_removed_by_the_next_run(tmp_path):
    """A run killed outright leaves its spill behind; the next streamed run in that folder
    removes it (its process is gone), and leaves a live run's alone."""
    from geostructure.stream.source import SPILL_PREFIX, remove_stale_spills

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = tmp_path / f"{SPILL_PREFIX}{dead.stdout.strip()}-abc"
    live = tmp_path / f"{SPILL_PREFIX}{os.getpid()}-def"
    for folder in (stale, live):
        folder.mkdir()
        (folder / "points.f8").write_bytes(b"\0" * 240)
    assert remove_stale_spills(tmp_path) == [stale]
    assert not stale.exists() and live.exists()


def test_an_interrupted_streamed_run_leaves_no_output_and_no_spill(tiled, tmp_path, capsys, monkeypatch):
    """Ctrl-C in the middle of the passes (here raised at the label pass's first chunk, while
    the point outputs are being written): the output folder holds nothing of the run (its
    lock file at most, as after any interrupted run), the spill is removed, and the command
    says so and exits 130."""
    from geostructure.stream import engine

    paths, _, _ = tiled
    spill, out = tmp_path / "spill", tmp_path / "out"
    spill.mkdir()

    def interrupted(self, context, labels_path, writers, *rest):
        for writer in writers:  # the point outputs are open, as when the label pass runs
            writer.begin(10, np.zeros(3), np.ones(3), self.spill.cloud())
        raise KeyboardInterrupt

    monkeypatch.setattr(engine._Run, "label", interrupted)
    code, _, err = run_cli(
        capsys, "measure", str(paths[0].parent), "-o", str(out), "--engine", "stream", "--spill-dir", str(spill), "-q"
    )
    assert code == 130 and "interrupted" in err
    left = [p.name for p in out.iterdir()] if out.exists() else []
    assert left in ([], [".geostructure-lock"])
    assert list(spill.iterdir()) == []


def test_the_noise_read_on_drawn_voxels_is_the_same_streamed(tiled, monkeypatch):
    """Above twice ``auto.NOISE_SAMPLE_POINTS`` points the noise sigma is read on whole voxels
    drawn by hash: streamed chunk by chunk, the same voxels are drawn and the same choice made,
    and it is close to the one read on every voxel."""
    paths, _, every_voxel = tiled
    monkeypatch.setattr(auto, "NOISE_SAMPLE_POINTS", 10_000)  # the 120k-point cloud draws
    drawn = choose_params(read_tiles(paths).local, VOXEL).params
    streamed = stream_planes(paths, VOXEL, auto={}, chunk_points=9_000)
    assert streamed.params == drawn
    assert drawn.zeta == pytest.approx(every_voxel.zeta, rel=0.05)


def test_a_streamed_survey_keeps_its_vegetation_marks_for_the_sets(tmp_path, capsys):
    """Streamed, a LAS's vegetation classes go to regions.ply (scalar_vegetation) as in
    memory, so `sets OUTDIR` takes those points for clutter; the marks start at the first
    tile that has any, the tiles before it unmarked."""
    from plyfile import PlyData

    rng = np.random.default_rng(0)
    wall = np.column_stack([rng.random(6000) * 6, np.zeros(6000), rng.random(6000) * 3])
    bush = rng.normal(size=(1500, 3)) * 0.3 + [3.0, -0.8, 0.6]
    (tmp_path / "tiles").mkdir()
    write_classified_las(tmp_path / "tiles" / "a.laz", wall[:3000], np.ones(3000), origin=UTM)  # unmarked
    points, classes = np.vstack([wall[3000:], bush]), np.repeat([1, 3], [3000, len(bush)])
    write_classified_las(tmp_path / "tiles" / "b.laz", points, classes, origin=UTM)
    out = tmp_path / "out"
    assert run_cli(capsys, "measure", tmp_path / "tiles", "-o", out, "--engine", "stream", "-q")[0] == 0
    vertex = PlyData.read(str(out / "regions.ply"))["vertex"].data
    marked = np.asarray(vertex["scalar_vegetation"], dtype=bool)
    y = np.asarray(vertex["y"]) - UTM[1]
    assert marked.any() and (np.abs(y[~marked]) < 0.05).all() and (y[marked] != 0).any()
    assert marked.sum() <= len(bush) and marked.sum() > 0.9 * len(bush)
    code, _, err = run_cli(capsys, "sets", out)
    assert code == 0 and "classified as vegetation" in err
