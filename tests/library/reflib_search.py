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
def humps(v, s, fraction):
    """Brackets of the local maxima of the sampled v (on sweep values s) that lie within
    ``fraction`` of v's range below its maximum: each bracket runs from the local minimum on
    its left to the one on its right, so that v has one maximum in it.  [(a, b, s_max)]."""
    m = len(v)
    vmax, vmin = np.nanmax(v), np.nanmin(v)
    threshold = vmax - fraction * (vmax - vmin)
    out, seen = [], set()
    for i in range(m):
        if v[i] < threshold or (i > 0 and v[i - 1] > v[i]) or (i < m - 1 and v[i + 1] > v[i]):
            continue
        left, right = i, i
        while left > 0 and v[left - 1] <= v[left]:
            left -= 1
        while right < m - 1 and v[right + 1] <= v[right]:
            right += 1
        if (left, right) not in seen:
            seen.add((left, right))
            out.append((s[left], s[right], s[i]))
    return out


def refine_many(problem, X, targets, iterations=7, h=1e-5):
    """Maxima of sign*row on [a, b] for every target (row, sign, a, b, s0) and every design of
    X (name -> (N, 1)), side by side: Newton's method on d(sign*row)/ds = 0 from s0, the
    derivatives by central differences of step h (one rows() call per iteration evaluates all
    targets at s - h, s, s + h), each step kept inside [a, b] (a maximum at a bracket's end
    stays there); where the curvature is not negative the step goes a quarter bracket uphill.
    Returns values (N, B): sign*row at the maxima."""
    rows_ = [t[0] for t in targets]
    B = len(targets)
    sign = np.array([t[1] for t in targets], float)[None, :]
    a = np.array([t[2] for t in targets], float)[None, :]
    b = np.array([t[3] for t in targets], float)[None, :]
    N = next(iter(X.values())).shape[0]
    s = np.repeat(np.array([t[4] for t in targets], float)[None, :], N, axis=0)

    for it in range(iterations + 1):
        probe = np.concatenate([np.clip(s - h, a, b), s, np.clip(s + h, a, b)], axis=1)
        out = problem.rows(X, probe)
        vals = np.stack([out[r][:, [j, B + j, 2 * B + j]] for j, r in enumerate(rows_)], axis=1) * sign[:, :, None]
        fm, f0, fp = vals[..., 0], vals[..., 1], vals[..., 2]
        if it == iterations:
            return f0
        d1 = (fp - fm) / (2 * h)
        d2 = (fp - 2 * f0 + fm) / h**2
        newton = np.where(d2 < 0, -d1 / np.where(d2 < 0, d2, -1.0), np.sign(d1) * (b - a) / 4)
        s = np.clip(s + newton, a, b)
    return f0


def polish(problem, x0, check_samples, base=61, rounds=40, tol=1e-11, radius=0.1):
    """A local minimax solve from x0 by local reduction: SLSQP on the epigraph t >= |drive|/f_ref
    where each hump of |drive| (a local maximum within 30 % of the peak, bracketed between its
    neighbouring local minima on ``check_samples`` samples at the round's start design) enters
    as its maximum over the bracket, found by golden section for every design SLSQP tries (so
    the constraint follows the moving maximum smoothly); the same for each per-sample
    constraint's extremes near its bound and for the extremes that the stroke aggregates read;
    ``base`` evenly spaced sweep values (ends included) hold every row in between.  After each
    solve the humps are found again at the solution, until the continuous peak agrees with the
    epigraph to ``tol``, no constraint is violated beyond 1e-10 (scaled) and the solve ended
    inside its trust region: each solve stays within ``radius`` (of the box's width) of where it
    starts, so that a linearisation far from it cannot throw it into designs that do not
    assemble.  Returns (x, peak, violation)."""
    lo, hi = problem.lower, problem.upper
    span = hi - lo
    S = np.linspace(*problem.sweep, base)
    s_check = np.linspace(*problem.sweep, check_samples)
    x = np.clip(np.asarray(x0, float), lo, hi)
    peak0, _, _, _ = evaluate(problem, x, check_samples)
    if not math.isfinite(peak0):
        return x, peak0, math.inf
    f_ref = peak0
    pairs = sorted(problem.needed())
    peak, viol = peak0, math.inf
    for _ in range(rounds):
        with np.errstate(all="ignore"):
            dense = problem.rows(problem.design(x), s_check)
        targets, roles = [], []
        u = dense["drive"][0]
        for a, b, s_max in humps(np.abs(u), s_check, 0.3):
            targets.append(("drive", 1.0 if u[np.searchsorted(s_check, s_max)] >= 0 else -1.0, a, b, s_max))
            roles.append(("peak",))
        for row, (a_lo, b_hi) in problem.per_sample.items():
            for sign, bound in ((1.0, b_hi), (-1.0, a_lo)):
                if math.isfinite(bound):
                    for a, b, s_max in humps(sign * dense[row][0], s_check, 0.2):
                        targets.append((row, sign, a, b, s_max))
                        roles.append(("bound", row, sign, bound))
        for row, sense in pairs:
            sign = 1.0 if sense == "max" else -1.0
            for a, b, s_max in humps(sign * dense[row][0], s_check, 0.2):
                targets.append((row, sign, a, b, s_max))
                roles.append(("aggregate", row, sense))

        def constraint_rows(W, targets=targets, roles=roles):
            W = np.atleast_2d(W)
            X = problem.design(lo + span * W[:, :-1])
            t = W[:, -1:]
            with np.errstate(all="ignore"):
                out = problem.rows(X, S)
                refined = refine_many(problem, X, targets)
            parts = [t - out["drive"] / f_ref, t + out["drive"] / f_ref]
            for row, (a, b) in problem.per_sample.items():
                sc = problem.scale(row, a, b)
                if math.isfinite(a):
                    parts.append((out[row] - a) / sc)
                if math.isfinite(b):
                    parts.append((b - out[row]) / sc)
            ext = {(row, sense): (np.max if sense == "max" else np.min)(out[row], axis=1) for row, sense in pairs}
            for j, role in enumerate(roles):
                v = refined[:, j]
                if role[0] == "peak":
                    parts.append(t - v[:, None] / f_ref)
                elif role[0] == "bound":
                    _, row, sign, bound = role
                    sc = problem.scale(row, *problem.per_sample[row])
                    parts.append(((bound - v) if sign > 0 else (-v - bound))[:, None] / sc)
                else:
                    _, row, sense = role
                    ext[(row, sense)] = np.maximum(ext[(row, sense)], v) if sense == "max" else np.minimum(ext[(row, sense)], -v)
            for name, (func, a, b, _) in problem.per_stroke.items():
                v = func(ext)[:, None]
                sc = problem.scale(name, a, b)
                if math.isfinite(a):
                    parts.append((v - a) / sc)
                if math.isfinite(b):
                    parts.append((b - v) / sc)
            g = np.hstack(parts)
            return np.where(np.isfinite(g), g, -1e3)

        def jac(w, h=1e-7, constraint_rows=constraint_rows):
            n = len(w)
            W = np.repeat(w[None, :], 2 * n, axis=0)
            for j in range(n):
                W[2 * j, j] += h
                W[2 * j + 1, j] -= h
            g = constraint_rows(W)
            return ((g[0::2] - g[1::2]) / (2 * h)).T

        z = (x - lo) / span
        w0 = np.r_[z, peak / f_ref * (1 + 1e-6) if math.isfinite(peak) else 1.0]
        box = [(max(0.0, zj - radius), min(1.0, zj + radius)) for zj in z]
        res = minimize(lambda w: w[-1], w0, jac=lambda w: np.r_[np.zeros(len(w) - 1), 1.0], method="SLSQP",
                       bounds=box + [(None, None)],
                       constraints=[{"type": "ineq", "fun": lambda w: constraint_rows(w)[0], "jac": jac}],
                       options={"ftol": 1e-13, "maxiter": 200})
        z_new = np.clip(res.x[:-1], [b[0] for b in box], [b[1] for b in box])
        inside = all((abs(zn - b[0]) > 1e-7 or b[0] == 0.0) and (abs(zn - b[1]) > 1e-7 or b[1] == 1.0)
                     for zn, b in zip(z_new, box))
        x_new = np.clip(lo + span * z_new, lo, hi)  # lo + span*1 may round past hi
        peak_new, viol_new, _, _ = evaluate(problem, x_new, check_samples)
        if not math.isfinite(peak_new):
            return x, peak, viol  # keep the last design that assembled
        moved = np.max(np.abs(z_new - z))
        x, peak, viol = x_new, peak_new, viol_new
        radius = radius if inside else min(2 * radius, 1.0)  # it assembled: allow longer steps
        if inside and (res.success or moved < 1e-6) and peak <= res.x[-1] * f_ref * (1 + tol) and viol <= 1e-10:
            break
    return x, peak, viol


def global_minimax(problem, per_dim, grid_samples, check_samples, polish_starts, extra_starts=(), final_samples=None,
                   refine_best=10):
    """The grid; the ``refine_best`` best grid points judged again on ``check_samples`` samples
    with every extreme refined (the best of them that is feasible on the continuous stroke is
    ``grid_best``); then a polish from each of the best ``polish_starts`` grid local minima (and
    ``extra_starts``), each polished design judged again on ``final_samples`` stroke samples
    (every extreme refined); the best one that is feasible on the continuous stroke, which must
    be no worse than ``grid_best``.  Returns a dict: design, peak, violation, grid_best (value,
    design), grid_feasible, grid_total, polished (list of (peak, violation, x))."""
    designs, peaks = grid_search(problem, per_dim, grid_samples)
    grid_best = (math.inf, None)
    for i in np.argsort(peaks)[:refine_best]:
        if not np.isfinite(peaks[i]):
            break
        peak, viol, _, _ = evaluate(problem, designs[i], check_samples)
        if viol <= 1e-9 and peak < grid_best[0]:
            grid_best = (float(peak), dict(zip(problem.names, map(float, designs[i]))))
    starts = list(grid_local_minima(designs, peaks, per_dim, polish_starts)) + [np.asarray(x, float) for x in extra_starts]
    polished = []
    for x0 in starts:
        x, peak, viol = polish(problem, x0, check_samples)
        if final_samples and final_samples != check_samples and math.isfinite(peak):
            peak, viol, _, _ = evaluate(problem, x, final_samples)
        polished.append((peak, viol, x))
    feasible = [p for p in polished if math.isfinite(p[0]) and p[1] <= 1e-9]
    best = min(feasible, key=lambda p: p[0]) if feasible else (math.nan, math.inf, None)
    return {"design": None if best[2] is None else dict(zip(problem.names, map(float, best[2]))),
            "peak": best[0], "violation": best[1], "grid_best": grid_best,
            "grid_feasible": int(np.sum(np.isfinite(peaks))), "grid_total": len(peaks),
            "polished": polished}
