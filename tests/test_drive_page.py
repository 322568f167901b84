"""The sized drive on one page (issue 29): optimise a servo transfer arm (crank-rocker, a
3-motor catalogue, a gear ratio) and a hydraulic hatch cover ([cylinder], three load cases, a
fixed stroke); their report.html, opened in headless Chromium, shows in its drive-train section
the numbers result.json holds and summary.txt prints, in the units drive engineers read (rpm,
bar, mm, l/min: converted here from the JSON's SI numbers), the gear ratio without a unit; the
torque-speed plot's points are the JSON's peak and RMS; the case figures' governing cases are
the JSON's, in the unit the scene wrote the sweep in (deg).  Each on the shipped results folders
(fast) and on folders optimised here with 2 starts (slow)."""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest

import optdesign
from optdesign.cli import main as cli

from figure_checks import check_png

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
DRIVER = shutil.which("chromedriver")

RESULTS = PROBLEMS.parent / "results"
# each page twice: the shipped results folder (the default suite; `optdesign optimise` wrote it
# with the default settings) and a folder optimised here with 2 starts (slow)
WHERE = ["shipped", pytest.param("optimised here", marks=pytest.mark.slow)]


def _folder(tmp_path_factory, name, where):
    if where == "shipped":
        out = RESULTS / name
    else:
        out = tmp_path_factory.mktemp("drive") / name
        assert cli.main(["optimise", str(PROBLEMS / f"{name}.toml"), "--starts", "2", "--workers", "2",
                         "--out", str(out)]) == 0
    return out, json.loads((out / "result.json").read_text()), (out / "summary.txt").read_text()


@pytest.fixture(scope="module", params=WHERE)
def arm(request, tmp_path_factory):
    return _folder(tmp_path_factory, "transfer_arm", request.param)


@pytest.fixture(scope="module", params=WHERE)
def hatch(request, tmp_path_factory):
    return _folder(tmp_path_factory, "hatch_cover", request.param)


def _g(x, digits=4):
    return f"{x:.{digits}g}"


def _page_tables(folder):
    """{table id: [[cell texts], ...]} of report.html as Chromium renders it (its console
    clean, every image loaded)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--window-size=1280,2000"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(executable_path=DRIVER), options=options)
    try:
        driver.get((folder / "report.html").resolve().as_uri())
        assert not [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]
        for img in driver.find_elements(By.TAG_NAME, "img"):
            assert driver.execute_script("return arguments[0].complete && arguments[0].naturalWidth", img) > 300
        tables = {}
        for table in driver.find_elements(By.CSS_SELECTOR, "table[id]"):
            tables[table.get_attribute("id")] = [[td.text for td in tr.find_elements(By.TAG_NAME, "td")]
                                                 for tr in table.find_elements(By.CSS_SELECTOR, "tbody tr")]
        figures = {f.get_attribute("id") for f in driver.find_elements(By.TAG_NAME, "figure")}
        return tables, figures
    finally:
        driver.quit()


needs_browser = pytest.mark.skipif(CHROMIUM is None or DRIVER is None,
                                   reason="Chromium and chromedriver are not installed here (CI installs them: .ci/run)")


@needs_browser
def test_arm_page_shows_the_catalogue_the_json_holds(arm):
    pytest.importorskip("selenium")
    folder, doc, summary = arm
    tables, figures = _page_tables(folder)
    assert {"cases", "torque_speed", "drive_and_constraints", "animation"} <= figures
    train = doc["cases"]["drive_train"]
    chosen = doc["chosen_motor"]
    motors = doc["catalogue_at_optimum"]
    assert set(motors) == {"servo 400 W", "servo 750 W", "servo 1.5 kW"}
    rows = {r[0]: r for r in tables["motors"]}
    assert f"{chosen} (chosen)" in rows
    rpm = 60 / (2 * math.pi)
    for name, m in motors.items():
        row = rows[name + (" (chosen)" if name == chosen else "")]
        assert row[1:5] == [_g(m["peak"]), _g(m["peak_torque"]), _g(m["rms"]), _g(m["rated_torque"])]
        assert row[5:7] == [_g(m["peak_speed"] * rpm), _g(m["max_speed"] * rpm)]
        assert row[8] == ("yes" if m["fits"] else "no")
        fits = m["peak"] <= m["peak_torque"] * (1 + 1e-6) and m["rms"] <= m["rated_torque"] * (1 + 1e-6) \
            and m["peak_speed"] <= m["max_speed"] * (1 + 1e-6)
        assert m["fits"] == fits
        # the same numbers in the summary
        assert (f"    {row[0]}: peak {row[1]} of {row[2]} N m, RMS {row[3]} of rated {row[4]} N m, speed {row[5]} of "
                f"{row[6]} rpm") in summary
    assert motors[chosen]["fits"]
    # the chosen motor's numbers at the chosen design are those of its own optimisation
    assert motors[chosen]["peak"] == pytest.approx(train["motors"][chosen]["peak"], rel=1e-9)
    # the gear ratio: dimensionless, with the motor and output speeds in rad/s and rpm
    ratio = dict(tuple(r) for r in tables["drive-train"])
    assert ratio["gear ratio i (motor speed / output speed)"] == f"{doc['design']['i']:.6g}"
    speed = train["motors"][chosen]["peak_speed"]
    assert ratio["peak motor speed"].startswith(f"{_g(speed)} rad/s ({_g(speed * rpm)} rpm)")
    assert ratio["peak output speed"] == f"{_g(speed / doc['design']['i'])} rad/s ({_g(speed / doc['design']['i'] * rpm)} rpm)"
    design = {r[0]: r for r in tables["design"]}
    assert design["i"][5] == "" and design["r"][5] == "m"
    # each catalogue motor's outcome as tried
    assert {r[0]: r[1] for r in tables["catalogue"]} == doc["motors"]


@needs_browser
def test_hatch_page_shows_the_cylinder_the_json_holds(hatch):
    pytest.importorskip("selenium")
    folder, doc, summary = hatch
    tables, figures = _page_tables(folder)
    assert {"cases", "cylinder", "drive_and_constraints"} <= figures
    t = doc["cases"]["drive_train"]
    rows = dict(tuple(r) for r in tables["cylinder-sizes"])
    area, annulus = math.pi * t["bore"] ** 2 / 4, math.pi * (t["bore"] ** 2 - t["rod"] ** 2) / 4
    assert rows["bore"] == f"{_g(t['bore'] * 1e3)} mm (needed {_g(t['bore_needed'] * 1e3)} mm)"
    assert rows["rod"].startswith(f"{_g(t['rod'] * 1e3)} mm")
    assert rows["system pressure"] == f"{_g(t['pressure'] / 1e5)} bar"
    # the pressures from the forces and the areas, computed here
    assert rows["pressure pushing"].startswith(f"{_g(t['peak_push'] / area / 1e5)} bar")
    assert rows["pressure pulling"].startswith(f"{_g(t['peak_pull'] / annulus / 1e5)} bar")
    assert rows["pump flow"] == f"{_g(t['pump_flow'] * 6e4)} l/min"
    assert rows["buckling utilisation"].startswith(_g(t["buckling_utilisation"], 3))
    for label, value in rows.items():
        assert f"  {label}: {value}" in summary
    # the objective (the peak force) is the cylinder's peak push, in every case
    assert t["peak_push"] == pytest.approx(doc["objective"], rel=1e-6)
    # the governing case, the sweep in deg as the scene wrote it
    g = doc["cases"]["governing_cases"]["drive"]
    governing = dict(tuple(r) for r in tables["governing"])
    assert governing["peak cylinder force"] == f"case '{g['case']}' at theta = {_g(math.degrees(g['s']))} deg"
    # the fixed stroke: an equality the solver holds, never shown VIOLATED
    c = {r[0]: r for r in tables["constraints"]}["cylinder stroke"]
    assert c[2] == "0.4"


def test_torque_speed_points_are_the_jsons(arm):
    """The torque-speed plot's governing peak and the duty cycle's RMS point
    (report/sized.operating_points) are the JSON's peak and RMS; the per-case RMS points
    combine to the cycle's RMS over time (the dwells carry no torque)."""
    from optdesign.report.sized import operating_points

    folder, doc, _ = arm
    check_png(folder / "torque_speed.png", min_size=(600, 400))
    scene = optdesign.load(PROBLEMS / "transfer_arm.toml").with_parameters(**doc["design"])
    cases = optdesign.analyse(scene).cases
    pts = operating_points(cases, doc["chosen_motor"])
    m = doc["cases"]["drive_train"]["motors"][doc["chosen_motor"]]
    assert pts["peak"]["value"] == m["peak"] and pts["peak"]["case"] == doc["cases"]["governing_cases"]["motor_torque"]["case"]
    assert abs(pts["peak"]["torque"]) == pytest.approx(m["peak"], rel=1e-3)   # on the samples: below the certified
    assert pts["cycle"][1] == pytest.approx(m["rms"], rel=1e-9)
    duty = cases.duty
    total = sum(cases.cases[s["case"]].duration * pts["cases"][s["case"]]["rms_torque"] ** 2 * s["repeat"]
                for s in duty["steps"] if s["kind"] == "case")
    assert math.sqrt(total / duty["cycle_time"]) == pytest.approx(m["rms"], rel=1e-9)
    # the peak envelope and the speed limit are the motor's own
    assert pts["limits"]["peak_torque"] == m["peak_torque"] and pts["limits"]["max_speed"] == m["max_speed"]
