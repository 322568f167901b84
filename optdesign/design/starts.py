"""Where the starts of the multistart come from: space-filling points of the design box,
screened with the NLP's own rows, and the reserve from which a start that cannot be made
feasible is retried.

* Candidates: a scrambled Sobol sequence over the design box (scipy.stats.qmc, seeded with the
  run's seed), ``CANDIDATES_PER_START`` per start (a power of two, at least ``MIN_CANDIDATES``,
  at most ``MAX_CANDIDATES`` unless the starts need more).
  A low-discrepancy sample covers the box evenly where independent uniform draws leave holes
  and clusters; benchmarks/bench_library.py measures it against Latin hypercube and uniform
  draws over the scene library.
* Screening (:class:`Screen`): every candidate is evaluated on the NLP's own sample points, the
  same rows and objective IPOPT sees (:mod:`.screening` runs them with numpy over all
  candidates at once), giving its objective there and its worst scaled constraint violation.
  Candidates are ranked feasible first by objective, then by violation; one that does not
  assemble ranks last.
* Zoom (``ZOOM``): around the best few distinct candidates a finer Sobol sample is screened
  (two levels, each in a box a fifth the size of the last), so that the best candidates are
  found inside the narrow feasible bands where optima of constrained mechanisms lie (the
  dump-truck hoist's global optimum is the tip of a band a few millimetres wide; a start on the
  wider band beside it ends at a local optimum 14 % worse).
* The starts are the scene's own start, then the best ranked candidates; the rest, in rank
  order, is the reserve: start i's k-th retry takes reserve entry ``k * starts + i``, so what a
  start does depends on its index alone, never on what the other starts did or when.

``--starts N`` stays N local solves: the screening evaluates the model, it solves nothing
(about 5,000 designs, 0.1 .. 1 s).

The Sobol points are scipy's (``qmc.Sobol``), but importing scipy.stats takes about 0.8 s, more
than a short optimise's solves: the points drawn are a pure function of the dimension, the
number of points, the seed and the versions of scipy and numpy, so they are kept in the user's
cache folder beside the compiled code (:func:`sobol`) and read back (bit for bit the same) by
later runs, which then do not import scipy.stats at all.
"""
from __future__ import annotations

import hashlib
import json

import casadi as ca
import numpy as np

from .screening import ManyDesigns

CANDIDATES_PER_START = 64   # space-filling candidates screened per start
MIN_CANDIDATES = 1024
MAX_CANDIDATES = 16384      # (or twice the starts, if more): a few seconds of screening at most
# zoom levels: (distinct seeds, candidates around each, half-width as a fraction of the box)
ZOOM = ((8, 256, 0.1), (4, 256, 0.02))
RETRIES = 4                 # fresh points a start may try after its first
FEASIBLE = 1e-9             # a candidate is feasible on the sample points when no scaled row is violated by more


class StartPlan:
    """The starts of one multistart: ``points`` (starts x design variables, the scene's start
    first) and the ``reserve`` of ranked candidates from which starts are retried (screened on
    first use when the points were given), with how many candidates were screened and how they
    were drawn ('sobol', 'lhs', 'uniform'; 'given' for explicit points)."""

    def __init__(self, points, reserve=None, screened=0, method="sobol", plan_reserve=None, fitting=0):
        self.points = np.atleast_2d(np.asarray(points, float))
        self._reserve, self._plan_reserve = reserve, plan_reserve
        self.screened, self.method = screened, method
        self.fitting = fitting   # how many of the points were screened feasible on the sample points

    @property
    def reserve(self) -> np.ndarray:
        if self._reserve is None:
            plan = self._plan_reserve() if self._plan_reserve is not None else None
            self._reserve = np.zeros((0, self.points.shape[1])) if plan is None else plan.reserve
        return self._reserve

    def retry(self, index: int, k: int):
        """Start ``index``'s k-th retry point (k = 0, 1, ...), or None when the reserve is spent."""
        j = k * len(self.points) + index
        return self.reserve[j] if j < len(self.reserve) else None

    def as_dict(self) -> dict:
        """How the starts were drawn (the same whoever solved them: a reserve screened on
        demand, in whichever process needed it, is not counted)."""
        return {"method": self.method, "screened": int(self.screened)}


def box(pb):
    """Lower and upper corner of the box the starts are drawn from (a variable with one bound
    gets a box around its start; scenes refuse those, problems built otherwise may have them)."""
    lo = np.where(np.isfinite(pb.lower), pb.lower, pb.start - np.abs(pb.start) - 1)
    hi = np.where(np.isfinite(pb.upper), pb.upper, pb.start + np.abs(pb.start) + 1)
    return lo, hi


def unit_sample(d: int, n: int, rng, method: str = "sobol") -> np.ndarray:
    """``n`` points of the unit cube: scrambled Sobol ('sobol', n rounded up to a power of two
    and cut), Latin hypercube ('lhs') or independent uniform draws ('uniform').  ``rng``: a
    seed (an int or a sequence of ints, as for ``np.random.default_rng``; Sobol points are then
    cached, :func:`sobol`) or a numpy Generator."""
    if method == "sobol":
        m = int(np.ceil(np.log2(max(n, 2))))
        if isinstance(rng, np.random.Generator):
            return _draw_sobol(d, m, rng)[:n]
        return sobol(d, m, rng)[:n]
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    if method == "lhs":
        from scipy.stats import qmc

        return qmc.LatinHypercube(d, seed=rng).random(n)
    if method == "uniform":
        return rng.random((n, d))
    raise ValueError(f"unknown start method {method!r}: expected 'sobol', 'lhs' or 'uniform'")


def _draw_sobol(d: int, m: int, rng) -> np.ndarray:
    from scipy.stats import qmc   # about 0.8 s to import: only when the cache cannot answer

    return qmc.Sobol(d, scramble=True, seed=rng).random_base2(m)


def sobol(d: int, m: int, seed) -> np.ndarray:
    """The 2**m scrambled Sobol points of the d-dimensional unit cube that
    ``qmc.Sobol(d, scramble=True, seed=np.random.default_rng(seed)).random_base2(m)`` draws,
    from the cache when an earlier run drew them (the file ``sobol-<key>.npy`` in the cache
    folder of :mod:`optdesign.model.compiled`, with its key and SHA-256 in ``sobol-<key>.json``;
    a file that does not match them is drawn again and replaced).  Without a writable cache
    folder the points are drawn each time."""
    import scipy

    if seed is None:   # fresh entropy: nothing to cache
        return _draw_sobol(d, m, np.random.default_rng())
    # default_rng(0) and default_rng([0]) differ: a sequence stays a list in the key
    seed_key = [int(v) for v in seed] if np.ndim(seed) else int(seed)
    key = {"kind": "sobol", "d": int(d), "m": int(m), "seed": seed_key, "scramble": True,
           "scipy": scipy.__version__, "numpy": np.__version__, "format": 1}
    name = "sobol-" + hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:32]
    points = _cached_sobol(name, key)
    if points is None:
        points = _draw_sobol(d, m, np.random.default_rng(seed))
        _store_sobol(name, key, points)
    return points


def _sobol_folder():
    from ..model.compiled import cache_dir

    return cache_dir()


def _cached_sobol(name: str, key: dict):
    """The points stored under ``name`` if their files are whole and match ``key``, else None."""
    import io

    try:
        folder = _sobol_folder()
        meta = json.loads((folder / f"{name}.json").read_text())
        data = (folder / f"{name}.npy").read_bytes()
        if meta.get("key") != key or meta.get("sha256") != hashlib.sha256(data).hexdigest():
            return None
        points = np.load(io.BytesIO(data), allow_pickle=False)
    except (OSError, ValueError, TypeError, AttributeError, EOFError):
        return None
    shape = (2 ** key["m"], key["d"])
    if points.shape != shape or points.dtype != np.float64 or not np.all((points >= 0) & (points < 1)):
        return None
    return points


def _store_sobol(name: str, key: dict, points: np.ndarray):
    """Write the points and then their key (the key file last: a torn write is not trusted)."""
    import io

    from ..model.cachefiles import write_atomic

    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(points, dtype=np.float64), allow_pickle=False)
    data = buf.getvalue()
    try:
        folder = _sobol_folder()
        folder.mkdir(parents=True, exist_ok=True)
        write_atomic(folder / f"{name}.npy", data)
        write_atomic(folder / f"{name}.json",
                      json.dumps({"key": key, "sha256": hashlib.sha256(data).hexdigest()}, indent=1).encode())
    except OSError:
        pass   # a read-only or full cache folder: the points are drawn again next time


def space_filling(pb, n: int, seed: int, method: str = "sobol") -> np.ndarray:
    """``n`` points of the design box, reproducible from ``seed``."""
    lo, hi = box(pb)
    if n <= 0:
        return np.zeros((0, len(lo)))
    return lo + (hi - lo) * unit_sample(len(lo), n, seed, method)


class Screen:
    """The NLP's objective and rows at many designs on the NLP's initial sample points:
    (objective, worst scaled violation) per design.  The epigraph variable of a peak is the
    sampled peak and each stroke aggregate its sampled extreme, so the epigraph's own rows
    hold and the others say what IPOPT would see at that design."""

    def __init__(self, pb):
        self.pb = pb
        nlp = pb._nlp_dict
        self.quantity = ManyDesigns(pb.quantity)
        # the NLP's objective and rows (an MX graph, as for an rms objective, is expanded: about
        # 0.2 s once per problem, then 0.1-1 s for 5,000 designs)
        self.rows = ManyDesigns(ca.Function("screen_rows", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]]))
        self.checked = np.ones(len(pb.lbg), bool)
        for _, kind, start, n in pb.g_blocks:
            if kind == "peak":
                self.checked[start:start + n] = False

    def __call__(self, xs, fixed, lbg, ubg):
        pb = self.pb
        xs = np.atleast_2d(np.asarray(xs, float))
        m, nd = len(xs), len(pb.design_names)
        s_pts = np.r_[pb.base_points, pb.initial_slots]
        P = np.repeat(pb.full_parameters(pb.start, fixed)[:, None], m, axis=1)
        P[pb.design_index, :] = xs.T
        Q = self.quantity(np.tile(s_pts, m)[None, :], np.repeat(P, len(s_pts), axis=1))[0]
        Q = Q.reshape(Q.shape[0], m, len(s_pts))
        W = np.zeros((pb.nw, m))
        W[:nd] = pb.to_z(xs).T
        if pb.n_t:
            W[nd] = np.max(np.abs(Q[pb.objective_quantity]), axis=-1) / pb.f_ref
        for i, ag in enumerate(pb.aggregates):
            W[nd + pb.n_t + i] = _sampled(ag, Q[ag.index], len(pb.base_points)) / pb.a_scale[i]
        f, g = self.rows(W, pb.nlp_parameters(fixed, s_pts, pb.start))
        with np.errstate(invalid="ignore"):
            viol = np.maximum(lbg[:, None] - g, g - ubg[:, None])[self.checked]
            worst = np.max(np.maximum(viol, 0.0), axis=0, initial=0.0)
        f = np.asarray(f, float).ravel()
        bad = ~np.all(np.isfinite(Q), axis=(0, 2)) | ~np.isfinite(worst) | ~np.isfinite(f)
        return np.where(bad, np.inf, f), np.where(bad, np.inf, worst)


def _sampled(ag, v, n_base):
    """An aggregate's value on the sample points (designs x points; the base points first,
    from the stroke's start to its end)."""
    if ag.func == "max":
        return np.max(v, axis=-1)
    if ag.func == "min":
        return np.min(v, axis=-1)
    return v[:, 0] if ag.func == "start" else v[:, n_base - 1]


def rank(f, viol) -> np.ndarray:
    """Candidates best first: those feasible on the sample points by objective, then the
    others by violation (those that do not assemble last)."""
    feasible = viol <= FEASIBLE
    return np.lexsort((np.where(feasible, f, viol), ~feasible))


def _distinct(z, order, k, r):
    """Indices of the first k of ``order`` at least r apart (max norm of the scaled design)."""
    out = []
    for i in order:
        if len(out) == k:
            break
        if all(np.max(np.abs(z[i] - z[j])) >= r for j in out):
            out.append(i)
    return out


def plan_starts(pb, starts: int, seed: int, fixed=None, method: str = "sobol", zoom=None) -> StartPlan:
    """The scene's own start, then the ``starts - 1`` best screened candidates, and the
    reserve for retries (see the module's docstring)."""
    fixed = pb.mech.parameter_values[pb.fixed_index] if fixed is None else np.asarray(fixed, float)
    d = len(pb.design_names)
    if starts <= 0:
        return StartPlan(np.zeros((0, d)), np.zeros((0, d)), 0, method)
    screen = pb._once("screen", lambda: Screen(pb))
    lo, hi = box(pb)
    wanted = max(MIN_CANDIDATES, min(CANDIDATES_PER_START * starts, MAX_CANDIDATES), 2 * starts)
    n = 2 ** int(np.ceil(np.log2(wanted)))
    cand = space_filling(pb, n, seed, method)
    f, viol = screen(cand, fixed, pb.lbg, pb.ubg)
    for level, (k, per, h) in enumerate(ZOOM if zoom is None else zoom):
        z = (cand - lo) / (hi - lo)
        seeds = _distinct(z, rank(f, viol), k, 2 * h)
        u = unit_sample(d, per * len(seeds), [seed, level + 1], method)
        new = np.concatenate([np.clip(z[c] + (2 * u[j * per:(j + 1) * per] - 1) * h, 0.0, 1.0)
                              for j, c in enumerate(seeds)]) if seeds else np.zeros((0, d))
        new = lo + (hi - lo) * new
        fn, vn = screen(new, fixed, pb.lbg, pb.ubg)
        cand, f, viol = np.vstack([cand, new]), np.r_[f, fn], np.r_[viol, vn]
    order = rank(f, viol)
    cand = cand[order]
    points = np.vstack([pb.start[None, :], cand[:starts - 1]])
    fitting = int(np.sum(viol[order[:starts - 1]] <= FEASIBLE))
    return StartPlan(points, cand[starts - 1:], len(cand), method, fitting=fitting)
