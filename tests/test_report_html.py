"""report.html in every optimise folder (issue 17, piece 5): self-contained (no script, no link,
every figure inlined), with the problem, the design table with bounds, the constraints with the
active ones marked, the certified peak, the local optima, sensitivities, the figures and the
animation; opened in a real headless Chromium (selenium), which must log no console error, load
every image and show the tables and figures.  The browser test is skipped only where Chromium
and its driver are absent (CI installs them in .ci/run)."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from optdesign.cli import main as cli

from figure_checks import check_png, gif_frames

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
DRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("optimise") / "truck_crane"
    assert cli.main(["optimise", str(PROBLEMS / "truck_crane.toml"), "--starts", "3", "--workers", "2",
                     "--out", str(out)]) == 0
    return out


def test_folder_holds_the_figures_and_the_page(folder):
    for name in ("result.json", "summary.txt", "drive_and_constraints.png", "mechanism.png", "mechanism.svg",
                 "animation.gif", "report.html"):
        assert (folder / name).is_file(), name
    check_png(folder / "mechanism.png", min_size=(1000, 500), min_ink=0.03)
    check_png(folder / "drive_and_constraints.png", min_size=(700, 500))
    assert len(gif_frames(folder / "animation.gif")) == 30


def test_page_is_self_contained(folder):
    page = (folder / "report.html").read_text()
    assert "<script" not in page and "<link" not in page and "@import" not in page
    # the only URLs are XML namespace names inside the inlined SVG, which are never fetched
    urls = set(re.findall(r"https?://[^\s\"'<>)]+", page))
    assert urls <= {"http://www.w3.org/2000/svg", "http://www.w3.org/1999/xlink"}, urls
    assert page.count("data:image/png;base64,") == 1 and page.count("data:image/gif;base64,") == 1
    assert page.count("<svg") >= 1
    for section in ('id="design"', 'id="constraints"', 'id="certified"', 'id="optima"', 'id="sensitivities"',
                    'id="mechanism"', 'id="animation"', 'id="starts"', 'id="problem"'):
        assert section in page, section
    assert "171.49" in page           # the certified optimum, in kN
    assert "at its min" in page       # yD on its lower bound


def _browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--window-size=1280,2000"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path=DRIVER), options=options)


@pytest.mark.skipif(CHROMIUM is None or DRIVER is None,
                    reason="Chromium and chromedriver are not installed here (CI installs them: .ci/run)")
def test_page_in_headless_chromium(folder):
    pytest.importorskip("selenium", reason="selenium is in the test extra: pip install -e '.[test]'")
    from selenium.webdriver.common.by import By

    driver = _browser()
    try:
        driver.get((folder / "report.html").resolve().as_uri())
        driver.execute_script("return document.readyState")
        errors = [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]
        assert not errors, errors
        assert driver.title.startswith("Truck-mounted crane")
        rows = driver.find_elements(By.CSS_SELECTOR, "#design tbody tr")
        assert [r.find_elements(By.TAG_NAME, "td")[0].text for r in rows] == ["xD", "yD", "b"]
        assert all(r.is_displayed() for r in rows)
        active = driver.find_elements(By.CSS_SELECTOR, "#constraints tr.active td:first-child")
        assert {a.text for a in active} == {"transmission angle", "cylinder length ratio"}
        images = driver.find_elements(By.TAG_NAME, "img")
        assert len(images) == 2
        for img in images:
            assert driver.execute_script("return arguments[0].complete && arguments[0].naturalWidth", img) > 300
            assert img.size["width"] > 300 and img.size["height"] > 200
        svg = driver.find_element(By.CSS_SELECTOR, "#mechanism svg")
        assert svg.size["width"] > 500 and svg.size["height"] > 250
        # nothing fetched from anywhere: every resource is inline
        fetched = driver.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
        assert all(not u.startswith(("http:", "https:")) for u in fetched), fetched
        verdict = driver.find_element(By.ID, "verdict").text
        assert "reached by 3 of 3 starts" in verdict
    finally:
        driver.quit()
