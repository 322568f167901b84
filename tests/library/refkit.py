"""Shared numpy machinery of the library references (tests/library/ref_*.py).

Nothing here uses optdesign.  A reference module writes its machine by hand (points, their
first and second derivatives along the sweep, the drive coordinate and the constraint rows) as
a :class:`Machine`; this module reads the scene's numbers with tomllib (:class:`SceneData`),
turns the machine into the drive load by Lagrange's equation for one coordinate
(:func:`drive_load`), and finds the global optimum of the design problem:

* a dense grid over the whole design box, every design evaluated on the stroke samples in one
  vectorised numpy call, each sampled extreme (of |drive|, of every per-sample constraint row,
  of the drive length for the length ratio, of k = dq/ds for the dead-centre guard) refined by
  a golden-section search between the neighbouring samples (vectorised over the designs);
* from the best feasible grid points (distinct local minima of the grid first), polished local
  solves: scipy SLSQP on the minimax as an epigraph (minimise t, -t <= F(s_j) <= t) over a base
  grid of stroke samples plus the refined local extremes of the previous iterate (an exchange
  method, repeated until the epigraph's t is the continuous peak), every constraint as an SLSQP
  constraint, the Jacobians exact by complex step in the design variables (every formula of the
  machines is analytic);
* each polished design checked again on ``DENSE`` (full level) stroke samples with every
  extreme refined by a bounded scalar search; the least feasible peak is the global optimum.

The drive load (the scene format's definition, docs/scenes.md and README "The physics"): with
the sweep s, every body's centre of mass r(s) and angle phi(s), the drive coordinate q(s) and
k = dq/ds,

    M_s = sum m |r'|^2 + I phi'^2,     Q_s = dV/ds - sum F . r_F' - sum T phi',
    M_q = M_s / k^2,    dM_q/dq = (M_s' / k^2 - 2 M_s k' / k^3) / k,
    u = Q_s / k + M_q a + 1/2 dM_q/dq v^2,      drive = c u,

with c = 1/eta while the drive delivers power (u v >= 0) and eta otherwise; v and a are the
drive's speed and acceleration (for a rotary drive q is the crank angle and the same formulas
give the torque).  ' is d/ds, written by hand in each machine.
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import minimize, minimize_scalar

ROOT = Path(__file__).resolve().parents[2]
DENSE = 20001
H_CS = 1e-30  # complex step in the design variables
GOLDEN = (math.sqrt(5) - 1) / 2
_NUMBER_DEG = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*deg\s*$")


# --- the scene's numbers ----------------------------------------------------------------------
def number(value, known=None):
    """A scene number: a float, 'N deg', or the name of a parameter defined above (or minus it)."""
    if isinstance(value, bool):
        raise ValueError(value)
    if isinstance(value, (int, float)):
        return float(value)
    text = str(value).strip()
    m = _NUMBER_DEG.match(text)
    if m:
        return math.radians(float(m.group(1)))
    if known is not None and text in known:
        return known[text]
    if known is not None and text.startswith("-") and text[1:].strip() in known:
        return -known[text[1:].strip()]
    return float(text)


class SceneData:
    """The numbers of a scene file, read with tomllib: parameters (plain numbers, 'N deg' or a
    parameter's name), design variables {name: (min, max)} in file order with their starts, the
    sweep's range and sample count, gravity, the drive's speed, acceleration and efficiency, and
    every constraint's bounds by name."""

    def __init__(self, path):
        self.path = Path(path)
        data = tomllib.loads(self.path.read_text())
        self.data = data
        p, self.design = {}, {}
        for name, v in data["parameters"].items():
            if isinstance(v, dict):
                p[name] = number(v["value"])
                self.design[name] = (number(v["min"]), number(v["max"]))
            else:
                p[name] = number(v, p)
        self.params = p
        sw = data["sweep"]
        self.sweep = (number(sw["from"], p), number(sw["to"], p))
        self.samples = int(sw["samples"])
        self.g = number(data["gravity"]["g"], p) if "gravity" in data else 0.0
        d = data["drive"]
        self.drive_kind = d["type"]
        self.v = number(d["speed"], p)
        self.a = number(d["acceleration"], p)
        self.eta = number(d.get("efficiency", 1.0), p)
        self.constraints = {}
        for c in data.get("constraints", []):
            lo = number(c["min"], p) if "min" in c else -math.inf
            hi = number(c["max"], p) if "max" in c else math.inf
            self.constraints[c["name"]] = (lo, hi, c["expr"])
        self.objective = data["objective"]["minimise"]

    @property
    def names(self):
        return list(self.design)

    def start(self):
        return {n: self.params[n] for n in self.design}


# --- a machine and its drive load ------------------------------------------------------------
@dataclass
class State:
    """One evaluation of a machine at designs x (arrays broadcast against the sweep s).

    bodies: (m, I, r, r1, r2, w1, w2): mass, inertia about the centre of mass, the centre of
        mass r (2, ...) and its first and second derivatives along s, the angle's derivatives;
    forces: (F, rF1): an applied force (2, ...) and the derivative of its point along s;
    q, q1, q2: the drive coordinate and its derivatives along s;
    rows: per-sample quantities by name (the constraint rows, the drive length)."""

    bodies: list
    q: object
    q1: object
    q2: object
    rows: dict
    forces: list = field(default_factory=list)


def drive_load(scene: SceneData, st: State):
    """The drive force (or torque) by Lagrange's equation for the one coordinate q, with the
    scene's efficiency rule (see the module docstring).  Complex-safe in the design variables."""
    Ms = Ms1 = Qs = 0.0
    for m, inertia, r, r1, r2, w1, w2 in st.bodies:
        Ms = Ms + m * (r1[0] ** 2 + r1[1] ** 2) + inertia * w1 ** 2
        Ms1 = Ms1 + 2 * m * (r1[0] * r2[0] + r1[1] * r2[1]) + 2 * inertia * w1 * w2
        Qs = Qs + m * scene.g * r1[1]
    for F, rF1 in st.forces:
        Qs = Qs - (F[0] * rF1[0] + F[1] * rF1[1])
    k, k1 = st.q1, st.q2
    Mq = Ms / k ** 2
    dMq = (Ms1 / k ** 2 - 2 * Ms * k1 / k ** 3) / k
    u = Qs / k + Mq * scene.a + 0.5 * dMq * scene.v ** 2
    if scene.eta == 1.0:
        return u
    c = np.where(np.real(u) * scene.v >= 0, 1 / scene.eta, scene.eta)
    return c * u


# --- kinematic helpers (by hand) -------------------------------------------------------------
def perp(v):
    """v turned by +90 deg."""
    return _stack(-v[1], v[0])


def _stack(a, b):
    a, b = np.broadcast_arrays(a, b)
    return np.stack([a, b])


def unit(angle):
    return _stack(np.cos(angle), np.sin(angle))


def length(d, d1, d2):
    """|d| and its first and second derivatives along s, from d, d' and d''."""
    L = np.sqrt(d[0] ** 2 + d[1] ** 2)
    L1 = (d[0] * d1[0] + d[1] * d1[1]) / L
    L2 = (d1[0] ** 2 + d1[1] ** 2 + d[0] * d2[0] + d[1] * d2[1] - L1 ** 2) / L
    return L, L1, L2


def angle_between(u, v):
    """The angle between vectors u and v, 0 .. pi (arccos of the normalised dot: complex-safe)."""
    return np.arccos((u[0] * v[0] + u[1] * v[1]) / np.sqrt((u[0] ** 2 + u[1] ** 2) * (v[0] ** 2 + v[1] ** 2)))


def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


# --- the design problem ----------------------------------------------------------------------
class Problem:
    """A machine's design problem: minimise the peak |drive| over the stroke subject to the
    scene's constraints, the design box and the drive's dead-centre guard.

    ``machine.state(x, s)`` -> :class:`State`; ``machine.per_sample`` lists the scene's
    per-sample constraints as (name, row); ``machine.ratios`` the stroke constraints
    max(row)/min(row) as (name, row).  The dead-centre guard is the one the scene format implies
    (a drive that stops inside the stroke is an error): k keeps the sign it has at the start
    design, sigma k / k_ref >= 1e-3, with k_ref the median |k| over the scene's samples at the
    start design (the margin only keeps designs off a dead centre; no optimum lies near one)."""

    DEAD_MARGIN = 1e-3

    def __init__(self, machine, scene: SceneData):
        self.m, self.scene = machine, scene
        self.names = scene.names
        self.lo = np.array([scene.design[n][0] for n in self.names])
        self.hi = np.array([scene.design[n][1] for n in self.names])
        self.s0, self.s1 = scene.sweep
        self.per_sample = [(name, row) + scene.constraints[name][:2] for name, row in machine.per_sample]
        self.ratios = [(name, row) + scene.constraints[name][:2] for name, row in machine.ratios]
        assert {c[0] for c in self.per_sample + self.ratios} == set(scene.constraints), \
            "every constraint of the scene must be modelled"
        start = np.array([scene.params[n] for n in self.names])
        k = np.real(self.evaluate(start[None, :], np.linspace(self.s0, self.s1, scene.samples)[None, :])["k"])[0]
        self.k_sign = 1.0 if np.median(k) >= 0 else -1.0
        self.k_ref = float(np.median(np.abs(k)))
        # scales (at the start design): of the drive, of each constraint row
        vals = self.evaluate(start[None, :], np.linspace(self.s0, self.s1, 201)[None, :])
        self.f_scale = float(np.max(np.abs(np.real(vals["drive"]))))
        self.row_scale = {}
        for name, row, lo, hi in self.per_sample + self.ratios:
            finite = [abs(b) for b in (lo, hi) if math.isfinite(b)]
            self.row_scale[row] = max(finite + [float(np.max(np.abs(np.real(vals[row]))))] + [1e-12])

    # evaluation -------------------------------------------------------------------------------
    def design(self, X):
        """Design dict of arrays (n, 1) from rows of X (n, nvar)."""
        X = np.asarray(X)
        return {n: X[:, i:i + 1] for i, n in enumerate(self.names)}

    def evaluate(self, X, s):
        """rows by name at designs X (n, nvar) and sweep values s (broadcast to (n, m)):
        'drive', 'k', and the machine's rows."""
        st = self.m.state(self.design(X), s)
        out = dict(st.rows)
        out["drive"] = drive_load(self.scene, st)
        out["k"] = st.q1
        out["q"] = st.q
        return out

    def senses(self):
        """(row, sense) pairs whose extremes matter: +1 largest, -1 smallest, 0 largest |.|."""
        pairs = [("drive", 0), ("k", -1 if self.k_sign > 0 else +1)]
        for _, row, lo, hi in self.per_sample:
            if math.isfinite(lo):
                pairs.append((row, -1))
            if math.isfinite(hi):
                pairs.append((row, +1))
        for _, row, lo, hi in self.ratios:
            pairs += [(row, +1), (row, -1)]
        return list(dict.fromkeys(pairs))

    @staticmethod
    def _signed(v, sense):
        v = np.real(v)
        return np.abs(v) if sense == 0 else sense * v

    def extremes(self, X, m=61, iters=45):
        """For designs X (n, nvar): {(row, sense): extreme value over the continuous stroke}
        (sense 0: the largest |value|), each from m samples refined by a vectorised
        golden-section search between the neighbours of the best sample."""
        n = len(X)
        s = np.linspace(self.s0, self.s1, m)
        with np.errstate(all="ignore"):
            vals = self.evaluate(X, s[None, :])
        pairs = self.senses()
        out = {}
        idx = {}
        for row, sense in pairs:
            v = self._signed(np.broadcast_to(vals[row], (n, m)), sense)
            v = np.where(np.isfinite(v), v, np.inf)
            i = np.argmax(v, axis=1)
            idx[(row, sense)] = i
            out[(row, sense)] = v[np.arange(n), i]
        h = s[1] - s[0]
        # golden section on [s_i - h, s_i + h] (clipped to the stroke), all pairs at once
        a = np.stack([np.maximum(s[idx[p]] - h, self.s0) for p in pairs], axis=1)
        b = np.stack([np.minimum(s[idx[p]] + h, self.s1) for p in pairs], axis=1)

        def f(t):
            with np.errstate(all="ignore"):
                vv = self.evaluate(X, t)
            cols = []
            for j, (row, sense) in enumerate(pairs):
                v = self._signed(np.broadcast_to(vv[row], t.shape)[:, j], sense)
                cols.append(np.where(np.isfinite(v), v, np.inf))
            return np.stack(cols, axis=1)

        c, d = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
        fc, fd = f(c), f(d)
        for _ in range(iters):
            left = fc > fd  # the maximum lies in [a, d]: drop (d, b]; else drop [a, c)
            a, b = np.where(left, a, c), np.where(left, d, b)
            probe = np.where(left, b - GOLDEN * (b - a), a + GOLDEN * (b - a))
            fp = f(probe)
            c, d, fc, fd = (np.where(left, probe, d), np.where(left, c, probe),
                            np.where(left, fp, fd), np.where(left, fc, fp))
        best = np.maximum(fc, fd)
        for j, p in enumerate(pairs):
            out[p] = np.maximum(out[p], best[:, j])
        return out

    def violation(self, ext):
        """Largest scaled violation of every constraint (and the dead-centre guard) from the
        extremes of :meth:`extremes` (<= 0: feasible)."""
        parts = []
        ksense = -1 if self.k_sign > 0 else +1
        kmin = -ext[("k", ksense)] if self.k_sign > 0 else ext[("k", ksense)]
        parts.append(self.DEAD_MARGIN - self.k_sign * kmin / self.k_ref)
        for _, row, lo, hi in self.per_sample:
            sc = self.row_scale[row]
            if math.isfinite(lo):
                parts.append((lo + ext[(row, -1)]) / sc)  # ext of sense -1 is -min
            if math.isfinite(hi):
                parts.append((ext[(row, +1)] - hi) / sc)
        for _, row, lo, hi in self.ratios:
            ratio = ext[(row, +1)] / (-ext[(row, -1)])
            if math.isfinite(hi):
                parts.append(ratio - hi)
            if math.isfinite(lo):
                parts.append(lo - ratio)
        return np.max(np.stack(parts), axis=0)

    # the grid -----------------------------------------------------------------------------------
    def grid(self, per_axis, m, chunk=1500):
        """Every design of a per_axis^nvar grid over the box: (X, peak, violation)."""
        axes = [np.linspace(l, h, per_axis) for l, h in zip(self.lo, self.hi)]
        X = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
        peak, viol = np.empty(len(X)), np.empty(len(X))
        for i in range(0, len(X), chunk):
            ext = self.extremes(X[i:i + chunk], m)
            peak[i:i + chunk] = ext[("drive", 0)]
            viol[i:i + chunk] = self.violation(ext)
        return X, peak, viol, per_axis

    def candidates(self, X, peak, viol, per_axis, count, tol=1e-9):
        """The best feasible grid points, distinct local minima of the grid first: a feasible
        point is a local minimum when no feasible grid neighbour (one step along each axis) is
        better."""
        n = len(self.names)
        shape = (per_axis,) * n
        F = np.where(viol <= tol, peak, np.inf).reshape(shape)
        local = np.isfinite(F)
        for axis in range(n):
            for shift in (-1, 1):
                nb = np.roll(F, shift, axis=axis)
                edge = [slice(None)] * n
                edge[axis] = 0 if shift == 1 else -1
                nb[tuple(edge)] = np.inf
                local &= F <= nb
        order = np.argsort(F.ravel())
        loc = [i for i in order if local.ravel()[i]]
        rest = [i for i in order if np.isfinite(F.ravel()[i]) and not local.ravel()[i]]
        picked = loc[:count] + rest[:max(0, count - len(loc[:count]))]
        return X[picked]

    # the polish ----------------------------------------------------------------------------------
    def _rows_and_jac(self, x, s):
        """rows at design x (nvar,) and points s (m,), with d rows / d x by complex step."""
        X = x[None, :]
        base = self.evaluate(X, s[None, :])
        jac = {}
        for i in range(len(x)):
            Xc = X.astype(complex)
            Xc[0, i] += 1j * H_CS
            v = self.evaluate(Xc, s[None, :])
            for key in v:
                jac.setdefault(key, []).append(np.imag(np.broadcast_to(v[key], (1, len(s)))[0]) / H_CS)
        vals = {key: np.real(np.broadcast_to(base[key], (1, len(s)))[0]) for key in base}
        return vals, {key: np.stack(j, axis=1) for key, j in jac.items()}

    def local_extremes(self, x, m=2001):
        """Points of the stroke where each relevant row has a local extreme (the sampled ones,
        refined by a bounded scalar search), plus the stroke's ends."""
        s = np.linspace(self.s0, self.s1, m)
        vals = self.evaluate(x[None, :], s[None, :])
        pts = [self.s0, self.s1]
        for row, sense in self.senses():
            v = self._signed(np.broadcast_to(vals[row], (1, m))[0], sense)
            left, right = v[1:-1] - v[:-2], v[1:-1] - v[2:]
            inner = np.flatnonzero((left >= 0) & (right >= 0) & ((left > 0) | (right > 0))) + 1
            for i in inner:
                pts.append(self._refine(x, row, sense, s[i - 1], s[i + 1])[1])
        return np.unique(np.array(pts))

    def _refine(self, x, row, sense, a, b):
        def neg(t):
            v = self.evaluate(x[None, :], np.array([[t]]))[row]
            return -float(self._signed(np.ravel(v)[0], sense))
        r = minimize_scalar(neg, bounds=(a, b), method="bounded", options={"xatol": 1e-13})
        return -r.fun, r.x

    def polish(self, x0, base=101, rounds=25):
        """SLSQP on the epigraph with exchange of points; returns the polished design."""
        n = len(self.names)
        span = self.hi - self.lo
        base_s = np.linspace(self.s0, self.s1, base)
        x = np.asarray(x0, float)
        extra = self.local_extremes(x)
        for round_ in range(rounds):
            S = np.unique(np.r_[base_s, extra])
            ratio_pts = self._ratio_points(x)

            def cons(z, S=S, ratio_pts=ratio_pts):
                xx = self.lo + span * z[:n]
                vals, jac = self._rows_and_jac(xx, S)
                g, J = [], []
                f, fJ = vals["drive"] / self.f_scale, jac["drive"] * span / self.f_scale
                one = np.ones((len(S), 1))
                g += [z[n] - f, z[n] + f]
                J += [np.hstack([-fJ, one]), np.hstack([fJ, one])]
                zero = np.zeros((len(S), 1))
                k, kJ = self.k_sign * vals["k"] / self.k_ref, self.k_sign * jac["k"] * span / self.k_ref
                g.append(k - self.DEAD_MARGIN)
                J.append(np.hstack([kJ, zero]))
                for _, row, lo, hi in self.per_sample:
                    sc = self.row_scale[row]
                    v, vJ = vals[row] / sc, jac[row] * span / sc
                    if math.isfinite(lo):
                        g.append(v - lo / sc)
                        J.append(np.hstack([vJ, zero]))
                    if math.isfinite(hi):
                        g.append(hi / sc - v)
                        J.append(np.hstack([-vJ, zero]))
                if self.ratios:
                    vr, jr = self._rows_and_jac(xx, ratio_pts)
                    for _, row, lo, hi in self.ratios:
                        sc = self.row_scale[row]
                        L, LJ = vr[row], jr[row] * span
                        for i in range(len(ratio_pts)):
                            for j in range(len(ratio_pts)):
                                if i == j:
                                    continue
                                if math.isfinite(hi):  # hi L_i - L_j >= 0
                                    g.append(np.array([(hi * L[i] - L[j]) / sc]))
                                    J.append(np.r_[(hi * LJ[i] - LJ[j]) / sc, 0.0][None, :])
                                if math.isfinite(lo):  # L_j - lo L_i >= 0
                                    g.append(np.array([(L[j] - lo * L[i]) / sc]))
                                    J.append(np.r_[(LJ[j] - lo * LJ[i]) / sc, 0.0][None, :])
                return np.concatenate(g), np.vstack(J)

            memo = {}

            def c_fun(z):
                key = z.tobytes()
                if key not in memo:
                    memo.clear()
                    memo[key] = cons(z)
                return memo[key]

            z0 = np.r_[(x - self.lo) / span, 0.0]
            z0[n] = float(np.max(np.abs(self.evaluate(x[None, :], S[None, :])["drive"].real))) / self.f_scale
            res = minimize(lambda z: z[n], z0, jac=lambda z: np.r_[np.zeros(n), 1.0], method="SLSQP",
                           bounds=[(0, 1)] * n + [(0, None)],
                           constraints=[{"type": "ineq", "fun": lambda z: c_fun(z)[0],
                                         "jac": lambda z: c_fun(z)[1]}],
                           options={"maxiter": 500, "ftol": 1e-15})
            x_new = self.lo + span * np.clip(res.x[:n], 0, 1)
            extra = self.local_extremes(x_new)
            change = np.max(np.abs(x_new - x) / span)
            x = x_new
            if round_ > 0 and change < 1e-12:
                break
        return x

    def _ratio_points(self, x):
        """The stroke points where the ratio rows have their extremes (refined) plus the
        ends: few points, so that every pair of them can be a constraint."""
        if not self.ratios:
            return np.array([self.s0, self.s1])
        pts = [self.s0, self.s1]
        for _, row, _, _ in self.ratios:
            for sense in (+1, -1):
                pts.append(self.stroke_extreme(x, row, sense, m=2001)[1])
        return np.unique(np.array(pts))

    # the final check ------------------------------------------------------------------------------
    def stroke_extreme(self, x, row, sense, m=DENSE):
        """(extreme, where) of a row over the continuous stroke at design x (sense as in
        :meth:`extremes`): the best of m samples refined by a bounded scalar search."""
        s = np.linspace(self.s0, self.s1, m)
        v = self._signed(np.broadcast_to(self.evaluate(x[None, :], s[None, :])[row], (1, m))[0], sense)
        i = int(np.argmax(v))
        val, where = self._refine(x, row, sense, s[max(i - 1, 0)], s[min(i + 1, m - 1)])
        return (val, where) if val >= v[i] else (float(v[i]), float(s[i]))

    def check(self, x, m=DENSE):
        """The design's peak |drive| and every constraint's extreme values over the continuous
        stroke (m samples, refined), and its largest scaled violation."""
        x = np.asarray(x, float)
        ext = {p: self.stroke_extreme(x, *p, m=m)[0] for p in self.senses()}
        report = {"peak": ext[("drive", 0)], "constraints": {}}
        for name, row, lo, hi in self.per_sample:
            report["constraints"][name] = {"min": -ext[(row, -1)] if (row, -1) in ext else None,
                                           "max": ext[(row, +1)] if (row, +1) in ext else None}
        for name, row, lo, hi in self.ratios:
            report["constraints"][name] = {"value": ext[(row, +1)] / (-ext[(row, -1)])}
        report["violation"] = float(self.violation({p: np.array([v]) for p, v in ext.items()})[0])
        bound_viol = np.max(np.r_[(self.lo - x) / (self.hi - self.lo), (x - self.hi) / (self.hi - self.lo)])
        report["violation"] = max(report["violation"], float(bound_viol))
        return report


# --- the global optimum ----------------------------------------------------------------------
LEVELS = {
    # grid points per axis (by number of design variables), grid stroke samples, polish starts,
    # samples of the final check
    "small": {"per_axis": {2: 41, 3: 17, 4: 9}, "m": 41, "starts": 3, "check": 2001},
    "full": {"per_axis": {2: 301, 3: 61, 4: 21}, "m": 121, "starts": 8, "check": DENSE},
}


def global_optimum(problem: Problem, level="small"):
    """The global optimum of the problem: grid, polish, dense check (see the module docstring).
    Returns {'value', 'design', 'check', 'candidates': [(value, design, violation), ...]}."""
    cfg = LEVELS[level]
    n = len(problem.names)
    X, peak, viol, per_axis = problem.grid(cfg["per_axis"][n], cfg["m"])
    assert np.any(viol <= 1e-9), "no feasible grid point"
    starts = problem.candidates(X, peak, viol, per_axis, cfg["starts"])
    found = []
    for x0 in starts:
        x = problem.polish(x0)
        rep = problem.check(x, cfg["check"])
        found.append((rep["peak"], x, rep["violation"], rep))
    feasible = [f for f in found if f[2] <= 1e-8]
    assert feasible, [(f[0], f[2]) for f in found]
    best = min(feasible, key=lambda f: f[0])
    return {"value": best[0], "design": dict(zip(problem.names, map(float, best[1]))), "check": best[3],
            "candidates": [(f[0], dict(zip(problem.names, map(float, f[1]))), f[2]) for f in found],
            "grid_best": float(np.min(np.where(viol <= 1e-9, peak, np.inf)))}
