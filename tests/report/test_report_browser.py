"""End-to-end: report.html in a real headless Chromium (Debian's chromium + chromedriver)."""

import time

import pytest

from geostructure.evaluation.groundtruth import match_scene
from geostructure.io.writers import write_evaluation, write_outputs
from geostructure.report.html import build_report

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def open_report(driver, path, timeout=90):
    driver.get(path.resolve().as_uri())
    end = time.monotonic() + timeout
    while not driver.execute_script("return window.reportReady === true"):
        assert time.monotonic() < end, "report.html never finished drawing"
        time.sleep(0.1)


#: The side panels whose title the mode bar (shown while the pointer is over them) would cover.
OVERLAPPING_TITLES = """
return ["stereonet", "rose"].filter((id) => {
  const panel = document.getElementById(id);
  const [title, bar] = [panel.querySelector(".gtitle"), panel.querySelector(".modebar")];
  if (!title || !bar) return true;
  const [t, b] = [title.getBoundingClientRect(), bar.getBoundingClientRect()];
  return t.top < b.bottom && b.top < t.bottom && t.left < b.right && b.left < t.right;
});
"""


def test_report_opens_lists_every_plane_and_shows_the_clicked_one(browser, tmp_path, scene, scene_result):
    from selenium.webdriver.common.by import By

    write_outputs(scene_result, tmp_path)
    write_evaluation(match_scene(scene_result, scene), tmp_path)
    open_report(browser, build_report(tmp_path, max_points=20_000))

    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not errors, errors
    rows = browser.find_elements(By.CSS_SELECTOR, "#planes tbody tr")
    assert sorted(int(r.get_attribute("data-id")) for r in rows) == list(range(len(scene_result)))

    browser.find_element(By.CSS_SELECTOR, 'th[data-key="dip"]').click()  # sort by dip
    dips = [
        float(r.find_elements(By.TAG_NAME, "td")[2].text)
        for r in browser.find_elements(By.CSS_SELECTOR, "#planes tbody tr")
    ]
    assert dips == sorted(dips)

    target = browser.find_element(By.CSS_SELECTOR, '#planes tbody tr[data-id="2"]')
    target.click()
    info = browser.find_element(By.ID, "info").text
    o = scene_result.orientation
    assert info.startswith("Plane 2")
    assert f"strike {o.strike[2]:.1f}°" in info and f"dip {o.dip[2]:.1f}°" in info
    assert "measured vs truth" in info
    assert "selected" in target.get_attribute("class")
    highlighted = browser.execute_script("return document.getElementById('scene3d').data[4].x.length")
    assert highlighted == 4  # the plane's rectangle is drawn as the highlight

    overlaps = browser.execute_script(OVERLAPPING_TITLES)
    assert overlaps == [], f"the mode bar covers the titles of {overlaps}"

    browser.find_element(By.CSS_SELECTOR, 'input[data-layer="voxels"]').click()
    assert browser.execute_script("return document.getElementById('scene3d').data[2].visible") is True
    browser.save_screenshot(str(tmp_path / "report.png"))
    assert (tmp_path / "report.png").stat().st_size > 10_000
    assert not [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
