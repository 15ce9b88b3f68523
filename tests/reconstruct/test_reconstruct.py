"""Reconstruction end to end on a rendered video of an outcrop with known planes, plus the
frame selection and the errors a user meets with bad input."""

import csv
import json

import numpy as np
import pytest

from geostructure.cli import main
from geostructure.core.orientation import angle_between_normals
from geostructure.reconstruct.frames import FrameOptions, decode, extract_frames
from geostructure.testing.render import faces, write_scene_video, write_video


@pytest.fixture(scope="module")
def outcrop(tmp_path_factory):
    return write_scene_video(tmp_path_factory.mktemp("outcrop"))


@pytest.fixture(scope="module")
def run_dir(outcrop, tmp_path_factory):
    video, gcp, _ = outcrop
    out = tmp_path_factory.mktemp("run")
    assert main(["run", str(video), "-o", str(out), "--gcp", str(gcp), "-q", "--no-report"]) == 0
    return out


def planes(out):
    with open(out / "planes.csv") as fh:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def normal(dip, dip_direction):
    d, dd = np.radians(dip), np.radians(dip_direction)
    return np.array([np.sin(d) * np.sin(dd), np.sin(d) * np.cos(dd), np.cos(d)])


def check_true_dips(measured, limit=2.0, min_points=500) -> dict:
    """Each face's plane (the largest whose centroid lies on the face: within 0.3 m of its
    plane and inside its rectangle), its dip and dip direction checked within ``limit``
    degrees of the truth."""
    found = {}
    for face in faces():

        def on_face(p):
            offset = np.array([p["centroid_x"], p["centroid_y"], p["centroid_z"]]) - face.centre
            return (
                abs(offset @ face.normal) < 0.3
                and abs(offset @ face.u) <= face.width / 2
                and abs(offset @ face.v) <= face.height / 2
            )

        near = [p for p in measured if on_face(p) and p["n_points"] > min_points]
        assert near, f"{face.name} not found"
        best = max(near, key=lambda p: p["n_points"])
        found[face.name] = best
        assert abs(best["dip"] - face.dip) < limit, (face.name, best["dip"])
        assert abs((best["dip_direction"] - face.dip_direction + 180) % 360 - 180) < limit, (
            face.name,
            best["dip_direction"],
        )
    return found


def test_rendered_video_gives_true_dips_after_georeferencing(run_dir):
    found = check_true_dips(planes(run_dir))
    names = [f.name for f in faces()]
    truth = {f.name: f.normal for f in faces()}
    for i, a in enumerate(names):  # angles between planes need no georeference
        for b in names[i + 1 :]:
            got = angle_between_normals(
                normal(found[a]["dip"], found[a]["dip_direction"]), normal(found[b]["dip"], found[b]["dip_direction"])
            )[0]
            want = angle_between_normals(truth[a], truth[b])[0]
            assert abs(got - want) < 1, (a, b, got, want)
    record = json.loads((run_dir / "reconstruct.json").read_text())
    assert record["georef"]["source"] == "gcp" and record["georef"]["rms_residual"] < 0.05
    assert (run_dir / "cloud.ply").stat().st_size > 100_000 and (run_dir / "surface.ply").exists()


def test_second_run_resumes_from_the_finished_stages(run_dir, outcrop, capsys):
    video, gcp, _ = outcrop
    assert main(["run", str(video), "-o", str(run_dir), "--gcp", str(gcp), "--no-report"]) == 0
    out = capsys.readouterr().out
    for stage in ("frames", "sfm", "dense", "surface"):
        assert f"{stage}: done before" in out


def test_unreferenced_model_is_not_measured(run_dir, outcrop, capsys):
    video, _, _ = outcrop
    assert main(["run", str(video), "-o", str(run_dir), "-q", "--no-report"]) == 2
    err = capsys.readouterr().err
    assert "not georeferenced" in err and "--gcp" in err and "--assume-level" in err and "Traceback" not in err


def test_frame_selection_drops_blurred_and_still_frames(outcrop, tmp_path):
    import cv2

    frames = [cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) for _, image in decode(outcrop[0])][:16]
    blurred = cv2.GaussianBlur(frames[8], (0, 0), 4)
    shaky = frames[:8] + [blurred] + [frames[8]] * 4 + frames[9:]  # one blurred frame, a pause
    video = write_video(tmp_path / "shaky.mp4", shaky)
    report = extract_frames(video, tmp_path / "frames")
    assert report.decoded == len(shaky)
    assert report.blurred >= 1 and report.still >= 4
    kept = {int(p.stem.split("_")[1]) for p in report.paths}
    assert 8 not in kept and len(kept) >= 5
    every = extract_frames(video, tmp_path / "all", FrameOptions(select=False))
    assert len(every.paths) == len(shaky)


def test_a_file_that_is_not_a_video(tmp_path, capsys):
    fake = tmp_path / "clip.mp4"
    fake.write_text("this is not a video\n")
    assert main(["frames", str(fake), "-o", str(tmp_path / "f"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "clip.mp4: not a video" in err and "Traceback" not in err
    assert main(["run", str(tmp_path / "notes.txt"), "-o", str(tmp_path / "o"), "-q"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_a_folder_with_no_images(tmp_path, capsys):
    (tmp_path / "photos").mkdir()
    (tmp_path / "photos" / "readme.txt").write_text("nothing here")
    assert main(["run", str(tmp_path / "photos"), "-o", str(tmp_path / "o"), "-q"]) == 2
    assert "holds no images (.jpg, .png or .tif); give a folder of photos or a video." in capsys.readouterr().err
    # A dataset's photos one level down (sceaux_castle/images): the sentence says where
    (tmp_path / "photos" / "images").mkdir()
    for name in ("a.jpg", "b.png"):
        (tmp_path / "photos" / "images" / name).touch()
    assert main(["run", str(tmp_path / "photos"), "-o", str(tmp_path / "o"), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"holds no images (.jpg, .png or .tif), but its subfolder {tmp_path / 'photos' / 'images'} holds 2" in err
    assert not (tmp_path / "o").exists()


def test_images_that_do_not_overlap(tmp_path, capfd, monkeypatch):
    """COLMAP's own 'E... sfm.cc:310] Failed to create any sparse model' lines reached the
    terminal beside the sentence, and its log files were left in the temporary folder."""
    import cv2
    import pycolmap

    from geostructure.testing.render import textures

    logs = tmp_path / "logs"
    logs.mkdir()
    monkeypatch.setattr(pycolmap.logging, "log_dir", str(logs))

    photos = tmp_path / "photos"
    photos.mkdir()
    for i, texture in enumerate(textures(4, size=400, seed=7)):
        cv2.imwrite(str(photos / f"img_{i}.jpg"), texture.astype(np.uint8))
    assert main(["run", str(photos), "-o", str(tmp_path / "o"), "-q", "--dense", "none"]) == 2
    err = capfd.readouterr().err
    assert "SfM registered" in err and "overlap" in err and "Traceback" not in err
    assert "sfm.cc" not in err and len(err.strip().splitlines()) == 1, err
    assert list(logs.iterdir()) == []


def test_walking_straight_at_the_outcrop_uses_the_plane_sweep(tmp_path, capsys):
    """Photos taken walking towards the faces: no pair can be rectified, so `--dense auto`
    (no CUDA) falls back to the plane sweep, and the dips still come out true."""
    from geostructure.testing.render import approach_path, write_scene_photos

    photos, gcp, _ = write_scene_photos(tmp_path / "scene", approach_path(8))
    out = tmp_path / "run"
    assert main(["run", str(photos), "-o", str(out), "--gcp", str(gcp), "--no-report"]) == 0
    assert "(sweep)" in capsys.readouterr().out
    # the face walked at sits around the epipole, where a pixel barely moves: it gets the
    # fewest points (about 700 against thousands), but its plane must still be true
    # Runs differ (threaded SfM and dense matching; one SfM thread did not make two runs agree):
    # over eight runs on 2026-12-01 this face's dip came out 0.2 to 3.04 deg off and its dip
    # direction 0.2 to 2.5 deg; the others within 0.5
    check_true_dips(planes(out), limit=4.0, min_points=200)
