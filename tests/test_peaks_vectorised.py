"""Continuous extrema refined in lockstep (optdesign.kinematics.peaks.refine_all / continuous_maxima_rows).

* Closed forms: the refined maxima of v(s) = sin(3 s) + 0.3 cos(7 s) (as |v|, v and -v) are the
  roots of the analytic v'(s) found here independently (sign changes of v' on a fine grid, then
  scipy's brentq), to 1e-12 in s and in v; maxima whose bracket touches a stroke end, a flat
  plateau (no sign change of v': the grid points themselves) and brackets where Newton's step
  is useless (convex there, or overshooting the bracket) so that bisection must take over.
* The lockstep driver gives exactly (==) the numbers of the one-bracket-at-a-time driver
  (continuous_maxima / refine), for many rows whose brackets finish after different numbers of
  steps.
* On a real scene, ``MappedFunction`` (CasADi's map through its buffer interface) returns
  CasADi's ordinary call's numbers exactly, for SX and for MX with a rootfinder, and
  ``Solver.continuous_check`` certifies exactly what the scalar refinement with ordinary CasADi
  calls gives for every block.
"""
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

from optdesign.design.problem import DesignProblem
from optdesign.kinematics.mapped import MappedFunction
from optdesign.design.solver import Solver
from optdesign.kinematics.peaks import (
    Request,
    continuous_maxima,
    continuous_maxima_rows,
    refine,
    refine_all,
)
from optdesign.scene.file import load

ROOT = Path(__file__).parents[1]
A, B = -1.0, 4.0  # the stroke of the closed forms


# --- closed forms: (v, dv/ds, d2v/ds2) at one s, with math (the same numbers in every driver) ---
def wave(s):
    return (math.sin(3 * s) + 0.3 * math.cos(7 * s), 3 * math.cos(3 * s) - 2.1 * math.sin(7 * s),
            -9 * math.sin(3 * s) - 14.7 * math.cos(7 * s))


def quadratic(c):
    """-(s - c)^2: one Newton step from anywhere lands on c."""
    return lambda s: (-(s - c) ** 2, -2 * (s - c), -2.0)


def lorentzian(c, w):
    """1 / (1 + u^2), u = (s - c)/w: convex (v'' > 0) for |u| > 1/sqrt(3), so Newton is refused
    there and bisection must bring the bracket in."""
    def f(s):
        u = (s - c) / w
        q = 1 + u * u
        return 1 / q, -2 * u / (w * q * q), (6 * u * u - 2) / (w * w * q ** 3)
    return f


def hyperbola(c, w):
    """-sqrt(1 + u^2), u = (s - c)/w: concave everywhere, but from |u| > 1 Newton's step
    (to u' = -u^3) overshoots the bracket."""
    def f(s):
        u = (s - c) / w
        r = math.sqrt(1 + u * u)
        return -r, -u / (w * r), -1 / (w * w * r ** 3)
    return f


def plateau(s):
    """1 - max(0, |s - 0.5| - 0.1)^3: flat (v' = 0) on [0.4, 0.6], C2 elsewhere."""
    d = abs(s - 0.5) - 0.1
    if d <= 0:
        return 1.0, 0.0, 0.0
    sgn = math.copysign(1.0, s - 0.5)
    return 1 - d ** 3, -3 * d * d * sgn, -6 * d


def many(*rows):
    """evaluate_many for refine_all: every row at every s (rows x len(s))."""
    def evaluate_many(s):
        out = np.array([[f(float(x)) for x in s] for f in rows]).reshape(len(rows), len(s), 3)
        return out[:, :, 0], out[:, :, 1], out[:, :, 2]
    return evaluate_many


def sampled(f, grid):
    return np.array([f(s)[0] for s in grid])


# --- the independent reference -------------------------------------------------------------
def wave_maxima(sense):
    """Interior local maxima of the target of the wave on (A, B): roots of v' by brentq, kept
    where the target curves down (sign * v'' < 0)."""
    fine = np.linspace(A, B, 20001)
    d1 = 3 * np.cos(3 * fine) - 2.1 * np.sin(7 * fine)
    roots = [brentq(lambda s: wave(s)[1], fine[i], fine[i + 1], xtol=1e-15, rtol=4 * np.finfo(float).eps)
             for i in np.flatnonzero(np.sign(d1[:-1]) * np.sign(d1[1:]) < 0)]
    out = []
    for r in roots:
        v, _, d2 = wave(r)
        sign = {"abs": math.copysign(1.0, v), "max": 1.0, "min": -1.0}[sense]
        if sign * d2 < 0:
            out.append(r)
    return out


@pytest.mark.parametrize("sense", ["abs", "max", "min"])
def test_wave_maxima_are_the_roots_of_the_analytic_derivative(sense):
    grid = np.linspace(A, B, 120)  # spacing 0.042, well below the extrema's spacing (>= 0.3)
    ext = continuous_maxima_rows(many(wave), grid, sampled(wave, grid)[None, :], [Request(0, sense)])[0]
    interior = sorted(e.s for e in ext if e.s not in (A, B))
    reference = wave_maxima(sense)
    assert len(reference) >= {"abs": 5, "max": 2, "min": 3}[sense] and len(interior) == len(reference)
    for s, r in zip(interior, reference):
        assert abs(s - r) <= 1e-12
        value = next(e.value for e in ext if e.s == s)
        assert abs(value - wave(r)[0]) <= 1e-12
    # the ends are candidates at their sampled values, and the list is sorted by the target
    assert {(e.s, e.value) for e in ext} >= {(A, wave(A)[0]), (B, wave(B)[0])}
    target = [{"abs": abs(e.value), "max": e.value, "min": -e.value}[sense] for e in ext]
    assert target == sorted(target, reverse=True)


def test_brackets_at_the_stroke_ends():
    """Grid maxima at the first and last interior points: the brackets [s0, s2] and
    [s(n-3), s(n-1)] end at the stroke's ends and are refined like any other."""
    grid = np.linspace(0.0, 1.0, 11)
    for c, i in ((0.13, 1), (0.88, 9)):
        f = quadratic(c)
        ext = continuous_maxima_rows(many(f), grid, sampled(f, grid)[None, :], [Request(0, "max")])[0]
        assert ext[0].s == pytest.approx(c, abs=1e-12) and abs(ext[0].value) <= 1e-24
        assert len(ext) == 3  # the two ends and the one grid maximum (at index i)
        assert abs(ext[0].s - grid[i]) < 0.05


def test_a_plateau_gives_its_grid_points():
    """No sign change of v' on a bracket inside or at the edge of the plateau: each grid maximum
    there is reported as itself, with v = 1 exactly."""
    grid = np.linspace(0.0, 1.0, 21)  # 0.4, 0.45, ..., 0.6 lie on the plateau
    ext = continuous_maxima_rows(many(plateau), grid, sampled(plateau, grid)[None, :], [Request(0, "max")])[0]
    interior = sorted((e.s, e.value) for e in ext if e.s not in (0.0, 1.0))
    on_plateau = [s for s in grid if abs(s - 0.5) <= 0.1 + 1e-12]
    assert interior == [(s, 1.0) for s in on_plateau]


def test_a_flat_row_costs_no_evaluation():
    """A constant row: every interior sample would be a grid maximum, none of them telling; the
    stroke's ends and the largest sample stand for them (between the samples, the enclosure
    speaks for such a row, kinematics/enclosure.py), and nothing is evaluated."""
    grid = np.linspace(0.0, 1.0, 21)
    calls = []

    def evaluate_many(s):
        calls.append(sorted(s))
        return many(lambda x: (2.5, 0.0, 0.0))(s)

    ext = continuous_maxima_rows(evaluate_many, grid, np.full((1, 21), 2.5), [Request(0, "max")])[0]
    assert {e.s for e in ext} <= set(grid) and all(e.value == 2.5 for e in ext)
    assert calls == []


@pytest.mark.parametrize("f, c", [(lorentzian(0.53, 0.01), 0.53), (hyperbola(0.47, 0.004), 0.47)])
def test_newton_falls_back_to_bisection(f, c):
    """The grid point 0.5 is the grid maximum; its bracket is [0.4, 0.6].  Newton is refused at
    0.5 (convex there, or the step leaves the bracket): the next point is the midpoint 0.55 or
    0.45 of the halved bracket, and the refinement still ends on the maximum c."""
    asked = []

    def evaluate(s):
        asked.append(float(s))
        return f(s)

    s, v = refine(evaluate, 0.4, 0.6, 0.5, 1.0)
    assert asked[:3] == [0.4, 0.6, 0.5]
    assert asked[3] == (0.55 if c > 0.5 else 0.45)
    assert abs(s - c) <= 1e-12 and abs(v - f(c)[0]) <= 1e-12
    grid = np.linspace(0.0, 1.0, 11)
    ext = continuous_maxima(f, grid, sampled(f, grid), "max")
    assert abs(ext[0].s - c) <= 1e-12


def test_a_newton_step_that_does_not_move_is_convergence():
    """On -(s - c)^2 Newton lands on c in one step; there dv/ds = 0 (or a round-off), so the
    next step is no step at all and lies on the bracket's new end: that is convergence, not a
    step out of the bracket to be replaced by some 45 bisections."""
    asked = []

    def evaluate(s):
        asked.append(float(s))
        return quadratic(0.13)(s)

    s, v = refine(evaluate, 0.0, 0.2, 0.1, 1.0)
    assert abs(s - 0.13) <= 1e-15 and abs(v) <= 1e-30
    assert len(asked) <= 6  # the bracket's ends and grid point, the Newton point, the answer


def test_no_sign_change_gives_the_grid_point():
    """dv/ds > 0 on the whole bracket (v = s): the grid point itself, not a refined one."""
    assert refine(lambda s: (s, 1.0, 0.0), 0.1, 0.3, 0.2, 1.0) == (0.2, 0.2)


def test_never_less_than_the_grid_point():
    """The refinement of a bracket never reports less than its grid point: with samples that
    put 10 at the grid maximum and an evaluate whose maximum is 1, the grid point wins."""
    grid = np.linspace(0.0, 1.0, 11)
    values = np.zeros(11)
    values[5] = 10.0
    ext = continuous_maxima(quadratic(0.52), grid, values, "max")
    assert (ext[0].s, ext[0].value) == (0.5, 10.0)


def test_only_above_leaves_the_lower_grid_maxima_out():
    grid = np.linspace(A, B, 120)
    threshold = 1.0
    ext = continuous_maxima_rows(many(wave), grid, sampled(wave, grid)[None, :], [Request(0, "abs", threshold)])[0]
    interior = sorted(e.s for e in ext if e.s not in (A, B))
    reference = [r for r in wave_maxima("abs") if abs(wave(r)[0]) >= threshold + 0.05]  # grid maxima clear of it
    below = [r for r in wave_maxima("abs") if abs(wave(r)[0]) < threshold - 0.05]
    assert reference and below
    assert len(interior) == len(reference)
    for s, r in zip(interior, reference):
        assert abs(s - r) <= 1e-12


# --- lockstep == one bracket at a time ---------------------------------------------------------
ROWS = [wave, lambda s: tuple(-x for x in wave(s)), plateau, lorentzian(0.53, 0.01), hyperbola(0.47, 0.004),
        quadratic(0.13), lambda s: (math.exp(s) * math.sin(5 * s), math.exp(s) * (math.sin(5 * s) + 5 * math.cos(5 * s)),
                                    math.exp(s) * (10 * math.cos(5 * s) - 24 * math.sin(5 * s)))]


def test_lockstep_equals_one_bracket_at_a_time():
    grid = np.linspace(-0.2, 1.3, 57)
    V = np.array([sampled(f, grid) for f in ROWS])
    requests = [Request(r, sense, only_above) for r in range(len(ROWS)) for sense in ("abs", "max", "min")
                for only_above in (None, 0.2)]
    calls = []

    def evaluate_many(s):
        calls.append(len(s))
        return many(*ROWS)(s)

    together = continuous_maxima_rows(evaluate_many, grid, V, requests)
    alone = [continuous_maxima(ROWS[q.row], grid, V[q.row], q.sense, only_above=q.only_above) for q in requests]
    assert together == alone
    assert sum(len(e) - 2 for e in together) > 50  # many brackets ...
    assert len(calls) < 50  # ... refined with one call per step, not one per evaluation


def test_refine_all_equals_refine_bracket_by_bracket():
    brackets = [(0, A, A + 0.5, A + 0.25, 1.0), (0, 0.3, 0.7, 0.5, -1.0), (2, 0.45, 0.55, 0.5, 1.0),
                (3, 0.4, 0.6, 0.5, 1.0), (4, 0.4, 0.6, 0.5, 1.0), (5, 0.0, 0.2, 0.1, 1.0), (6, 0.0, 1.0, 0.5, 1.0)]
    together = refine_all(many(*ROWS), brackets)
    alone = [refine(ROWS[row], lo, hi, s0, sign) for row, lo, hi, s0, sign in brackets]
    assert together == alone


# --- CasADi: the mapped evaluation and the continuous check --------------------------------------
def test_mapped_function_returns_casadis_own_numbers():
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 2)
    sparse = ca.SX(4, 1)  # rows 1 and 3 structurally zero (as in the quantities' derivatives)
    sparse[0], sparse[2] = s * p[1], ca.cos(s)
    sx = ca.Function("f", [s, p], [ca.vertcat(ca.sin(p[0] * s), ca.exp(s) / p[1]), s * p[1], sparse])
    x, sm, pm = ca.MX.sym("x"), ca.MX.sym("s"), ca.MX.sym("p", 2)
    root = ca.rootfinder("r", "newton", {"x": x, "p": ca.vertcat(sm, pm), "g": x ** 3 + pm[0] * x - sm},
                         {"error_on_fail": False})
    y = root(0.5, ca.vertcat(sm, pm))
    mx = ca.Function("g", [sm, pm], [ca.vertcat(y, y * pm[1]), ca.jacobian(ca.vertcat(y, pm[0], sm), sm)])
    values = np.linspace(-0.7, 2.3, 13)
    P = np.array([1.7, 0.3])
    for f in (sx, mx):
        mapped = MappedFunction(f)
        for n in (1, 5, 13, 5):  # a size asked for again reuses its buffer
            out = mapped(values[:n], P)
            assert len(out) == f.n_out()
            for j in range(f.n_out()):
                assert out[j].shape == (f.size1_out(j), n)
                for k in range(n):
                    assert np.array_equal(out[j][:, k], np.asarray(f(values[k], P)[j]).ravel())


def test_continuous_check_equals_the_scalar_refinement():
    """Every block's certified extremum on the jib at a (non-optimal) design: exactly what the
    one-bracket-at-a-time refinement with ordinary CasADi calls gives."""
    pb = DesignProblem(load(ROOT / "problems" / "seed1_jib.toml"))
    solver = Solver(pb)
    fixed = solver.fixed_values()
    x = np.array([0.5 * (lo + hi) for lo, hi in zip(pb.lower, pb.upper)])
    p = pb.full_parameters(x, fixed)
    # the grid by CasADi's ordinary mapped call (not the buffered one under test)
    V = np.asarray(pb.quantity.map(len(pb.s_grid))(pb.s_grid[None, :], p))
    t = [float(np.max(np.abs(V[pb.objective_quantity]))) / pb.f_ref] if pb.n_t else []
    a = [float(np.max(V[ag.index]) if ag.func == "max" else np.min(V[ag.index])) / sc
         for ag, sc in zip(pb.aggregates, pb.a_scale)]
    w = np.r_[pb.to_z(x), t, a]
    _, certified, _ = solver.continuous_check(x, fixed, w, pb.s_grid)
    checks = solver._checks(x, fixed, w, pb.s_grid)
    assert len(checks) >= 4
    for c in checks:
        def evaluate(s, row=c.row):
            out = pb.quantity_derivatives(s, p)
            return float(out[0][row]), float(out[1][row]), float(out[2][row])
        ext = continuous_maxima(evaluate, pb.s_grid, V[c.row], c.sense, only_above=c.request.only_above)
        assert certified[(c.name, c.sense)] == ext[0].value
