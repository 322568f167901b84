"""Bad input: every case gives a SceneError (ExpressionError for expressions) whose message
names the file, the line where the file has one, the table and key, what was found, what was
expected, and the near miss where there is one.  Never a traceback from inside CasADi or a
bare Python error.

Each test mutates a valid scene in one place (``mutate`` checks that the place exists exactly
once, so a test cannot pass by mutating nothing) and reads the expected line number off the
mutated text itself.
"""
import math

import pytest

from optdesign.cli import main as cli
from optdesign.errors import ExpressionError, SceneError
from optdesign.scene import (Body, Closure, Drive, Dyad, Fixed, Loop, Parameter, Polar, Scene, Slider,
                             Sweep)
from optdesign.scene.file import load, loads

# A four-bar with a dyad, a slider on the coupler's extension, a body and a drive: every
# construction kind of the closed form, in a dozen lines.
BASE = '''title = "four-bar with a slider"

[parameters]
r = 0.1
l = 0.35
c = { value = 0.3, min = 0.2, max = 0.5 }
m = 2.0

[sweep]
name = "alpha"
from = "10 deg"
to = "80 deg"
samples = 11

[points]
A = { fixed = [0, 0] }
D = { fixed = ["c", 0] }
B = { polar = ["A", "r", "alpha"] }
C = { dyad = ["B", "l", "D", "0.3"], side = "left" }
E = { slider = ["C", "l", "A", "90 deg"], side = "ahead" }
P = { attach = ["B", "C", 0.1, 0] }

[[bodies]]
name = "coupler"
frame = ["B", "C"]
mass = "m"
com = [0.1, 0]

[[bodies]]
name = "slider"
frame = ["E", "C"]
mass = 1.0
com = [0, 0]

[drive]
type = "rotary"
crank = ["A", "B"]
speed = 10.0
acceleration = 0.0

[[constraints]]
name = "transmission"
expr = "angle(B, C, D)"
min = "30 deg"
'''

LOOP = '''title = "four-bar as a Newton loop"

[parameters]
R = 0.4
L = 0.2

[sweep]
name = "phi1"
from = "20 deg"
to = "60 deg"
samples = 5
rate = 1.0

[points]
A = { fixed = [0, 0] }
D = { fixed = ["L", 0] }

[points.chain]
loop = "A"
lengths = ["R", "L", "R"]
angles = ["phi1", "phi2", "phi3"]
joints = ["B", "C", "D3"]
unknowns = { phi2 = "90 deg", phi3 = "pi - phi1" }
closure = { point = "D3", fixed = "D" }
'''


def mutate(text, old, new):
    assert text.count(old) == 1, f"{old!r} must occur exactly once in the scene"
    return text.replace(old, new)


def line(text, needle):
    """The 1-based line of the first line of ``text`` that holds ``needle``."""
    for no, row in enumerate(text.splitlines(), 1):
        if needle in row:
            return no
    raise AssertionError(f"{needle!r} not in the text")


def assert_fails(text, cls, *words, at=None, path="bad.toml"):
    """Load ``text``; it must raise exactly ``cls`` with all ``words`` in its message, led by
    the file name and, when ``at`` is given, the line of ``at``."""
    with pytest.raises(cls) as info:
        loads(text, path)
    assert info.type is cls, f"{info.type.__name__}: {info.value}"
    message = str(info.value)
    head = f"{path}, line {line(text, at)}: " if at else f"{path}"
    assert message.startswith(head), message
    for w in words:
        assert w in message, f"{w!r} not in {message!r}"
    assert info.value.__cause__ is None and info.value.__suppress_context__, "no chained traceback"
    return message


def test_the_base_scenes_are_valid():
    """The mutations below must be the only thing wrong."""
    assert loads(BASE, "bad.toml").point_names() == ["A", "D", "B", "C", "E", "P"]
    assert loads(LOOP, "bad.toml").point_names() == ["A", "D", "B", "C", "D3"]


# --- TOML syntax ----------------------------------------------------------------------------
def test_toml_syntax_error():
    text = mutate(BASE, "r = 0.1", "r = = 0.1")
    assert_fails(text, SceneError, "TOML syntax error", "Invalid value", at="r = = 0.1")


def test_toml_unterminated_string():
    text = mutate(BASE, 'title = "four-bar with a slider"', 'title = "four-bar')
    assert_fails(text, SceneError, "TOML syntax error", at='title = "four-bar')


# --- unknown keys -----------------------------------------------------------------------------
def test_unknown_top_level_table_suggests_the_near_miss():
    text = mutate(BASE, "[sweep]", "[sweeep]")
    assert_fails(text, SceneError, "unknown top-level table or key 'sweeep'", "did you mean 'sweep'?", at="[sweeep]")


def test_unknown_top_level_key_without_near_miss_lists_the_keys():
    text = "colour = 3\n" + BASE
    assert_fails(text, SceneError, "unknown top-level table or key 'colour'", "expected one of: title, source,",
          at="colour = 3")


def test_unknown_key_in_sweep_suggests_samples():
    text = mutate(BASE, "samples = 11", "sampels = 11")
    assert_fails(text, SceneError, "[sweep] sampels", "unknown key 'sampels'", "did you mean 'samples'?",
          at="sampels = 11")


def test_unknown_key_in_a_body():
    text = mutate(BASE, 'mass = "m"', 'mas = "m"')
    assert_fails(text, SceneError, "[[bodies]] 'coupler', mas", "unknown key 'mas'", "did you mean 'mass'?",
          at='mas = "m"')


def test_unknown_key_in_a_construction():
    text = mutate(BASE, 'side = "left"', 'sied = "left"')
    assert_fails(text, SceneError, "[points] C, sied", "unknown key 'sied'", "did you mean 'side'?", at="sied")


def test_unknown_construction_kind():
    text = mutate(BASE, "A = { fixed = [0, 0] }", "A = { fixd = [0, 0] }")
    assert_fails(text, SceneError, "[points] A", "expected exactly one construction kind (fixed, polar, dyad, "
          "slider, attach, loop)", "found 'fixd'", "did you mean 'fixed'?", at="A = { fixd")


def test_unknown_key_in_a_loop_closure():
    text = mutate(LOOP, 'fixed = "D" }', 'fixd = "D" }')
    assert_fails(text, SceneError, "[points] chain, closure.fixd", "unknown key 'fixd'", "did you mean 'fixed'?",
          at="closure =")


def test_unknown_key_in_a_design_parameter():
    text = mutate(BASE, "min = 0.2", "mn = 0.2")
    assert_fails(text, SceneError, "[parameters] c, mn", "unknown key 'mn'", "did you mean 'min'?", at="mn = 0.2")


def test_unknown_key_in_the_drive_and_the_objective():
    text = mutate(BASE, "speed = 10.0", "sped = 10.0")
    assert_fails(text, SceneError, "[drive] sped", "unknown key 'sped'", "did you mean 'speed'?", at="sped")
    text = BASE + '\n[objective]\nminimize = "peak(drive)"\n'
    assert_fails(text, SceneError, "[objective] minimize", "did you mean 'minimise'?", at="minimize")


# --- unknown names and functions in expressions ----------------------------------------------
def test_unknown_name_in_an_expression_suggests_the_near_miss():
    text = mutate(BASE, '"A", "r", "alpha"', '"A", "r", "alpah"')
    assert_fails(text, ExpressionError, "[points] B, polar angle", "'alpah'", "unknown name 'alpah'",
          "did you mean 'alpha'?", at="alpah")


def test_unknown_name_without_near_miss_lists_what_is_known():
    text = mutate(BASE, 'mass = "m"', 'mass = "zeta"')
    assert_fails(text, ExpressionError, "[[bodies]] 'coupler', mass", "unknown name 'zeta'",
          "expected one of: alpha, c, l, m, r, pi, deg", at='mass = "zeta"')


def test_unknown_function_suggests_the_near_miss():
    text = mutate(BASE, 'expr = "angle(B, C, D)"', 'expr = "angel(B, C, D)"')
    assert_fails(text, ExpressionError, "[[constraints]] 'transmission', expr", "unknown function 'angel'",
          "did you mean 'angle'?", at="angel")


def test_a_point_used_as_a_number():
    text = mutate(BASE, '"A", "r", "alpha"', '"A", "r", "D"')
    assert_fails(text, ExpressionError, "[points] B, polar angle", "'D' is a point, not a number", "use x(D), y(D)",
          at='"A", "r", "D"')


def test_the_sweep_in_a_parameter():
    text = mutate(BASE, "m = 2.0", 'm = "2*alpha"')
    assert_fails(text, ExpressionError, "[parameters] m", "the sweep variable 'alpha' cannot be used here",
          "expected a value that is the same over the whole stroke", at='m = "2*alpha"')


def test_a_parameter_used_before_it_is_defined():
    text = mutate(BASE, "r = 0.1", 'r = "l/3.5"')
    assert_fails(text, ExpressionError, "[parameters] r", "'l' is defined further down", "move its line",
          at='r = "l/3.5"')


def test_an_aggregate_outside_a_constraint():
    text = mutate(BASE, '"A", "r", "alpha"', '"A", "r", "max(alpha)"')
    assert_fails(text, ExpressionError, "[points] B, polar angle", "min() or max() with one argument is the "
          "extreme over the whole stroke", "max(a, b)", at="max(alpha)")


def test_a_constraint_that_mixes_aggregate_and_samples():
    text = mutate(BASE, 'expr = "angle(B, C, D)"', 'expr = "max(length(A, C)) - length(A, C)"')
    assert_fails(text, ExpressionError, "[[constraints]] 'transmission', expr", "mixes one value per stroke",
          "'A', 'C' outside min/max", at="max(length(A, C))")


@pytest.mark.parametrize("bad, words", [
    ("sin(1, 2)", ["sin() takes 1 argument, found 2"]),
    ("2 +", ["the expression ends too early after '+'", "expected a number, a name or '('"]),
    ("length(A)", ["length() takes 2 point names, found 1 argument"]),
    ("x(3)", ["x() takes point names as arguments, found 3"]),
    ("__import__('os')", ["unexpected character"]),
    ("min()", ["min() needs an argument"]),
    ("alpha deg", ["'deg' after something other than a number"]),
    ("1/0", ["evaluates to inf", "expected a finite number"]),
    ("sqrt(-1)", ["evaluates to nan"]),
])
def test_malformed_expression_never_reaches_casadi(bad, words):
    text = mutate(BASE, "m = 2.0", f"m = {bad!r}".replace("'", '"') if "'" not in bad else f'm = "{bad}"')
    message = assert_fails(text, ExpressionError, "[parameters] m", *words, at="m = ")
    assert bad in message


# --- points used before they are built ---------------------------------------------------------
def test_a_point_used_before_it_is_built():
    text = mutate(BASE, 'B = { polar = ["A", "r", "alpha"] }', 'B = { polar = ["C", "r", "alpha"] }')
    assert_fails(text, SceneError, "[points] B, polar centre", "point 'C' is used before it is built",
          "move its line above this one", at='B = { polar = ["C"')


def test_a_point_that_is_never_built_suggests_the_near_miss():
    text = mutate(BASE, 'crank = ["A", "B"]', 'crank = ["A", "BB"]')
    assert_fails(text, SceneError, "[drive] crank", "no point 'BB' is constructed", "did you mean 'B'?", at="crank")


def test_a_point_that_is_never_built_lists_the_built_ones():
    text = mutate(BASE, '"C", "l", "A", "90 deg"', '"C", "l", "Z", "90 deg"')
    assert_fails(text, SceneError, "[points] E, slider line origin", "no point 'Z' is constructed",
          "points built so far: A, D, B, C", at='"Z"')


def test_a_point_in_an_expression_used_before_it_is_built():
    text = mutate(BASE, 'D = { fixed = ["c", 0] }', 'D = { fixed = ["x(B)", 0] }')
    assert_fails(text, ExpressionError, "[points] D, fixed x", "'x(B)'", "point 'B' is used before it is built",
          at="x(B)")


def test_a_body_frame_point_never_built():
    text = mutate(BASE, 'frame = ["B", "C"]', 'frame = ["B", "Cc"]')
    assert_fails(text, SceneError, "[[bodies]] 'coupler', frame", "no point 'Cc' is constructed",
          "did you mean 'C'?", at='"Cc"')


# --- missing values -----------------------------------------------------------------------------
def test_missing_sweep_samples():
    text = mutate(BASE, "samples = 11\n", "")
    assert_fails(text, SceneError, "[sweep] samples", "missing key 'samples'", "a whole number >= 2", at="[sweep]")


def test_missing_com_of_a_body_with_mass():
    text = mutate(BASE, "com = [0.1, 0]\n", "")
    assert_fails(text, SceneError, "[[bodies]] 'coupler', com", "a body with mass needs its centre of mass",
          "missing key 'com'", "com = [a, b]", at="[[bodies]]")


def test_missing_drive_speed():
    text = mutate(BASE, "speed = 10.0\n", "")
    assert_fails(text, SceneError, "[drive] speed", "missing key 'speed'", "the drive speed in rad/s", at="[drive]")


def test_missing_dyad_side():
    text = mutate(BASE, ', side = "left"', "")
    assert_fails(text, SceneError, "[points] C, side", "missing key 'side'", "'left' or 'right'", at="C = { dyad")


def test_missing_title_and_tables():
    assert_fails(mutate(BASE, 'title = "four-bar with a slider"\n', ""), SceneError, "missing key 'title'")
    text = BASE.split("[points]")[0]
    assert_fails(text, SceneError, "missing table 'points'", "expected the table [points]")


def test_missing_value_of_a_design_variable():
    text = mutate(BASE, "c = { value = 0.3, min", "c = { min")
    assert_fails(text, SceneError, "[parameters] c, value", "missing key 'value'", at="c = { min")


def test_an_empty_constraint():
    text = mutate(BASE, 'min = "30 deg"\n', "")
    assert_fails(text, SceneError, "[[constraints]] 'transmission'", "expected min, max or both; found neither",
          at="[[constraints]]")


# --- non-numbers where numbers belong -------------------------------------------------------------
def test_samples_must_be_a_whole_number():
    text = mutate(BASE, "samples = 11", 'samples = "many"')
    assert_fails(text, SceneError, "[sweep] samples", "expected a whole number >= 2", "found 'many'", at="samples")
    text = mutate(BASE, "samples = 11", "samples = 2.5")
    assert_fails(text, SceneError, "[sweep] samples", "found 2.5", at="samples")
    text = mutate(BASE, "samples = 11", "samples = true")
    assert_fails(text, SceneError, "[sweep] samples", "found true", at="samples")


def test_a_parameter_that_is_a_list():
    text = mutate(BASE, "m = 2.0", "m = [1, 2]")
    assert_fails(text, ExpressionError, "[parameters] m", "expected a number or an expression string",
          "found [1, 2] (a list)", at="m = [1, 2]")


def test_a_parameter_that_is_a_boolean():
    text = mutate(BASE, "m = 2.0", "m = true")
    assert_fails(text, ExpressionError, "[parameters] m", "found true (a boolean)", at="m = true")


def test_a_body_mass_that_is_a_table():
    text = mutate(BASE, "mass = 1.0", "mass = { kg = 1.0 }")
    assert_fails(text, ExpressionError, "[[bodies]] 'slider', mass", "found {'kg': 1.0} (a table)", at="mass = {")


def test_a_bound_that_is_not_a_number():
    text = mutate(BASE, "min = 0.2", 'min = "low"')
    assert_fails(text, ExpressionError, "[parameters] c, min", "unknown name 'low'", at='min = "low"')


def test_a_list_of_the_wrong_length():
    text = mutate(BASE, 'B = { polar = ["A", "r", "alpha"] }', 'B = { polar = ["A", "r"] }')
    assert_fails(text, SceneError, "[points] B, polar", "expected polar = [centre, length, angle] (3 items)",
          "found ['A', 'r']", at="B = { polar")
    text = mutate(BASE, "com = [0.1, 0]", "com = [0.1, 0, 0]")
    assert_fails(text, SceneError, "[[bodies]] 'coupler', com", "expected [a, b] in the body frame (a list of 2",
          "found [0.1, 0, 0]", at="com = [0.1, 0, 0]")


def test_a_point_name_that_is_a_number():
    text = mutate(BASE, 'B = { polar = ["A", "r", "alpha"] }', 'B = { polar = [0, "r", "alpha"] }')
    assert_fails(text, SceneError, "[points] B, polar centre", "expected a point name", "found 0", at="B = { polar")


# --- bounds, sides, names -------------------------------------------------------------------------
def test_design_start_outside_its_bounds():
    text = mutate(BASE, "c = { value = 0.3, min = 0.2, max = 0.5 }", "c = { value = 0.6, min = 0.2, max = 0.5 }")
    assert_fails(text, SceneError, "[parameters] c, value", "the start value 0.6 lies outside its bounds [0.2, 0.5]",
          "move the start inside or widen the bounds", at="c = { value = 0.6")


def test_design_bounds_crossed():
    text = mutate(BASE, "c = { value = 0.3, min = 0.2, max = 0.5 }", "c = { value = 0.3, min = 0.5, max = 0.2 }")
    assert_fails(text, SceneError, "[parameters] c, min", "min 0.5 must be below max 0.2", at="c = {")


def test_dyad_side_must_be_left_or_right():
    text = mutate(BASE, 'side = "left"', 'side = "up"')
    assert_fails(text, SceneError, "[points] C, side", "expected 'left' or 'right'", "of the directed line P -> Q",
          "found 'up'", at='side = "up"')
    text = mutate(BASE, 'side = "left"', 'side = "lefft"')
    assert_fails(text, SceneError, "found 'lefft'", "did you mean 'left'?", at="lefft")


def test_slider_side_must_be_ahead_or_behind():
    text = mutate(BASE, 'side = "ahead"', 'side = "left"')
    assert_fails(text, SceneError, "[points] E, side", "expected 'ahead' or 'behind'", "found 'left'", at='E = {')


def test_duplicate_point_names_in_the_file():
    text = mutate(BASE, 'P = { attach', 'B = { attach')
    assert_fails(text, SceneError, "TOML syntax error", "'B' is defined twice in the same table", "rename",
          at='B = { attach')


def test_a_loop_joint_with_the_name_of_a_point():
    text = mutate(LOOP, 'joints = ["B", "C", "D3"]', 'joints = ["B", "D", "D3"]')
    assert_fails(text, SceneError, "[points] chain", "point 'D' is constructed twice (also at [points] D)",
          "rename one of them", at="[points.chain]")


def test_duplicate_point_names_built_in_python():
    with pytest.raises(SceneError) as info:
        Scene("t", [Parameter("r", 1.0)], Sweep("s", 0, 1, 3),
              [Fixed("A", 0, 0), Polar("B", "A", "r", "s"), Fixed("B", 1, 0)])
    assert info.type is SceneError
    assert "<python>: [points] B: point 'B' is constructed twice" in str(info.value)


def test_a_point_with_the_name_of_a_parameter():
    text = mutate(BASE, 'P = { attach', 'm = { attach')
    assert_fails(text, SceneError, "[points] m", "point 'm' has the name of a parameter or of the sweep",
          at="m = { attach")


def test_duplicate_body_and_constraint_names():
    text = mutate(BASE, 'name = "slider"', 'name = "coupler"')
    assert_fails(text, SceneError, "[[bodies]] 'coupler'", "the body name 'coupler' is used twice")
    text = BASE + '\n[[constraints]]\nname = "transmission"\nexpr = "length(A, C)"\nmax = 1\n'
    assert_fails(text, SceneError, "[[constraints]] 'transmission'", "the constraint name 'transmission' is used twice")


def test_bad_parameter_names():
    assert_fails(mutate(BASE, "m = 2.0", '"2m" = 2.0'), SceneError, "[parameters] 2m", "expected a parameter name",
          at='"2m"')
    assert_fails(mutate(BASE, "m = 2.0", "pi = 3.0"), SceneError, "[parameters] pi", "'pi' is reserved", at="pi = 3.0")


def test_drive_type_suggests_the_near_miss():
    text = mutate(BASE, 'type = "rotary"', 'type = "rotory"')
    assert_fails(text, SceneError, "[drive] type", "expected 'rotary' or 'linear'", "found 'rotory'",
          "did you mean 'rotary'?", at="type =")


def test_efficiency_out_of_range():
    text = mutate(BASE, "acceleration = 0.0\n", "acceleration = 0.0\nefficiency = 1.5\n")
    assert_fails(text, SceneError, "[drive] efficiency", "expected 0 < eta <= 1, found 1.5", at="efficiency")


def test_sweep_rate_beside_a_drive():
    text = mutate(BASE, "samples = 11\n", "samples = 11\nrate = 2.0\n")
    assert_fails(text, SceneError, "[sweep] rate", "the scene has a [drive]", "remove rate from [sweep]", at="rate = 2.0")


def test_empty_stroke():
    text = mutate(BASE, 'to = "80 deg"', 'to = "10 deg"')
    assert_fails(text, SceneError, "[sweep] to", "the stroke is empty", at='to = "10 deg"')


# --- loops ------------------------------------------------------------------------------------
def test_loop_with_too_few_unknowns_for_a_closed_loop():
    text = mutate(LOOP, 'unknowns = { phi2 = "90 deg", phi3 = "pi - phi1" }', 'unknowns = { phi2 = "90 deg" }')
    assert_fails(text, SceneError, "[points] chain, unknowns", "found 1 unknown angle(s) ['phi2']",
          "a closed loop (closure fixed = POINT) gives 2 equation(s)", "expected 2 unknown(s)", at="unknowns =")


def test_loop_with_too_many_unknowns_for_a_semi_closed_loop():
    text = mutate(LOOP, 'closure = { point = "D3", fixed = "D" }', 'closure = { point = "D3", line = ["D", 0] }')
    assert_fails(text, SceneError, "[points] chain, unknowns", "found 2 unknown angle(s)",
          "a semi-closed loop (closure line = [POINT, angle]) gives 1 equation(s)", "expected 1 unknown(s)",
          at="unknowns =")


def test_open_chain_with_unknowns():
    text = mutate(LOOP, 'closure = { point = "D3", fixed = "D" }\n', "")
    assert_fails(text, SceneError, "[points] chain, unknowns", "no closure (an open chain) gives 0 equation(s)",
          at="unknowns =")


def test_loop_unknown_that_no_angle_uses():
    text = mutate(LOOP, 'angles = ["phi1", "phi2", "phi3"]', 'angles = ["phi1", "phi2", "phi_3"]')
    assert_fails(text, SceneError, "[points] chain, unknowns", "the unknown 'phi3' appears in none of the angles",
          "did you mean 'phi_3'?", at="unknowns =")


def test_loop_closure_point_not_a_joint():
    text = mutate(LOOP, 'point = "D3"', 'point = "D4"')
    assert_fails(text, SceneError, "[points] chain, closure", "the closure point 'D4' is not one of the loop's joints",
          "['B', 'C', 'D3']", at="closure =")


def test_loop_lists_of_different_lengths():
    text = mutate(LOOP, 'lengths = ["R", "L", "R"]', 'lengths = ["R", "L"]')
    assert_fails(text, SceneError, "[points] chain", "found 3 angles, 2 lengths, 3 joints", at="[points.chain]")


def test_loop_initial_guess_with_an_unknown_name():
    text = mutate(LOOP, 'phi3 = "pi - phi1"', 'phi3 = "pi - ph1"')
    assert_fails(text, ExpressionError, "[points] chain, unknowns.phi3", "unknown name 'ph1'", "did you mean 'phi1'?",
          at="unknowns =")


def test_loop_built_in_python_with_a_wrong_count():
    with pytest.raises(SceneError, match=r"found 1 unknown angle\(s\) \['u'\].*expected 2 unknown"):
        Scene("t", [], Sweep("s", 0, 1, 3), [
            Fixed("A", 0, 0), Fixed("D", 1, 0),
            Loop("chain", "A", [1, 1], ["s", "u"], ["B", "C"], {"u": 0}, Closure("C", fixed="D"))])


# --- errors from Python-built objects name the key too ---------------------------------------
def test_python_objects_check_themselves():
    with pytest.raises(SceneError, match=r"\[points\] C, side: expected 'left' or 'right'.*found 'up'"):
        Dyad("C", "B", 1, "D", 1, "up")
    with pytest.raises(SceneError, match=r"\[points\] C, side: expected 'ahead' or 'behind'"):
        Slider("C", "B", 1, "D", 0, "left")
    with pytest.raises(SceneError, match=r"\[\[bodies\]\] 'b', com: a body with mass needs its centre of mass"):
        Body("b", ("A", "B"), mass=1.0)
    with pytest.raises(SceneError, match=r"\[drive\] speed: missing key 'speed'"):
        Drive("rotary", ("A", "B"), None, 0.0)
    with pytest.raises(ExpressionError, match=r"\[parameters\] k: expected a number.*found \[1, 2\] \(a list\)"):
        Parameter("k", [1, 2])
    with pytest.raises(SceneError, match=r"\[parameters\] k, value: the start value 5 lies outside"):
        Scene("t", [Parameter("k", 5.0, 0.0, 1.0)], Sweep("s", 0, 1, 3), [Fixed("A", 0, 0)])


# --- overrides (--set) ---------------------------------------------------------------------------
def test_override_of_an_unknown_parameter_through_load(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(BASE)
    with pytest.raises(SceneError) as info:
        load(path, {"rr": 0.2})
    message = str(info.value)
    assert info.type is SceneError
    assert message.startswith(str(path))
    for w in ("cannot set parameter 'rr'", "the scene has no parameter 'rr'", "did you mean 'r'?",
              "its parameters: r, l, c, m"):
        assert w in message, message


def test_override_of_an_unknown_parameter_through_with_parameters():
    scene = loads(BASE, "bad.toml")
    with pytest.raises(SceneError, match=r"cannot set parameter 'mm'.*did you mean 'm'\?"):
        scene.with_parameters(mm=3.0)
    with pytest.raises(SceneError, match=r"'alpha' is the sweep variable, not a parameter"):
        scene.with_parameters(alpha=3.0)


def test_override_with_a_bad_value_says_it_came_from_the_override(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(BASE)
    with pytest.raises(SceneError, match=r"the start value 0\.9 lies outside its bounds.*--set c="):
        load(path, {"c": 0.9})
    with pytest.raises(ExpressionError, match=r"\[parameters\] m: 'heavy': unknown name 'heavy'.*--set m="):
        load(path, {"m": "heavy"})
    assert load(path, {"c": 0.4}).parameter_values()["c"] == 0.4  # a good value is taken


def test_missing_file():
    with pytest.raises(SceneError, match=r"nowhere\.toml: no such scene file"):
        load("nowhere.toml")


# --- the command line ------------------------------------------------------------------------
def test_command_line_reports_a_bad_file_without_traceback(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    text = mutate(BASE, "samples = 11", "sampels = 11")
    path.write_text(text)
    assert cli.main(["kinematics", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert "error:" in err and "Traceback" not in err
    assert f"{path}, line {line(text, 'sampels')}: [sweep] sampels: unknown key 'sampels'; did you mean " \
           "'samples'?" in err


def test_command_line_reports_a_bad_override(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text(BASE)
    assert cli.main(["analyse", str(path), "--set", "rr=0.2"]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "cannot set parameter 'rr'" in err and "did you mean 'r'?" in err


def test_base_scene_runs_through_the_command_line(tmp_path, capsys):
    """The control case: the same path with a good file returns 0."""
    path = tmp_path / "scene.toml"
    path.write_text(BASE)
    assert cli.main(["kinematics", str(path), "--samples", "3"]) == 0
    assert math.isfinite(len(capsys.readouterr().out))


@pytest.mark.parametrize("argv, message", [
    (["optimise", "SCENE", "--starts", "0"], "argument --starts: expected a whole number >= 1, found '0'"),
    (["optimise", "SCENE", "--workers", "two"], "argument --workers: expected a whole number >= 1, found 'two'"),
    (["analyse", "SCENE", "--samples", "1"], "argument --samples: expected a whole number >= 2, found '1'"),
    (["study", "SCENE", "--values", "r=0.1", "--starts", "-1"], "argument --starts: expected a whole number >= 1, found '-1'"),
    (["study", "SCENE", "--values", "r=0.1", "--workers", "0"], "argument --workers: expected a whole number >= 1, found '0'"),
    (["study", "SCENE", "--values", "r=0.1", "--chain", "0"], "argument --chain: expected a whole number >= 1, found '0'"),
])
def test_command_line_refuses_counts_out_of_range(tmp_path, capsys, argv, message):
    """A count below its least sensible value is refused by the argument parser (exit 2),
    before anything is loaded or written: '--starts 0' used to run no start and report 'no
    optimum' with an empty status."""
    path = tmp_path / "scene.toml"
    path.write_text(BASE)
    with pytest.raises(SystemExit) as exc:
        cli.main([str(path) if a == "SCENE" else a for a in argv])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]
