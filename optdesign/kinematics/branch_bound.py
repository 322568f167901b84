"""The proof of the one certification (:mod:`.peaks`, :mod:`.extrema`): branch and bound over
the stroke with the enclosure of the rows (:mod:`.enclosure`), for every task (a request of a
case) of a batch of cases at once.

Each case's stroke is first cut into coarse intervals (blocks of BLOCK sample intervals) and,
around each located maximum near its task's best (NEAR), at s* and about it at +- the distances
CUTS (from the point of a fine lattice nearest s*, so that cases whose maxima lie close share
these intervals): pieces shrinking towards the maximum, as the Taylor form needs them to, and
growing away from it by ratios of 1.5 and 4/3 out to two blocks, so that the monotone and
mean-value forms close them in the same pass (on the slider crank, ratio-2 pieces out to one
block left 10 intervals near its two largest drive maxima open after the first pass: a second
pass for them cost ~0.45 ms of its ~1.9 ms of certified extremes).  An interval
holding (or ending at) its tasks' best located maximum is expanded there instead of at its
midpoint: v' ~ 0 there, and where v'' is proven negative the form bounds v by v(s*) itself, so
the pieces next to the maximum close in the first pass (with it, PRESPLIT 4 instead of 8 leaves
the later passes as they were: truck crane ~111 -> ~96 intervals per case).  Every task
of a case bounds its target over every one of its case's intervals, all intervals of all cases
in one evaluation of the enclosure per pass (each distinct (case, interval) once, whatever the
rows asking); an interval whose bound exceeds the task's best located target by more than the
tolerance is halved and bounded again in the next pass, until none is left.  A piece whose
midpoint beats the best located target has its maximum located by Newton in it.  What a task
does depends only on its case's numbers: a case stops (its open intervals left uncertified)
after MAX_PASSES passes, above MAX_INTERVALS open intervals, or at an interval 1e-13 of the
stroke wide, on its own.
"""
from __future__ import annotations

import numpy as np

from .extrema import _starts, newton, target

CERTIFY_TOL = 1e-9   # the certificate's tolerance, relative to the row's scale (its largest |v|)
MAX_PASSES = 60      # subdivision passes of the branch and bound before a case gives up
MAX_INTERVALS = 16384  # intervals of one case open at once, idem
PRESPLIT = 4         # cuts towards a located maximum in the later passes (HALVES); 0: no cuts about maxima
BLOCK = 8            # sample intervals per interval of the first pass away from the maxima
LATTICE = 3         # the first pass's cuts about a maximum on the lattice of h 2^-LATTICE (first_intervals)
HALVES = 2.0 ** -np.arange(1, PRESPLIT + 1)[None, :]   # (cuts towards a maximum: the width times these)
# the first pass's cuts each side of a maximum (first_intervals), in units of that lattice's
# spacing h 2^-LATTICE (h the sample spacing): from h/32 to 4 h by factors of 2, then out to
# 32 h (two blocks) by 1.5 and 4/3
CUTS = np.array([0.25, 0.5, 1, 2, 4, 8, 16, 24, 32, 48, 64, 96, 128, 192, 256], float)
NEAR = 0.05          # maxima within this fraction of their task's best get the first pass's cuts
UNITS = np.concatenate((-CUTS[::-1], CUTS))   # (the cuts each side of a maximum, ascending)


def certify(enclosure, evaluate, tasks, s_grid, T, found, s_tol=1e-13, tol=None):
    """Branch and bound (module docstring) of every task's target (``T``: tasks x samples on
    ``s_grid``); located maxima join ``found`` (in place).  Returns (bound, notes) per task: the
    upper bound of its target over the stroke (the largest bound of the intervals left behind,
    never below the best located target; NaN without an enclosure) and why it is missing or
    wider than the tolerance ("" when certified)."""
    n = len(tasks)
    notes = [""] * n
    if getattr(enclosure, "reason", None) is not None:   # no enclosure for these rows
        return np.full(n, np.nan), [f"not certified: {enclosure.reason}"] * n
    tol = CERTIFY_TOL if tol is None else tol
    best = found.best(tasks.code)[1].copy()   # (updated in place as better maxima are located)
    with np.errstate(invalid="ignore"):
        scale = np.fmax.reduce(np.abs(T), axis=1, initial=0.0) if T.size else np.zeros(n)   # (np.nanmax's)
    tol_abs = np.where(np.isnan(tasks.tol), tol * np.maximum(np.abs(best), scale), tasks.tol) + 1e-300
    bound = np.empty(n)
    bound.fill(-np.inf)
    span = abs(float(s_grid[-1] - s_grid[0])) if len(s_grid) > 1 else 0.0
    limits = (float(np.minimum.reduce(s_grid)), float(np.maximum.reduce(s_grid))) if len(s_grid) else (0.0, 0.0)
    task, lo, hi, where, pick = first_intervals(tasks, s_grid, found, best)
    left_ub = np.empty(len(task))
    left_ub.fill(np.inf)   # bounds of the intervals still open (inf: not bounded yet)
    left = []   # (task, lo, hi, bound) of the intervals of the cases that stopped
    with np.errstate(invalid="ignore"):   # (NaN compared: False, as meant)
        for pass_ in range(MAX_PASSES):
            if not len(task):
                break
            case = tasks.case.take(task)
            if pass_:   # the distinct intervals of each case (the tasks of a case share them)
                order = np.lexsort((hi, lo, case))
                c, a, b = case[order], lo[order], hi[order]
                first = _starts((c[1:] != c[:-1]) | (a[1:] - a[:-1] != 0) | (b[1:] - b[:-1] != 0), len(order))
                where = np.empty(len(task), int)
                where[order] = first.cumsum() - 1
                pick = order[first]
            # each distinct interval expanded at a located maximum inside it or at its end (its
            # tasks' best; the largest such s where several are), else at its midpoint
            top, _ = found.best(tasks.code)
            centre = found.s[top].take(task)   # (per task, then per interval: one gather of each)
            inside = ((lo <= centre) & (centre <= hi)).nonzero()[0]   # (the others leave ``at`` NaN)
            at = np.empty(len(pick))
            at.fill(np.nan)
            np.fmax.at(at, where[inside], centre[inside])
            r_of, code = tasks.row.take(task), tasks.code.take(task)
            rows = np.bincount(r_of).nonzero()[0]   # (the rows asked for, ascending: np.unique's)
            skipped = _prefiltered(enclosure, pass_, lo, hi, pick, case, r_of, where, code, best.take(task))
            if skipped is None:
                L, U, vm_lo, vm_hi = enclosure.bounds(lo[pick], hi[pick], rows, case[pick], at)
                # each entry's row and interval, as one index into the flattened arrays (np.take:
                # the same elements as L[r_of, where], without numpy's two-array indexing, ~5x its cost)
                flat = r_of * L.shape[1] + where
                ub = target_bound(L.take(flat), U.take(flat), code, upper=True)
                vm_lo, vm_hi = vm_lo.take(flat), vm_hi.take(flat)
            else:
                ub, vm_lo, vm_hi = _open_bounds(enclosure, skipped, lo, hi, pick, case, at, rows, r_of, where, code)
            at_mid = target_bound(vm_lo, vm_hi, code, upper=False)
            locate_better(evaluate, tasks, found, best, task, lo, hi, at_mid, vm_lo + vm_hi, s_tol, limits)
            # the tolerance, or where rounding is larger, four times the width of the midpoint's
            # own enclosure (a row that cancels to ~0: its floating-point evaluation cannot say more)
            width_m = vm_hi - vm_lo
            noise = 4.0 * np.where(np.isfinite(width_m), width_m, 0.0)
            threshold = np.maximum(best.take(task) + np.maximum(tol_abs.take(task), noise), tasks.only_above.take(task))
            keep = ~(ub <= threshold)   # NaN: not bounded, split again
            closed = ~keep
            if np.count_nonzero(closed):
                np.maximum.at(bound, task[closed], ub[closed])
            task, lo, hi, left_ub = task[keep], lo[keep], hi[keep], ub[keep]
            if not len(task):   # all closed (the rest of the pass would work on empty arrays)
                break
            left_ub[left_ub != left_ub] = np.inf
            width = hi - lo
            case = tasks.case.take(task)
            stop = np.bincount(case, minlength=tasks.n_cases) > MAX_INTERVALS
            stop[case[width <= max(span, 1e-300) * 1e-13]] = True
            stopping = stop[case] | (pass_ == MAX_PASSES - 1)
            if np.count_nonzero(stopping):
                left.append((task[stopping], lo[stopping], hi[stopping], left_ub[stopping]))
                task, lo, hi, left_ub = task[~stopping], lo[~stopping], hi[~stopping], left_ub[~stopping]
                width = hi - lo
            # halved; one that holds its task's best located maximum cut towards it as in the first pass
            top, _ = found.best(tasks.code)
            centre = found.s[top].take(task)   # (per task, then per interval: one gather of each)
            around = (lo < centre) & (centre < hi)
            steps = width[around, None] * HALVES
            cuts = centre[around, None] + np.concatenate((-steps, np.zeros((len(steps), 1)), steps[:, ::-1]), axis=1)
            task, lo, hi, left_ub = split(task, lo, hi, left_ub, cuts, around, lo + width * 0.5)
    if left:
        task, lo, hi, left_ub = (np.concatenate(a) for a in zip(*left))
        np.maximum.at(bound, task, left_ub)
        for k in np.unique(task):
            i = int(np.flatnonzero(task == k)[0])
            notes[k] = (f"not certified: the enclosure did not close within {tol_abs[k]:.3g} of the located value "
                        f"near s = {0.5 * (lo[i] + hi[i]):.9g} (bound {bound[k]:.9g} against {best[k]:.9g})")
    return np.maximum(bound, best), notes


def _prefiltered(enclosure, pass_, lo, hi, pick, case, r_of, where, code, best):
    """In the first pass, with an enclosure that has a pre-filter
    (:class:`~.linear_parts.Prefiltered`): (per entry its pre-filter bound, per distinct
    interval whether every entry's is <= its task's best located target ``best``: no per-case
    enclosure needed); else (or where none is) None."""
    upper = getattr(enclosure, "upper", None) if pass_ == 0 else None
    if upper is None:
        return None
    pre = upper(lo[pick], hi[pick], case[pick], r_of, where, code, best)
    if pre is None:
        return None
    needed = np.zeros(len(pick), bool)
    needed[where[~(pre <= best)]] = True   # (NaN: needed)
    if np.count_nonzero(needed) == len(pick):
        return None
    return pre, needed


def _open_bounds(enclosure, skipped, lo, hi, pick, case, at, rows, r_of, where, code):
    """(ub, vm_lo, vm_hi) per entry of the first pass (:func:`certify`'s) where the pre-filter
    closed some intervals (``skipped``: :func:`_prefiltered`'s): the per-case enclosure of the
    others only (the same bits per interval as in one call of all), the pre-filter's bound for
    the entries of the closed ones and no midpoint (NaN: its value is below that bound, so it
    cannot beat its task's best)."""
    pre, needed = skipped
    kept = needed.nonzero()[0]
    ub = pre.copy()
    vm_lo, vm_hi = np.full(len(pre), np.nan), np.full(len(pre), np.nan)
    if len(kept):
        p = pick[kept]
        L, U, m_lo, m_hi = enclosure.bounds(lo[p], hi[p], rows, case[p], at[kept])
        position = np.full(len(pick), -1)
        position[kept] = np.arange(len(kept))
        e = needed.take(where).nonzero()[0]
        flat = r_of.take(e) * L.shape[1] + position.take(where.take(e))
        ub[e] = target_bound(L.take(flat), U.take(flat), code.take(e), upper=True)
        vm_lo[e], vm_hi[e] = m_lo.take(flat), m_hi.take(flat)
    return ub, vm_lo, vm_hi


def split(task, lo, hi, left_ub, cuts, around=None, middle=None):
    """Each interval [lo, hi] cut at its row of ``cuts`` (ascending, NaN: none) strictly inside
    it; the pieces keep their interval's task and bound, in order.  Returns (task, lo, hi,
    left_ub).  With ``around`` (a mask), ``cuts`` are the rows of the intervals it marks, and
    each other interval is cut at its ``middle`` alone."""
    if around is None:
        around, middle = np.ones(len(lo), bool), np.full(len(lo), np.nan)
    with np.errstate(invalid="ignore"):
        inside = (cuts > lo[around, None]) & (cuts < hi[around, None])
        halved = (middle > lo) & (middle < hi) & ~around
    inside[:, 1:] &= cuts[:, 1:] != cuts[:, :-1]   # each cut once
    pieces = 1 + halved.astype(int)
    pieces[around] = 1 + inside.sum(axis=1)
    start = pieces.cumsum() - pieces   # each interval's first piece
    owner = np.arange(len(lo)).repeat(pieces)
    new_lo, new_hi = lo[owner], hi[owner]
    h = halved.nonzero()[0]   # the halves: [lo, middle], [middle, hi]
    new_hi[start[h]], new_lo[start[h] + 1] = middle[h], middle[h]
    if len(cuts):   # the cuts' pieces, as consecutive edges of one interval
        a = around.nonzero()[0]
        edges = np.concatenate((lo[a, None], cuts, hi[a, None]), axis=1)
        keep = np.ones(edges.shape, bool)
        keep[:, 1:-1] = inside
        flat, row = edges[keep], keep.nonzero()[0]
        piece = (row[:-1] == row[1:]).nonzero()[0]
        at = start[a][row[piece]] + (piece - row.searchsorted(row[piece]))
        new_lo[at], new_hi[at] = flat[piece], flat[piece + 1]
    return task[owner], new_lo, new_hi, left_ub[owner]


def first_intervals(tasks, s_grid, found, best):
    """The first pass's intervals: per case, its stroke cut every BLOCK samples and, around each
    located maximum strictly inside the stroke within NEAR of its task's best (where the bound
    must come within the tolerance of the located value, or the blocks about a maximum a little
    lower would not close), at s* and c +- g CUTS (g = h 2^-LATTICE, h the largest sample
    spacing, c the point of the lattice s_0 + j g nearest s*: cases whose maxima lie near one
    another get the same cuts, to the bit, and share the work of these intervals that does not
    depend on their parameters:
    :class:`~optdesign.model.intervals_compiled.CompiledProgram`); every task of the case gets
    all its case's intervals.  Returns (task, lo, hi) arrays, the index of each entry's interval among the
    distinct ones and, per distinct interval, the index of its first entry."""
    increasing = len(s_grid) > 1 and bool(np.logical_and.reduce(s_grid[1:] > s_grid[:-1]))
    grid = s_grid if increasing else np.unique(s_grid)   # (np.unique's values: sorted, each once)
    n_cases, k = tasks.n_cases, len(tasks.requests)
    if len(grid) < 2:
        return np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0, int), np.zeros(0, int)
    a, b = grid[0], grid[-1]
    every = np.arange(0, len(grid), BLOCK)   # (and the last sample)
    if every[-1] != len(grid) - 1:
        every = np.concatenate((every, [len(grid) - 1]))
    blocks = grid[every]
    cut_case = [np.arange(n_cases).repeat(len(blocks))]
    cut_s = [blocks[None, :].repeat(n_cases, axis=0).ravel()]
    if PRESPLIT:
        h = float(np.maximum.reduce(grid[1:] - grid[:-1]))
        t = found.task
        near = (target(found.v, tasks.code[t]) >= best[t] - NEAR * np.abs(best[t])) & (found.s > a) & (found.s < b)
        centres, owner = found.s[near], tasks.case[t[near]]
        # the cuts about the lattice point nearest each maximum (a + j g: the same bits for every
        # case whose maximum is near it, so that cases share these intervals), and at the maximum
        g = h * 2.0 ** -LATTICE
        around = np.concatenate(
            (a + (((centres - a) / g).round()[:, None] + UNITS[None, :]) * g, centres[:, None]), axis=1)
        inside = (around > a) & (around < b)
        cut_case.append(owner[inside.nonzero()[0]])
        cut_s.append(around[inside])
    case, s = np.concatenate(cut_case), np.concatenate(cut_s)
    if n_cases == 1:   # (the arrays below for one case, without sorting and counting by case)
        s = s[s.argsort(kind="stable")]
        s = s[_starts(s[1:] - s[:-1] != 0, len(s))]
        m = max(len(s) - 1, 0)
        index = np.tile(np.arange(m), k)
        first = np.arange(m) if k else np.full(m, -1)
        return np.arange(k).repeat(m), s[:-1][index], s[1:][index], index, first
    order = np.lexsort((s, case))
    case, s = case[order], s[order]
    distinct = _starts((case[1:] != case[:-1]) | (s[1:] - s[:-1] != 0), len(s))
    case, s = case[distinct], s[distinct]
    pair = (case[:-1] == case[1:]).nonzero()[0]   # consecutive cuts of one case: an interval
    i_case, i_lo, i_hi = case[pair], s[pair], s[pair + 1]
    counts = np.bincount(i_case, minlength=n_cases)
    # each task of a case: all its case's intervals (tasks case-major; counts.repeat(k) where
    # every case has k tasks, but also cases of Tasks.joined, each with its own number of tasks)
    starts = np.concatenate(([0], counts.cumsum()[:-1]))
    per_task = counts[tasks.case]
    task = np.arange(len(tasks.case)).repeat(per_task)
    within = np.arange(len(task)) - np.concatenate(([0], per_task.cumsum()[:-1])).repeat(per_task)
    case_major = tasks.case[1:] >= tasks.case[:-1]
    if np.logical_and.reduce(case_major):   # (each case's tasks in a row: repeats, not gathers and a scatter)
        per_case = np.bincount(tasks.case, minlength=n_cases) * counts   # each case's entries
        index = starts.repeat(per_case) + within   # (starts[tasks.case[task]])
        # each interval's smallest entry, its case's first task's: case c's entries start after
        # the earlier cases' (-1: a case without tasks)
        first = np.arange(len(i_lo)) + (per_case.cumsum() - per_case - starts).repeat(counts)
        first[(per_case == 0).repeat(counts)] = -1
        return task, i_lo[index], i_hi[index], index, first
    index = starts[tasks.case[task]] + within
    first = np.empty(len(i_lo), int)
    first.fill(-1)
    first[index[::-1]] = np.arange(len(index))[::-1]   # (the smallest entry of each interval)
    return task, i_lo[index], i_hi[index], index, first


def target_bound(L, U, code, upper):
    """Per interval, an upper (``upper``) or lower bound of its task's target from v's bounds
    [L, U]; ``code``: the sense, an index into SENSES (abs, max, min)."""
    high, low = (U, L) if upper else (L, U)
    minus = -low
    out = np.maximum(high, minus)
    np.copyto(out, high, where=code == 1)
    np.copyto(out, minus, where=code == 2)
    return out


def locate_better(evaluate, tasks, found, best, task, lo, hi, at_mid, v_mid, s_tol, limits):
    """Where an interval's midpoint beats its task's best located target, locate the maximum
    near the best such midpoint of each task (Newton on dv/ds = 0 in the interval widened by its
    width each side, from the midpoint) and add it to ``found``; ``best`` is updated in place."""
    better = (at_mid > best[task]).nonzero()[0]
    if not len(better):
        return
    order = np.lexsort((better, -at_mid[better], task[better]))   # per task: largest midpoint, then first
    chosen = better[order][_starts(np.diff(task[better][order]) != 0, len(order))]
    k = task[chosen]
    w, m = hi[chosen] - lo[chosen], 0.5 * (lo[chosen] + hi[chosen])
    code = tasks.code[k]
    sign = np.where(code == 1, 1.0, np.where(code == 2, -1.0, np.where(v_mid[chosen] >= 0, 1.0, -1.0)))
    s_star, v_star = newton(evaluate, tasks.case[k], tasks.row[k], np.maximum(lo[chosen] - w, limits[0]),
                            np.minimum(hi[chosen] + w, limits[1]), m, sign, s_tol)
    value = target(v_star, code)
    ok = value == value
    found.add(k[ok], s_star[ok], v_star[ok])
    best[k[ok]] = np.maximum(best[k[ok]], value[ok])
