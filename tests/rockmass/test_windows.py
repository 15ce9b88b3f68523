"""Circular windows against known geometry: the mean trace length and P21 of traces cut by
the exposure's edge, read from counts alone (Mauldon 1998)."""

import numpy as np
import pytest

from geostructure.rockmass.windows import count_in_windows, window_centres, window_estimate


def random_traces(length: float, n: int, size: float, seed: int = 0) -> list[np.ndarray]:
    """``n`` straight traces of one ``length`` (m) per square of ``size``, centres uniform
    over the square grown by half a length (so that the intensity is the same up to its
    edges) and uniform directions, each as vertices 2 cm apart, clipped to the square (censored)."""
    rng = np.random.default_rng(seed)
    grown = size + length
    n = int(round(n * grown**2 / size**2))
    centres = rng.random((n, 2)) * grown - length / 2
    angle = rng.random(n) * np.pi
    out = []
    for c, a in zip(centres, angle):
        t = np.arange(-length / 2, length / 2 + 1e-9, 0.02)
        line = c + np.outer(t, [np.cos(a), np.sin(a)])
        line = line[np.all((line >= 0) & (line <= size), axis=1)]
        if len(line) >= 2:
            out.append(line)
    return out


@pytest.mark.parametrize("length", [0.5, 2.0, 6.0])
def test_windows_read_the_true_mean_length_and_intensity_of_censored_traces(length):
    """On a 30 m square, traces of one length: the mean of what is seen falls short as the
    traces grow (cut by the edge), the windows' estimate does not."""
    size, cell = 30.0, 0.1
    n = int(600 / length)  # about 20 m of trace per 30 m square row: P21 = 600 / 900
    traces = random_traces(length, n, size)
    occupied = np.ones((int(size / cell), int(size / cell)), dtype=bool)
    found = window_estimate(traces, occupied, np.zeros(2), cell)
    assert found is not None and found.windows >= 3
    assert found.radius == pytest.approx(6.4)  # 64 cells: the largest radius tried
    assert found.mean_length == pytest.approx(length, rel=0.25), found
    assert found.p21 == pytest.approx(n * length / size**2, rel=0.25), found
    seen = np.mean([np.linalg.norm(t[-1] - t[0]) for t in traces])
    if length == 6.0:
        assert seen < 0.9 * length  # the censored mean the windows do not lean on


def test_windows_lie_only_where_the_face_is_exposed():
    occupied = np.zeros((100, 100), dtype=bool)
    occupied[:50, :] = True  # the lower half exposed
    centres = window_centres(occupied, 10)
    assert len(centres) == 2 * 5 and (centres[:, 0] + 10 <= 50).all()  # two rows of five, on the rock


def test_a_trace_wholly_inside_a_window_gives_two_ends_and_no_crossing():
    inside = np.c_[np.linspace(-0.3, 0.3, 31), np.zeros(31)]
    assert count_in_windows([inside], np.array([[0.0, 0.0]]), 1.0) == (0, 2)


def test_the_traces_p10_on_scanlines_across_them_is_their_count_per_metre():
    """Straight traces 0.5 m apart across a 10 m square, censored by nothing: P10 is 2 /m;
    a hole in the face takes its stretch of scanline and its crossings out alike."""
    from geostructure.rockmass.windows import trace_p10

    traces = [np.c_[np.full(101, x), np.linspace(0.0, 10.0, 101)] for x in np.arange(0.25, 10.0, 0.5)]
    occupied = np.ones((100, 100), dtype=bool)
    p10, crossings, length = trace_p10(traces, occupied, np.zeros(2), 0.1)
    assert p10 == pytest.approx(2.0, rel=0.05) and crossings > 100
    occupied[40:60, :] = False  # a hole across every scanline
    holed, _, shorter = trace_p10(traces, occupied, np.zeros(2), 0.1)
    assert holed == pytest.approx(2.0, rel=0.1) and shorter == pytest.approx(0.8 * length, rel=0.05)
