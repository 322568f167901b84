"""Analyse cases run together (tasks.run_batch: one Analysis.run_many and sweep_rms_many over
the cases that share a build, optdesign/model/runs.py) give each case exactly the row of its own
run: the truck crane over boom and payload masses and its
geometry, a generated family of crank-rocker four-bars (Sobol, with a torque bump narrower than
the samples, as in tests/test_enclosure_fourbars.py) with one that does not assemble, and the
cases.csv of a study run case by case, in batches, on the process pool and on Dask, byte for
byte."""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.study import Study, grid, together
from optdesign.study import execute as study_execute
from optdesign.study.tasks import run_batch, run_task

from test_enclosure_fourbars import G, M2, M3, OMEGA, SCENE, designs

ROOT = Path(__file__).resolve().parents[1]


def _tasks(study):
    return [study.task(case) for case in study.cases()]


def _rows(outs):
    return [json.dumps(o["row"], sort_keys=True) for o in outs]   # floats to their last digit


@pytest.fixture(params=[None, 3], ids=["one call", "calls of 3"])
def chunk(request, monkeypatch):
    """A batch's cases analysed in one call, or in calls of 3 cases (analysed.CHUNK)."""
    from optdesign.study import analysed

    if request.param is not None:
        monkeypatch.setattr(analysed, "CHUNK", request.param)
    return request.param


def test_truck_crane_cases_in_a_batch_give_each_case_its_own_row(chunk):
    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    u = np.random.default_rng(3).random((10, 5))
    rows = [{"mB": 400 + 500 * a, "mP": 300 + 3000 * b, "b": 0.6 + 1.5 * c, "xD": -0.1 + 0.6 * d, "yD": -1.8 + 1.2 * e}
            for a, b, c, d, e in u]
    tasks = _tasks(Study(scene, [together(rows)], mode="analyse"))
    alone = [run_task(t) for t in tasks]
    assert all(o["row"]["success"] for o in alone)
    assert _rows(run_batch(tasks)) == _rows(alone)


def test_a_family_of_four_bars_in_a_batch_gives_each_its_own_row():
    cases = [{k: float(v) for k, v in d.items()} for d in designs(8, seed=11)]
    scene = optdesign.loads(SCENE.format(side="left", g=G, omega=OMEGA, m2=M2, m3=M3, **cases[0]), "four-bars")
    cases.append(dict(cases[0], a=4.0))   # not a crank-rocker: does not assemble over the sweep
    tasks = _tasks(Study(scene, [together(cases)], mode="analyse"))
    alone = [run_task(t) for t in tasks]
    assert not alone[-1]["row"]["success"] and sum(o["row"]["success"] for o in alone) >= 3
    assert _rows(run_batch(tasks)) == _rows(alone)


def test_a_batch_made_column_by_column_gives_the_blocks_of_its_cases_run_alone(chunk):
    """tasks.batch_blocks (a batch's rows made a column at a time on the worker) gives the
    blocks that .blocks.blocks makes from the rows of each case run alone: the same cases in the
    same blocks in the same order, the same keys and values, the same journal lines (but for the
    batch's shared time_s); a case that does not assemble mid-batch makes a block of its own.
    Analysed in calls of 3 cases (the failing one in the first), the blocks are the same."""
    import re

    from optdesign.study.tasks import batch_blocks
    from optdesign.study.blocks import blocks

    cases = [{k: float(v) for k, v in d.items()} for d in designs(8, seed=5)]
    scene = optdesign.loads(SCENE.format(side="left", g=G, omega=OMEGA, m2=M2, m3=M3, **cases[0]), "four-bars")
    cases.insert(2, dict(cases[0], a=4.0))   # not a crank-rocker: does not assemble over the sweep
    study = Study(scene, [together(cases)], mode="analyse")
    tasks = _tasks(study)
    index, ids = [c.index for c in study.cases()], [c.id for c in study.cases()]
    made, alone = batch_blocks(tasks, index, ids), blocks(index, ids, [run_task(t) for t in tasks])
    assert len(made) == len(alone) == 2 and sum(len(b) for b in made) == len(cases)
    timeless = re.compile(r'"time_s":[^}]*}')
    for mine, theirs in zip(made, alone):
        assert (mine.index, mine.ids, mine.keys, mine.values, mine.x) == \
            (theirs.index, theirs.ids, theirs.keys, theirs.values, theirs.x)
        assert [type(v) for c in mine.values for v in c] == [type(v) for c in theirs.values for v in c]
        assert [timeless.sub("", line) for line in mine.lines()] == [timeless.sub("", line) for line in theirs.lines()]


def test_a_models_cache_key_is_the_json_of_what_it_depends_on_also_when_found_again():
    """tasks._model_key: the key found again by values and types (not json.dumps per case) is
    the JSON of the case's inputs; values equal in Python but not in JSON (1, 1.0, True; 0.0
    and -0.0) keep their own keys; settings that cannot be hashed still give their JSON."""
    import dataclasses

    from optdesign.study.tasks import Task, _model_key

    base = Task(b"", "d1", "analyse", (("mP", 1.0),), (), 1, 0, 1, (("tol", 1e-10), ("grid", 13)), None)
    cases = [({}, ()), ({"n": 1}, ()), ({"n": 1.0}, ()), ({"n": True}, ()), ({"n": 0.0}, ()), ({"n": -0.0}, ()),
             ({"n": "1"}, ()), ({}, (("c", "upper", 2.0),)), ({}, (("c", "upper", 2),))]
    for settings in (base.settings, (("tol", 1e-10), ("grid", 13.0)), (("options", {"a": 1}),)):
        task = dataclasses.replace(base, settings=settings)
        for _ in range(2):   # made, then found again
            keys = [_model_key(task, structural, bounds, ["mP"]) for structural, bounds in cases]
            assert keys == [json.dumps(["d1", "analyse", sorted(structural.items()), bounds, settings, ["mP"]],
                                       default=repr) for structural, bounds in cases]
            assert len(set(keys)) == len(cases)


def test_a_batchs_cases_prepared_together_are_each_prepared_as_alone():
    """tasks.prepare_all (a case that sets the same leaf numbers as the one before it takes its
    model without a lookup) gives each case the model and values of its own tasks._prepare: leaf
    cases, other names set, a structural parameter (the sweep's start: another build), a value
    that is not a float and cases not checked together (their case scenes), a model that fails."""
    import dataclasses

    from optdesign.study.tasks import _prepare, prepare_all

    text = (ROOT / "problems" / "truck_crane.toml").read_text()
    text = text.replace('from = "-10 deg"', 'from = "th0"').replace("[parameters]\n", "[parameters]\nth0 = -0.17\n")
    scene = optdesign.loads(text, "truck_crane_th0.toml")
    study = Study(scene, [grid("mB", 500, 800, 2), grid("mP", 500, 3000, 3)], mode="analyse")
    tasks = _tasks(study)
    assert all(t.checked for t in tasks)
    mixed = tasks[:3] + [dataclasses.replace(t, overrides=t.overrides[1:]) for t in tasks[3:5]] + [
        dataclasses.replace(tasks[0], overrides=tasks[0].overrides + (("th0", -0.2),)),
        dataclasses.replace(tasks[1], overrides=tasks[1].overrides + (("th0", -0.2),)),
        dataclasses.replace(tasks[2], overrides=(("mP", 1000),)), tasks[3],
        dataclasses.replace(tasks[4], checked=False), tasks[5],
        dataclasses.replace(tasks[0], overrides=(("mP", 700.0), ("th0", 2.0))),   # the sweep's ends swapped
        dataclasses.replace(tasks[1], overrides=(("mP", 800.0), ("th0", 2.0))), tasks[0]]
    together, alone = prepare_all(mixed), [_prepare(t) for t in mixed]
    assert len(together) == len(alone) == len(mixed)
    for (t1, m1, v1), (t2, m2, v2) in zip(together, alone):
        assert t1 is t2
        assert m1 is m2 if not isinstance(m2, Exception) else str(m1) == str(m2)
        assert type(v1) is type(v2) and (v1 == v2 if type(v2) in (dict, type(None)) else v1.parameters == v2.parameters)
    assert len({id(m) for _, m, _ in alone}) >= 3   # builds: the leaf cases', the th0 cases', the failed one


def test_batch_sizes_follow_the_processor_time_per_case_of_the_last_batches():
    """execute._work: a batch's seconds per case are the processor time of the process that
    computed it where the blocks carry it (on a busy machine its wall time is several times
    more), else its wall time; execute._group_size: the median of the last batches, so that a
    worker's first batch (the model's build) does not keep the next ones small."""
    import collections

    from optdesign.study.blocks import Block

    ids = [f"{i:016x}" for i in range(4)]
    timed = Block(range(4), ids, ("status",), [["ok"] * 4], [None] * 4, [0.005] * 4, 0.001)
    untimed = Block(range(4), ids, ("status",), [["ok"] * 4], [None] * 4, [0.005] * 4)
    assert study_execute._work([timed], 4) == 0.001
    assert study_execute._work([untimed], 4) == 0.005
    assert study_execute._work([timed, untimed], 8) == 0.005   # not measured everywhere: the wall time

    class Pool:
        window = 4

    work = collections.deque([0.1, 0.1, 0.001, 0.001, 0.001], maxlen=study_execute.GROUP_SEEN)
    assert study_execute._group_size(Pool(), work, 10**6) == int(study_execute.GROUP_S / 0.001)
    assert study_execute._group_size(Pool(), collections.deque(), 10**6) == study_execute.GROUP_FIRST


@pytest.fixture(scope="module")
def crane_study():
    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    return Study(scene, [grid("mP", 300, 3300, 24)], mode="analyse")


@pytest.fixture(scope="module")
def one_by_one(crane_study, tmp_path_factory):
    folder = tmp_path_factory.mktemp("one_by_one")
    old = study_execute.BATCH_MAX
    study_execute.BATCH_MAX = 1   # batches of one case: each run alone (tasks.run_task)
    try:
        crane_study.run(out=folder, workers=1, figures=False)
    finally:
        study_execute.BATCH_MAX = old
    return (folder / "cases.csv").read_bytes()


@pytest.mark.parametrize("where", ["serial", "pool"])
def test_cases_csv_in_batches_is_the_one_by_one_file(crane_study, one_by_one, tmp_path, where):
    result = crane_study.run(out=tmp_path, workers=1 if where == "serial" else 2, figures=False)
    assert result.computed == 24 and all(r["success"] for r in result.rows)
    assert (tmp_path / "cases.csv").read_bytes() == one_by_one


def test_cases_csv_on_dask_is_the_one_by_one_file(crane_study, one_by_one, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        result = crane_study.run(out=tmp_path, scheduler=cluster.scheduler_address, figures=False)
    assert result.computed == 24
    assert (tmp_path / "cases.csv").read_bytes() == one_by_one


def test_an_enclosure_with_a_parameter_row_per_interval_bounds_each_as_its_own_vector():
    """The array interface batching relies on (kinematics/enclosure.py): parameters of shape
    intervals x parameters give each interval exactly the bounds of its own vector."""
    from optdesign.model.analysis import Analysis
    from optdesign.scene.resolved import ResolvedScene

    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    analysis = Analysis(ResolvedScene(scene, variable=["mB", "mP", "b"]))
    names, base = analysis.mech.parameter_names, np.asarray(analysis.mech.parameter_values, float)
    rng = np.random.default_rng(5)
    ps = np.repeat(base[None, :], 3, axis=0)
    for k, (name, lo, hi) in enumerate((("mB", 300, 900), ("mP", 0, 3000), ("b", 0.6, 2.5))):
        ps[:, names.index(name)] = rng.uniform(lo, hi, 3)
    s0, s1 = sorted((analysis.s_values[0], analysis.s_values[-1]))
    edges = np.sort(rng.uniform(s0, s1, (3, 41)), axis=1)
    lo, hi = edges[:, :-1], edges[:, 1:]
    enclosures = analysis.certified.enclosures
    alone = [enclosures.at(p).bounds(a, b) for p, a, b in zip(ps, lo, hi)]
    together_ = enclosures.at(np.repeat(ps, 40, axis=0)).bounds(lo.ravel(), hi.ravel())
    for k, one in enumerate(alone):
        for x, y in zip(one, together_):
            np.testing.assert_array_equal(x, y[:, 40 * k:40 * (k + 1)])


@pytest.fixture
def compiling(tmp_path, monkeypatch):
    """Compiled code on (a fresh disk cache, compiled on demand), as outside the tests."""
    from optdesign.model import compiled

    monkeypatch.delenv("OPTDESIGN_NO_COMPILE", raising=False)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "wait")
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(tmp_path / "cache"))
    compiled._compiler.clear()
    yield
    compiled._compiler.clear()


@pytest.mark.skipif(shutil.which(os.environ.get("CC", "gcc")) is None,
                    reason="no C compiler on this machine: nothing compiled to compare")
@pytest.mark.slow   # ~10 s compiling; fast siblings: the batch tests above (numpy) and tests/test_compiled.py
def test_compiled_the_sweep_rms_and_a_batch_give_the_virtual_machines_and_each_case_its_own_numbers(
        compiling, monkeypatch):
    """With compiled code (the interval programs, the model's blocks and the RMS integrand from
    the disk cache), a batch still gives each case its own row, and an analyse row's rms:*
    (Analysis.sweep_rms) equal those of numpy's evaluation instruction by instruction (without
    compiled code) to the last digit."""
    from optdesign.model import compiled as compiled_module
    from optdesign.model.analysis import Analysis

    scene = optdesign.load(ROOT / "problems" / "truck_crane.toml")
    tasks = _tasks(Study(scene, [grid("mP", 0, 3000, 5)], mode="analyse"))
    alone = [run_task(t) for t in tasks]
    assert _rows(run_batch(tasks)) == _rows(alone)
    compiled = Analysis(scene, certify=False)
    compiled.sweep_rms(compiled.mech.parameter_values)   # its function made (compiled) at the first call
    monkeypatch.setenv("OPTDESIGN_NO_COMPILE", "1")
    machine = Analysis(scene, certify=False)
    for mP in (0.0, 1234.5, 3000.0):
        p = np.array(compiled.mech.parameter_values, float)
        p[compiled.mech.parameter_names.index("mP")] = mP
        assert compiled.sweep_rms(p) == machine.sweep_rms(p)
    # the comparison is between the compiled blocks and numpy's evaluation (a compiler is here)
    from optdesign.model.blocked import BlockedFunction
    from optdesign.model.vectorised import VectorisedSX

    assert isinstance(compiled._squares[1], BlockedFunction)
    assert isinstance(machine._squares[1], VectorisedSX)
