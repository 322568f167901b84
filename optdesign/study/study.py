"""Design studies: many analyses or optimisations of one scene (front door :class:`Study`).

A study is a list of *cases*, the cartesian product of its axes (the last axis varies
fastest).  An axis is a sweep of one parameter (:func:`grid`, :func:`values`), a list of cases
in which several parameters change together (:func:`together`), or the bound of one of the
scene's constraints (:func:`pareto`): minimising the objective for each bound value traces the
Pareto front between the objective and the constrained quantity (epsilon-constraint method).

Optimisation cases along the last axis form *chains*: each case starts from the previous
case's optimum (a warm start, plus ``warm_starts - 1`` of the cold starts), the first case of a
chain from ``starts`` cold starts.  Chains are cut every ``chain`` cases, a fixed length, so
that their number, and every result, is the same whatever runs them.  A chain's cases run in
order; different chains run in parallel: in this process (``workers=1``), over the machine's
cores (a process pool, the default), or on a Dask cluster (``scheduler=ADDRESS``).  A case's
result is a pure function of its content (:mod:`optdesign.study.tasks`), so the three give
byte-identical CSV files.

Every finished case is appended to ``journal.jsonl`` at once (:mod:`optdesign.study.journal`); a
study that was interrupted (Ctrl-C, a killed process) resumes, when run again with the same
folder, without redoing any finished case.  ``cases.csv`` (one row per case, in case order),
figures and ``summary.txt`` are written at the end, atomically.

    >>> study = Study(load("problems/truck_crane.toml"), [grid("mP", 500, 3000, 6), values("L", [5, 6, 7])])
    >>> result = study.run(out="results/truck_crane_study")     # doctest: +SKIP
"""
from __future__ import annotations

import collections.abc
import dataclasses
import functools
import hashlib
import json
import math
import pickle
from pathlib import Path

from ..errors import SceneError
from ..scene.arguments import scene_argument, study_cases, whole
from .caselist import Case, Cases
from .axes import Axis, _constant, _number, grid, pareto, together, values  # noqa: F401  (re-exported)
from .results import StudyInterrupted, StudyResult  # noqa: F401  (re-exported)
from .tasks import Task, case_scene, scene_digest
from .validity import CORNERS_MAX, corners, ranged as all_ranged, recorded_checks

MODES = ("optimise", "analyse")


# --- the study --------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Study:
    """Many analyses (``mode='analyse'``) or optimisations (``'optimise'``) of one scene.

    ``axes``: a list of :class:`Axis` (from :func:`grid`, :func:`values`, :func:`together`,
    :func:`pareto`) or a dict {parameter: values}.  ``starts``/``seed``: the cold starts of an
    optimisation case (the scene's start, then the best screened space-filling points:
    :func:`~optdesign.design.starts.plan_starts`); ``warm``: chain the cases along the last axis,
    each starting from the previous optimum and ``warm_starts - 1`` cold starts (falling back to
    the cold starts when that fails); ``chain``: cases per chain at most; ``settings``: a
    :class:`~optdesign.design.problem.SolverSettings`."""

    scene: object
    axes: tuple = ()
    mode: str = "optimise"
    starts: int = 8
    seed: int = 0
    warm: bool = True
    warm_starts: int = 1
    chain: int = 25
    settings: object = None

    def __post_init__(self):
        scene_argument("Study", self.scene)
        axes = self.axes
        if not isinstance(axes, (dict, Axis, list, tuple)) or any(
                not isinstance(a, Axis) for a in (axes if isinstance(axes, (list, tuple)) else ())):
            raise TypeError("Study: axes: expected a list of axes (grid(...), values(...), together(...), "
                            f"pareto(...)) or a dict {{parameter: values}}, found {type(axes).__name__} {axes!r:.80}")
        if isinstance(axes, dict):
            axes = [values(k, v) for k, v in axes.items()]
        elif isinstance(axes, Axis):
            axes = [axes]
        axes = [self._resolve(a) for a in axes]
        # a Pareto axis is the last one: the front is drawn along it and its chain runs along it
        axes = [a for a in axes if a.kind != "pareto"] + [a for a in axes if a.kind == "pareto"]
        if sum(a.kind == "pareto" for a in axes) > 1:
            raise SceneError("study: at most one pareto axis (a front between the objective and one constraint)")
        object.__setattr__(self, "axes", tuple(axes))
        if self.settings is None:
            from ..design.problem import SolverSettings

            object.__setattr__(self, "settings", SolverSettings())
        self._validate()

    # --- checks ---
    def _resolve(self, axis: Axis) -> Axis:
        """A Pareto axis with its side filled in from the scene's constraint."""
        if axis.kind != "pareto":
            return axis
        c = next((c for c in self.scene.constraints if c.name == axis.constraint), None)
        if c is None:
            from ..scene.expressions import near_miss

            names = [c.name for c in self.scene.constraints]
            raise SceneError(f"{self.scene.path}: pareto axis: the scene has no constraint {axis.constraint!r}"
                             + near_miss(axis.constraint, names) + f" (its constraints: {', '.join(names) or 'none'})")
        side = axis.side
        if side is None:
            sides = [s for s, e in (("min", c.lower), ("max", c.upper)) if e is not None]
            if len(sides) != 1:
                raise SceneError(f"{self.scene.path}: pareto axis {c.name!r} has both a min and a max bound: "
                                 f"say which one to sweep ({c.name}.min=... or {c.name}.max=...)")
            side = sides[0]
        points = tuple(((f"bound:{c.name}:{side}", p[0][1]),) for p in axis.points)
        return Axis("pareto", points, c.name, side)

    def _validate(self):
        sc = self.scene
        if self.mode not in MODES:
            raise SceneError(f"study mode must be one of {', '.join(MODES)}, found {self.mode!r}")
        for what in ("starts", "warm_starts", "chain"):
            if int(getattr(self, what)) < 1:
                raise SceneError(f"study: {what} must be at least 1, found {getattr(self, what)!r}")
        object.__setattr__(self, "seed", whole("Study: seed", self.seed, 0))
        study_cases("Study: cases", math.prod(len(a) for a in self.axes), self.columns_estimate())
        if self.mode == "optimise":
            if sc.objective is None:
                raise SceneError(f"{sc.path}: an optimise study needs an [objective] table (or use mode 'analyse')")
            if not any(p.is_design for p in sc.parameters):
                raise SceneError(f"{sc.path}: an optimise study needs design variables (parameters with min/max)")
        elif sc.drive is None:
            raise SceneError(f"{sc.path}: an analyse study needs a [drive] table")
        seen = set()
        for axis in self.axes:
            if axis.kind == "pareto" and self.mode != "optimise":
                raise SceneError("a pareto axis needs mode 'optimise' (it minimises the objective for each bound)")
            for col in axis.columns:
                if col in seen:
                    raise SceneError(f"study: {col!r} is on two axes")
                seen.add(col)
            design = sorted({n for point in axis.points for n in dict(point)} & {p.name for p in sc.parameters if p.is_design}) \
                if axis.kind != "pareto" and self.mode == "optimise" else []
            if design:
                raise SceneError(f"study: {design[0]!r} is a design variable of {sc.path}: each optimisation chooses it, "
                                 f"so an axis over it would only move the start and every case would give the same "
                                 f"optimum; use --mode analyse to evaluate it at given values, or make it a fixed "
                                 f"parameter in the scene (a number instead of {{ value, min, max }}) to optimise the rest")
        self._validate_points()

    def _validate_points(self):
        """Unknown names and bad values fail here, early: every case's scene is known valid
        (:mod:`.validity`: the axes' corners checked where that suffices, else each point of
        each axis, and combinations of several axes where each case runs)."""
        sc, axes = self.scene, [a for a in self.axes if a.kind != "pareto"]
        if not axes:
            return
        first = dict(p for a in axes for p in a.points[0])
        calls = recorded_checks(lambda: case_scene(sc, self.mode, first))
        ranged = all_ranged(axes, calls) and len(corners(axes)) <= CORNERS_MAX
        if ranged:   # the corners' checks recorded too: a check that runs only at other values is seen
            for corner in corners(axes):
                calls += recorded_checks(lambda: case_scene(sc, self.mode, corner))
            ranged = all_ranged(axes, calls)
        if not ranged:
            for axis in axes:
                for point in axis.points:
                    case_scene(sc, self.mode, dict(point))
        # every combination known valid: the cases run as vectors of leaf values (tasks.Task.checked)
        object.__setattr__(self, "_all_valid", ranged or len(axes) <= 1)

    def columns_estimate(self) -> int:
        """About how many columns a case's row has (for the memory check): identification and
        inputs, then per mode its results (an analysis: 3 per peak of 4 quantities, 2 RMS, 2 per
        constraint, ~16 for load cases; an optimisation: ~10, the design, 3 per constraint, a
        sensitivity per parameter)."""
        sc = self.scene
        n = 4 + len(self.input_columns) + 2
        if self.mode == "analyse":
            return n + 12 + 2 + 2 * len(sc.constraints) + (16 if sc.cases else 0)
        return n + 10 + sum(p.is_design for p in sc.parameters) + 3 * len(sc.constraints) + len(sc.parameters)

    # --- cases ---
    @property
    def input_columns(self) -> list:
        return [c for a in self.axes for c in a.columns]

    def cases(self) -> Cases:
        """The cases in study order (the last axis fastest), with chains and ids: a lazy sequence
        (:class:`~optdesign.study.caselist.Cases`: 8 bytes per case, each Case made when asked for)."""
        chained = self.warm and self.mode == "optimise"
        return Cases(self.axes, int(self.chain) if chained else None,
                     {"scene": scene_digest(self.scene), "mode": self.mode, "run": self._run_settings()})

    def _run_settings(self) -> dict:
        if self.mode == "analyse":
            return {}
        return {"starts": int(self.starts), "seed": int(self.seed), "warm_starts": int(self.warm_starts),
                "settings": dataclasses.asdict(self.settings)}

    @functools.cached_property
    def _settings_items(self) -> tuple:
        """The solver settings as a task carries them, made once (asdict costs ~1 ms: a million
        cases' tasks took as long as their analyses)."""
        return tuple(dataclasses.asdict(self.settings).items())

    def task(self, case: Case, x_warm=None, blob=None, digest=None) -> Task:
        """The worker's view of a case (see :func:`optdesign.study.tasks.run_task`)."""
        return self.tasks([case.overrides], [case.bounds], x_warm, blob, digest)[0]

    def tasks(self, overrides: list, bounds: list, x_warm=None, blob=None, digest=None) -> "TaskList":
        """The tasks of a batch of cases (their ``overrides`` and ``bounds``; ``x_warm`` the first
        one's warm start), each :class:`~optdesign.study.tasks.Task` made when asked for: where the
        batch is computed, not here (the client's cost per case)."""
        return TaskList((blob if blob is not None else pickle.dumps(self.scene), digest or scene_digest(self.scene),
                         self.mode, int(self.starts), int(self.seed), int(self.warm_starts), self._settings_items,
                         self._checked), overrides, bounds, None if x_warm is None else tuple(x_warm))

    @property
    def _checked(self) -> bool:
        """Whether every case's overrides are known valid together (:meth:`_validate_points`)."""
        return getattr(self, "_all_valid", True)

    def default_folder(self) -> Path:
        """``optdesign-results/<scene>_study-<axes>-<digest>`` under the current directory: named
        from the scene and the study's axes, with a digest of the scene, the mode, the axes'
        values and the run settings, so that two different studies never share a folder while
        the same study, run again, resumes in its own."""
        import re

        stem = Path(self.scene.path).stem if self.scene.path not in ("", "<python>") else "scene"
        axes = "-".join(re.sub(r"[^A-Za-z0-9_.=]+", "_", a.label) for a in self.axes)[:60] or "cases"
        content = {"scene": scene_digest(self.scene), "mode": self.mode, "run": self._run_settings(),
                   "axes": [dataclasses.asdict(a) for a in self.axes]}
        digest = hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode()).hexdigest()[:8]
        return Path("optdesign-results") / f"{stem}_study-{axes}-{digest}"

    def run(self, out=None, workers: int | None = None, scheduler=None, progress=None,
            restart: bool = False, figures: bool = True) -> "StudyResult":
        """Run (or resume) the study into folder ``out`` (default :meth:`default_folder`).

        ``workers``: processes on this machine (default: its cores; 1 runs in this process);
        ``scheduler``: a Dask scheduler address, or a ``distributed.Client``, to run there
        instead; ``progress(done, total)`` after each case; ``restart``: forget finished cases.
        Raises :class:`StudyInterrupted` on Ctrl-C after keeping every finished case."""
        from .execute import execute

        return execute(self, Path(out) if out else self.default_folder(), workers, scheduler,
                       progress, restart, figures)


class TaskList(collections.abc.Sequence):
    """A batch's tasks: what they share held once, each :class:`~optdesign.study.tasks.Task`
    made when asked for (``tasks[j]``; a slice gives a list)."""

    __slots__ = ("common", "overrides", "bounds", "x_warm")

    def __init__(self, common, overrides, bounds, x_warm):
        self.common, self.overrides, self.bounds, self.x_warm = common, overrides, bounds, x_warm

    def __len__(self):
        return len(self.overrides)

    def __getitem__(self, j):
        if isinstance(j, slice):
            return [self[k] for k in range(*j.indices(len(self)))]
        blob, digest, mode, starts, seed, warm_starts, settings, checked = self.common
        j = range(len(self))[j]
        return Task(blob, digest, mode, self.overrides[j], self.bounds[j], starts, seed, warm_starts, settings,
                    self.x_warm if j == 0 else None, checked)

    def __getstate__(self):
        return self.common, self.overrides, self.bounds, self.x_warm

    def __setstate__(self, state):
        self.common, self.overrides, self.bounds, self.x_warm = state


__all__ = ["Study", "StudyResult", "StudyInterrupted", "Axis", "Case", "grid", "values", "together", "pareto"]
