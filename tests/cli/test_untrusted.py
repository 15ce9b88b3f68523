"""Text from a user's file never runs: not in report.html (as a file name or a truth surface's
name, on every path into the page) and not as a formula in any CSV the project writes."""

import csv
import shutil
import time

import pytest
from helpers import run_cli, scene_points, write_xyz

from geostructure.io.atomic import text_cell, write_columns_csv, write_table_csv
from geostructure.report.html import fill_template, script_json

#: A name that would run a script if it reached the page as markup, and that also holds a
#: placeholder of the report's template.
HOSTILE = "{{PAYLOAD}}<img src=x onerror=document.title='owned'>"
FORMULAS = ['=HYPERLINK("http://x")', "=cmd|' /C calc'!A0", "+SUM(1+1)*cmd|x", "@SUM(A1)", "-1+2", "+nan", "-inf"]


def test_template_is_filled_in_one_pass():
    page = fill_template("<title>{{TITLE}}</title>{{PAYLOAD}}", {"TITLE": "{{PAYLOAD}}", "PAYLOAD": "data"})
    assert page == "<title>{{PAYLOAD}}</title>data"


def test_script_json_cannot_close_its_element():
    text = script_json({"name": "</script><!-- <script>"})
    assert "<" not in text and ">" not in text
    import json

    assert json.loads(text) == {"name": "</script><!-- <script>"}


@pytest.mark.parametrize("text", FORMULAS + ["\tx", "\rx"])
def test_formula_cells_are_quoted(text):
    assert text_cell(text) == "'" + text


@pytest.mark.parametrize("text", ["wall", "-2.5", "+3", "1e-3", ""])
def test_plain_cells_are_kept(text):
    assert text_cell(text) == text


def test_both_csv_writers_quote_formulas(tmp_path):
    for write in (
        lambda p: write_table_csv([{"name": f} for f in FORMULAS], p, columns=["name"]),
        lambda p: write_columns_csv({"name": FORMULAS}, p),
    ):
        path = write(tmp_path / "t.csv")
        with open(path, newline="") as fh:
            cells = [row[0] for row in csv.reader(fh)][1:]
        assert cells == ["'" + f for f in FORMULAS]


@pytest.fixture(scope="module")
def hostile_run(tmp_path_factory):
    """A cloud under a hostile file name, measured with a truth file of hostile surface names,
    a report and an evaluation."""
    folder = tmp_path_factory.mktemp("hostile")
    cloud = write_xyz(folder / f"{HOSTILE}.xyz", scene_points(20_000, seed=3))
    truth = folder / "truth.csv"
    names = [HOSTILE.replace("{{PAYLOAD}}", ""), *FORMULAS]
    rows = [(n, 40 + 5 * i, (90 * i) % 360) for i, n in enumerate(names)]
    with open(truth, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["surface", "dip", "dip_direction"])
        writer.writerows(rows)
    out = folder / "out"
    assert run_cli_plain("measure", cloud, "-o", out, "--truth", truth, "--report", "-q") == 0
    return out, truth


def run_cli_plain(*argv) -> int:
    from geostructure.cli import main

    return main([str(a) for a in argv])


def test_report_holds_no_markup_from_the_files(hostile_run):
    out, _ = hostile_run
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<img" not in page
    assert page.count('<script id="payload" type="application/json">') == 1


def test_every_command_that_writes_the_report_escapes(hostile_run, capsys, tmp_path):
    out, truth = hostile_run
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    # Each command that changes the folder, then the report drawn from what it left.
    for argv in (["evaluate", copy, "--truth", truth], ["sets", copy], ["kinematics", copy, "--friction", "30"]):
        code, _, err = run_cli(capsys, *argv, "-q")
        assert code == 0, (argv, err)
        assert run_cli(capsys, "report", copy, "-q")[0] == 0
        assert "<img" not in (copy / "report.html").read_text(encoding="utf-8"), argv


def test_evaluation_csv_runs_no_formula(hostile_run):
    out, _ = hostile_run
    with open(out / "evaluation.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    cells = [cell for row in rows for cell in row.values() if cell]
    assert not [c for c in cells if c[0] in "=+@\t\r" or (c[0] == "-" and not _number(c))]
    assert any(c.startswith("'=") for c in cells)


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


@pytest.mark.browser
@pytest.mark.slow
def test_nothing_runs_in_chromium_when_every_plane_is_clicked(hostile_run, browser):
    out, _ = hostile_run
    browser.get((out / "report.html").resolve().as_uri())
    end = time.monotonic() + 90
    while not browser.execute_script("return window.reportReady === true"):
        assert time.monotonic() < end, "report.html never finished drawing"
        time.sleep(0.1)
    title = browser.title
    for row in browser.find_elements("css selector", "#planes tbody tr"):
        row.click()
        assert browser.title == title
        assert not browser.find_elements("css selector", "#info img, #planes img, #sets img")
    # The name is shown as the text it is; a script that ran would have set the title to 'owned'.
    assert browser.title == f"GeoStructure: {HOSTILE}.xyz"
    assert browser.find_element("id", "title").text == browser.title
