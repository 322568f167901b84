"""Force elements ([[forces]], issue 30): springs, gas springs, dampers, constant forces and
torsion springs.

Their loads in analyse are checked by the power balance of every shipped scene and of a four-bar
carrying one element of each kind (tests/test_power_balance.py: their power computed in numpy
from the kinematics).  Here: the tailgate's gas struts written as a gas spring against the same
struts written as a massless body with a hand-written force (the scene before issue 30, kept in
tests/data/tailgate_strut_as_body.toml) and against its optimum (20.4942343 N m, found before the
rewrite: results/optimise_library.md); the motion in time of a damped torsion pendulum against
scipy's solve_ivp of its equation written here; load cases that change a spring's rate; errors.
"""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.stats import qmc

import optdesign
from default_optimum import default_optimum  # noqa: E402 (tests/ is on sys.path under pytest)
from optdesign.errors import SceneError

ROOT = Path(__file__).resolve().parent.parent
TAILGATE = ROOT / "problems" / "lib_tailgate_strut.toml"
TAILGATE_AS_BODY = ROOT / "tests" / "data" / "tailgate_strut_as_body.toml"
TAILGATE_OPTIMUM = 20.4942343  # N m, the scene before the rewrite (results/optimise_library.md)


def test_tailgate_gas_spring_is_the_hand_written_body():
    """At 16 designs spread over the design box (Sobol), the drive load over the stroke of the
    gas-spring scene is the body scene's to 1e-12 of its peak, and the hold-open value
    end(static_load) is the old ramp's maximum (the static torque at full opening)."""
    new, old = optdesign.load(TAILGATE), optdesign.load(TAILGATE_AS_BODY)
    names = [p.name for p in new.parameters if p.is_design]
    lo = np.array([new.parameter(n).lower for n in names])
    hi = np.array([new.parameter(n).upper for n in names])
    designs = qmc.scale(qmc.Sobol(len(names), seed=3).random(16), lo, hi)
    for x in designs:
        values = dict(zip(names, map(float, x)))
        a = optdesign.analyse(new.with_parameters(**values), samples=41, certify=False)
        b = optdesign.analyse(old.with_parameters(**values), samples=41, certify=False)
        scale = np.max(np.abs(b.columns["drive"]))
        assert np.max(np.abs(a.columns["drive"] - b.columns["drive"])) <= 1e-12 * scale, values
        ramp = np.asarray(b.constraints["holds itself open"])
        assert a.constraints["holds itself open"] == pytest.approx(ramp.max(), rel=1e-12, abs=1e-12 * scale)
        assert ramp.argmax() == len(ramp) - 1


def test_tailgate_gas_spring_optimum_is_todays():
    """optimise (default settings, 20 starts): the optimum of the scene before the rewrite,
    20.4942343 N m (to its printed digits), reached by at least 18 of 20 starts."""
    result = default_optimum(TAILGATE)[0]
    assert result.success, (result.status, result.message)
    assert abs(result.objective - TAILGATE_OPTIMUM) <= 1e-7
    reached = [s for s in result.starts if s.success and s.objective is not None
               and abs(s.objective - result.objective) <= 1e-6 * result.objective]
    assert len(reached) >= 18, [(s.index, s.status, s.objective) for s in result.starts]


PENDULUM = """
title = "test: a bar on a torsion spring and a damper, free motion"
[parameters]
L = 0.8
m = 2.0
k_t = 30.0
c = 12.0
xP = 0.5
yP = 0.4
[sweep]
name = "phi"
from = "-170 deg"
to = "170 deg"
samples = 101
[points]
O = { fixed = [0, 0] }
A = { polar = ["O", "L", "phi"] }
P = { fixed = ["xP", "yP"] }
[[bodies]]
name = "bar"
frame = ["O", "A"]
mass = "m"
com = ["L/2", 0]
inertia = "m*L^2/12"
[[forces]]
name = "spring"
kind = "torsion"
bodies = ["bar"]
rate = "k_t"
free_angle = "30 deg"
[[forces]]
name = "damper"
kind = "damper"
between = ["P", "A"]
rate = "c"
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["O", "A"]
speed = 1.0
acceleration = 0.0
law = "0"
[simulation]
start = "-40 deg"
speed = 0.5
t_end = 2.0
samples = 81
tolerance = 1e-10
"""


def test_damped_torsion_pendulum_against_solve_ivp():
    """The motion in time of a bar on a torsion spring with a damper from a fixed point to its
    tip, gravity on, no drive torque: phi(t) is that of scipy's solve_ivp on the equation written
    here, I_O phi'' = -k_t (phi - phi0) - m g (L/2) cos phi - c (dL/dphi)^2 phi'."""
    scene = optdesign.loads(PENDULUM)
    result = optdesign.simulate(scene)
    L, m, k_t, c, xP, yP, g = 0.8, 2.0, 30.0, 12.0, 0.5, 0.4, 9.81
    inertia = m * L**2 / 12 + m * (L / 2) ** 2

    def rhs(t, y):
        phi, w = y
        ax, ay = L * math.cos(phi) - xP, L * math.sin(phi) - yP
        dL = (ax * -L * math.sin(phi) + ay * L * math.cos(phi)) / math.hypot(ax, ay)
        torque = -k_t * (phi - math.radians(30)) - m * g * L / 2 * math.cos(phi) - c * dL**2 * w
        return [w, torque / inertia]

    t = np.asarray(result.t)
    ref = solve_ivp(rhs, (0, t[-1]), [math.radians(-40), 0.5], t_eval=t, rtol=1e-12, atol=1e-12, method="DOP853")
    assert result.stop == "t_end"
    np.testing.assert_allclose(np.asarray(result.s), ref.y[0], atol=1e-7)
    # the damper takes energy: without it the same motion keeps more (a check that it acts)
    free = optdesign.simulate(scene.with_parameters(c=0.0))
    # (each run's samples hold its own located peaks' instants: compared at this run's times)
    assert np.max(np.abs(np.interp(t, np.asarray(free.t), np.asarray(free.s)) - ref.y[0])) > 1e-2


CASES = PENDULUM.split("[simulation]")[0].replace('law = "0"\n', "") + """
[[cases]]
name = "soft"
direction = "forward"
set = { k_t = 10.0 }
[[cases]]
name = "stiff"
direction = "forward"
set = { k_t = 60.0, c = 0.0 }
"""


def test_cases_set_the_force_elements():
    """A load case that sets a spring's rate and a damper's rate has the drive load of the
    scene with those values (analyse of the scene with the parameters set), to 1e-12."""
    scene = optdesign.loads(CASES)
    result = optdesign.analyse(scene, samples=41)
    for name, values in (("soft", {"k_t": 10.0}), ("stiff", {"k_t": 60.0, "c": 0.0})):
        alone = optdesign.analyse(optdesign.loads(CASES.split("[[cases]]")[0]).with_parameters(**values), samples=41)
        case = result.cases.cases[name].columns["drive"]
        np.testing.assert_allclose(case, alone.columns["drive"], rtol=0, atol=1e-12 * np.max(np.abs(case)))
    assert not np.allclose(result.cases.cases["soft"].columns["drive"], result.cases.cases["stiff"].columns["drive"])


BASE = PENDULUM.split("[simulation]")[0]


@pytest.mark.parametrize("table,message", [
    ('kind = "sprung"', "[[forces]] 'spring', kind: expected one of 'spring', 'gas_spring', 'damper', 'constant', "
                        "'torsion', found 'sprung'; did you mean 'spring'?"),
    ('kind = "torsion"\nbodies = ["barr"]\nrate = 1\nfree_angle = 0',
     "[[forces]] 'spring', bodies: no body 'barr' in [[bodies]]; did you mean 'bar'?"),
    ('kind = "spring"\nbetween = ["O", "Q"]\nrate = 1\nfree_length = 1',
     "[[forces]] 'spring', between: no point 'Q' is constructed"),
    ('kind = "spring"\nbetween = ["O", "A"]\nrate = 1\nfree_length = 1\nlength = 1',
     "expected either free_length (where the tension is 0) or length with preload (the tension there), found both"),
    ('kind = "spring"\nbetween = ["O", "A"]\nrate = 1\nfree_length = 1\npreload = 5',
     "preload is the tension at length; with free_length the tension there is 0"),
    ('kind = "gas_spring"\nbetween = ["O", "A"]\nextended_length = 1\ntable = [[0.1, 5], [0.0, 6]]',
     "the compressions must ascend"),
    ('kind = "gas_spring"\nbetween = ["O", "A"]\nextended_length = 1\nextended_force = 5',
     "missing key 'compressed_length': a gas spring needs extended_force, compressed_length and progression"),
    ('kind = "damper"\nbetween = ["O", "A"]\nrate = "k_tt"', "unknown name 'k_tt'; did you mean 'k_t'?"),
    ('kind = "damper"\nbetween = ["O", "A"]\nrate = 1\nfree_length = 2', "a damper has no key 'free_length'"),
    ('kind = "constant"\nbetween = ["O", "A"]\ntension = 1\nspeed = 2', "unknown key 'speed'"),
])
def test_errors_name_the_element(table, message):
    text = BASE.replace('[[forces]]\nname = "spring"\nkind = "torsion"\nbodies = ["bar"]\nrate = "k_t"\n'
                        'free_angle = "30 deg"\n', f'[[forces]]\nname = "spring"\n{table}\n')
    with pytest.raises(SceneError) as err:
        optdesign.loads(text, "scene.toml")
    assert message in str(err.value)
    assert str(err.value).startswith("scene.toml, line ")


def test_cli_error_exit_status_2(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(BASE.replace('rate = "c"', 'rate = "c"\nfree_length = 1'))
    out = subprocess.run([sys.executable, "-m", "optdesign", "analyse", str(path)], capture_output=True, text=True)
    assert out.returncode == 2, out.stderr
    assert "a damper has no key 'free_length'" in out.stderr and "Traceback" not in out.stderr


def test_drawing_shows_the_force_elements():
    """The mechanism figure draws each element between its two points, named at its middle:
    the tailgate's gas struts as a bar from D to B."""
    import matplotlib
    import matplotlib.pyplot as plt

    matplotlib.use("Agg")
    from optdesign.report import mechanism as figure
    from optdesign.report.joint_arrows import ELEMENT

    v = figure.view(optdesign.load(TAILGATE))
    fig, ax = plt.subplots()
    figure.draw_design(ax, v, joints=False)
    lines = [ln for ln in ax.lines if matplotlib.colors.same_color(ln.get_color(), ELEMENT)]
    assert len(lines) == 1
    ends = np.array(lines[0].get_xydata())
    frame = v.frames.at(0)
    np.testing.assert_allclose(ends, [frame.points["D"][0], frame.points["B"][0]], atol=1e-12)
    assert [t.get_text() for t in ax.texts if matplotlib.colors.same_color(t.get_color(), ELEMENT)] == ["gas struts"]
    plt.close(fig)
