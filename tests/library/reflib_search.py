"""A global minimax search for the library scenes' references: a dense grid over the design
box, every constraint checked on the stroke samples, then polished local solves (scipy SLSQP on
the numpy model, the peak as an epigraph whose points are exchanged until the peak of the
continuous stroke equals the epigraph), with every extreme refined between samples.

Nothing here knows a machine: a reference module describes its machine as a
:class:`MinimaxProblem` (design names, box, stroke, a vectorised ``rows(X, s)`` that returns the
drive load and the constraints' per-sample quantities for many designs at once).  Nothing of
optdesign is used.
"""
from __future__ import annotations

import itertools
import math
import tomllib
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

GOLDEN = (math.sqrt(5) - 1) / 2


# --- reading a scene's numbers (tomllib only) -------------------------------------------------
def number(value, known=None):
    """A plain scene number: a float, a design table's start, '<number> deg', or a known name."""
    if isinstance(value, dict):
        value = value["value"]
    if isinstance(value, str):
        text = value.strip()
        if known and text in known:
            return float(known[text])
        m = re.fullmatch(r"([-+0-9.eE]+)\s*deg", text)
        if m:
            return math.radians(float(m.group(1)))
        m = re.fullmatch(r"([-+]?)(?:([0-9.eE]+)\s*\*\s*)?pi", text)  # 'pi', '-pi', '2*pi'
        if m:
            return (-1 if m.group(1) == "-" else 1) * float(m.group(2) or 1) * math.pi
        return float(text)
    return float(value)


def read_scene(path):
    """The scene as tomllib reads it, with its plain parameters as numbers (derived ones, given
    as expressions, are left out: each reference computes them from the geometry), its design
    box, the sweep's range and samples, the drive's motion and the constraints' bounds."""
    data = tomllib.loads(Path(path).read_text())
    params, box = {}, {}
    for name, v in data["parameters"].items():
        if isinstance(v, dict):
            params[name] = float(v["value"])
            box[name] = (number(v["min"]), number(v["max"]))
            continue
        try:
            params[name] = number(v, params)
        except ValueError:
            continue  # a derived value (an expression): the reference derives it itself
    sweep = data["sweep"]
    drive = data["drive"]
    bounds = {}
    for c in data.get("constraints", []):
        lo = number(c["min"], params) if "min" in c else -math.inf
        hi = number(c["max"], params) if "max" in c else math.inf
        bounds[c["name"]] = (lo, hi)
    return {
        "params": params, "box": box, "sweep": (number(sweep["from"], params), number(sweep["to"], params)),
        "samples": int(sweep["samples"]), "speed": number(drive["speed"], params),
        "acceleration": number(drive["acceleration"], params),
        "efficiency": number(drive["efficiency"], params) if "efficiency" in drive else None,
        "gravity": number(data["gravity"]["g"]) if "gravity" in data else None,
        "bounds": bounds, "objective": data.get("objective", {}).get("minimise"), "raw": data,
    }


# --- the problem ----------------------------------------------------------------------------
@dataclass
class MinimaxProblem:
    """Minimise the peak |drive| over the stroke subject to per-sample and per-stroke constraints.

    ``rows(X, s)``: X maps each design name to an array of shape (n, 1) (n designs), s is an
    array of shape (m,); returns a dict row name -> array (n, m) holding ``"drive"`` and every
    row a constraint needs; a design that does not assemble at a sample gives NaN there.
    ``per_sample``: row name -> (lo, hi), held at every point of the stroke.
    ``per_stroke``: name -> (function of the extremes dict {(row, "max"|"min"): (n,) array},
    lo, hi, the (row, sense) pairs it reads).
    ``scales``: constraint name (or row) -> a scale for violations (default max(1, |bound|))."""

    names: list
    lower: np.ndarray
    upper: np.ndarray
    sweep: tuple
    rows: callable
    per_sample: dict = field(default_factory=dict)
    per_stroke: dict = field(default_factory=dict)
    scales: dict = field(default_factory=dict)

    def design(self, x):
        """Design array(s) -> the dict of (n, 1) arrays that rows() takes."""
        x = np.atleast_2d(np.asarray(x, float))
        return {n: x[:, j:j + 1] for j, n in enumerate(self.names)}

    def scale(self, name, lo, hi):
        if name in self.scales:
            return self.scales[name]
        finite = [abs(b) for b in (lo, hi) if math.isfinite(b)]
        return max([1e-300] + finite)

    def needed(self):
        """(row, sense) pairs whose stroke extremes the constraints need."""
        out = set()
        for row in self.per_sample:
            out |= {(row, "max"), (row, "min")}
        for _, (_, _, _, pairs) in self.per_stroke.items():
            out |= set(pairs)
        return out


# --- extremes over the stroke -----------------------------------------------------------------
def golden_refine(problem, x, targets, iterations=48):
    """Refine extremes of one design: ``targets`` is a list of (row, sign, a, b) asking for the
    largest value of sign*row on [a, b]; golden-section searches run side by side (one rows()
    call per iteration for all of them).  Returns (values of sign*row, s) arrays."""
    if not targets:
        return np.zeros(0), np.zeros(0)
    X = problem.design(x)
    rows = [t[0] for t in targets]
    sign = np.array([t[1] for t in targets], float)
    a = np.array([t[2] for t in targets], float)
    b = np.array([t[3] for t in targets], float)

    def f(s):
        out = problem.rows(X, s)
        return sign * np.array([out[r][0, i] for i, r in enumerate(rows)])

    c = b - GOLDEN * (b - a)
    d = a + GOLDEN * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iterations):
        left = fc > fd  # the maximum lies in [a, d] (else in [c, b])
        a, b = np.where(left, a, c), np.where(left, d, b)
        c_next = np.where(left, b - GOLDEN * (b - a), d)
        d_next = np.where(left, c, a + GOLDEN * (b - a))
        fp = f(np.where(left, c_next, d_next))
        fc, fd = np.where(left, fp, fd), np.where(left, fc, fp)
        c, d = c_next, d_next
    s = np.where(fc > fd, c, d)
    return np.maximum(fc, fd), s


def stroke_extremes(problem, x, samples, pairs, local=None):
    """Extremes over the continuous stroke of one design: the rows on ``samples`` evenly spaced
    sweep values, each sampled extreme refined between its neighbours (golden section), the
    sample itself kept when it is better (an end of the stroke).  ``pairs``: (row, sense).
    ``local``: {row: fraction}: also every local maximum of |row| within that fraction of its
    peak (refined), for the epigraph's exchange.  Returns (extremes {(row, sense): value},
    where {(row, sense): s}, locals [(row, s)], sampled rows dict)."""
    s = np.linspace(*problem.sweep, samples)
    out = problem.rows(problem.design(x), s)
    targets, start_values = [], []
    for row, sense in pairs:
        v = out[row][0]
        if row == "drive" and sense == "abs":
            v = np.abs(v)
            sign = None
        else:
            sign = 1.0 if sense == "max" else -1.0
            v = sign * v
        i = int(np.nanargmax(v)) if np.any(np.isfinite(v)) else 0
        lo, hi = s[max(i - 1, 0)], s[min(i + 1, samples - 1)]
        if sign is None:
            sign = 1.0 if out[row][0][i] >= 0 else -1.0
        targets.append((row, sign, lo, hi, (row, sense), s[i], v[i]))
    extra = []
    for row, fraction in (local or {}).items():
        v = np.abs(out[row][0])
        peak = np.nanmax(v)
        idx = [i for i in range(samples)
               if v[i] >= (1 - fraction) * peak and (i == 0 or v[i] >= v[i - 1]) and (i == samples - 1 or v[i] >= v[i + 1])]
        for i in idx:
            sign = 1.0 if out[row][0][i] >= 0 else -1.0
            extra.append((row, sign, s[max(i - 1, 0)], s[min(i + 1, samples - 1)]))
    values, where = golden_refine(problem, x, [t[:4] for t in targets] + extra)
    extremes, at = {}, {}
    for j, t in enumerate(targets):
        key, s_i, v_i = t[4], t[5], t[6]
        val, s_star = (values[j], where[j]) if values[j] > v_i else (v_i, s_i)
        if key[1] == "abs":
            extremes[key] = abs(val)
        else:
            extremes[key] = val if key[1] == "max" else -val
        at[key] = s_star
    locals_ = [(extra[j][0], where[len(targets) + j]) for j in range(len(extra))]
    return extremes, at, locals_, out


def evaluate(problem, x, samples):
    """Peak |drive| over the continuous stroke of one design and its worst scaled constraint
    violation (<= 0: feasible), every extreme refined; NaN where the design does not assemble."""
    pairs = [("drive", "abs")] + sorted(problem.needed())
    ext, at, _, out = stroke_extremes(problem, x, samples, pairs)
    if any(not np.all(np.isfinite(v)) for v in out.values()):
        return math.nan, math.inf, ext, at
    return ext[("drive", "abs")], violation(problem, ext), ext, at


def violation(problem, ext):
    worst = -math.inf
    for row, (lo, hi) in problem.per_sample.items():
        sc = problem.scale(row, lo, hi)
        worst = max(worst, (lo - ext[(row, "min")]) / sc, (ext[(row, "max")] - hi) / sc)
    for name, (func, lo, hi, _) in problem.per_stroke.items():
        v = float(func({k: np.array([val]) for k, val in ext.items()})[0])
        sc = problem.scale(name, lo, hi)
        worst = max(worst, (lo - v) / sc, (v - hi) / sc)
    return worst


# --- the grid -----------------------------------------------------------------------------------
def grid_search(problem, per_dim, samples, chunk=4000):
    """Every design of a per_dim^n grid over the box (ends included), on ``samples`` stroke
    samples: sampled peak and feasibility (every constraint at every sample, stroke aggregates
    from the sampled extremes).  Returns (designs (N, n), peaks (N,) with inf where infeasible
    or not assembling)."""
    axes = [np.linspace(lo, hi, per_dim) for lo, hi in zip(problem.lower, problem.upper)]
    designs = np.array(list(itertools.product(*axes)))
    s = np.linspace(*problem.sweep, samples)
    peaks = np.full(len(designs), np.inf)
    for start in range(0, len(designs), chunk):
        xs = designs[start:start + chunk]
        with np.errstate(all="ignore"):
            out = problem.rows(problem.design(xs), s)
            ok = np.all(np.isfinite(out["drive"]), axis=1)
            for row in out:
                ok &= np.all(np.isfinite(out[row]), axis=1)
            for row, (lo, hi) in problem.per_sample.items():
                ok &= np.all((out[row] >= lo) & (out[row] <= hi), axis=1)
            ext = {}
            for row in out:
                ext[(row, "max")] = np.max(out[row], axis=1)
                ext[(row, "min")] = np.min(out[row], axis=1)
            for name, (func, lo, hi, _) in problem.per_stroke.items():
                v = func(ext)
                ok &= (v >= lo) & (v <= hi)
            peak = np.max(np.abs(out["drive"]), axis=1)
        peaks[start:start + chunk] = np.where(ok, peak, np.inf)
    return designs, peaks


def grid_local_minima(designs, peaks, per_dim, count):
    """Up to ``count`` feasible grid points that are no worse than their feasible neighbours
    (one per basin of the grid), best first."""
    n = designs.shape[1]
    cube = peaks.reshape((per_dim,) * n)
    picks = []
    for flat in np.argsort(peaks):
        if not np.isfinite(peaks[flat]):
            break
        idx = np.unravel_index(flat, cube.shape)
        best = True
        for delta in itertools.product((-1, 0, 1), repeat=n):
            nb = tuple(i + d for i, d in zip(idx, delta))
            if all(0 <= i < per_dim for i in nb) and cube[nb] < cube[idx]:
                best = False
                break
        if best:
            picks.append(flat)
        if len(picks) >= count:
            break
    return designs[picks]


# --- the polish ------------------------------------------------------------------------------------
def polish(problem, x0, check_samples, base=61, rounds=10, tol=1e-11):
    """A local minimax solve from x0: SLSQP on the epigraph t >= |drive(s_j)|/f_ref over a point
    set S (``base`` evenly spaced sweep values plus the refined extremes found so far), every
    per-sample constraint at S and every stroke aggregate from S's extremes; after each solve the
    continuous extremes at the solution (``check_samples`` samples, refined) join S, until the
    continuous peak agrees with the epigraph to ``tol`` and no constraint is violated beyond
    1e-10 (scaled).  Returns (x, peak, violation)."""
    lo, hi = problem.lower, problem.upper
    span = hi - lo
    S = np.linspace(*problem.sweep, base)
    x = np.clip(np.asarray(x0, float), lo, hi)
    peak0, _, _, _ = evaluate(problem, x, check_samples)
    f_ref = peak0 if math.isfinite(peak0) and peak0 > 0 else 1.0
    pairs = sorted(problem.needed())

    def constraint_rows(W):
        """Constraint values (>= 0 feasible) for designs W = [z..., t] (rows of a 2-D array)."""
        W = np.atleast_2d(W)
        X = problem.design(lo + span * W[:, :-1])
        t = W[:, -1:]
        with np.errstate(all="ignore"):
            out = problem.rows(X, S)
        u = out["drive"] / f_ref
        parts = [t - u, t + u]
        for row, (a, b) in problem.per_sample.items():
            sc = problem.scale(row, a, b)
            if math.isfinite(a):
                parts.append((out[row] - a) / sc)
            if math.isfinite(b):
                parts.append((b - out[row]) / sc)
        ext = {}
        for row, sense in pairs:
            ext[(row, sense)] = (np.max if sense == "max" else np.min)(out[row], axis=1)
        for name, (func, a, b, _) in problem.per_stroke.items():
            v = func(ext)[:, None]
            sc = problem.scale(name, a, b)
            if math.isfinite(a):
                parts.append((v - a) / sc)
            if math.isfinite(b):
                parts.append((b - v) / sc)
        g = np.hstack(parts)
        return np.where(np.isfinite(g), g, -1e3)

    def jac(w, h=1e-7):
        n = len(w)
        W = np.repeat(w[None, :], 2 * n, axis=0)
        for j in range(n):
            W[2 * j, j] += h
            W[2 * j + 1, j] -= h
        g = constraint_rows(W)
        return ((g[0::2] - g[1::2]) / (2 * h)).T

    peak, viol = peak0, math.inf
    for _ in range(rounds):
        z = (x - lo) / span
        g0 = constraint_rows(np.r_[z, 0.0])[0]
        t0 = float(np.max(np.abs(problem.rows(problem.design(x), S)["drive"][0]))) / f_ref
        w0 = np.r_[z, t0 * 1.0001]
        res = minimize(lambda w: w[-1], w0, jac=lambda w: np.r_[np.zeros(len(w) - 1), 1.0], method="SLSQP",
                       bounds=[(0, 1)] * len(z) + [(None, None)],
                       constraints=[{"type": "ineq", "fun": lambda w: constraint_rows(w)[0], "jac": jac}],
                       options={"ftol": 1e-15, "maxiter": 300})
        x = lo + span * np.clip(res.x[:-1], 0, 1)
        t = res.x[-1]
        peak, viol, ext, at = evaluate(problem, x, check_samples)
        if not math.isfinite(peak):
            return x, peak, viol
        _, _, locals_, _ = stroke_extremes(problem, x, check_samples, [], local={"drive": 0.05})
        new = [s for _, s in locals_] + [at[k] for k in at]
        S = np.unique(np.r_[S, new])
        if peak <= t * f_ref * (1 + tol) and viol <= 1e-10:
            break
    return x, peak, viol


def global_minimax(problem, per_dim, grid_samples, check_samples, polish_starts, extra_starts=()):
    """The grid, then a polish from each of the best ``polish_starts`` grid local minima (and
    ``extra_starts``); the best polished design that is feasible on the continuous stroke.
    Returns a dict: design, peak, violation, grid_best (value, design), polished (list)."""
    designs, peaks = grid_search(problem, per_dim, grid_samples)
    starts = list(grid_local_minima(designs, peaks, per_dim, polish_starts)) + [np.asarray(x, float) for x in extra_starts]
    polished = []
    for x0 in starts:
        x, peak, viol = polish(problem, x0, check_samples)
        polished.append((peak, viol, x))
    feasible = [p for p in polished if math.isfinite(p[0]) and p[1] <= 1e-9]
    best = min(feasible, key=lambda p: p[0]) if feasible else (math.nan, math.inf, None)
    i = int(np.argmin(peaks))
    return {"design": None if best[2] is None else dict(zip(problem.names, map(float, best[2]))),
            "peak": best[0], "violation": best[1],
            "grid_best": (float(peaks[i]), dict(zip(problem.names, map(float, designs[i])))),
            "grid_feasible": int(np.sum(np.isfinite(peaks))), "grid_total": len(peaks),
            "polished": polished}
