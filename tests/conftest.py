"""Shared fixtures: real data from ../shared/data (skipped with a message when absent)."""

from pathlib import Path

import numpy as np
import pytest

from geostructure.__main__ import prefer_small_pages, reuse_freed_memory
from geostructure.detect.pipeline import measure
from geostructure.synthetic import observatory_scene

# The tests call the command in this process (cli.main) and in subprocesses: both with the
# numpy page and malloc settings the command gives itself.
prefer_small_pages()
reuse_freed_memory()

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def shared_file(relative: str) -> Path:
    path = DATA / relative
    if not path.exists():
        pytest.skip(f"real test data {relative} is not here (expected ../shared/data beside the checkout)")
    return path


@pytest.fixture(scope="session")
def scene():
    return observatory_scene(120_000, seed=3)


@pytest.fixture(scope="session")
def scene_result(scene):
    return measure(scene.cloud)


def random_rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    return q if np.linalg.det(q) > 0 else -q


def plane_points(normal, n=4000, size=10.0, noise=0.01, center=(0, 0, 0), seed=0):
    """Noisy points on a square patch with the given normal."""
    rng = np.random.default_rng(seed)
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    helper = np.array([1.0, 0, 0]) if abs(normal[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    ab = (rng.random((n, 2)) - 0.5) * size
    return np.asarray(center) + ab[:, :1] * u + ab[:, 1:] * v + rng.normal(0, noise, (n, 1)) * normal


@pytest.fixture(scope="module")
def browser():
    """Debian's headless Chromium under selenium, logging the page's console; skipped with a
    message where it is not installed (a failure in CI, which installs it)."""
    import os
    import shutil

    from geostructure.testing.browser import CHROMIUM, DRIVER, start_chromium

    if not (os.path.exists(CHROMIUM) and os.path.exists(DRIVER)):
        message = "Debian's chromium and chromium-driver are not installed (make test installs them as root)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    pytest.importorskip("selenium.webdriver")
    driver, profile = start_chromium(log_console=True)
    yield driver
    driver.quit()
    shutil.rmtree(profile, ignore_errors=True)
