"""The console (issue 17, piece 7): --version, --quiet, the summary first and the long tables
behind --table, analyse's units and flagged violations (console, JSON, CSV), short reprs and
to_dict() of the result objects, default result folders named from the scene (and a study's
axes) outside the project's results/, and a number written with a unit in a scene."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

import optdesign
from optdesign.cli import main as cli
from optdesign.errors import SceneError
from optdesign.study import Study, values

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
JIB = str(PROBLEMS / "seed1_jib.toml")


def test_version(capsys):
    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"optdesign {cli.version()}"


def test_quiet(capsys):
    assert cli.main(["analyse", JIB, "-q"]) == 0
    assert capsys.readouterr() == ("", "")
    assert cli.main(["analyse", JIB, "--quiet", "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["kind"] == "analysis" and err == ""
    assert cli.main(["analyse", JIB, "-q", "--set", "zz=1"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "error:" in err and "'zz'" in err


def test_optdesigns_warnings_print_as_their_line(capsys, monkeypatch):
    """A CompileWarning (the models left on CasADi's virtual machine) reaches the console as its
    message alone; another package's warning goes to Python's own handler."""
    import warnings

    import optdesign.cli.kinematics as command
    from optdesign.model.compiled import CompileWarning

    def run(args):
        warnings.warn("optdesign: compiling x failed: it runs on CasADi's virtual machine, slower", CompileWarning)
        warnings.warn("something else", DeprecationWarning)
    monkeypatch.setattr(command, "run", run)
    monkeypatch.setattr(warnings, "showwarning", warnings.showwarning)   # restored afterwards
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert cli.main(["kinematics", JIB]) == 0
    err = capsys.readouterr().err
    assert "optdesign: compiling x failed: it runs on CasADi's virtual machine, slower\n" in err
    assert "CompileWarning" not in err and "warnings.warn" not in err
    assert "\nsomething else\n" not in "\n" + err   # not ours: left to Python's (here pytest's) handler


def test_analyse_prints_the_summary_first_and_the_table_on_request(capsys):
    assert cli.main(["analyse", JIB]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == optdesign.load(JIB).title
    assert lines[1].startswith("peak |drive| = 13.70") and " kN at theta = " in lines[1]
    assert "transmission angle: 28.96 .. 40.42 deg (min 30 deg and max 150 deg): VIOLATED" in lines
    assert any(line.startswith("  violated: transmission angle: below its min 30 deg by 1.04 deg") for line in lines)
    assert len(lines) < 40 and lines[-1].startswith("(every sample: --table")
    assert cli.main(["analyse", JIB, "--table"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:2] == ["s", "q"] and len(lines) > 201
    assert any(line.startswith("violated: transmission angle") for line in lines)
    # --table keeps the summary, after the table
    assert "transmission angle: 28.96 .. 40.42 deg (min 30 deg and max 150 deg): VIOLATED" in lines


def test_analyse_json_and_csv_flag_the_violation(tmp_path, capsys):
    csv = tmp_path / "jib.csv"
    assert cli.main(["analyse", JIB, "--json", "--csv", str(csv)]) == 0
    out, err = capsys.readouterr()
    (v,) = json.loads(out)["violations"]
    assert v["name"] == "transmission angle" and v["bound"] == "min" and v["unit_shown"] == "deg"
    assert 0.0181 < v["by"] < 0.0183 and v["from"] < v["to"] == v["at"]          # rad (1.04 deg), at the end
    head = csv.read_text().splitlines()[0].split(",")
    assert head[:2] == ["theta [-]", "q [m]"] and "drive [N]" in head and "transmission angle [deg]" in head
    assert f"wrote {csv}" in err


def test_kinematics_and_simulate_summaries(capsys):
    assert cli.main(["kinematics", str(PROBLEMS / "truck_crane.toml")]) == 0
    out = capsys.readouterr().out
    assert "161 samples of theta = -10 .. 70 deg; 4 points, 2 bodies" in out and len(out.splitlines()) < 10
    assert cli.main(["kinematics", str(PROBLEMS / "truck_crane.toml"), "--table", "--samples", "5"]) == 0
    lines = capsys.readouterr().out.splitlines()   # the table's header and 5 samples, then the summary kept
    assert lines[0].split()[0] == "s" and len(lines[1].split()) == len(lines[0].split())
    assert lines[6] == "" and "5 samples of theta = -10 .. 70 deg; 4 points, 2 bodies" in lines[8]
    assert cli.main(["simulate", str(PROBLEMS / "sim_bar.toml")]) == 0
    out = capsys.readouterr().out
    assert "stopped at t = 5 s: t_end" in out and len(out.splitlines()) < 12
    assert cli.main(["simulate", str(PROBLEMS / "sim_bar.toml"), "--table"]) == 0
    assert len(capsys.readouterr().out.splitlines()) > 100


def _short(obj):
    text = repr(obj)
    assert "\n" not in text and len(text) < 300, text
    return text


def test_short_reprs_and_plain_dicts(tmp_path):
    scene = optdesign.load(JIB)
    analysis = optdesign.analyse(scene)
    assert _short(analysis).startswith(f"AnalysisResult({JIB!r}: 201 samples, peak |drive| 13706.")
    optimum = optdesign.optimise(optdesign.load(PROBLEMS / "seed1_jib_design.toml"), starts=1, workers=1)
    assert "optimum 11294.3" in _short(optimum) and "1/1 starts at the best" in repr(optimum)
    sim = optdesign.simulate(optdesign.load(PROBLEMS / "sim_bar.toml"))
    assert _short(sim).startswith("SimulationResult(") and "stop 't_end'" in repr(sim)
    study = Study(scene, [values("mC", [400.0, 500.0])], mode="analyse").run(out=tmp_path / "s", workers=1,
                                                                             figures=False)
    assert "2 cases (2 computed now, 0 from the journal), complete" in _short(study)
    for obj, kind in ((analysis, "analysis"), (optimum, "optimisation"), (sim, "simulation"), (study, "study")):
        data = obj.to_dict()
        assert data["kind"] == kind and data["title"] == obj.to_dict()["title"]
        json.dumps(data, allow_nan=False)
    assert analysis.to_dict()["columns"]["drive"] == analysis.columns["drive"].tolist()
    assert optimum.to_dict()["design"] == optimum.design
    assert len(study.to_dict()["rows"]) == 2


def test_default_folders(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["optimise", str(PROBLEMS / "seed1_jib_design.toml"), "--starts", "1", "--workers", "1",
                     "--no-animation", "-q"]) == 0
    folder = tmp_path / "optdesign-results" / "seed1_jib_design"
    assert (folder / "result.json").is_file() and (folder / "report.html").is_file()
    assert not (folder / "animation.gif").exists() and not (tmp_path / "results").exists()
    scene = optdesign.load(JIB)
    a = Study(scene, [values("mC", [400.0, 500.0])], mode="analyse").default_folder()
    b = Study(scene, [values("mC", [400.0, 600.0])], mode="analyse").default_folder()
    c = Study(scene, [values("l", [3.0, 4.0])], mode="analyse").default_folder()
    again = Study(scene, [values("mC", [400.0, 500.0])], mode="analyse").default_folder()
    assert len({a, b, c}) == 3 and a == again
    assert a.parent == Path("optdesign-results") and a.name.startswith("seed1_jib_study-mC-")
    assert c.name.startswith("seed1_jib_study-l-")


SCENE = '''title = "x"
[parameters]
VALUE
[sweep]
name = "s"
from = 0
to = 1
samples = 3
[points]
A = { fixed = [0, 0] }
'''


@pytest.mark.parametrize("value, expected", [
    ('mP = "15 t"', '''[parameters] mP: '15 t': units are not read, except 'deg' after an angle: write 15 t as 15e3 (kg), or as an expression such as "15*1000"'''),
    ('mP = 15 t', '''TOML syntax error: Expected newline or end of document after a statement (at line 3, column 9): units are not read, except 'deg' after an angle: write 15 t as 15e3 (kg)'''),
    ('L = "300 mm"', '''write 300 mm as 300e-3 (m), or as an expression such as "300/1000"'''),
    ('psi = -60 deg', '''write an angle in degrees as a string, psi = "-60 deg"'''),
])
def test_a_number_with_a_unit(value, expected):
    with pytest.raises(SceneError) as err:
        optdesign.loads(SCENE.replace("VALUE", value), "x.toml")
    assert expected in str(err.value)


def test_one_animation_frame(tmp_path):
    out = tmp_path / "frame.png"
    assert cli.main(["animate", str(PROBLEMS / "truck_crane.toml"), "--frame", "0.6", "--out", str(out), "-q"]) == 0
    from figure_checks import check_png

    check_png(out, min_size=(700, 400))
    assert cli.main(["animate", str(PROBLEMS / "truck_crane.toml"), "--frame", "1.6", "--out", str(out)]) == 2
