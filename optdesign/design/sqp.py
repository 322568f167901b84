"""An active-set SQP for the objective phase: CasADi's ``sqpmethod`` with the QP solver qpOASES
(bundled with CasADi), IPOPT the fallback from the same point.  Measured over the scene library
as an alternative to IPOPT; the tool's rule stays IPOPT (``SOLVER = 'ipopt'``), see below.

Why try it.  The design NLPs are small and dense (2-4 design variables, an epigraph variable, a
few stroke aggregates; 55-160 rows), and an exchange step re-solves near the last solution with
a few sample points moved: an active-set SQP takes one to three iterations of a small dense QP
there, where IPOPT's interior point takes 5-20 with a sparse factorisation each.

How the SQP is made as reliable as IPOPT on a solve (each setting measured on the library scenes
where the plain sqpmethod failed, results/per_start.md):

* ``convexify_strategy = eigen-clip``: the exact Hessian of the Lagrangian is indefinite away
  from a minimum (the mechanisms' kinematics are far from convex), and qpOASES needs a convex QP:
  without it the QP fails and the SQP stops after its first iteration (scissor lift: 10 of 10
  first solves ended 'Search_Direction_Becomes_Too_Small').  Clipping the eigenvalues of the
  (small) Hessian at ``convexify_margin`` keeps the exact curvature where it is positive.
* ``max_iter_ls = 20`` and ``beta = 0.5``: the line search backtracks up to 0.5^20 of the step.
  With CasADi's default (3 trials of 0.8) a step into designs that do not assemble (NaN rows) is
  taken anyway and the next iteration fails 'Non_Regular_Sensitivities' (crank-luffing jib: 9 of
  10 first solves).
* ``tol_pr = 1e-10``, ``tol_du = 1e-8``: sqpmethod's tolerances are absolute (IPOPT's ``tol``
  is scaled by the multipliers' size); with large multipliers the Lagrangian's gradient does not
  fall below 1e-10 in floating point and the SQP ends 'Search_Direction_Becomes_Too_Small' at the
  optimum.  The certificate is the continuous check's anyway (:mod:`.certify`), and the rows'
  violation stays IPOPT's (1e-10).

On the library's first objective solves (results/per_start.md) these settings make the SQP succeed
where the plain one fails (scissor lift 10 of 10 against 0, crank-luffing jib 10 against 1) but
fail where the plain one succeeds (dump truck hoist and wheel loader: 3 of 10 each); the fallback
to IPOPT catches those, at the cost of both solves.

A solve is accepted only when sqpmethod reports success, its design and rows are finite and
within their bounds (the NLP's tolerance), and it is no worse than its start when the start was
feasible; otherwise IPOPT solves from the same point (:meth:`.solver.Solver._nlp`).  Phase 1
keeps IPOPT.  qpOASES hot-starts each QP from the working set of the last QP it solved, in the
solver's memory, so each start gets a fresh SQP (a shared one made a start's result depend on
the starts before it), made from the compiled library in the disk cache in 0.3-0.6 ms; on
CasADi's virtual machine a fresh one costs 30-340 ms of derivative building, more than it
saves, so without the library the solves are IPOPT's.

The rules (``SOLVER``, one for every scene; benchmarks/bench_library.py measures each over the
library, results/optimise_library.md):

* 'ipopt' (the tool's): every objective-phase solve by IPOPT.
* 'sqpmethod on re-solves': a start's first solve by IPOPT, every re-solve after an exchange step
  and the best start's polish by the SQP first.  Over the library (20 starts per scene, median
  CPU per start): the same 360 of 360 starts at the global optimum, but IPOPT only / this rule
  1.04x in geometric mean (0.68x to 2.95x): faster where starts take many exchange steps (the
  toggle press), slower where a fresh SQP per start and its fallbacks cost more than the few
  re-solves save (level-luffing cylinder, crank-luffing jib, wheel loader).
* 'sqpmethod': the SQP first on a start's first solve too: 1.51x in geometric mean (0.84x to
  3.72x), but 359 of 360 starts: the first solve decides which local optimum a start reaches,
  the SQP descends to the nearest one, IPOPT's barrier path often further, and
  seed1_jib_design's own start ends at the local optimum 0.6 % above the global one, which
  IPOPT reaches.

Neither rule meets the bar for the tool's (no start lost anywhere, and faster per start over the
library); either would also make a run's numbers depend on whether the compiled library is in the
cache (the first run, or a machine without a compiler,
solves by IPOPT), where today the compiled code gives the same numbers as the virtual machine
(tests/test_compiled.py).
"""
from __future__ import annotations

import contextlib
import io
import os

import numpy as np

from ..model import compiled

SOLVER = "ipopt"
SOLVERS = ("sqpmethod on re-solves", "sqpmethod", "ipopt")

OPTIONS = {
    "qpsol": "qpoases", "qpsol_options": {"printLevel": "none", "error_on_fail": False},
    "hessian_approximation": "exact", "convexify_strategy": "eigen-clip", "convexify_margin": 1e-7,
    "max_iter": 100, "max_iter_ls": 20, "beta": 0.5, "tol_pr": 1e-10, "tol_du": 1e-8,
    "print_header": False, "print_iteration": False, "print_status": False, "print_time": False,
    "error_on_fail": False, "show_eval_warnings": False,
}


def use_sqp(first: bool) -> bool:
    """Whether a solve goes to the SQP first (``first``: a start's first objective solve)."""
    return SOLVER == "sqpmethod" or (SOLVER == "sqpmethod on re-solves" and not first)


def sqp_solver(pb):
    """A fresh sqpmethod on the design NLP (the same Function as IPOPT's, exact derivatives),
    its functions from the compiled library in the disk cache (model/compiled.py); None while
    there is none (then IPOPT solves, as before issue 18).

    Fresh, because qpOASES hot-starts every QP from the working set of the last QP it solved,
    in this solver's memory: a solver shared by the starts would make a start's result depend
    on the starts before it.  One per start (:class:`.solver.Solver` asks once per start and
    per polish) costs 0.3-0.6 ms from the library, but 30-340 ms of derivative building on
    CasADi's virtual machine, more than the SQP saves: hence the library or IPOPT."""
    path = pb._once("sqp library", lambda: _library(pb))
    if path is None:
        return None
    import casadi as ca

    with _c_output_hidden():   # qpOASES prints its copyright notice whenever it is set up
        try:
            return ca.nlpsol("design_sqp", "sqpmethod", str(path), OPTIONS)
        except RuntimeError:   # a library that does not load: IPOPT
            return None


def _library(pb):
    """The compiled library of the SQP's functions, or None: looked up in the disk cache, else
    compiled now or in the background as model/compiled.py decides for every NLP (None for this
    run when in the background, or with no compiler, or with the cache turned off)."""
    key = compiled.nlpsol_key(pb._nlp_function.serialize(), "sqpmethod")   # the key compiled.solver stores under
    if key is None:
        return None
    found = compiled.lookup(key)
    if found is None:
        with _c_output_hidden():
            compiled.solver("design_sqp", "sqpmethod", pb._nlp_function, OPTIONS)   # compiles it (or starts to)
        found = compiled.lookup(key)
    return found


@contextlib.contextmanager
def _c_output_hidden():
    """File descriptor 1 (the C library's stdout) sent to the null device while this runs, the
    C library's buffer flushed before it is restored, and Python's sys.stdout (where CasADi
    writes its own messages, such as a solver's header) to nowhere."""
    with contextlib.redirect_stdout(io.StringIO()):   # CasADi's own messages go through sys.stdout
        try:
            import ctypes

            libc = ctypes.CDLL(None)
            saved, null = os.dup(1), os.open(os.devnull, os.O_WRONLY)
        except (OSError, AttributeError, ValueError):   # no file descriptors to redirect (an embedded stdout)
            yield
            return
        try:
            libc.fflush(None)
            os.dup2(null, 1)
            yield
        finally:
            libc.fflush(None)
            os.dup2(saved, 1)
            os.close(saved)
            os.close(null)


def accepted(pb, res, stats, w0, p, bounds) -> bool:
    """Whether an SQP solve may stand: success, finite, within the variable and row bounds to
    the NLP's tolerance, and not worse than the start ``w0`` when the start is feasible."""
    if not stats.get("success"):
        return False
    tol = 10 * pb.settings.tol
    w, g, f = np.asarray(res["x"]).ravel(), np.asarray(res["g"]).ravel(), float(res["f"])
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(g)) and np.isfinite(f)):
        return False
    if violation(w, g, bounds) > tol:
        return False
    f0, g0 = pb._nlp_function(w0, p)
    g0 = np.asarray(g0).ravel()
    f0 = float(f0)
    if np.all(np.isfinite(g0)) and np.isfinite(f0) and violation(np.asarray(w0, float), g0, bounds) <= tol:
        return f <= f0 + 1e-9 * max(abs(f0), 1.0)
    return True


def violation(w, g, bounds) -> float:
    """The largest violation of the variable bounds and the row bounds (scaled units)."""
    with np.errstate(invalid="ignore"):
        vx = np.maximum(bounds["lbx"] - w, w - bounds["ubx"])
        vg = np.maximum(bounds["lbg"] - g, g - bounds["ubg"])
    return float(max(np.max(vx, initial=0.0), np.max(vg, initial=0.0), 0.0))
