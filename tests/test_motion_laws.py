"""Motion laws in time (scene/motion_laws.py) against their textbook displacement formulas,
written here and differentiated with mpmath at 40 digits: each law's f, f', f'' on a grid, and
its peak speed and acceleration coefficients against the closed forms (cycloidal 2 and 2 pi,
harmonic pi/2 and pi^2/2, modified sine 1.76 and 5.53, modified trapezoid 2.00 and 4.89,
3-4-5 1.875 and 5.77, 4-5-6-7 35/16 and 7.51), located by mpmath's root finder on f'' and f'''."""
import math

import casadi as ca
import mpmath as mp
import numpy as np
import pytest

from optdesign.scene.motion_laws import general, standard

mp.mp.dps = 40
pi = mp.pi


def cycloidal(t):
    return t - mp.sin(2 * pi * t) / (2 * pi)


def harmonic(t):
    return (1 - mp.cos(pi * t)) / 2


def modified_sine(t):   # Norton, Design of Machinery, eq. 8.21 (the three segments' displacements)
    if t <= mp.mpf(1) / 8:
        return (pi * t - mp.sin(4 * pi * t) / 4) / (4 + pi)
    if t <= mp.mpf(7) / 8:
        return (2 + pi * t - mp.mpf(9) / 4 * mp.sin(pi / 3 + 4 * pi * t / 3)) / (4 + pi)
    return (4 + pi * t - mp.sin(4 * pi * t) / 4) / (4 + pi)


def modified_trapezoid(t):
    """From its acceleration: sine ramps of period 1/2 on [0, 1/8], [3/8, 5/8], [7/8, 1], +-A
    between; integrated here in closed form piece by piece, A from f(1) = 1."""
    w = 4 * pi

    def raw(t):   # with A = 1
        e = [mp.mpf(0), mp.mpf(1) / 8, mp.mpf(3) / 8, mp.mpf(5) / 8, mp.mpf(7) / 8, mp.mpf(1)]
        v, f = mp.mpf(0), mp.mpf(0)
        # (acceleration antiderivatives as closures of u): speed(u), position(u) from 0
        pieces = [
            (lambda u: (1 - mp.cos(w * u)) / w, lambda u: (u - mp.sin(w * u) / w) / w),
            (lambda u: u, lambda u: u**2 / 2),
            (lambda u: mp.sin(w * u) / w, lambda u: (1 - mp.cos(w * u)) / w**2),
            (lambda u: -u, lambda u: -u**2 / 2),
            (lambda u: -mp.sin(w * u) / w, lambda u: -(1 - mp.cos(w * u)) / w**2),
        ]
        for (a, b), (sp, po) in zip(zip(e[:-1], e[1:]), pieces):
            u = min(t, b) - a
            if u < 0:
                break
            pos = f + v * u + po(u)
            if t <= b:
                return pos
            f, v = pos, v + sp(b - a)
        return f
    return raw(t) / raw(mp.mpf(1))


def poly345(t):
    return 10 * t**3 - 15 * t**4 + 6 * t**5


def poly4567(t):
    return 35 * t**4 - 84 * t**5 + 70 * t**6 - 20 * t**7


REFERENCE = {"cycloidal": cycloidal, "harmonic": harmonic, "modified-sine": modified_sine,
             "modified-trapezoid": modified_trapezoid, "polynomial-345": poly345, "polynomial-4567": poly4567}
# the coefficients as the literature quotes them (rounded), and where f'' peaks (a guess for findroot)
QUOTED = {"cycloidal": (2.0, 2 * math.pi, 3), "harmonic": (math.pi / 2, math.pi**2 / 2, 3),
          "modified-sine": (1.76, 5.53, 2), "modified-trapezoid": (2.00, 4.89, 2),
          "polynomial-345": (1.875, 5.77, 2), "polynomial-4567": (2.1875, 7.51, 2)}


def derivative(f, t, n):
    return mp.diff(f, t, n)


def peak(f, n, guesses):
    """max |f^(n)| over [0, 1]: at the ends, at the pieces' ends, and where f^(n+1) = 0."""
    candidates = [mp.mpf(0), mp.mpf(1)] + [mp.mpf(k) / 8 for k in range(1, 8)]
    for g in guesses:
        try:
            candidates.append(mp.findroot(lambda t: derivative(f, t, n + 1), mp.mpf(g)))
        except (ValueError, ZeroDivisionError):
            pass
    best = max(abs(derivative(f, min(max(t, mp.mpf(0)), mp.mpf(1)), n)) for t in candidates)
    grid = max(abs(derivative(f, mp.mpf(k) / 200, n)) for k in range(201))
    assert best >= grid - mp.mpf(10) ** -30   # no sample above the located peak
    return best


@pytest.mark.parametrize("name", list(REFERENCE))
def test_law_against_its_textbook_formula(name):
    law, ref = standard(name), REFERENCE[name]
    tau = np.r_[np.linspace(0, 1, 161), 1e-6, 0.124999, 0.125001, 0.3751, 0.87499, 0.999999]
    f, v, a, _ = law.evaluate(tau)
    for n, got in ((0, f), (1, v), (2, a)):
        want = np.array([float(derivative(ref, mp.mpf(float(t)), n)) for t in tau])
        assert np.max(np.abs(got - want)) < 1e-12 * max(1.0, np.max(np.abs(want))), (name, n)


@pytest.mark.parametrize("name", list(REFERENCE))
def test_peak_coefficients_against_closed_forms(name):
    law, ref = standard(name), REFERENCE[name]
    c_v = peak(ref, 1, [0.5])
    c_a = peak(ref, 2, [0.05, 0.1, 0.2, 0.25, 0.3])
    assert law.peak_speed == pytest.approx(float(c_v), rel=1e-13)
    assert law.peak_acceleration == pytest.approx(float(c_a), rel=1e-12)
    v, a, digits = QUOTED[name]
    assert round(law.peak_speed, digits) == round(v, digits)
    assert round(law.peak_acceleration, digits) == round(a, digits)


def test_closed_forms_of_the_simple_laws():
    assert standard("cycloidal").peak_speed == pytest.approx(2.0, rel=1e-15)
    assert standard("cycloidal").peak_acceleration == pytest.approx(2 * math.pi, rel=1e-15)
    assert standard("harmonic").peak_acceleration == pytest.approx(math.pi**2 / 2, rel=1e-15)
    assert standard("polynomial-345").peak_acceleration == pytest.approx(10 / math.sqrt(3), rel=1e-14)
    assert standard("modified-sine").peak_acceleration == pytest.approx(4 * math.pi**2 / (4 + math.pi), rel=1e-14)


@pytest.mark.parametrize("v0, v1, a0, a1", [(0, 0, 0, 0), (0.5, 0.2, 0, 0), (1.0, 1.0, 0.0, 0.0), (0.3, 0.0, 2.0, -1.0)])
def test_general_polynomial_meets_its_ends(v0, v1, a0, a1):
    law = general(v0, v1, a0, a1)
    f, v, a, _ = law.evaluate(np.array([0.0, 1.0]))
    assert np.allclose(f, [0, 1], atol=1e-14) and np.allclose(v, [v0, v1], atol=1e-13)
    assert np.allclose(a, [a0, a1], atol=1e-12)
    if (v0, v1, a0, a1) == (0, 0, 0, 0):   # rest to rest: the 3-4-5 polynomial
        assert law.peak_acceleration == pytest.approx(10 / math.sqrt(3), rel=1e-12)


@pytest.mark.parametrize("name", list(REFERENCE))
def test_inverse_and_its_derivative(name):
    law = standard(name)
    u = ca.SX.sym("u")
    tau = law.inverse(u)
    fn = ca.Function("inv", [u], [tau, ca.jacobian(tau, u)])
    for x in (1e-9, 1e-6, 0.01, 0.3, 0.5, 0.77, 0.999):   # (to round-off beyond 1e-9 of a rest)
        t, dt = (float(v) for v in fn(x))
        f, v, _, _ = law.evaluate(np.array([t]))
        assert abs(f[0] - x) <= (2e-15 * x if x < 0.5 else 1e-14)   # near 1: f's own round-off
        # d tau/du = 1/f': near the far end f's round-off (5e-16) over f' ~ 0.06 limits it to ~1e-12
        assert dt * v[0] == pytest.approx(1.0, rel=1e-11)
    assert float(fn(0.0)[0]) == 0.0 and float(fn(1.0)[0]) == 1.0


BAR = """
title = "a bar turned by its crank"
[parameters]
m = 2.0
[sweep]
name = "phi"
from = "0 deg"
to = "90 deg"
samples = 41
[points]
A = {{ fixed = [0, 0] }}
B = {{ polar = ["A", 0.5, "phi"] }}
[[bodies]]
name = "bar"
frame = ["A", "B"]
mass = "m"
com = [0.25, 0]
inertia = 0.1
[gravity]
g = 9.81
[drive]
type = "rotary"
crank = ["A", "B"]
speed = 1.0
acceleration = 0.0
[profiles.move]
{profile}
[[cases]]
name = "move"
direction = "forward"
profile = "move"
"""


def bar_case(profile):
    import optdesign

    return optdesign.analyse(optdesign.loads(BAR.format(profile=profile))).cases.cases["move"]


@pytest.mark.parametrize("name", ["cycloidal", "modified-trapezoid"])
def test_the_time_follows_from_the_peak_limits(name):
    """speed = v: T = C_v L / v and the peak sweep speed is v; acceleration = a: T = sqrt(C_a L / a)."""
    law, L = standard(name), math.pi / 2
    by_speed = bar_case(f'kind = "{name}"\nspeed = 2.0')
    assert by_speed.duration == pytest.approx(law.peak_speed * L / 2.0, rel=1e-14)
    assert np.max(np.abs(by_speed.columns["sd"])) <= 2.0 * (1 + 1e-12)
    by_acc = bar_case(f'kind = "{name}"\nacceleration = 5.0')
    assert by_acc.duration == pytest.approx(math.sqrt(law.peak_acceleration * L / 5.0), rel=1e-14)
    both = bar_case(f'kind = "{name}"\nspeed = 2.0\nacceleration = 5.0')
    assert both.duration == pytest.approx(max(by_speed.duration, by_acc.duration), rel=1e-14)


def test_polynomial_profile_ends_and_reversal():
    case = bar_case('kind = "polynomial"\ntime = 1.0\nstart_speed = 0.5\nend_speed = 1.0')
    sd = case.columns["sd"]
    assert sd[0] == pytest.approx(0.5, rel=1e-12) and sd[-1] == pytest.approx(1.0, rel=1e-12)
    assert case.duration == 1.0
    from optdesign.errors import SceneError

    with pytest.raises(SceneError) as info:   # too fast at the ends for the stroke: it runs back in between
        bar_case('kind = "polynomial"\ntime = 1.0\nstart_speed = 6.0\nend_speed = 6.0')
    assert "[profiles] move, time: this polynomial reverses: its speed is" in str(info.value)
    assert "along the stroke of 1.5708" in str(info.value)


@pytest.mark.parametrize("name", ["cycloidal", "modified-sine"])
def test_a_laws_kept_function_is_not_pickled_and_gives_the_same_numbers(name):
    """MotionLaw.evaluate keeps the law's CasADi Function after its first use: a pickle of the
    law (a scene's, sent to a study's workers) is the same bytes as before the first use, and
    the law unpickled, which builds its Function again, gives the same numbers bit for bit."""
    import pickle

    law = standard(name)
    law.__dict__.pop("_function", None)
    before = pickle.dumps(law)
    tau = np.linspace(0.0, 1.0, 41)
    first = law.evaluate(tau)
    assert "_function" in law.__dict__ and pickle.dumps(law) == before
    again = pickle.loads(before).evaluate(tau)
    assert all(np.array_equal(a, b) for a, b in zip(first, again))
    assert all(np.array_equal(a, b) for a, b in zip(first, law.evaluate(tau)))
