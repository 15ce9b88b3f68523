"""Colour read from every format that carries it (the traces' dark lines need it), the field
map's disc columns and set labels, and the traces' files read back."""

import numpy as np
import pytest

from geostructure.errors import InputError
from geostructure.io.fieldmap import read_field_map, read_set_labels
from geostructure.io.readers import read_cloud


def test_text_colour_from_x_y_z_r_g_b_and_from_a_header(tmp_path):
    plain = tmp_path / "c.txt"
    plain.write_text("0 0 0 255 255 255\n1 0 0 0 0 30\n0 1 0 10 20 30\n1 1 1 1 2 3\n")
    assert read_cloud(plain).grey == pytest.approx([1.0, 10 / 255, 20 / 255, 2 / 255], abs=1e-6)
    named = tmp_path / "c.csv"
    named.write_text("Red,x,y,z,Green,Blue\n255,0,0,0,255,255\n0,1,0,0,0,0\n0,0,1,0,0,0\n0,1,1,1,0,0\n")
    assert read_cloud(named).grey == pytest.approx([1.0, 0.0, 0.0, 0.0])


def test_normals_or_a_later_line_without_colour_are_no_colour(tmp_path):
    normals = tmp_path / "n.xyz"
    normals.write_text("0 0 0 0.1 0.2 0.97\n1 0 0 0 0 1\n0 1 0 0 0 1\n1 1 1 0 1 0\n")
    assert read_cloud(normals).grey is None
    ragged = tmp_path / "r.xyz"
    ragged.write_text("0 0 0 10 20 30\n1 0 0\n0 1 0\n1 1 1\n")
    cloud = read_cloud(ragged)
    assert cloud.grey is None and len(cloud) == 4


def test_ply_and_las_colour(tmp_path):
    from plyfile import PlyData, PlyElement

    vertex = np.zeros(4, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8"), ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    vertex["x"], vertex["y"] = [0, 1, 0, 1], [0, 0, 1, 1]
    vertex["red"] = vertex["green"] = vertex["blue"] = [0, 51, 102, 255]
    PlyData([PlyElement.describe(vertex, "vertex")]).write(str(tmp_path / "c.ply"))
    assert read_cloud(tmp_path / "c.ply").grey == pytest.approx([0.0, 0.2, 0.4, 1.0], abs=1e-6)
    import laspy

    las = laspy.create(point_format=2, file_version="1.2")
    las.x, las.y, las.z = np.array([0.0, 1, 0, 1]), np.array([0.0, 0, 1, 1]), np.array([0.0, 0, 0, 1])
    las.red = las.green = las.blue = np.array([0, 13107, 26214, 65535])
    las.write(tmp_path / "c.las")
    assert read_cloud(tmp_path / "c.las").grey == pytest.approx([0.0, 0.2, 0.4, 1.0], abs=1e-6)


def test_a_field_maps_discs_and_its_set_labels(tmp_path):
    path = tmp_path / "fit_planes.csv"
    path.write_text("Dip,DipDirection,Radius,Xcenter,Ycenter,Zcenter,Nx,Ny,Nz\n80,90,0.3,1,2,3,1,0,0\n")
    mapped = read_field_map(path)
    assert mapped.radius.tolist() == [0.3] and mapped.normals.tolist() == [[1.0, 0.0, 0.0]]
    labels = tmp_path / "set_labels.csv"
    labels.write_text("Dip,DipDirection,Set\n80,90,2.0\n")
    assert read_set_labels(labels, 1) == ["2"]
    with pytest.raises(InputError, match="2 rows of set labels for a field map of 1"):
        labels.write_text("Set\n1\n2\n")
        read_set_labels(labels, 1)
    path.write_text("Dip,DipDirection,Radius,Xcenter,Ycenter,Zcenter\n80,90,-1,1,2,3\n")
    with pytest.raises(InputError, match="radius is no length"):
        read_field_map(path)
    path.write_text("Dip,DipDirection,Xcenter,Ycenter,Zcenter,Nx,Ny,Nz\n80,90,1,2,3,3,0,0\n")
    with pytest.raises(InputError, match="not a unit normal"):
        read_field_map(path)
