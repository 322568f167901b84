"""The interval enclosure of CasADi instruction programs (kinematics/enclosure.py) and the branch
and bound that certifies a maximum over the continuous stroke with it (kinematics/peaks.py).

References: dense samples of the same CasADi Function (an enclosure must hold every value the
function takes on the interval), closed forms (the bump of issue 27: v(s) = -0.2 s +
5 exp(-((s - 1.4)/0.3)^2) has its maximum where v' = 0, found here by scipy's brentq), mpmath's
interval arithmetic (mpmath.iv) for single operations."""
from __future__ import annotations

import casadi as ca
import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from optdesign.errors import ResultError
from optdesign.kinematics.enclosure import Enclosure, Enclosures, interval_program
from optdesign.kinematics.intervals import _div, _mul, _unary
from optdesign.kinematics.peaks import CERTIFY_TOL, Extremum, Request, _check_invariant, continuous_maxima_rows


FINITE = st.floats(-1e6, 1e6).filter(lambda x: x == 0 or abs(x) > 1e-200)   # (quotients that overflow: not here)


def function(expr_of):
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 2)
    v = expr_of(s, p)
    dv = ca.jacobian(v, s)
    return ca.Function("f", [s, p], [v, dv, ca.jacobian(dv, s)], ["s", "p"], ["v", "dv", "d2v"], {"cse": True})


def evaluator(f, p):
    return lambda x: [np.asarray(a) for a in f.map(len(x))(np.asarray(x, float)[None, :], p)]


def bump(s, p):
    return -0.2 * s + 5 * ca.exp(-((s - 1.4) / 0.3) ** 2)


def test_the_bump_between_two_samples_is_certified():
    """Issue 27's minimal reproduction: on the grid [0, 1, 2] the samples see 0.645 at s = 1 and
    the refinement alone stops there; the certified maximum is 4.720 at s = 1.398."""
    f = function(bump)
    ev = evaluator(f, [0.0, 0.0])
    grid = np.array([0.0, 1.0, 2.0])
    V = ev(grid)[0]
    old = continuous_maxima_rows(ev, grid, V, [Request(0, "abs", ends=True)])[0][0]
    assert old.bound is None   # no enclosure: no certificate claimed
    top = continuous_maxima_rows(ev, grid, V, [Request(0, "abs", ends=True)],
                                 enclosure=Enclosures(f).at([0.0, 0.0]))[0][0]
    s_star = brentq(lambda x: -0.2 - 10 * (x - 1.4) / 0.09 * np.exp(-((x - 1.4) / 0.3) ** 2), 1.3, 1.45)
    v_star = -0.2 * s_star + 5 * np.exp(-((s_star - 1.4) / 0.3) ** 2)
    assert round(top.value, 3) == 4.720 and round(top.s, 3) == 1.398
    assert top.value == pytest.approx(v_star, rel=1e-12) and top.s == pytest.approx(s_star, abs=1e-9)
    assert top.note == "" and top.value <= top.bound <= top.value + CERTIFY_TOL * top.value + 1e-15


EXPRESSIONS = {
    "trig": lambda s, p: ca.sin(3 * s + p[0]) * ca.cos(s * s) + ca.tan(0.3 * s),
    "roots": lambda s, p: ca.sqrt(1.5 + ca.sin(s)) / (2 + ca.cos(5 * s)) + ca.asin(0.4 * ca.sin(s)),
    "acos_atan2": lambda s, p: ca.acos(0.9 * ca.cos(2 * s)) + ca.atan2(ca.sin(s) - 0.3, ca.cos(s) + p[1]),
    "atan2_periodic": lambda s, p: ca.cos(ca.atan2(ca.sin(4 * s), ca.cos(4 * s) - 0.2)) * s,
    "pow_exp_log": lambda s, p: (1.2 + ca.sin(s)) ** 2.5 + ca.exp(-s * s) * ca.log(2 + s * s) + s ** 3,
    "switches": lambda s, p: ca.if_else(ca.sin(2 * s) > 0.1, s * s, -ca.fabs(s - 0.3)) + ca.fmax(s, 0.2 * s) + ca.fmin(ca.cos(s), 0.5),
    "sign_tanh": lambda s, p: ca.sign(s - 0.25) * ca.tanh(3 * s) + ca.sinh(0.5 * s) - ca.cosh(0.3 * s) + ca.atan(s),
}


@pytest.mark.parametrize("name", sorted(EXPRESSIONS))
def test_enclosures_hold_every_value_on_random_intervals(name):
    """Random intervals (centres and widths from 1e-6 to 2): the enclosure of v (plain, mean
    value and Taylor forms as kinematics.enclosure.Enclosure combines them) holds the
    function's values at 401 points of each interval, computed by CasADi."""
    f = function(EXPRESSIONS[name])
    p = [0.7, 0.4]
    enc = Enclosure(interval_program(f)[0], p)
    rng = np.random.default_rng(7)
    centre = rng.uniform(-3, 3, 200)
    width = 10 ** rng.uniform(-6, np.log10(2), 200)
    lo, hi = centre - width / 2, centre + width / 2
    L, U, _, _ = enc.bounds(lo, hi)
    ev = evaluator(f, p)
    t = np.linspace(0, 1, 401)
    for k in range(len(lo)):
        x = np.clip(lo[k] + (hi[k] - lo[k]) * t, lo[k], hi[k])   # (rounded, the last point may pass hi)
        v = ev(x)[0][0]
        v = v[np.isfinite(v)]
        assert np.all(L[0, k] <= v) and np.all(v <= U[0, k]), (name, lo[k], hi[k], L[0, k], U[0, k], v.min(), v.max())


@pytest.mark.parametrize("name", sorted(EXPRESSIONS))
def test_enclosures_expanded_off_the_midpoint_hold_every_value(name):
    """The forms expanded at a given point of each interval (a located maximum: at one end of
    the interval, or anywhere inside it; outside it or NaN: the midpoint) instead of its
    midpoint: L <= v <= U at 401 points of each interval, and the expansion point's own
    enclosure holds v there (CasADi's values)."""
    f = function(EXPRESSIONS[name])
    p = [0.7, 0.4]
    enc = Enclosure(interval_program(f)[0], p)
    rng = np.random.default_rng(11)
    n = 240
    lo = rng.uniform(-3, 3, n)
    hi = lo + 10 ** rng.uniform(-6, np.log10(2), n)
    u = rng.uniform(0, 1, n)
    at = np.select([np.arange(n) % 4 == 0, np.arange(n) % 4 == 1, np.arange(n) % 4 == 2],
                   [lo, hi, lo + (hi - lo) * u], np.where(u < 0.5, np.nan, hi + 1.0))
    L, U, m_lo, m_hi = enc.bounds(lo, hi, centre=at)
    ev = evaluator(f, p)
    inside = (lo <= at) & (at <= hi)
    m = np.where(inside, at, 0.5 * (lo + hi))
    vm = ev(m)[0][0]
    ok = np.isfinite(vm)
    assert np.all(m_lo[0, ok] <= vm[ok]) and np.all(vm[ok] <= m_hi[0, ok])
    t = np.linspace(0, 1, 401)
    for k in range(n):
        x = np.clip(lo[k] + (hi[k] - lo[k]) * t, lo[k], hi[k])
        v = ev(x)[0][0]
        v = v[np.isfinite(v)]
        assert np.all(L[0, k] <= v) and np.all(v <= U[0, k]), (name, lo[k], hi[k], at[k], L[0, k], U[0, k], v.min(), v.max())


def test_an_operation_without_enclosure_is_said_so():
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 1)
    f = ca.Function("f", [s, p], [ca.fmod(s, 1.0), s, s])
    program, reason = interval_program(f)
    assert program is None and "fmod" in reason
    ev = evaluator(f, [0.0])
    grid = np.linspace(0, 2, 5)
    top = continuous_maxima_rows(ev, grid, ev(grid)[0], [Request(0, "max")], enclosure=Enclosures(f).at([0.0]))[0][0]
    assert top.bound is None and top.note.startswith("not certified") and "fmod" in top.note


def test_a_located_maximum_is_never_below_the_samples():
    """The invariant: the largest located target is never below the largest sampled one.  An
    evaluation that disagrees with the samples (here smaller) cannot pull a reported maximum
    below them; a certified extremum that is below them is an error, never a result."""
    grid = np.linspace(0.0, 1.0, 11)
    V = np.sin(3 * grid)[None, :]

    def lying(s):
        s = np.asarray(s, float)
        return 0.5 * np.sin(3 * s)[None, :], 1.5 * np.cos(3 * s)[None, :], -4.5 * np.sin(3 * s)[None, :]

    for sense in ("abs", "max", "min"):
        top = continuous_maxima_rows(lying, grid, V, [Request(0, sense, ends=True)])[0][0]
        sign = 1.0 if sense == "max" else -1.0 if sense == "min" else np.sign(top.value)
        assert sign * top.value >= (np.max(np.abs(V)) if sense == "abs" else np.max(sign * V))
    with pytest.raises(ResultError, match="below the largest sampled"):
        _check_invariant(Extremum(0.5, 0.9), V[0], Request(0, "max"))


def test_a_maximum_at_a_jump_of_an_if_else_is_certified():
    """v jumps down at s = 0.5337 (an if_else, as the model's efficiency switch and profile phases
    write): its supremum is the left branch's limit there, 1.5337; the enclosure of the if_else
    is the hull of its two branches, so the bound closes on it (the two if_else_zero terms taken
    apart would each be hulled with 0, and never close)."""
    f = function(lambda s, p: ca.if_else(s <= 0.5337, 1 + s, 0.2 + 0.1 * s))
    ev = evaluator(f, [0.0, 0.0])
    grid = np.linspace(0.0, 1.0, 6)
    top = continuous_maxima_rows(ev, grid, ev(grid)[0], [Request(0, "max", ends=True)],
                                 enclosure=Enclosures(f).at([0.0, 0.0]))[0][0]
    assert top.note == "" and top.bound == pytest.approx(1.5337, abs=2e-9)
    assert top.value == pytest.approx(1.5337, abs=2e-9) and top.value <= top.bound


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(FINITE, st.floats(0, 1e3), FINITE, st.floats(0, 1e3)), min_size=1, max_size=20))
def test_products_and_quotients_hold_mpmaths_intervals(boxes):
    """[a, b] * [c, d] and [a, b] / [c, d] (kinematics/intervals: the quotient as the quotients of
    the ends, one rounding) hold mpmath's interval result (iv, outward rounded) and are no wider
    than it by more than a few units in the last place; a divisor interval holding 0 gives the
    whole line."""
    a, w1, c, w2 = (np.array(x, float) for x in zip(*boxes))
    b, d = a + w1, c + w2
    with np.errstate(all="ignore"):
        products, quotients = _mul(a, b, c, d), _div(a, b, c, d)
    for k in range(len(a)):
        x, y = mpmath.iv.mpf([a[k], b[k]]), mpmath.iv.mpf([c[k], d[k]])
        for (lo, hi), exact in ((products, x * y), (quotients, None if c[k] <= 0 <= d[k] else x / y)):
            if exact is None:
                assert lo[k] == -np.inf and hi[k] == np.inf
                continue
            e_lo, e_hi = float(exact.a), float(exact.b)
            assert lo[k] <= e_lo and e_hi <= hi[k], (a[k], b[k], c[k], d[k], lo[k], hi[k], e_lo, e_hi)
            assert (hi[k] - lo[k]) - (e_hi - e_lo) <= 1e-14 * max(abs(e_lo), abs(e_hi)) + 1e-290


OVERFLOWING = st.tuples(st.floats(1.0, 1e300), st.floats(1e-320, 1e-300), st.sampled_from([1.0, -1.0]),
                        st.sampled_from([1.0, -1.0]))


@settings(max_examples=60, deadline=None)
@given(st.lists(OVERFLOWING, min_size=1, max_size=20))
def test_quotients_and_products_that_overflow_hold_mpmaths_intervals(boxes):
    """A quotient or product whose exact value lies beyond the largest double (1 / 2e-313,
    1e300 * 1e300) holds mpmath's interval (exact exponents, no overflow), with no NaN: the bound
    on the overflowing side stays infinite, the other is the largest finite double (the old
    outward rounding took inf - inf there and gave NaN)."""
    a, c, sa, sc = (np.array(x, float) for x in zip(*boxes))
    a, c = sa * a, sc * c
    with np.errstate(all="ignore"):
        quotients, products = _div(a, a, c, c), _mul(a, a, 1 / c, 1 / c)
        powers = _unary(ca.OP_EXP, 1e3 * np.abs(a), 1e3 * np.abs(a))[:2]
    for k in range(len(a)):
        x, y = mpmath.iv.mpf(a[k]), mpmath.iv.mpf(c[k])
        with np.errstate(over="ignore"):   # 1 / 2e-313 overflows: no product to check then
            inv_c = 1 / c[k]
        inv_y = mpmath.iv.mpf(inv_c) if np.isfinite(inv_c) else None
        for (lo, hi), exact in ((quotients, x / y), (products, None if inv_y is None else x * inv_y),
                                (powers, mpmath.iv.exp(1e3 * abs(x)))):
            assert not np.isnan(lo[k]) and not np.isnan(hi[k]), (a[k], c[k], lo[k], hi[k])
            if exact is None:
                continue
            assert mpmath.mpf(lo[k]) <= exact.a and exact.b <= mpmath.mpf(hi[k]), (a[k], c[k], lo[k], hi[k], exact)
            big_side = hi[k] if exact.a > 0 else -lo[k]
            if abs(exact.a) > np.finfo(float).max:
                assert big_side == np.inf
