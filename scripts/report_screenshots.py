"""Screenshots of a report's views in headless Chromium, to look at them before saying they
are right (the developers' guide): ``python scripts/report_screenshots.py OUTDIR/report.html
FOLDER [PREFIX]`` writes FOLDER/PREFIX_<view>.png for the 3D view, the stereonet, the rose,
the spacing histograms and the tables, each as the page lays it out at 1400 px wide."""

from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path

from geostructure.testing.browser import start_chromium

#: The page's elements worth a look, by id.
VIEWS = ("scene3d", "stereonet", "rose", "spacing", "sets", "planes")


def screenshots(report: Path, folder: Path, prefix: str = "report") -> list[Path]:
    """One PNG per view of ``report`` that the page has, in ``folder``."""
    from selenium.webdriver.common.by import By

    folder.mkdir(parents=True, exist_ok=True)
    driver, profile = start_chromium()
    written = []
    try:
        driver.set_window_size(1400, 1000)
        driver.get(report.resolve().as_uri())
        time.sleep(4)  # plotly draws the WebGL view after the page loads
        for view in VIEWS:
            found = driver.find_elements(By.ID, view)
            if not found or not found[0].size["height"]:  # no sets: no spacing panel
                continue
            driver.execute_script("arguments[0].scrollIntoView();", found[0])
            time.sleep(0.5)
            path = folder / f"{prefix}_{view}.png"
            found[0].screenshot(str(path))
            written.append(path)
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
    return written


if __name__ == "__main__":
    for path in screenshots(Path(sys.argv[1]), Path(sys.argv[2]), *(sys.argv[3:4] or [])):
        print(path)
