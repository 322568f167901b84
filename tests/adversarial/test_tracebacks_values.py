"""Tracebacks and unclear messages: every command-line value and API argument is checked at the
front door (optdesign/cli/common.py, optdesign/scene/arguments.py), with a message that names it;
exit 2 on the command line, TypeError or an ArgumentError (ValueError) in Python."""
from __future__ import annotations

import math
import os

import pytest

import optdesign
from optdesign.cli.main import main
from optdesign.errors import ArgumentError, ExpressionError, SceneError
from optdesign.study import Study, values

from .util import JIB, JIB_DESIGN, SIM


def run(capsys, *argv):
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    captured = capsys.readouterr()
    return code, captured.err


# --- the command line ----------------------------------------------------------------------------
@pytest.mark.parametrize("argv, message", [
    (["optimise", JIB_DESIGN, "--seed", "-1"], "argument --seed: expected a whole number >= 0, found '-1'"),
    (["optimise", JIB_DESIGN, "--seed", "1.5"], "argument --seed: expected a whole number >= 0, found '1.5'"),
    (["optimise", JIB_DESIGN, "--seed", "x"], "argument --seed: expected a whole number >= 0, found 'x'"),
    (["study", JIB, "--values", "mC=1", "--seed", "-1"], "argument --seed: expected a whole number >= 0, found '-1'"),
    (["simulate", SIM, "--tolerance=-1e-6"], "argument --tolerance: expected a finite number > 0 and <= 0.1, found '-1e-6'"),
    (["simulate", SIM, "--tolerance", "0"], "argument --tolerance: expected a finite number > 0 and <= 0.1, found '0'"),
    (["simulate", SIM, "--tolerance", "nan"], "argument --tolerance: expected a finite number > 0 and <= 0.1, found 'nan'"),
    (["simulate", SIM, "--tolerance", "inf"], "argument --tolerance: expected a finite number > 0 and <= 0.1, found 'inf'"),
    (["simulate", SIM, "--tolerance", "1"], "argument --tolerance: expected a finite number > 0 and <= 0.1, found '1'"),
    (["simulate", SIM, "--tolerance", "tight"], "argument --tolerance: expected a number, found 'tight'"),
    (["simulate", SIM, "--t-end", "nan"], "argument --t-end: expected a finite number > 0, found 'nan'"),
    (["simulate", SIM, "--t-end", "inf"], "argument --t-end: expected a finite number > 0, found 'inf'"),
    (["simulate", SIM, "--t-end=-1e-300"], "argument --t-end: expected a finite number > 0, found '-1e-300'"),
    (["simulate", SIM, "--t-end", "0"], "argument --t-end: expected a finite number > 0, found '0'"),
    (["simulate", SIM, "--t-end", "1e400"], "argument --t-end: expected a finite number > 0, found '1e400'"),
    (["simulate", SIM, "--steps", "1"], "argument --steps: expected a whole number >= 2, found '1'"),
    (["simulate", SIM, "--steps", "2.5"], "argument --steps: expected a whole number >= 2, found '2.5'"),
    (["analyse", JIB, "--samples", "1"], "argument --samples: expected a whole number >= 2, found '1'"),
    (["analyse", JIB, "--samples", "1e400"], "argument --samples: expected a whole number >= 2, found '1e400'"),
    (["optimise", JIB_DESIGN, "--workers", "0"], "argument --workers: expected a whole number >= 1, found '0'"),
])
def test_bad_option_values_exit_2_naming_the_option(capsys, tmp_path, argv, message):
    code, err = run(capsys, *argv, *(["--out", tmp_path / "o"] if argv[0] in ("optimise", "study") else []))
    assert code == 2 and message in err, err
    assert "Traceback" not in err and not (tmp_path / "o").exists()


def test_a_whole_number_may_be_written_in_e_notation(capsys):
    code, err = run(capsys, "analyse", JIB, "--samples", "1e2", "--json")
    assert code == 0, err


def test_a_scheduler_that_is_not_an_address_is_a_clear_error(capsys, tmp_path):
    pytest.importorskip("distributed")
    code, err = run(capsys, "study", JIB, "--mode", "analyse", "--values", "mC=1,2", "--scheduler", "not an address",
                    "--out", tmp_path / "s")
    assert code == 2
    assert ("--scheduler 'not an address': cannot reach the Dask scheduler (" in err
            and "expected an address such as tcp://10.0.0.5:8786" in err), err


def test_a_drive_speed_whose_square_overflows_is_a_scene_error(tmp_path, capsys):
    text = JIB.read_text().replace("speed = 0.1", "speed = 1e200")
    assert "speed = 1e200" in text
    (tmp_path / "fast.toml").write_text(text)
    code, err = run(capsys, "analyse", tmp_path / "fast.toml")
    assert code == 2 and "[drive] speed = 1e+200: too large, its square overflows a float" in err


@pytest.mark.parametrize("make, message", [
    (lambda p: os.mkfifo(p), "not a regular file (a pipe or a device)"),
    (lambda p: p.mkdir(), "cannot read it as a scene file"),
    (lambda p: None, "no such scene file"),
    (lambda p: p.write_bytes(b"title = '\xff\xfe'"), "cannot read it as a scene file"),
])
def test_a_scene_that_cannot_be_read_is_a_clear_error(tmp_path, capsys, make, message):
    path = tmp_path / "scene.toml"
    make(path)
    code, err = run(capsys, "analyse", path)
    assert code == 2 and f"{path}: {message}" in err, err


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads every file")
def test_an_unreadable_scene_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text(JIB.read_text())
    path.chmod(0)
    code, err = run(capsys, "analyse", path)
    assert code == 2 and "cannot read the scene file (Permission denied)" in err


# --- deep expressions -------------------------------------------------------------------------------
@pytest.mark.parametrize("expr, message", [
    ("(" * 101 + "1" + ")" * 101, "parentheses nested 101 deep; at most 100"),
    ("(" * 400 + "1" + ")" * 400, "parentheses nested 400 deep; at most 100"),
    ("+".join(["1"] * 201), "nested too deeply (201 operations inside one another; at most 200)"),
    ("+".join(["mC"] * 3000), "nested too deeply (3000 operations inside one another; at most 200)"),
    ("-" * 5000 + "1", "nested too deeply (operations inside one another; at most 200)"),
])
def test_expressions_nested_too_deeply_are_expression_errors(capsys, expr, message):
    with pytest.raises(ExpressionError, match=message.replace("(", r"\(").replace(")", r"\)")):
        optdesign.load(JIB, {"mC": expr})
    code, err = run(capsys, "analyse", JIB, "--set", f"mC={expr}")
    assert code == 2 and "[parameters] mC: " in err and message in err


def test_a_deep_expression_within_the_limit_gives_the_right_answer():
    deep = optdesign.analyse(optdesign.load(JIB, {"mC": "+".join(["2.5"] * 200)}))
    flat = optdesign.analyse(optdesign.load(JIB, {"mC": 500}))
    assert deep.peaks == flat.peaks
    nested = optdesign.analyse(optdesign.load(JIB, {"mC": "(" * 100 + "500" + ")" * 100}))
    assert nested.peaks == flat.peaks


def test_a_deep_expression_through_study_values_is_an_expression_error(capsys, tmp_path):
    code, err = run(capsys, "study", JIB, "--mode", "analyse", "--values", "mC=" + "+".join(["1"] * 300),
                    "--out", tmp_path / "s")
    assert code == 2 and "nested too deeply (300 operations" in err


# --- the Python front doors ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def jib():
    return optdesign.load(JIB)


@pytest.mark.parametrize("call, error, message", [
    (lambda s: optdesign.load(JIB.read_text()), ArgumentError, "load: path: .* is the text of a scene, not a file path; "
                                                               r"use optdesign.loads\(text\)"),
    (lambda s: optdesign.load(3), TypeError, r"load: path: expected a file path \(str or pathlib.Path\), found int 3"),
    (lambda s: optdesign.load(JIB.read_bytes()), TypeError, r"load: path: expected a file path .*found bytes"),
    (lambda s: optdesign.load(JIB, ["mC=5"]), TypeError, r"load: overrides: expected a dict \{name: value\}, found list"),
    (lambda s: optdesign.loads(JIB.read_bytes()), TypeError, r"loads: text: expected the scene's TOML text as a str, "
                                                             r"found bytes; decode it first"),
    (lambda s: optdesign.loads(JIB), TypeError, r"loads: text: .* found PosixPath; for a file use optdesign.load\(path\)"),
    (lambda s: optdesign.analyse(None), TypeError, r"analyse: scene: expected a Scene .*found NoneType None$"),
    (lambda s: optdesign.analyse("file.toml"), TypeError,
     r"analyse: scene: .*found str 'file.toml'; load the file first: analyse\(optdesign.load\('file.toml'\)\)"),
    (lambda s: optdesign.analyse(s, 0), ArgumentError, "samples: expected a whole number >= 2, found 0"),
    (lambda s: optdesign.analyse(s, 1), ArgumentError, "samples: expected a whole number >= 2, found 1"),
    (lambda s: optdesign.analyse(s, 2.5), ArgumentError, "samples: expected a whole number >= 2, found 2.5"),
    (lambda s: optdesign.analyse(s, "10"), TypeError, "samples: expected a whole number, found str '10'"),
    (lambda s: optdesign.analyse(s, True), TypeError, "samples: expected a whole number, found bool True"),
    (lambda s: optdesign.analyse(s, math.nan), ArgumentError, "samples: expected a whole number >= 2, found nan"),
    (lambda s: optdesign.kinematics(None), TypeError, "kinematics: scene: expected a Scene"),
    (lambda s: optdesign.kinematics(s, -5), ArgumentError, "samples: expected a whole number >= 2, found -5"),
    (lambda s: optdesign.simulate(None), TypeError, "simulate: scene: expected a Scene"),
    (lambda s: optdesign.optimise(None), TypeError, "optimise: scene: expected a Scene"),
    (lambda s: optdesign.optimise(optdesign.load(JIB_DESIGN), starts=0), ArgumentError,
     "starts: expected a whole number >= 1, found 0"),
    (lambda s: optdesign.optimise(optdesign.load(JIB_DESIGN), seed=-1), ArgumentError,
     "seed: expected a whole number >= 0, found -1"),
    (lambda s: optdesign.optimise(optdesign.load(JIB_DESIGN), workers=0), ArgumentError,
     "workers: expected a whole number >= 1, found 0"),
    (lambda s: optdesign.optimise(optdesign.load(JIB_DESIGN), starts="3"), TypeError,
     "starts: expected a whole number, found str '3'"),
    (lambda s: Study(s, "mC"), TypeError, r"Study: axes: expected a list of axes .* found str 'mC'"),
    (lambda s: Study(s, ["mC"]), TypeError, r"Study: axes: expected a list of axes .* found list \['mC'\]"),
    (lambda s: Study(None, [values("mC", [1])]), TypeError, "Study: scene: expected a Scene"),
    (lambda s: Study(s, [values("mC", [1])], mode="analyse", seed=-1), ArgumentError,
     "Study: seed: expected a whole number >= 0, found -1"),
])
def test_api_calls_with_wrong_types_or_values_name_the_argument(jib, call, error, message):
    with pytest.raises(error, match=message):
        call(jib)


@pytest.mark.parametrize("kwargs, error, message", [
    ({"t_end": math.nan}, ArgumentError, "t_end: expected a finite number > 0, found nan"),
    ({"t_end": math.inf}, ArgumentError, "t_end: expected a finite number > 0, found inf"),
    ({"t_end": -1.0}, ArgumentError, "t_end: expected a finite number > 0, found -1"),
    ({"tolerance": 0.0}, ArgumentError, "tolerance: expected a finite number > 0 and <= 0.1, found 0"),
    ({"tolerance": math.nan}, ArgumentError, "tolerance: expected a finite number > 0 and <= 0.1, found nan"),
    ({"tolerance": "1e-6"}, TypeError, "tolerance: expected a number, found str '1e-6'"),
    ({"samples": 1}, ArgumentError, "samples: expected a whole number >= 2, found 1"),
    ({"integrator": "euler"}, SceneError, "integrator 'euler': expected one of bdf, adams, rk4"),
])
def test_simulate_arguments_are_checked_before_integrating(kwargs, error, message):
    with pytest.raises(error, match=message):
        optdesign.simulate(optdesign.load(SIM), **kwargs)
