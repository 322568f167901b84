"""Generated inputs (hypothesis): random expressions against numpy's IEEE arithmetic (the right
value, or an error naming the parameter when that value is not a finite number), and random text for the
command line's numeric options (a value that obeys the option's rule, or exit 2 naming it)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import optdesign
from optdesign.cli.main import parser
from optdesign.errors import OptdesignError

from .util import JIB

TEXT = JIB.read_text()
MC = 500.0                     # the jib's mC

numbers = st.sampled_from(["0", "1", "2", "0.5", "3.25", "1e-3", "1e3", "7", "mC"])


def trees(depth=4):
    return st.recursive(
        numbers.map(lambda t: (t, np.float64(MC if t == "mC" else float(t)))),
        lambda kids: st.one_of(
            st.tuples(kids, st.sampled_from("+-*/"), kids).map(_binary),
            kids.map(lambda k: (f"-({k[0]})", _neg(k[1]))),
            st.tuples(st.sampled_from(["sqrt", "abs", "sin", "cos", "exp", "log", "atan"]), kids).map(_call),
        ),
        max_leaves=12)


def _binary(parts):
    (ta, va), op, (tb, vb) = parts
    with np.errstate(all="ignore"):      # IEEE: 1/0 = inf, 0/inf = 0, inf - inf = nan
        value = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide}[op](va, vb)
    return f"({ta}) {op} ({tb})", float(value)


def _neg(v):
    return -v


def _call(parts):
    name, (text, v) = parts
    fn = {"sqrt": np.sqrt, "abs": np.abs, "sin": np.sin, "cos": np.cos, "exp": np.exp, "log": np.log,
          "atan": np.arctan}[name]
    with np.errstate(all="ignore"):
        return f"{name}({text})", float(fn(np.float64(v)))


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tree=trees())
def test_a_random_expression_has_python_s_value_or_is_an_expression_error(tree):
    text, expected = tree
    scene_text = TEXT.replace("mC = 500.0", f"mC = 500.0\nv = \"{text}\"")
    finite = math.isfinite(expected)
    try:
        value = optdesign.loads(scene_text, "jib.toml").parameter_values()["v"]
    except OptdesignError as exc:
        assert not finite, f"{text} = {expected} refused: {exc}"
        assert "[parameters] v" in str(exc)
        return
    assert finite, f"{text}: accepted as {value}, Python says {expected}"
    assert value == pytest.approx(expected, rel=1e-12, abs=1e-300)


OPTIONS = {  # option -> (command line before it, the rule a parsed value obeys)
    "--samples": (["analyse", "S"], lambda v: isinstance(v, int) and v >= 2),
    "--seed": (["optimise", "S"], lambda v: isinstance(v, int) and v >= 0),
    "--starts": (["optimise", "S"], lambda v: isinstance(v, int) and v >= 1),
    "--tolerance": (["simulate", "S"], lambda v: math.isfinite(v) and 0 < v <= 0.1),
    "--t-end": (["simulate", "S"], lambda v: math.isfinite(v) and v > 0),
    "--steps": (["simulate", "S"], lambda v: isinstance(v, int) and v >= 2),
}
texts = st.one_of(st.text(max_size=12), st.floats(allow_nan=True, allow_infinity=True).map(repr),
                  st.integers(-10**30, 10**30).map(str), st.sampled_from(["1e4", "2.0", "-0", "0x10", " 5", "1_000"]))


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(option=st.sampled_from(sorted(OPTIONS)), text=texts)
def test_random_option_text_is_a_valid_value_or_exit_2_naming_the_option(capsys, option, text):
    before, rule = OPTIONS[option]
    try:
        args = parser().parse_args([*before, f"{option}={text}"])
    except SystemExit as exc:
        err = capsys.readouterr().err
        assert exc.code == 2 and f"argument {option}: expected " in err, err
        return
    value = getattr(args, option.lstrip("-").replace("-", "_"))
    assert rule(value), (option, text, value)
