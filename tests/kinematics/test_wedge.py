"""The wedge's block and factor of safety against Hoek & Bray's (1981) worked example."""

import numpy as np
import pytest

from geostructure.core.orientation import normal_from_orientation
from geostructure.kinematics.modes import Slope, wedges
from geostructure.kinematics.wedge import wedge_blocks, wedge_factor_of_safety

# Hoek & Bray (1981), Rock Slope Engineering, chapter 8 (and Wyllie & Mah 2004, chapter 7):
# joints A 45/105 (friction 20, cohesion 500 lb/ft2) and B 70/235 (friction 30, 1000 lb/ft2)
# under a face 65/185 with an upper slope 12/195. The book reads these angles off its net
# (degrees): the line of intersection plunges 31.2; between the poles 101; between the lines
# 2 and 4, 65; 4 and 5, 25; line 2 and pole a, 50; lines 1 and 3, 62; 3 and 5, 31; line 1 and
# pole b, 60. Line 1 is where A meets the face, 2 where B does, 3 and 4 where A and B meet the
# upper slope, 5 where A meets B.
JOINT_A, JOINT_B, FACE, UPPER = (45.0, 105.0), (70.0, 235.0), (65.0, 185.0), (12.0, 195.0)
BOOK_ANGLES = {"plunge": 31.2, "na_nb": 101, "24": 65, "45": 25, "2_na": 50, "13": 62, "35": 31, "1_nb": 60}
PSF_TO_KPA, PCF_TO_KN_M3 = 0.0478803, 0.157087


def normal(dip_and_direction):
    return normal_from_orientation(dip_and_direction[1], dip_and_direction[0])


def down(vector):
    vector = vector / np.linalg.norm(vector)
    return -vector if vector[2] > 0 else vector


def angle(u, v):
    """Degrees between two directions on the lower hemisphere, as read off the net."""
    return float(np.degrees(np.arccos(np.clip(down(u) @ down(v), -1.0, 1.0))))


def short_solution_weights(angles):
    """Hoek & Bray's X, Y, A and B from the net's angles (degrees)."""
    s, c = (lambda a: np.sin(np.radians(a))), (lambda a: np.cos(np.radians(a)))
    x = s(angles["24"]) / (s(angles["45"]) * c(angles["2_na"]))
    y = s(angles["13"]) / (s(angles["35"]) * c(angles["1_nb"]))
    denominator = s(angles["plunge"]) * s(angles["na_nb"]) ** 2
    big_a = (c(JOINT_A[0]) - c(JOINT_B[0]) * c(angles["na_nb"])) / denominator
    big_b = (c(JOINT_B[0]) - c(JOINT_A[0]) * c(angles["na_nb"])) / denominator
    return x, y, big_a, big_b


def measured_angles():
    a, b, face, upper = normal(JOINT_A), normal(JOINT_B), normal(FACE), normal(UPPER)
    lines = {1: np.cross(a, face), 2: np.cross(b, face), 3: np.cross(a, upper), 4: np.cross(b, upper)}
    lines[5] = np.cross(a, b)
    return {
        "plunge": float(np.degrees(np.arcsin(-down(lines[5])[2]))),
        "na_nb": angle(a, b),
        "24": angle(lines[2], lines[4]),
        "45": angle(lines[4], lines[5]),
        "2_na": angle(lines[2], a),
        "13": angle(lines[1], lines[3]),
        "35": angle(lines[3], lines[5]),
        "1_nb": angle(lines[1], b),
    }


def test_the_books_angles_come_out_of_the_orientations():
    measured = measured_angles()
    for name, value in BOOK_ANGLES.items():
        assert measured[name] == pytest.approx(value, abs=0.8), name  # read off a net to a degree


@pytest.mark.parametrize("height_m", [10.0, 30.48, 60.0])
def test_the_wedge_with_cohesion_is_hoek_and_brays_short_solution(height_m):
    a, b = normal(JOINT_A)[None], normal(JOINT_B)[None]
    gamma, c_a, c_b = 160 * PCF_TO_KN_M3, 500 * PSF_TO_KPA, 1000 * PSF_TO_KPA
    blocks = wedge_blocks(a, b, normal(FACE), height_m, normal(UPPER))
    assert blocks.formed.all()
    fs, rides = wedge_factor_of_safety(
        a, b, 20.0, 30.0, cohesion_a=c_a, cohesion_b=c_b, blocks=blocks, unit_weight=gamma
    )
    assert rides.tolist() == [-1]
    # H in the short solution is the wedge's height, from its toe to the top of line 5.
    x, y, big_a, big_b = short_solution_weights(measured_angles())
    friction = big_a * np.tan(np.radians(20.0)) + big_b * np.tan(np.radians(30.0))
    short = 3.0 * (c_a * x + c_b * y) / (gamma * blocks.height[0]) + friction
    assert fs[0] == pytest.approx(short, rel=1e-9)
    # The book's own rounded angles give the same factors to within their rounding.
    bx, by, ba, bb = short_solution_weights(BOOK_ANGLES)
    assert (bx, by, ba, bb) == pytest.approx((x, y, big_a, big_b), rel=0.03)


def test_the_frictional_wedge_is_a_tan_phi_a_plus_b_tan_phi_b_and_ignores_size():
    a, b = normal(JOINT_A)[None], normal(JOINT_B)[None]
    _, _, big_a, big_b = short_solution_weights(BOOK_ANGLES)
    fs, _ = wedge_factor_of_safety(a, b, 20.0, 30.0)
    assert fs[0] == pytest.approx(big_a * np.tan(np.radians(20.0)) + big_b * np.tan(np.radians(30.0)), rel=0.02)
    assert 1.10 < fs[0] < 1.12  # 1.548 tan 20 + 0.956 tan 30 = 1.115 from the book's angles
    small = wedge_blocks(a, b, normal(FACE), 1.0, normal(UPPER))
    large = wedge_blocks(a, b, normal(FACE), 100.0, normal(UPPER))
    assert large.volume[0] == pytest.approx(small.volume[0] * 100.0**3, rel=1e-9)
    assert wedge_factor_of_safety(a, b, 20.0, 30.0, blocks=large)[0] == pytest.approx(fs)


def test_cohesion_holds_a_small_wedge_more_than_a_large_one():
    slope = Slope(*FACE)
    dry = wedges([JOINT_A[0], JOINT_B[0]], [JOINT_A[1], JOINT_B[1]], slope, 30.0)
    low = wedges([JOINT_A[0], JOINT_B[0]], [JOINT_A[1], JOINT_B[1]], slope, 30.0, cohesion=20.0, height=50.0)
    high = wedges([JOINT_A[0], JOINT_B[0]], [JOINT_A[1], JOINT_B[1]], slope, 30.0, cohesion=20.0, height=5.0)
    assert dry.factor_of_safety[0] < low.factor_of_safety[0] < high.factor_of_safety[0]
    # The cohesive part scales as 1 / height: the block's faces grow as H^2, its weight as H^3.
    assert high.factor_of_safety[0] - dry.factor_of_safety[0] == pytest.approx(
        10.0 * (low.factor_of_safety[0] - dry.factor_of_safety[0]), rel=1e-9
    )


def test_a_line_steeper_than_the_upper_slope_allows_cuts_no_block():
    # The upper surface dips along the line, more steeply than the line plunges: no wedge.
    a, b = normal(JOINT_A)[None], normal(JOINT_B)[None]
    steep_top = normal((40.0, 158.0))
    blocks = wedge_blocks(a, b, normal(FACE), 20.0, steep_top)
    assert not blocks.formed.any()
    fs, _ = wedge_factor_of_safety(a, b, 20.0, 30.0, cohesion_a=10.0, blocks=blocks)
    assert np.isnan(fs).all()


def test_cohesion_without_the_block_is_refused_as_a_parameter_error():
    from geostructure.errors import ParameterError

    a, b = normal_from_orientation([105, 235], [45, 70])
    with pytest.raises(ParameterError, match="needs its block"):
        wedge_factor_of_safety(a[None], b[None], 20.0, 30.0, cohesion_a=25.0)
