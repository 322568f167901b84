"""The integrator calls: one run over the output grid, interval by interval where it fails, and
RK4's error estimate, with the integrator statistics summed over every call.

**Integrators** (CasADi's ``integrator``): 'bdf' = CVODES BDF with Newton iterations (implicit,
for stiff cases), 'adams' = CVODES Adams with functional iteration (non-stiff, no Jacobian),
'rk4' = CasADi's fixed-step explicit RK4 (``steps`` per output sample; no error control of its
own, so the run is repeated with half the steps and the Richardson estimate of its error must be
within the tolerance, else a :class:`~optdesign.errors.SolverError`: :func:`rk4_error`).  CVODES
in CasADi 3.8 has only experimental event support, so the stroke ends and rests are found by
:mod:`.events`, which re-integrates one interval over a variable length h: every integrator here
is one of the time-scaled ODE, with h a parameter.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..errors import SolverError

MAX_STEPS = 20000  # CVODES steps per output interval before it gives up ("too much work")
STALL_CHUNK = 10   # output intervals per integrator call where a self-locking drive can stall


class IntegratorFailed(Exception):
    pass


class Counts:
    """Integrator statistics summed over calls, in common names for CVODES and RK4."""

    def __init__(self):
        self.steps = self.rhs = self.error_fails = self.nonlinear = self.calls = 0

    def add(self, stats, method):
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

    def as_dict(self):
        return {"steps": self.steps, "rhs_evaluations": self.rhs, "error_test_failures": self.error_fails,
                "nonlinear_iterations": self.nonlinear, "integrator_calls": self.calls}


def state_scales(x0, lo, hi, t_end, rotary):
    """State scales: tolerances are relative to the stroke length and a reference sweep rate."""
    length = hi - lo
    rate = max(abs(x0[1]), length / t_end)
    scale = [length, rate] + ([abs(x0[2]) + length] if rotary else [])
    return np.array(scale)


class Integration:
    """One run of the :class:`~.equations.Equations` ``eq`` at the parameter values ``p``: the
    integrator ``method`` ('bdf', 'adams', 'rk4'), its ``tol`` and RK4 ``steps`` per output sample
    (None for CVODES), the start ``x0``, the stroke [lo, hi], the state ``scale`` and the
    :class:`Counts` of every integrator call."""

    def __init__(self, eq, p, x0, lo, hi, scale, method, tol, steps):
        self.eq, self.p, self.x0, self.lo, self.hi, self.scale = eq, p, x0, lo, hi, scale
        self.method, self.tol, self.steps = method, tol, steps
        self.counts = Counts()

    def integrator(self, tau, total_steps, one_sided=False):
        """A CasADi integrator over the tau grid (0 .. 1) of the time-scaled ODE
        dy/dtau = h f(y * scale) / scale: the state y is scaled to order one (so that one
        absolute tolerance fits s, its rate and q), and the interval length h is a parameter
        (one integrator serves every interval, which the stroke-end search needs).  With
        ``one_sided`` f is the one-sided equation and the direction d is a parameter before h;
        ``total_steps``: RK4's steps over the whole tau grid."""
        eq, scale, method = self.eq, self.scale, self.method
        sym = eq.mech.sym
        y, p, h = sym.sym("y", eq.n_x), sym.sym("p", len(self.p)), sym.sym("h")
        x = y * scale
        states = [x[i] for i in range(eq.n_x)]
        if one_sided:
            d = sym.sym("d")
            ode, params = h * eq.rhs_one(*states, p, d) / scale, ca.vertcat(p, d, h)
        else:
            ode, params = h * eq.rhs(*states, p) / scale, ca.vertcat(p, h)
        dae = {"x": y, "p": params, "ode": ode}
        if method == "rk4":
            opts = {"number_of_finite_elements": int(total_steps), "show_eval_warnings": False}
            return ca.integrator("simulate", "rk", dae, 0.0, list(tau), opts)
        opts = {"abstol": self.tol, "reltol": self.tol, "max_num_steps": MAX_STEPS,
                "disable_internal_warnings": True, "show_eval_warnings": False}
        if method == "bdf":
            opts.update(linear_multistep_method="bdf", nonlinear_solver_iteration="newton")
        else:
            opts.update(linear_multistep_method="adams", nonlinear_solver_iteration="functional")
        return ca.integrator("simulate", "cvodes", dae, 0.0, list(tau), opts)

    def call(self, F, x0, h, direction=None):
        """The states (columns) of the integrator F from x0 over an interval of length h (with a
        ``direction`` on the one-sided equation); its statistics are counted, a failure raises
        :class:`IntegratorFailed`."""
        scale = self.scale
        extra = [] if direction is None else [direction]
        p = np.concatenate([self.p, extra, [h]])
        try:
            xf = np.asarray(F(x0=x0 / scale, p=p)["xf"]) * scale[:, None]
        except RuntimeError as exc:
            self.counts.add(F.stats(), self.method)
            raise IntegratorFailed(str(exc)) from None
        self.counts.add(F.stats(), self.method)
        return xf

    def inside(self, X):
        """Per sample: finite and within the stroke."""
        return np.isfinite(X).all(axis=0) & (X[0] >= self.lo) & (X[0] <= self.hi)


def integrate_grid(run, grid, held_rest):
    """The whole run in one integrator call; on failure, interval by interval to find where.

    Where a self-locking drive can bring the mechanism to rest (eta < 1, CVODES), in chunks
    of STALL_CHUNK output intervals, each checked for a held rest before the next: past
    that instant CVODES steps on through the switch's chatter up to t_end, at loose
    tolerances about ten thousand steps per output interval.  ``held_rest(grid, X, last, first)``
    (:func:`.events.held_rest`) finds such a rest, or None."""
    method, steps = run.method, run.steps
    n = len(grid) - 1
    chunk = STALL_CHUNK if run.eq.uses_efficiency and method != "rk4" else n
    cols, i = [run.x0], 0
    while i < n:
        j = min(i + chunk, n)
        tau = (grid[i + 1:j + 1] - grid[i]) / (grid[j] - grid[i])
        F = run.integrator(tau, steps * (j - i) if steps else None)
        try:
            cols += list(run.call(F, cols[-1], grid[j] - grid[i]).T)
        except IntegratorFailed:
            return integrate_stepwise(run, grid, np.column_stack(cols))
        first, i = i + 1, j
        if i < n and chunk < n:
            X = np.column_stack(cols)
            if not run.inside(X[:, first:]).all() or held_rest(grid[:i + 1], X, i, first) is not None:
                return np.column_stack([X, np.full((X.shape[0], n - i), np.nan)])
    return np.column_stack(cols)


def integrate_stepwise(run, grid, X0=None):
    """Interval by interval (restarts) from the columns ``X0`` already integrated (the start
    alone by default): the states up to the interval where the integrator fails; a failing
    interval gets a NaN column, which :func:`.events.stop` examines."""
    F = run.integrator([1.0], run.steps)
    cols = [run.x0] if X0 is None else list(X0.T)
    for i in range(len(cols) - 1, len(grid) - 1):
        try:
            x = run.call(F, cols[-1], grid[i + 1] - grid[i])[:, 0]
        except IntegratorFailed:
            x = np.full_like(run.x0, np.nan)
        cols.append(x)
        if not (np.all(np.isfinite(x)) and run.lo <= x[0] <= run.hi):
            break
    X = np.column_stack(cols)
    return np.column_stack([X, np.full((X.shape[0], len(grid) - X.shape[1]), np.nan)])


def rk4_error(run, t, X, stop, where):
    """RK4's global error, estimated by Richardson from a run with half the steps over the
    same output times: err ~ max |x_N - x_{N/2}| / 15 (scaled states).  ``where``: the scene's
    path, for the message."""
    tol, steps, scale = run.tol, run.steps, run.scale
    m = len(t) if stop == "t_end" else len(t) - 1  # samples on the uniform grid
    cols = [run.x0]
    if m >= 2:
        F = run.integrator(t[1:m] / t[m - 1], (steps // 2) * (m - 1))
        cols += list(run.call(F, run.x0, t[m - 1]).T)
    if m < len(t):  # the stroke end or the rest, reached in a shorter last interval
        d = math.copysign(1.0, X[1, m - 1]) if stop == "stalled" else None  # the rest: one-sided
        F = run.integrator([1.0], steps // 2, one_sided=d is not None)
        cols.append(run.call(F, cols[-1], t[-1] - t[m - 1], d)[:, 0])
    diff = (X - np.column_stack(cols)) / scale[:, None]
    error = float(np.max(np.abs(diff))) / 15 if np.isfinite(diff).all() else math.inf
    if not error <= tol:
        need = steps * max(2.0, (error / tol) ** 0.25) if math.isfinite(error) else 10 * steps
        raise SolverError(
            f"{where}: the rk4 integrator with {steps} steps per output sample is not accurate "
            f"enough: its estimated error {error:.3g} (relative to the stroke length and the reference "
            f"rate; from a run with half the steps) exceeds the tolerance {tol:.3g}. Use about "
            f"{math.ceil(need)} steps per sample (--steps), or the implicit integrator (bdf).")
    return error
