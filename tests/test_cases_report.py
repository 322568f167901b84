"""analyse reports every load case (issue 16, piece 3): the table's columns per case, each case's
peaks, the governing case of each peak, the duty cycle; the same in --json (keys cases,
governing, duty); the figures cases.png and duty.png.  The governing case is checked against a
brute-force loop over the cases in the JSON, and each case's peaks against its own samples."""
import json
import math

import pytest

from optdesign.cli import main as cli

from test_cases_time import YOKE


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("cases") / "yoke.toml"
    path.write_text(YOKE.replace("SAMPLES", "41"))
    return path


@pytest.fixture(scope="module")
def document(scene_file):
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert cli.main(["analyse", str(scene_file), "--json"]) == 0
    return json.loads(out.getvalue())


def test_json_carries_every_case(document):
    assert list(document["cases"]) == ["up", "down", "cam", "steady"]
    for name, case in document["cases"].items():
        samples = case["samples"]
        assert sum(s["scene_sample"] for s in samples) == 41
        # the peak over the continuous stroke (located and certified in every case): never
        # below the samples' largest, never above its enclosure's bound
        assert case["peaks_sampled"]["drive"] == max(abs(s["drive"]) for s in samples)
        certificate = case["certificates"]["peak |drive|"]
        assert certificate["note"] == "" and case["peaks_sampled"]["drive"] <= case["peaks"]["drive"] <= certificate["bound"]
        assert case["duration"] == pytest.approx(max(s["t"] for s in samples), rel=1e-12)
        assert {"rms_time", "energy", "energy_driving", "drive_squared"} <= set(case["integrals"])
    assert document["cases"]["down"]["set"] == {"m": 20.0}
    assert document["cases"]["down"]["direction"] == "reverse"
    # the nominal analysis is still there, as without cases
    assert {"samples", "peaks", "units"} <= set(document)


def test_governing_case_in_json_against_a_loop(document):
    for key, g in document["governing"].items():
        loop = max(((c["peaks"][key], name) for name, c in document["cases"].items() if key in c["peaks"]))
        assert (g["case"], g["value"]) == (loop[1], loop[0])


def test_duty_in_json(document):
    duty = document["duty"]
    assert duty["cycle_time"] == pytest.approx(sum(s["time"] for s in duty["steps"]), rel=1e-12)
    assert duty["mean_power"] == pytest.approx(duty["energy"] / duty["cycle_time"], rel=1e-12)
    assert set(duty["rms_time"]) == {"drive"}
    assert math.isfinite(duty["rms_time"]["drive"])


def test_table_has_columns_per_case_and_the_governing_cases(scene_file, capsys):
    assert cli.main(["analyse", str(scene_file), "--table"]) == 0
    text = capsys.readouterr().out
    header = next(line for line in text.splitlines() if "drive[up]" in line)
    for name in ("up", "down", "cam", "steady"):
        assert f"drive[{name}]" in header and f"t[{name}]" in header
    assert "governing cases:" in text and "case 'down': reverse, profile inline s-curve" in text
    assert "duty cycle:" in text and "hold at the end of up 2 s" in text


def test_figures(scene_file, tmp_path, capsys):
    out = tmp_path / "figures"
    assert cli.main(["analyse", str(scene_file), "--plot", str(out)]) == 0
    for name in ("cases.png", "duty.png", "drive.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_scene_without_cases_reports_as_before(tmp_path, capsys):
    text = YOKE.replace("SAMPLES", "21")
    path = tmp_path / "plain.toml"
    path.write_text(text[:text.index("[profiles.trap]")])
    assert cli.main(["analyse", str(path), "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    assert not {"cases", "governing", "duty", "drive_train"} & set(document)


def _titles(monkeypatch, scene_text, tmp_path):
    """{figure file: its titles} of analyse's figures over the stroke (each figure captured
    instead of saved; the cases' own figures left out)."""
    import optdesign
    import optdesign.report.analysis as analysis
    import optdesign.report.cases as cases_report
    import optdesign.report.forked as forked
    import optdesign.report.stroke_plots as stroke_plots

    titles = {}

    def capture(fig, path, label=""):
        titles[path.name] = " ".join([t for ax in fig.axes for loc in ("left", "center", "right")
                                      for t in (ax.get_title(loc=loc),) if t]
                                     + ([fig._suptitle.get_text()] if fig._suptitle else []))
        return path

    monkeypatch.setattr(stroke_plots, "save_figure", capture)
    monkeypatch.setattr(cases_report, "cases_figure_jobs", lambda result, folder: [])
    monkeypatch.setattr(forked, "_cores", lambda: 1)   # drawn here, where save_figure is captured
    analysis._analysis_figures(optdesign.analyse(optdesign.loads(scene_text), certify=False), tmp_path)
    return titles


NOMINAL = "(the nominal [drive] state; the load cases: cases.png)"


def test_figures_of_the_nominal_state_say_so_where_there_are_cases(tmp_path, monkeypatch):
    """With [[cases]], drive.png, reduced_inertia.png and constraints.png show the nominal
    [drive] state, not a case: their titles say so (issue 29: no figure shows a nominal value
    where the scene has cases without saying so)."""
    text = YOKE.replace("SAMPLES", "21")
    titles = _titles(monkeypatch, text, tmp_path)
    assert {"drive.png", "reduced_inertia.png"} <= set(titles)
    for name in ("drive.png", "reduced_inertia.png", "constraints.png"):
        if name in titles:
            assert NOMINAL in " ".join(titles[name].split()), (name, titles[name])
    plain = _titles(monkeypatch, text[:text.index("[profiles.trap]")], tmp_path)
    assert set(plain) == set(titles) and not any("nominal" in t for t in plain.values())
