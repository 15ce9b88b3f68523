"""The synthetic outcrop photographed (geostructure.testing.outcrop_photos): photos of rock,
not of sky through its steps, and ground control where the photos see it."""

import csv

import numpy as np


def test_photos_see_rock_and_the_control_points_on_it(tmp_path):
    import cv2

    from geostructure.synthetic import outcrop_scene
    from geostructure.testing.outcrop_photos import drone_path, write_outcrop_photos

    layout = outcrop_scene(width=2.0, height=1.5, point_spacing=0.05, seed=3, cameras=0)
    cameras = drone_path(layout, distance=3.0, rows=1, per_row=2, focal=300.0, size=(320, 240))
    scene, photos, gcp = write_outcrop_photos(tmp_path, width=2.0, height=1.5, surface_spacing=0.01, seed=3,
                                              cameras=cameras)  # fmt: skip
    images = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in sorted(photos.iterdir())]
    assert len(images) == 2 and not np.array_equal(images[0], images[1])
    with open(gcp, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert rows
    for row in rows:  # each control point's pixel shows rock (textured), not the sky's flat 200
        image = images[int(row["image"][6:9])]
        u, v = int(float(row["u"])), int(float(row["v"]))
        patch = image[max(v - 3, 0) : v + 4, max(u - 3, 0) : u + 4]
        assert patch.std() > 2.0 or abs(float(patch.mean()) - 200.0) > 10.0
        centre = np.array([float(row[k]) for k in ("E", "N", "Up")])
        assert np.linalg.norm(scene.facet_center - centre, axis=1).min() < 1e-9
    # Rock fills the face's outline: little sky shows through its steps (0.043 of it here;
    # 0.11 without the risers between the facets).
    uv, depth = cameras[0].project(scene.cloud.points)
    seen = (depth > 0) & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] < 320) & (uv[:, 1] < 240)
    outline = np.zeros((240, 320), np.uint8)
    cv2.fillConvexPoly(outline, cv2.convexHull(uv[seen].astype(np.float32)).astype(np.int32), 1)
    assert ((images[0] == 200) & (outline > 0)).sum() / outline.sum() < 0.07
