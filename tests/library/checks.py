"""The checks every library scene gets (tests/library/test_lib_*.py subclass :class:`SceneChecks`).

optdesign is used only through its front doors (``optdesign.load``, ``optdesign.optimise``,
``optdesign.analyse``); every expected value comes from the scene's independent numpy model
(tests/library/ref_*.py, read with tomllib, kinematics by hand, the drive load by Lagrange's
equation):

* optimise(load(scene), 20, 0), default settings: it succeeds and its best objective is the
  reference's global optimum (dense grid over the whole design box + polished SLSQP minimax)
  to 1e-6 relative, at the same design (1e-4 of each variable's range);
* its certified peak is the peak |drive| of the numpy model at optdesign's optimum design over
  DENSE = 20,001 stroke samples with the extreme refined by a scalar search, to 1e-8 relative;
  every constraint of the scene holds there on the same dense stroke;
* the drive load of the start design and of the optimum at 9 points of the stroke
  (``optdesign.analyse``) is the numpy model's to 1e-9 of the peak, and so are the
  per-sample constraint rows;
* every constraint is reported by its true range over the stroke (the numpy dense extremes);
* how many of the 20 starts reach the global optimum (within 1e-6) is printed with the
  statuses of the others (not asserted: the multistart is being improved).
"""
from __future__ import annotations

import functools
import time

import numpy as np
import pytest

import optdesign
from default_optimum import default_optimum  # noqa: E402 (tests/ is on sys.path under pytest)

from . import refkit

OBJECTIVE_REL = 1e-6
PEAK_REL = 1e-8
LOAD_REL = 1e-9


def optimum(path):
    """``optdesign.optimise(optdesign.load(path), 20, 0)`` (default settings) and its wall time,
    run once per scene for the whole session (tests/default_optimum.py)."""
    return default_optimum(path)


@functools.cache
def reference(module):
    t0 = time.perf_counter()
    ref = module.global_optimum("small")
    return ref, time.perf_counter() - t0


class SceneChecks:
    ref = None  # the scene's reference module (ref_<name>.py), set by the subclass

    @property
    def path(self):
        return self.ref.SCENE

    def test_best_is_the_global_optimum(self):
        result, t_opt = optimum(self.path)
        glob, t_ref = reference(self.ref)
        at_global = [s for s in result.starts if s.success and s.objective is not None
                     and abs(s.objective - glob["value"]) <= OBJECTIVE_REL * glob["value"]]
        others = [(s.index, s.status, s.objective) for s in result.starts if s not in at_global]
        print(f"\n{self.path.name}: global optimum {glob['value']!r} at {glob['design']} "
              f"(reference {t_ref:.1f} s); optdesign {result.objective!r} at {result.design} "
              f"({t_opt:.1f} s); starts at the global optimum: {len(at_global)}/{len(result.starts)}; "
              f"others: {others}")
        assert result.success, (result.status, result.message)
        assert result.objective == pytest.approx(glob["value"], rel=OBJECTIVE_REL)
        pb = self.ref.problem()
        for i, name in enumerate(pb.names):
            span = pb.hi[i] - pb.lo[i]
            assert abs(result.design[name] - glob["design"][name]) <= 1e-4 * span, (name, result.design, glob["design"])

    def test_certified_peak_is_the_dense_peak(self):
        result, _ = optimum(self.path)
        assert result.success, (result.status, result.message)
        pb = self.ref.problem()
        x = np.array([result.design[n] for n in pb.names])
        rep = pb.check(x, refkit.DENSE)
        assert result.peak_certified == pytest.approx(rep["peak"], rel=PEAK_REL)
        assert result.objective == pytest.approx(rep["peak"], rel=PEAK_REL)
        # the optimum is feasible on the dense stroke (to the solver's tolerance)
        assert rep["violation"] <= 1e-6, rep

    def _compare(self, design):
        scene = optdesign.load(self.path)
        if design:
            scene = scene.with_parameters(**design)
        an = optdesign.analyse(scene, samples=9)
        pb = self.ref.problem()
        x = np.array([design.get(n, pb.scene.params[n]) for n in pb.names])
        s = np.asarray(an.columns["s"])
        vals = pb.evaluate(x[None, :], s[None, :])
        ours = np.real(np.broadcast_to(vals["drive"], (1, len(s)))[0])
        theirs = np.asarray(an.columns["drive"])
        scale = np.max(np.abs(ours))
        assert np.max(np.abs(theirs - ours)) <= LOAD_REL * scale, (theirs, ours)
        q = np.real(np.broadcast_to(vals["q"], (1, len(s)))[0])
        assert np.max(np.abs(np.asarray(an.columns["q"]) - q)) <= 1e-12 * np.max(np.abs(q)) + 1e-14
        ends = getattr(pb.m, "ends", {})  # constraints the scene states at the stroke's end: end(...)
        for name, row, _, _ in pb.per_sample:
            if name in ends:
                end = np.real(pb.evaluate(x[None, :], np.array([[pb.s1]]))[ends[name]]).ravel()[0]
                assert an.constraints[name] == pytest.approx(end, rel=1e-12, abs=1e-12 * pb.row_scale[row])
                continue
            mine = np.real(np.broadcast_to(vals[row], (1, len(s)))[0])
            np.testing.assert_allclose(an.constraints[name], mine, rtol=1e-12, atol=1e-12 * pb.row_scale[row])
        for name, row, _, _ in pb.ratios:
            Lq = np.real(np.broadcast_to(vals[row], (1, len(s)))[0])
            assert an.constraints[name] == pytest.approx(Lq.max() / Lq.min(), rel=1e-12)

    def test_start_design_against_the_numpy_model(self):
        self._compare({})

    def test_optimum_against_the_numpy_model(self):
        result, _ = optimum(self.path)
        assert result.success, (result.status, result.message)
        self._compare(dict(result.design))

    def test_reported_constraint_ranges_are_the_dense_ones(self):
        """Every constraint is reported by its values over the continuous stroke, active or not
        (issue 14: an inactive per-sample constraint was reported by values short of its true
        extremes, e.g. the dump truck's transmission angle 0.98148 rad against its 0.99110 rad
        at theta = 5.9 deg): each per-sample constraint's min and max are the numpy model's
        over DENSE samples with the extreme refined by a bounded scalar search (1e-9 of the
        row's scale), each length ratio is max/min of the numpy length (1e-9)."""
        result, _ = optimum(self.path)
        assert result.success, (result.status, result.message)
        pb = self.ref.problem()
        x = np.array([result.design[n] for n in pb.names])
        ends = getattr(pb.m, "ends", {})  # constraints the scene states at the stroke's end: end(...)
        for name, row, _, _ in pb.per_sample:
            if name in ends:
                end = np.real(pb.evaluate(x[None, :], np.array([[pb.s1]]))[ends[name]]).ravel()[0]
                assert result.constraints[name]["value"] == pytest.approx(end, abs=1e-9 * pb.row_scale[row])
                continue
            hi, _ = pb.stroke_extreme(x, row, +1)
            lo, _ = pb.stroke_extreme(x, row, -1)
            reported = result.constraints[name]
            assert reported["max"] == pytest.approx(hi, abs=1e-9 * pb.row_scale[row]), (name, reported, hi)
            assert reported["min"] == pytest.approx(-lo, abs=1e-9 * pb.row_scale[row]), (name, reported, -lo)
        for name, row, _, _ in pb.ratios:
            hi, _ = pb.stroke_extreme(x, row, +1)
            lo, _ = pb.stroke_extreme(x, row, -1)
            assert result.constraints[name]["value"] == pytest.approx(hi / -lo, rel=1e-9), name
