"""The screening's instruction programs run by compiled C (optdesign/model/programs_c.py): the
numbers are the numpy loop's (optdesign/model/vectorised.run_program) bit for bit, on a graph
of every operation the C does itself or hands to numpy's loops, with special values, the
parameters the same for every column or given per column, and any number of columns (blocks
and a short last one); both are CasADi's own numbers to round-off (its map of the Function:
CasADi's tanh is the C library's, numpy's is not); numpy's loops called through their
addresses give the ufuncs' bits; a program whose truth values would reach an operation where
numpy changes type is left to numpy."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from optdesign.design.screening import ManyDesigns
from optdesign.model import programs_c
from optdesign.model.programs import _rows
from optdesign.model.vectorised import instruction_program, run_program


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("OPTDESIGN_NO_COMPILE", raising=False)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "wait")
    programs_c._tried[0] = -np.inf
    return tmp_path / "cache"


def graph():
    """(x[4], p[3]) -> (f, g): every operation of the C's own and of numpy's loops."""
    x, p = ca.SX.sym("x", 4), ca.SX.sym("p", 3)
    a = x[0] * p[0] + x[1] / (p[1] + 2) - x[2] ** 2
    g = ca.vertcat(
        ca.sin(a) + ca.cos(x[1]) * ca.tan(x[2] / 3), ca.tanh(3 * x[0]) - ca.sinh(x[1] / 4) + ca.cosh(x[2] / 5),
        ca.atan2(x[1], x[0] + p[2]), ca.asin(ca.tanh(x[3])) + ca.acos(ca.tanh(x[2])) + ca.atan(a),
        ca.exp(-x[2] ** 2) * ca.log(1 + x[0] ** 2) + ca.log1p(ca.fabs(x[1])) - ca.expm1(x[3] / 7),
        ca.sqrt(ca.fabs(a)) + 1 / (x[3] + 5) + ca.power(ca.fabs(x[0]) + 0.5, p[1]) + ca.constpow(ca.fabs(x[1]) + 1, 2.5),
        ca.fmin(x[0], p[0]) - ca.fmax(x[1], -p[1]) + ca.sign(x[2]) * ca.floor(3 * x[3]) + ca.ceil(x[0]),
        ca.if_else(x[0] > 0.2, x[1] * 2, -x[2]) + ca.if_else(ca.logic_and(x[1] < 0, x[2] >= p[2] - 1), p[0], x[3]),
        ca.if_else(ca.logic_or(x[0] == 0, ca.logic_not(x[1] != x[2])), 1.0, 0.5) * (x[0] <= x[3]),
        ca.hypot(x[0], x[1]) + ca.fmod(x[2] * 7, 3) + ca.copysign(x[3], x[0] - 0.1) - (p[0] * p[1] + ca.sin(p[2])))
    return ca.Function("rows", [x, p], [ca.sumsqr(g) + ca.tanh(p[0]), g])


def inputs(m, rng):
    X = rng.uniform(-2, 2, (4, m))
    X[:, :3] = [[0.0, -0.0, np.nan], [np.inf, 0.0, 1.0], [-np.inf, 2.0, -0.0], [1e-300, -1e300, 5.0]]
    return X, rng.uniform(0.2, 2, (3, m))


def numpy_loop(f, X, P):
    """The numpy loop over the same program (what the screening ran before)."""
    sx = f.expand() if not f.is_a("SXFunction") else f
    program, m = instruction_program(sx), X.shape[1]
    cols = [X, P if P.ndim == 2 else P.reshape(-1, 1)]
    outs = [np.zeros((f.numel_out(j), m)) for j in range(f.n_out())]
    where = [f.sparsity_out(j).find() for j in range(f.n_out())]

    def store(j, k, value):
        outs[j][where[j][k]] = value
    run_program(program, sx.sz_w(), lambda i, k: cols[i][k], store)
    return outs


def bits(a):
    return np.ascontiguousarray(a, float).view(np.int64)


@pytest.mark.parametrize("m", [3, 63, 64, 65, 300])
def test_the_c_gives_the_numpy_loops_bits(cache, m):
    f = graph()
    X, P = inputs(m, np.random.default_rng(m))
    many = ManyDesigns(f)
    for p in (P, P[:, 0]):   # the parameters per column, or one vector for all
        ours = many(X, p)
        assert programs_c.pending() is False and many._c, "the C ran"
        theirs = numpy_loop(f, X, p)
        for o, t in zip(ours, theirs):
            assert np.array_equal(bits(o), bits(t))
        finite = np.all(np.isfinite(X), axis=0)
        for o, c in zip(ours, [np.asarray(v) for v in f.map(m)(X, np.broadcast_to(
                p if p.ndim == 2 else p[:, None], (3, m)))]):
            np.testing.assert_allclose(o[:, finite], c[:, finite], rtol=1e-13, atol=1e-13)


def test_numpys_loops_called_by_address_give_the_ufuncs_bits(cache):
    for u in set(programs_c.LOOPS.values()):
        assert programs_c._check(u) is not None, u.__name__


def test_truth_values_where_numpy_changes_type_are_left_to_numpy(cache):
    x = ca.SX.sym("x", 2)
    for expr, c_runs in (((x[0] < x[1]) * x[0], True), (ca.sqrt(x[0] < x[1]), False),
                         ((x[0] < x[1]) + (x[1] < 0), False)):
        f = ca.Function("f", [x], [expr])
        rows, constants = _rows(instruction_program(f))
        made = programs_c.program(rows, constants, f.sz_w(), (True,))
        assert (made is not None) == c_runs
        X = np.random.default_rng(0).uniform(-1, 1, (2, 100))
        ours, theirs = ManyDesigns(f)(X)[0], numpy_loop(f, X, np.zeros(0))[0]
        assert np.array_equal(ours, theirs)
