import csv

import numpy as np

from geostructure.cli import main
from geostructure.core.params import Params
from geostructure.detect.pipeline import measure
from geostructure.io.gis import geojson
from geostructure.report.stereonet import stereonet_figure


def test_pole_at_dip_40_dip_direction_89_sits_where_mplstereonet_puts_it():
    import mplstereonet

    strike, dip = (89 - 90) % 360, 40
    fig, ax = stereonet_figure([strike], [dip])
    poles = [line for line in ax.lines if line.get_label() == "poles"][0]
    x, y = poles.get_data()
    lon, lat = mplstereonet.pole(strike, dip)
    np.testing.assert_allclose([x[0], y[0]], [lon[0], lat[0]], atol=1e-12)
    # The pole of a plane dipping 40 towards 089 plunges 50 towards 269.
    plunge, bearing = mplstereonet.geographic2plunge_bearing(x, y)
    assert abs(plunge[0] - 50) < 1e-9
    assert abs(bearing[0] - 269) < 1e-9


def test_exports_written_by_measure(tmp_path, scene, capsys):
    from helpers import write_ply

    path = tmp_path / "scene.ply"
    write_ply(path, scene.cloud.points, text=False)
    out = tmp_path / "out"
    assert main(["measure", str(path), "-o", str(out), "-q"]) == 0
    dips = list(csv.reader(open(out / "planes_dips.csv")))
    planes = list(csv.DictReader(open(out / "planes.csv")))
    assert dips[0][:2] == ["Dip Direction", "Dip"] and len(dips) - 1 == len(planes)
    assert float(dips[1][0]) == round(float(planes[0]["dip_direction"]), 2)
    # the synthetic scene has no CRS: no file claims a place on Earth
    assert not (out / "planes.geojson").exists() and not (out / "planes.gpkg").exists()
    assert main(["report", str(out), "-q"]) == 0
    for name in ("stereonet.png", "stereonet.svg", "rose.png"):
        assert (out / name).stat().st_size > 1000


def test_geojson_of_a_gps_referenced_cloud_is_in_longitude_and_latitude(scene):
    from dataclasses import replace

    from geostructure.core.geodesy import geodetic_to_enu

    origin = (55.7, 13.19, 40.0)
    cloud = replace(scene.cloud, enu_origin=origin)
    result = measure(cloud, Params())
    data = geojson(result.planes, enu_origin=origin)
    ring = np.array(data["features"][0]["geometry"]["coordinates"][0])
    lon, lat, alt = ring[0]
    assert 13.18 < lon < 13.20 and 55.69 < lat < 55.71  # a building-sized scene about the origin
    back = geodetic_to_enu(ring[:-1, 1], ring[:-1, 0], ring[:-1, 2], origin)
    assert np.allclose(back, result.planes.local_corners[0] + cloud.offset, atol=1e-6)
