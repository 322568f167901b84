"""The integrator calls: one branch of the equation of motion from a state over a time h, with
the states at equally spaced points of it (dense output), and the statistics of every call.

**Integrators** (CasADi's ``integrator``): 'bdf' = CVODES BDF with Newton iterations (implicit,
for stiff cases), 'adams' = CVODES Adams with functional iteration (non-stiff, no Jacobian),
'rk4' = CasADi's fixed-step explicit RK4 (``steps`` per output sample; no error control of its
own, so :mod:`.simulator` repeats the run with half the steps and the Richardson estimate of its
error must be within the tolerance).  Every integrator here is one of the time-scaled ODE
dy/dtau = h f(y * scale, c) / scale on tau in [0, 1]: the state is scaled to order one (one
absolute tolerance fits s, its rate and q), and the length h and the branch c are parameters,
so that one integrator serves every stretch of a run with the same number of output points
(:meth:`Integration.integrator` keeps them by that number).  CasADi 3.8's own event support in
CVODES is experimental (it fails on a bouncing ball), so events are found by :mod:`.events`
from the dense output: CasADi stops CVODES at each output point, which costs a few steps in a
thousand (a pendulum: 1,039 steps with 1 point, 1,035 with 1,000) and moves where the steps
fall, and a little time per point.

**Statistics** (:class:`Counts`) are summed over every call, failed ones included.  CasADi keeps
a failed call's counts up to its last output point before the failure; the stretch from there
to the failure is not reported: a call that fails for too much work spent exactly
``MAX_STEPS`` steps on it (counted, with as many right-hand sides, a lower bound), any other
failure an unreported handful.  ``failed_calls`` says how many calls failed, ``failures`` how
many for each of CVODES's return flags (CV_TOO_MUCH_WORK, CV_CONV_FAILURE, ...).
"""
from __future__ import annotations

import re

import casadi as ca
import numpy as np

from ..errors import check_interrupt

DEFAULT_TOLERANCE = 1e-8  # relative, when neither the scene nor the caller gives one
MAX_STEPS = 20000  # CVODES steps per output point (8 or more per output interval) before it gives up
SUBSAMPLES = 8     # CVODES output points per output interval at least, at which events are watched
LONGEST = 128      # output intervals per integrator call at most
DENSE = SUBSAMPLES * LONGEST  # CVODES output points per call at most


class IntegratorFailed(Exception):
    pass


class Counts:
    """Integrator statistics summed over calls, in common names for CVODES and RK4."""

    def __init__(self):
        self.steps = self.rhs = self.error_fails = self.nonlinear = self.calls = self.failed = 0
        self.failures = {}  # failed calls by CVODES's return flag

    def add(self, stats, method, failure=None):
        """Add one call's ``stats``; ``failure``: the message of a failed call, else None."""
        self.calls += 1
        if method == "rk4":
            n = int(stats.get("n_call_step", 0))
            self.steps += n
            self.rhs += 4 * n
        else:
            self.steps += int(stats.get("nsteps", 0))
            self.rhs += int(stats.get("nfevals", 0))
            self.error_fails += int(stats.get("netfails", 0))
            self.nonlinear += int(stats.get("nniters", 0))
        if failure is not None:
            self.failed += 1
            flag = re.search(r'returned "(\w+)"', failure)
            flag = flag.group(1) if flag else "other"
            self.failures[flag] = self.failures.get(flag, 0) + 1
            if flag == "CV_TOO_MUCH_WORK":
                self.steps += MAX_STEPS
                self.rhs += MAX_STEPS

    def merge(self, other):
        """Add the counts of another run (RK4's run at half the steps)."""
        for name in ("steps", "rhs", "error_fails", "nonlinear", "calls", "failed"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        for flag, n in other.failures.items():
            self.failures[flag] = self.failures.get(flag, 0) + n

    def as_dict(self):
        return {"steps": self.steps, "rhs_evaluations": self.rhs, "error_test_failures": self.error_fails,
                "nonlinear_iterations": self.nonlinear, "integrator_calls": self.calls, "failed_calls": self.failed,
                "failures": dict(self.failures)}


def state_scales(x0, lo, hi, t_end, rotary):
    """State scales: tolerances are relative to the stroke length and a reference sweep rate."""
    length = hi - lo
    rate = max(abs(x0[1]), length / t_end)
    scale = [length, rate] + ([abs(x0[2]) + length] if rotary else [])
    return np.array(scale)


class Integration:
    """One run of the :class:`~.equations.Equations` ``eq`` at the parameter values ``p``: the
    integrator ``method`` ('bdf', 'adams', 'rk4'), its ``tol`` and RK4 ``steps`` per output
    interval (None for CVODES), the start ``x0``, the stroke's ``ends`` {'from': s, 'to': s}
    (``lo``, ``hi`` in order), the state ``scale``, the
    :class:`Counts` of every integrator call, and ``eta``.  ``cache``: a dict for the compiled
    integrators, shared by the runs of one simulator."""

    def __init__(self, eq, p, x0, ends, scale, method, tol, steps, cache=None):
        self.eq, self.p, self.x0, self.ends, self.scale = eq, p, x0, ends, scale
        self.lo, self.hi = min(ends.values()), max(ends.values())
        self.method, self.tol, self.steps = method, tol, steps
        self.counts = Counts()
        self.peak_counts = Counts()   # the calls that located peaks between samples (:mod:`.time_peaks`)
        self.eta = float(eq.eta(p))
        self.uses_efficiency = eq.uses_efficiency and self.eta != 1.0
        # points per output interval where events are watched: RK4's own steps, else dense output
        self.subsamples = steps if method == "rk4" else SUBSAMPLES
        self._cache = {} if cache is None else cache

    def statistics(self) -> dict:
        """The counts of the run's integrator calls, and apart under 'peak_location' those that
        located its peaks between the output samples."""
        located = {k: v for k, v in self.peak_counts.as_dict().items() if k != "failures"}
        return {**self.counts.as_dict(), "peak_location": located}

    def integrator(self, n):
        """A CasADi integrator of the time-scaled ODE on one branch with its output at tau = 1/N,
        2/N, .. 1, N a multiple of n: RK4 N = n (one step per output point); CVODES N = 8 n up
        to DENSE (dense output costs no steps, only a little time per point)."""
        if self.method != "rk4" and n > 1:
            if DENSE % n:
                raise ValueError(f"{n} output points: expected a divisor of {DENSE}")
            n = min(DENSE, 8 * n)
        key = (self.method, self.tol, n)
        F = self._cache.get(key)
        if F is not None:
            return F
        dae = self._cache.get("dae")
        if dae is None:
            eq, scale = self.eq, self.scale
            sym = eq.mech.sym
            y, p, c, h = sym.sym("y", eq.n_x), sym.sym("p", len(self.p)), sym.sym("c"), sym.sym("h")
            x = y * ca.DM(scale)
            ode = h * eq.rhs_branch(*[x[i] for i in range(eq.n_x)], p, c) / ca.DM(scale)
            if sym is ca.SX:
                ode = ca.cse(ode)  # the inlined graph, common subexpressions eliminated
            dae = self._cache["dae"] = {"x": y, "p": ca.vertcat(p, c, h), "ode": ode}
        tau = list(np.arange(1, n + 1) / n)
        if self.method == "rk4":
            opts = {"number_of_finite_elements": int(n), "show_eval_warnings": False}
            F = ca.integrator("simulate", "rk", dae, 0.0, tau, opts)
        else:
            opts = {"abstol": self.tol, "reltol": self.tol, "max_num_steps": MAX_STEPS,
                    "disable_internal_warnings": True, "show_eval_warnings": False}
            if self.method == "bdf":
                opts.update(linear_multistep_method="bdf", nonlinear_solver_iteration="newton")
            else:
                opts.update(linear_multistep_method="adams", nonlinear_solver_iteration="functional")
            F = ca.integrator("simulate", "cvodes", dae, 0.0, tau, opts)
        self._cache[key] = F
        return F

    def advance(self, x0, h, c, n=1):
        """The states (columns) at h/N, 2h/N, .. h from x0 on branch c, N a multiple of n
        (:meth:`integrator`); its statistics are counted, a failure raises
        :class:`IntegratorFailed`."""
        F = self.integrator(n)
        scale = self.scale
        p = np.concatenate([self.p, [c, h]])
        try:
            xf = F(x0=x0 / scale, p=p)["xf"].full() * scale[:, None]
        except RuntimeError as exc:
            check_interrupt(exc)   # a Ctrl-C that CasADi reported as a failed call
            self.counts.add(F.stats(), self.method, failure=str(exc))
            raise IntegratorFailed(str(exc)) from None
        self.counts.add(F.stats(), self.method)
        check_interrupt()   # a Ctrl-C that CasADi noticed and let pass (it goes on in some callbacks)
        return xf
