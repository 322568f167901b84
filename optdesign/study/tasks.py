"""One case of a study, computed where it runs (this process, a pool worker or a Dask worker).

A case is a pure function of its task: the scene, the mode, the parameter overrides, the
constraint bounds, the run settings and (for a warm-started case) the previous case's optimum.
Nothing else enters, so a case gives the same numbers wherever and in whatever order it runs;
this is what makes a serial, a parallel and a distributed run of a study identical.

Speed comes from building the scene's model once per process and re-running it with new
parameter values.  A parameter can be changed without a rebuild when it is a *leaf* of the
CasADi graphs (Mechanism.p): then :class:`~optdesign.design.problem.DesignProblem` takes it as an NLP
parameter (``Solver.solve(x0, fixed)``) and :class:`~optdesign.model.analysis.Analysis` as a value
of ``run(p_values)``.  Parameters that the build evaluates to numbers (derived parameters, the
sweep's range, constraint bounds, stroke expressions, design variables' starts) are
*structural*: a case that changes one of them gets a problem built for it (cached per process).
The reused problem keeps the scaling of the scene's own parameter values; its optimum agrees
with a fresh ``optimise(scene.with_parameters(...))`` to IPOPT's tolerance (tests check 1e-7
relative; 4e-10 was seen on the truck crane from half to three times the payload).

The bounds of a Pareto axis need no build either: they are the NLP's lbg/ubg, and
:meth:`~optdesign.design.problem.DesignProblem.with_bounds` derives each point's problem from the one
built for the scene's own bounds (sharing its NLP, solvers and start repair).  That problem
keeps the base build's scales (a per-sample constraint's scale counts the scene's bounds, not
the swept one), so a case's numbers still depend on nothing but its task.
"""
from __future__ import annotations

import dataclasses
import gc
import hashlib
import json
import pickle
import threading
import time

from . import analysed
from .analysed import failed_row, leaf_values
from .blocks import Block, blocks

_LOCAL = threading.local()   # per thread: a Dask worker may run tasks in several threads
_CACHE_SIZE = 8              # models kept per thread (one per structural variant; bounds need none)


@dataclasses.dataclass(frozen=True)
class Task:
    """Everything a case's result depends on (picklable; shipped to workers)."""

    scene_blob: bytes          # pickle of the base Scene
    scene_digest: str          # its content digest (key of the per-process scene cache)
    mode: str                  # 'optimise' or 'analyse'
    overrides: tuple           # ((parameter, value), ...) in the study's order
    bounds: tuple              # ((constraint, side, value), ...): epsilon-constraint bounds
    starts: int                # starts of a cold case
    seed: int
    warm_starts: int           # starts of a warm case: the previous optimum, then the first cold ones
    settings: tuple            # SolverSettings fields as ((name, value), ...)
    x_warm: tuple | None       # the previous case's optimum (design variables in scene order)
    checked: bool = False      # the overrides were validated together when the study was made


def case_scene(base, mode: str, overrides: dict):
    """The scene of a case: ``base`` with the case's parameter values.  An analysis has no
    design box, so in mode 'analyse' a design variable may take any value (its min/max are
    dropped); an optimisation keeps the box, and a value outside it is an error."""
    if mode == "analyse" and overrides:
        base = base.without_bounds(*overrides)
    return base.with_parameters(**overrides) if overrides else base


def scene_digest(scene) -> str:
    """A digest of everything in a scene that can change a result (not its file path)."""
    text = repr(dataclasses.replace(scene, path=""))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def structural_names(scene, mode: str) -> set:
    """Parameters whose change needs a new build (see the module docstring)."""
    derived = {p.name for p in scene.parameters if p.value.names()}
    used = set(scene.sweep.start.names()) | set(scene.sweep.stop.names())
    if mode == "optimise":
        used |= {p.name for p in scene.parameters if p.is_design}
        for c in scene.constraints:
            for e in (c.lower, c.upper):
                if e is not None:
                    used |= e.names()
            if c.expr.is_aggregate:
                used |= c.expr.outside_aggregates()[0]
        if scene.objective is not None:
            from ..errors import OptdesignError
            from ..scene.expressions import parse

            try:
                used |= parse(scene.objective.minimise, "[objective]").names()
            except OptdesignError:   # peak(drive) etc. name outputs, not parameters
                pass
    return derived | _dependencies(scene, used)


def _dependencies(scene, names: set) -> set:
    """``names`` and every parameter a derived one among them is computed from."""
    by_name = {p.name: p for p in scene.parameters}
    out, todo = set(), [n for n in names if n in by_name]
    while todo:
        n = todo.pop()
        if n in out:
            continue
        out.add(n)
        todo += [m for m in by_name[n].value.names() if m in by_name]
    return out


# --- per-process caches ----------------------------------------------------------------------
def _cache():
    if not hasattr(_LOCAL, "scenes"):
        _LOCAL.scenes, _LOCAL.models, _LOCAL.unbounded, _LOCAL.structural = {}, {}, {}, {}
        _LOCAL.keys, _LOCAL.settings = {}, (None, None)
        _LOCAL.builds = _LOCAL.frozen = 0
    return _LOCAL


def _scene(task: Task):
    c = _cache()
    if task.scene_digest not in c.scenes:
        c.scenes[task.scene_digest] = pickle.loads(task.scene_blob)
    return c.scenes[task.scene_digest]


def _structural(task: Task, base) -> frozenset:
    """:func:`structural_names` of the case's scene ``base``, found once per process and scene
    (it walks every expression of the scene: 0.15 ms, once per case before)."""
    c = _cache()
    key = (task.scene_digest, task.mode)
    if key not in c.structural:
        c.structural[key] = frozenset(structural_names(base, task.mode))
    return c.structural[key]


def _unbounded(task: Task, base):
    """``base`` without the bounds of the case's parameters in mode 'analyse' (see
    :func:`case_scene`), made once per process for a study's parameters: a case's scene is then
    validated once, when its values are set, not twice."""
    if task.mode != "analyse" or not task.overrides:
        return base
    c = _cache()
    key = (task.scene_digest, tuple(sorted(k for k, _ in task.overrides)))
    if key not in c.unbounded:
        c.unbounded[key] = base.without_bounds(*key[1])
    return c.unbounded[key]


def _model(task: Task, base, structural: dict):
    """The problem and its start repair (optimise) or the analysis (analyse) of a case."""
    if task.mode != "optimise":
        return _built(task, base, structural, task.bounds)
    problem, repair = _built(task, base, structural, ())
    # the case's bounds on the problem built for the scene's own: no rebuild (the repair
    # depends on the design box and the assembly margins only, not on constraint bounds)
    return problem.with_bounds(task.bounds), repair


def _built(task: Task, base, structural: dict, bounds: tuple):
    """The built problem and repair (optimise) or analysis (analyse), cached per thread."""
    c = _cache()
    varied = sorted(k for k, _ in task.overrides) if task.mode == "analyse" else []
    key = _model_key(task, structural, bounds, varied)
    if key in c.models:
        c.models[key] = c.models.pop(key)   # most recently used last
        return c.models[key]
    scene = (base.without_bounds(*varied) if varied else base).with_parameters(**structural)
    if bounds:
        from ..design.bounds import scene_with_bounds

        scene = scene_with_bounds(scene, bounds)
    if task.mode == "optimise":
        from ..design.problem import DesignProblem, SolverSettings
        from ..design.repair import Repair

        problem = DesignProblem(scene, SolverSettings(**dict(task.settings)))
        model = (problem, Repair(problem))
    else:
        from ..model.analysis import Analysis
        from ..scene.resolved import ResolvedScene

        # the build serves every value of the varied parameters: none of them may be folded
        # into a constant (a mass swept from 0 must keep its term)
        model = Analysis(ResolvedScene(scene, variable=varied))
    while len(c.models) >= _CACHE_SIZE:
        c.models.pop(next(iter(c.models)))
        gc.unfreeze()   # what it held may now be garbage (see settle)
    c.models[key] = model
    c.builds += 1
    return model


def settle():
    """In a worker process, after a batch: once a model was built, the objects alive (the models'
    graphs, the scene: ~40,000 on the truck crane) are left out of the collector's full passes
    (gc.freeze; garbage collected first, so that none is kept).  Each full pass over them took
    20-46 ms, one per ~1,000 analyse cases: 0.02-0.04 ms a case.  A model dropped from the cache
    unfreezes them (:func:`_built`)."""
    c = _cache()
    if c.frozen != c.builds:
        gc.collect()
        gc.freeze()
        c.frozen = c.builds


def _model_key(task: Task, structural: dict, bounds: tuple, varied: list) -> str:
    """The key of a case's model in the cache: the JSON of what the model depends on, found by
    the values and their types (:func:`_typed`) once made (json.dumps of the solver settings:
    ~25 us a case)."""
    c = _cache()
    try:
        if c.settings[0] is not task.settings:   # the last settings seen (a batch's tasks share them)
            c.settings = (task.settings, _typed(task.settings))
        fast = (task.scene_digest, task.mode, _typed(tuple(sorted(structural.items()))), _typed(bounds),
                c.settings[1], tuple(varied))
        key = c.keys.get(fast)
    except TypeError:   # a value that is not hashable: the JSON made each time
        fast = key = None
    if key is None:
        key = json.dumps([task.scene_digest, task.mode, sorted(structural.items()), bounds,
                          task.settings, varied], default=repr)
        if fast is not None and len(c.keys) < 4096:
            c.keys[fast] = key
    return key


def _typed(value):
    """``value`` (tuples, lists and scalars) as a hashable value that is equal only for values
    of the same types with the same JSON (1, 1.0 and True apart; floats by their repr: -0.0 and
    0.0 apart); TypeError for anything else (a dict, an object: its JSON is made each time)."""
    kind = type(value)
    if kind is tuple or kind is list:
        return kind, tuple(map(_typed, value))
    if kind is float:
        return kind, repr(value)
    if kind not in _EXACT:
        raise TypeError(kind.__name__)
    return kind, value


_EXACT = (str, int, bool, type(None))   # equal values of one of these types have the same JSON


# --- one case --------------------------------------------------------------------------------
def run_task(task: Task) -> dict:
    """Compute one case: {'row': {column: value}, 'x': optimum or None, 'time_s': seconds}.

    A case that fails on purpose (a geometry that does not assemble, no start converging) is a
    finished case with ``success`` False and the reason in ``status``; any other exception is a
    bug and propagates."""
    t0 = time.perf_counter()
    row, x = _finish(_prepare(task))
    return {"row": row, "x": x, "time_s": time.perf_counter() - t0}


def _prepare(task: Task):
    """What a case needs before its computation: (task, its built model, its case scene or the
    dict of its leaf values or None), or (task, the OptdesignError that stops it, None)."""
    from ..errors import OptdesignError

    base = _scene(task)
    overrides = dict(task.overrides)
    names = _structural(task, base)
    structural = {k: v for k, v in overrides.items() if k in names}
    # a case whose overrides are numbers the study validated together (one axis) is a vector of
    # leaf values for the built model: no case scene rebuilt and validated again (94
    # dataclasses.replace per case on the truck crane); else the case's scene gives them
    vector = task.checked and all(type(v) is float for v in overrides.values())
    try:
        model = _model(task, base, structural)
        if vector or not overrides:
            scene = overrides or None
        elif task.mode == "analyse":   # case_scene's, its bounds dropped once per process
            scene = _unbounded(task, base).with_parameters(**overrides)
        else:
            scene = case_scene(base, task.mode, overrides)
    except OptdesignError as exc:
        return task, exc, None
    return task, model, scene


def prepare_all(tasks) -> list:
    """:func:`_prepare` of each of a batch's tasks (each made once), a case that sets the same
    leaf parameters as the case before it to numbers (none of them structural; the same scene,
    mode and settings, no bounds) given that case's model without looking it up again: the
    same (task, model, its values) as its own :func:`_prepare`."""
    out, last = [], None
    for task in tasks:
        if (last is not None and task.checked and task.mode == "analyse" and task.scene_digest == last.scene_digest
                and not task.bounds and task.settings is last.settings
                and [k for k, _ in task.overrides] == [k for k, _ in last.overrides]
                and all(type(v) is float for _, v in task.overrides)):
            out.append((task, out[-1][1], dict(task.overrides) or None))
            continue
        out.append(_prepare(task))
        shared = (task.checked and task.mode == "analyse" and not task.bounds and not isinstance(out[-1][1], Exception)
                  and type(out[-1][2]) is dict and not _structural(task, _scene(task)) & {k for k, _ in task.overrides})
        last = task if shared else None
    return out


def _finish(prepared):
    """(row, x) of a prepared case (:func:`_prepare`)."""
    from ..errors import OptdesignError

    task, model, scene = prepared
    try:
        if isinstance(model, OptdesignError):
            raise model
        if task.mode == "optimise":
            return _optimise(task, model, scene)
    except OptdesignError as exc:
        return failed_row(exc), None
    return _analyse_rows([prepared])[0], None


def run_batch(tasks: list, each=None) -> list:
    """Consecutive cases of one chain, in order, in one call (one Dask task for several cases):
    each case after the first is warm-started from the optimum of the one before it, exactly as
    the client would start it from the journal (None after a failed case), so a batch gives the
    numbers of the cases run one by one.  The cases of an analyse study (no chain) that share a
    build are analysed together (:meth:`~optdesign.model.analysis.Analysis.run_many`: each stage
    over all of them at once), with the numbers of each run alone.  Returns their outputs in
    order; ``each(output)`` is called as each case finishes (an analyse batch: all at its end)."""
    if len(tasks) > 1 and all(t.mode == "analyse" for t in tasks):
        t0 = time.perf_counter()
        rows = _analyse_rows(prepare_all(tasks))
        per_case = (time.perf_counter() - t0) / len(tasks)   # the batch's time, shared
        outs = []
        for row in rows:
            outs.append({"row": row, "x": None, "time_s": per_case})
            if each is not None:
                each(outs[-1])
        return outs
    outs = []
    for task in tasks:
        outs.append(run_task(warm_from(task, outs[-1]) if outs else task))
        if each is not None:
            each(outs[-1])
    return outs


def warm_from(task: Task, before: dict) -> Task:
    """``task`` warm-started from the output of the case before it in its chain."""
    x = before["x"]
    return dataclasses.replace(task, x_warm=None if x is None else tuple(x))


def died_output(reason: str) -> dict:
    """The output recorded for a case that was not computed because the process computing it
    kept dying (see :mod:`.executors`): a failed case with the reason."""
    return {"row": {"status": f"error: {reason}", "success": False}, "x": None, "time_s": 0.0}


def _optimise(task: Task, model, scene):
    import numpy as np

    from ..design.multistart import draw_plan, solve_start, summarise
    from ..design.solver import Solver
    from ..design.starts import StartPlan, plan_starts

    problem, repair = model
    # a fresh Solver per case (a Solver passes nothing from one start to the next, so this
    # only keeps its buffers to one case)
    solver = Solver(problem)
    fixed = leaf_values(problem.fixed_names, scene, solver.fixed_values())
    t0 = time.perf_counter()

    def run(plan):
        runs = [solve_start(solver, repair, i, x0, fixed, retry=lambda k, i=i: plan.retry(i, k))
                for i, x0 in enumerate(plan.points)]
        reports, solutions = [r for r, _ in runs], [s for _, s in runs]
        return summarise(problem, solver, reports, solutions, {"total_s": time.perf_counter() - t0}, plan, fixed), reports

    fallback = None
    if task.x_warm is None:
        result, reports = run(draw_plan(problem, task.starts, task.seed, fixed))
    else:
        n = max(task.warm_starts, 1)
        cold = plan_starts(problem, n - 1, task.seed, fixed).points if n > 1 else np.zeros((0, len(problem.design_names)))
        points = np.vstack([np.asarray(task.x_warm, float)[None, :], cold])
        plan = StartPlan(points, method="warm", plan_reserve=lambda: plan_starts(problem, n, task.seed, fixed))
        result, reports = run(plan)
        fallback = False
        if not result.success:
            # a warm start (the previous case's optimum) that fails says nothing about this case:
            # a cold multistart decides before the case is reported infeasible
            result, more = run(draw_plan(problem, task.starts, task.seed, fixed))
            reports, fallback = reports + more, True
    row = {"status": result.status, "success": result.success, "objective": result.objective,
           "objective_sampled": result.objective_sampled, "peak_certified": result.peak_certified,
           "starts_total": result.starts_total, "starts_at_best": result.starts_at_best,
           "warm": task.x_warm is not None, "iterations": sum(r.iterations for r in reports)}
    row["cold_fallback"] = bool(fallback)  # in every row: a partial table has the same columns
    if not result.success:
        return row, None
    row.update({f"design:{k}": v for k, v in result.design.items()})
    for name, c in result.constraints.items():
        if c["kind"] != "bound":
            if "min" in c:
                row[f"constraint:{name}:min"], row[f"constraint:{name}:max"] = c["min"], c["max"]
            else:
                row[f"constraint:{name}"] = c["value"]
        row[f"multiplier:{name}"] = c["multiplier"]
    row.update({f"sensitivity:{k}": v for k, v in result.sensitivities.items()})
    return row, [result.design[n] for n in problem.design_names]


def batch_blocks(tasks: list, index: list, ids: list) -> list:
    """:func:`.tasks.run_batch` of the cases ``index``/``ids`` as :func:`.blocks.blocks` gives
    its outputs (blocks of rows with the same keys, in the order of their first case, each case's
    row, x and time_s), made column by column for a batch of analyse cases."""
    tasks = list(tasks)   # each task made once (a study's TaskList makes them when asked)
    if not (len(tasks) > 1 and all(t.mode == "analyse" for t in tasks)):
        return blocks(index, ids, run_batch(tasks))
    t0, c0 = time.perf_counter(), time.process_time()
    pieces = analysed.analyse(prepare_all(tasks))
    per_case = (time.perf_counter() - t0) / len(tasks)   # the batch's time, shared (run_batch's)
    cpu = (time.process_time() - c0) / len(tasks)
    merged = {}
    for positions, keys, columns in pieces:
        if keys in merged:
            merged[keys][0].extend(positions)
            for column, more in zip(merged[keys][1], columns):
                column.extend(more)
        else:
            merged[keys] = (list(positions), [list(c) for c in columns])
    made = []
    for keys, (positions, columns) in sorted(merged.items(), key=lambda item: min(item[1][0])):
        order = sorted(range(len(positions)), key=positions.__getitem__)
        if order != list(range(len(order))):
            positions = [positions[j] for j in order]
            columns = [[c[j] for j in order] for c in columns]
        made.append(Block([index[j] for j in positions], [ids[j] for j in positions], keys, columns,
                          [None] * len(positions), [per_case] * len(positions), cpu))
    return made


def _analyse_rows(prepared: list) -> list:
    """The rows of prepared analyse cases (:func:`_prepare`), those that share a built analysis
    together (:func:`.analysed.analyse`)."""
    return analysed.rows(analysed.analyse(prepared), len(prepared))
