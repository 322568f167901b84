"""Compiled Functions cached on disk (optdesign/model/compiled.py, model/blocked.py): the same
numbers as CasADi's virtual machine, a damaged cache entry found and rebuilt, the fallback
without a compiler said once, the opt-out, the background compiler, and a key that another
process (a study's worker) finds again.  Each test has its own cache folder."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from optdesign import load
from optdesign.model import blocked, compiled
from optdesign.model.analysis import Analysis
from optdesign.model.blocked import BlockedFunction, stroke_evaluator
from optdesign.model.vectorised import VectorisedSX

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(compiled.shutil.which(os.environ.get("CC", "gcc")) is None,
                                reason="no C compiler on this machine")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh cache folder, compiling on demand (wait), no memory of earlier warnings."""
    monkeypatch.delenv("OPTDESIGN_NO_COMPILE", raising=False)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "wait")
    monkeypatch.setenv("OPTDESIGN_CACHE_DIR", str(tmp_path / "cache"))
    compiled._compiler.clear()
    compiled._warned.clear()
    yield tmp_path / "cache"
    compiled._compiler.clear()
    compiled._warned.clear()


def small_function():
    """Every kind of operation the blocked code writes, on a value that varies with s and on
    parameters alone; NaN where sqrt(negative) (a design that does not assemble)."""
    s, p = ca.SX.sym("s"), ca.SX.sym("p", 3)
    a = ca.sqrt(p[0] - s**2) / (1 + ca.fabs(s)) + ca.atan2(s, p[1]) * ca.sign(s - 0.1)
    b = ca.if_else(s <= p[2], ca.sin(s) * ca.cos(p[1]), 1 / (s + 2)) - 2 * p[2] ** 3
    return ca.Function("small", [s, p], [a, b, p[0] * p[1]], ["s", "p"], ["a", "b", "c"], {"cse": True})


def vm(func, s, p):
    out = func.map(len(s))(s[None, :], p)
    out = out if isinstance(out, (list, tuple)) else [out]
    return {func.name_out(j): np.broadcast_to(np.asarray(o, float).ravel(), (len(s),)) for j, o in enumerate(out)}


def assert_same(got: dict, expected: dict):
    for name, value in expected.items():
        mine = np.broadcast_to(np.asarray(got[name], float), value.shape)
        finite = np.isfinite(value)
        assert np.array_equal(finite, np.isfinite(mine)), name
        scale = max(float(np.max(np.abs(value[finite]), initial=0.0)), 1e-300)
        assert np.max(np.abs(mine[finite] - value[finite]), initial=0.0) <= 1e-15 * scale, name


S = np.linspace(-1.5, 1.5, 1001)   # not a whole number of blocks; sqrt(1 - s^2) NaN outside |s| <= 1
P = np.array([1.0, 0.7, 0.3])


def test_small_function_compiled_equals_the_virtual_machine(cache):
    f = small_function()
    ev = stroke_evaluator(f)
    assert isinstance(ev, BlockedFunction)
    assert_same(ev(S, P), vm(f, S, P))
    assert_same(ev(S[:5], P), vm(f, S[:5], P))          # fewer samples than a block
    assert sorted(p.suffix for p in cache.glob("external-*") if p.suffix != ".lock") == [".json", ".so"]


def test_many_cases_in_whole_chunks_equal_each_case_alone(cache):
    """BlockedFunction.many and .ragged (as many values per case, and not) over enough cases for
    several whole mapped calls of CHUNK blocks (read and written in place) and a partial one: each
    case's values are those of its own call (==), whatever the batch; NaN where the case's sqrt is
    undefined."""
    from optdesign.model.blocked import BLOCK, CHUNK

    ev = stroke_evaluator(small_function())
    rng = np.random.default_rng(7)
    cases = 2 * CHUNK + 5   # S: 16 blocks per case, many whole chunks and a partial one
    params = np.column_stack([rng.uniform(0.2, 3.0, cases), rng.uniform(-1, 1, cases), rng.uniform(-1, 1, cases)])
    got = ev.many(S, params)
    counts = rng.integers(0, 3 * BLOCK, cases)
    counts[3] = 0   # a case without values
    points = rng.uniform(-1.5, 1.5, counts.sum())
    ragged = ev.ragged(points, counts, params)
    ends = np.cumsum(counts)
    even = rng.uniform(-1.5, 1.5, 100 * cases)
    equal = ev.ragged(even, np.full(cases, 100), params)   # as many values each
    for i in range(cases):
        alone = ev(S, params[i])
        mine = ev(points[ends[i] - counts[i]:ends[i]], params[i])
        mine_equal = ev(even[100 * i:100 * (i + 1)], params[i])
        for name in ev.names:
            # cases x values, a view of the padded blocks (not copied): each case's row contiguous
            assert got[name].shape == (cases, len(S)) and got[name].strides[1] == got[name].itemsize
            assert np.array_equal(got[name][i], alone[name], equal_nan=True), (i, name)
            assert np.array_equal(ragged[name][ends[i] - counts[i]:ends[i]], mine[name], equal_nan=True), (i, name)
            assert np.array_equal(equal[name][100 * i:100 * (i + 1)], mine_equal[name], equal_nan=True), (i, name)


@pytest.mark.parametrize("scene", ["truck_crane", "level_luffing_crane"])
def test_blocks_compiled_at_their_level_equal_the_general_flags_bit_for_bit(cache, scene):
    """The blocked model compiled at blocked.LEVEL (-O2, its library's flags say so) gives the
    numbers of the same C compiled at FLAGS' -O1, bit for bit (==: no fast-math, no contraction),
    on a stroke of many blocks and its ragged ends, for several parameter rows."""
    import json

    analysis = Analysis(load(ROOT / "problems" / f"{scene}.toml"), samples=1001, certify=False)
    fast = analysis.vectorised
    assert isinstance(fast, BlockedFunction)
    flags = [json.loads(m.read_text())["flags"][0] for m in cache.glob("external-*.json")]
    assert flags == [blocked.LEVEL] and blocked.LEVEL != compiled.FLAGS[0]
    f = analysis.function
    general = BlockedFunction(compiled.external(f, "optdesign_blocked", lambda name: blocked.blocked_source(f, name, blocked.BLOCK)))
    P = analysis.mech.parameter_values * np.array([[1.0], [0.9], [1.1]])
    for s in (analysis.s_values, analysis.s_values[:7], analysis.s_values[::3]):
        got, expected = fast.many(s, P), general.many(s, P)
        assert all(np.array_equal(got[k], expected[k], equal_nan=True) for k in fast.names)


@pytest.mark.parametrize("scene, axes", [("truck_crane", ("mB", "mP")), ("level_luffing_crane", None)])
def test_cases_sharing_the_sweep_equal_each_case_alone(cache, scene, axes):
    """A study's build (its axes' parameters variable) runs many cases that share their sweep
    values in one call of the library's NAME_cases, the work that depends on s alone once per
    block: each case's values equal its own call of the plain library (==, NaN included), for the
    model over the stroke and for the RMS quadrature's nodes; parameter rows that differ
    elsewhere, and rows of different sweep values, take the plain path, with the same numbers."""
    from optdesign.scene.resolved import ResolvedScene

    base = load(ROOT / "problems" / f"{scene}.toml")
    names = Analysis(base, certify=False).mech.parameter_names
    axes = axes or names[-2:]   # the last two leaves, whatever they are
    study = Analysis(ResolvedScene(base.without_bounds(*axes), variable=list(axes)), samples=301, certify=False)
    plain = Analysis(base, samples=301, certify=False)
    assert study.vectorised._cases is not None and plain.vectorised._cases is None
    rng = np.random.default_rng(3)
    P = np.tile(study.mech.parameter_values, (70, 1))
    for name in axes:
        k = names.index(name)
        P[:, k] *= rng.uniform(0.2, 3.0, len(P))
    P[5, names.index(axes[0])] = -1e30    # a case whose values overflow or are not finite
    s = study.s_values
    assert study.vectorised._shared(np.broadcast_to(s, (len(P), len(s))), P)
    for S, Q in ((s, P), (s[:9], P[:3]), (s, P[:1])):
        got, alone = study.vectorised.many(S, Q), [plain.vectorised(S, q) for q in Q]
        for name in study.vectorised.names:
            assert all(np.array_equal(got[name][i], alone[i][name], equal_nan=True) for i in range(len(Q))), name
    other = P.copy()
    other[7, [k for k, n in enumerate(names) if n not in axes][0]] *= 1.01   # a fixed parameter differs in one case
    assert not study.vectorised._shared(np.broadcast_to(s, (len(P), len(s))), other)
    got = study.vectorised.many(s, other)
    assert all(np.array_equal(got["drive"][i], plain.vectorised(s, q)["drive"], equal_nan=True)
               for i, q in enumerate(other))
    live = np.arange(len(P)) != 5
    assert study.sweep_rms_many(P[live]) == plain.sweep_rms_many(P[live])


@pytest.mark.parametrize("scene", ["level_luffing_crane", "seed1_slider_crank"])
def test_reduced_model_compiled_equals_the_virtual_machine(cache, scene):
    analysis = Analysis(load(ROOT / "problems" / f"{scene}.toml"), samples=2001, certify=False)
    assert isinstance(analysis.vectorised, BlockedFunction)
    p = analysis.mech.parameter_values
    assert_same(analysis.vectorised(analysis.s_values, p), vm(analysis.function, analysis.s_values, p))
    # a second build finds the library in the cache (no compiler run: the folder is unchanged)
    before = sorted(cache.iterdir())
    again = Analysis(load(ROOT / "problems" / f"{scene}.toml"), samples=2001, certify=False)
    assert isinstance(again.vectorised, BlockedFunction) and sorted(cache.iterdir()) == before


def test_design_nlp_compiled_gives_the_same_optimum(cache, monkeypatch):
    from optdesign.design.multistart import optimise
    from optdesign.design.problem import SolverSettings

    settings = SolverSettings(grid=5, slots=2)
    scene = load(ROOT / "problems" / "seed1_jib.toml")
    monkeypatch.setenv("OPTDESIGN_NO_COMPILE", "1")
    reference = optimise(scene, starts=3, settings=settings)
    monkeypatch.delenv("OPTDESIGN_NO_COMPILE")
    result = optimise(scene, starts=3, settings=settings)
    assert list(cache.glob("nlpsol-*.so")), "the NLP was not compiled"
    assert result.objective == pytest.approx(reference.objective, rel=1e-12)
    assert [s.iterations for s in result.starts] == [s.iterations for s in reference.starts]


def _nlp_flags(cache) -> list:
    import json

    return sorted(json.loads(m.read_text())["flags"][0] for m in cache.glob("nlpsol-*.json"))


def test_an_nlp_is_compiled_optimised_up_to_its_own_limit(cache, monkeypatch):
    """An NLP solver's C above the general -O0 limit (LARGE_SOURCE, here made small) is still
    compiled at -O1 up to NLP_OPTIMISED_SOURCE, at -O0 beyond it; the optimum and every
    start's iterations are the same either way (IEEE arithmetic, no contraction)."""
    from optdesign.design.multistart import optimise
    from optdesign.design.problem import SolverSettings

    settings = SolverSettings(grid=5, slots=2)
    scene = load(ROOT / "problems" / "seed1_jib.toml")
    monkeypatch.setattr(compiled, "LARGE_SOURCE", 1000)
    optimised = optimise(scene, starts=2, settings=settings)
    assert _nlp_flags(cache) and set(_nlp_flags(cache)) == {"-O1"}
    monkeypatch.setattr(compiled, "NLP_OPTIMISED_SOURCE", 1000)   # another key: compiled again
    plain = optimise(scene, starts=2, settings=settings)
    assert "-O0" in _nlp_flags(cache)
    assert optimised.objective == plain.objective
    assert [s.iterations for s in optimised.starts] == [s.iterations for s in plain.starts]


def test_an_nlp_whose_optimised_compile_fails_is_compiled_unoptimised(cache, monkeypatch, tmp_path):
    """The optimiser running out of memory or time (a compiler that fails at -O1) leaves the
    NLP compiled at -O0, not on the virtual machine."""
    gcc = compiled.shutil.which("gcc")
    fake = tmp_path / "cc-without-O1"
    fake.write_text(f'#!/bin/sh\nif [ "$1" = "-O1" ]; then echo "virtual memory exhausted" >&2; exit 1; fi\n'
                    f'exec {gcc} "$@"\n')
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    from optdesign.design.problem import DesignProblem

    pb = DesignProblem(load(ROOT / "problems" / "seed1_jib.toml"))
    assert pb.solver.stats is not None and _nlp_flags(cache) == ["-O0"]
    assert not list(cache.glob("*.failed"))


def test_design_problem_evaluations_compiled_equal_the_virtual_machine(cache):
    """The design problem's per-sample rows, their s-derivatives (the continuous check) and the
    extrema's tracking, compiled (model/mapped.py: compiled_function), give the virtual
    machine's numbers bit for bit (the optimiser's numbers must not depend on the cache)."""
    from optdesign.design.problem import DesignProblem
    from optdesign.kinematics.mapped import MappedFunction
    from optdesign.model.mapped import compiled_function

    pb = DesignProblem(load(ROOT / "problems" / "lib_pumpjack.toml"))
    p = pb.full_parameters(pb.start)
    s = np.r_[np.linspace(pb.s_grid[0], pb.s_grid[-1], 37), pb.s_grid[0] - 1.0]   # one point off the stroke
    for func in (pb.quantity, pb.quantity_derivatives):
        fast = MappedFunction(func, compile=compiled_function)
        assert fast.func.is_a("External"), func.name()
        for mine, reference in zip(fast(s, p), MappedFunction(func)(s, p)):
            assert np.array_equal(mine, reference, equal_nan=True), func.name()
    tracking = pb.quantity_tracking
    assert tracking.is_a("External")
    vm_tracking = pb.mech.function("quantities_tracking", {"d2v": pb.mech.ds(pb._dv),
                                                           "dvdp": ca.jacobian(pb._dv, pb.mech.p)})
    for s_k in s[:5]:
        for mine, reference in zip(tracking(s_k, p), vm_tracking(s_k, p)):
            assert np.array_equal(np.asarray(mine), np.asarray(reference), equal_nan=True)
    assert compiled_function(pb.quantity).is_a("External")   # the second time: from the cache


@pytest.mark.parametrize("damage", ["flipped bytes", "truncated", "bad record", "no record"])
def test_a_damaged_entry_is_found_and_rebuilt(cache, damage):
    f = small_function()
    stroke_evaluator(f)
    lib = next(cache.glob("external-*.so"))
    meta = lib.with_suffix(".json")
    data = bytearray(lib.read_bytes())
    if damage == "flipped bytes":
        mid = len(data) // 2
        data[mid:mid + 64] = bytes(b ^ 0xFF for b in data[mid:mid + 64])
        lib.write_bytes(bytes(data))
    elif damage == "truncated":
        lib.write_bytes(bytes(data[:len(data) // 3]))
    elif damage == "bad record":
        meta.write_text("{not json")
    else:
        meta.unlink()
    key = lib.stem
    assert compiled.lookup(key) is None               # found damaged (and removed)
    ev = stroke_evaluator(f)                          # built again
    assert isinstance(ev, BlockedFunction)
    assert compiled.lookup(key) == lib
    assert_same(ev(S, P), vm(f, S, P))


def test_without_a_compiler_the_virtual_machine_is_used_and_said_once(cache, monkeypatch):
    monkeypatch.setenv("CC", "no-such-compiler-here")
    f = small_function()
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        first, second = stroke_evaluator(f), stroke_evaluator(f)
    assert isinstance(first, VectorisedSX) and isinstance(second, VectorisedSX)
    said = [w for w in seen if issubclass(w.category, compiled.CompileWarning)]
    assert len(said) == 1 and "no C compiler" in str(said[0].message)
    assert_same(first(S, P), vm(f, S, P))


def test_a_failing_compiler_is_noted_and_said_once(cache, monkeypatch, tmp_path):
    fake = tmp_path / "fakecc"
    fake.write_text('#!/bin/sh\nif [ "$1" = "--version" ]; then echo "fakecc 1.0"; exit 0; fi\n'
                    'echo "fakecc: out of order" >&2\nexit 1\n')
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    f = small_function()
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        first, second = stroke_evaluator(f), stroke_evaluator(f)
    assert isinstance(first, VectorisedSX) and isinstance(second, VectorisedSX)
    said = [w for w in seen if issubclass(w.category, compiled.CompileWarning)]
    assert len(said) == 1 and "failed" in str(said[0].message)
    failed = list(cache.glob("*.failed"))
    assert len(failed) == 1 and "out of order" in failed[0].read_text()
    assert not list(cache.glob("*.so"))


def test_opt_out_compiles_and_loads_nothing(cache, monkeypatch):
    stroke_evaluator(small_function())                 # an entry that could be loaded
    monkeypatch.setenv("OPTDESIGN_NO_COMPILE", "1")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert isinstance(stroke_evaluator(small_function()), VectorisedSX)
        s, p = ca.SX.sym("s"), ca.SX.sym("p", 1)
        assert isinstance(stroke_evaluator(ca.Function("other", [s, p], [s * p])), VectorisedSX)
    assert len(list(cache.glob("*.so"))) == 1


def test_background_compiler_fills_the_cache_for_later_runs(cache, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_COMPILE", "background")
    f = small_function()
    assert isinstance(stroke_evaluator(f), VectorisedSX)   # this run: the VM, compiling aside
    deadline = time.time() + 120
    while not list(cache.glob("external-*.json")) and time.time() < deadline:
        time.sleep(0.2)
    for child in compiled._children:
        child.wait(timeout=max(deadline - time.time(), 1))
    ev = stroke_evaluator(f)
    assert isinstance(ev, BlockedFunction)
    assert_same(ev(S, P), vm(f, S, P))
    assert not [p for p in cache.iterdir() if ".tmp" in p.name or ".job" in p.name or ".src" in p.name]


def test_a_studys_build_runs_on_the_plain_library_while_its_own_is_compiled(cache, monkeypatch):
    """A study's build (its axes variable) whose library for many cases is not yet in the cache
    runs on the scene's plain library when the cache holds that (not on numpy), and on its own
    once the background compiler has made it."""
    from optdesign.scene.resolved import ResolvedScene

    scene = load(ROOT / "problems" / "truck_crane.toml")
    Analysis(scene, certify=False)   # the plain library, compiled (wait)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "background")
    study = ResolvedScene(scene.without_bounds("mB", "mP"), variable=["mB", "mP"])
    first = Analysis(study, certify=False).vectorised
    assert isinstance(first, BlockedFunction) and first._cases is None
    for child in compiled._children:
        child.wait(timeout=300)
    later = Analysis(study, certify=False).vectorised
    assert isinstance(later, BlockedFunction) and later._cases is not None


def test_another_process_finds_the_same_entry(cache):
    """A study's worker builds the scene again: its graph has the same key, so it loads the
    library this process compiled instead of compiling it again."""
    scene = str(ROOT / "problems" / "truck_crane.toml")
    a = Analysis(load(scene), samples=101, certify=False)
    assert isinstance(a.vectorised, BlockedFunction)
    mine = compiled.entry_key("external", a.function.serialize(), {"name": "optdesign_blocked", "level": blocked.LEVEL})
    before = sorted((p.name, p.stat().st_mtime_ns) for p in cache.iterdir())
    code = textwrap.dedent("""
        import sys
        from optdesign import load
        from optdesign.model import blocked, compiled
        from optdesign.model.analysis import Analysis
        a = Analysis(load(sys.argv[1]), samples=101, certify=False)
        print(type(a.vectorised).__name__)
        print(compiled.entry_key("external", a.function.serialize(), {"name": "optdesign_blocked", "level": blocked.LEVEL}))
    """)
    out = subprocess.run([sys.executable, "-c", code, scene], capture_output=True, text=True, cwd=ROOT,
                         env=dict(os.environ), check=True).stdout.split()
    assert out == ["BlockedFunction", mine]
    assert sorted((p.name, p.stat().st_mtime_ns) for p in cache.iterdir()) == before



def test_the_cache_keeps_within_its_size_least_recently_used_out_first(cache, monkeypatch):
    """Three libraries of 1, 2 and 3 MB last used in the order b, c, a, a limit of 3.5 MB: a new
    entry (compiled here for real) makes the cache remove the least recently used until it fits
    (b, then c: 1 MB and the new one left); an entry in use is marked used; a killed compiler's
    temporary files go once they are stale, a running one's stay; alone above the limit the
    newest entry is kept."""
    cache.mkdir(parents=True)
    now = time.time()
    for key, size, used in (("external-a", 1_000_000, now - 100), ("external-b", 2_000_000, now - 300),
                            ("external-c", 3_000_000, now - 200)):
        (cache / f"{key}.so").write_bytes(b"\0" * size)
        (cache / f"{key}.json").write_text("{}")
        os.utime(cache / f"{key}.so", (used, used))
    stale, fresh = cache / "nlpsol-x.tmp4545.c", cache / "nlpsol-y.fn7833"
    stale.write_text("int f;")
    fresh.write_text("graph")
    os.utime(stale, (now - 2 * compiled.STALE_S,) * 2)
    monkeypatch.setenv("OPTDESIGN_CACHE_MAX_MB", "3.5")
    assert isinstance(stroke_evaluator(small_function()), BlockedFunction)   # compiled: a new entry
    libraries = {p.stem for p in cache.glob("*.so")}
    new = libraries - {"external-a", "external-b", "external-c"}
    assert len(new) == 1 and libraries == {"external-a"} | new
    assert not (cache / "external-b.json").exists() and not (cache / "external-c.json").exists()
    assert not stale.exists() and fresh.exists()
    (new_key,) = new
    old = now - 1000
    os.utime(cache / f"{new_key}.so", (old, old))
    assert compiled.lookup(new_key) is not None and (cache / f"{new_key}.so").stat().st_mtime > now - 100
    monkeypatch.setenv("OPTDESIGN_CACHE_MAX_MB", "0.001")
    assert compiled.prune(keep=new_key) == ["external-a"] and (cache / f"{new_key}.so").exists()
    monkeypatch.setenv("OPTDESIGN_CACHE_MAX_MB", "lots")
    with pytest.warns(compiled.CompileWarning, match="OPTDESIGN_CACHE_MAX_MB='lots' is not a number"):
        assert compiled.max_bytes() == compiled.CACHE_MAX_BYTES


def test_a_graph_too_large_is_not_written_as_c(cache, monkeypatch):
    """A graph above MAX_GRAPH serialized bytes runs on the virtual machine at once (said once,
    the reason noted in the cache), with no background compiler and no C written."""
    f = small_function()
    monkeypatch.setattr(compiled, "MAX_GRAPH", len(f.serialize()) - 1)
    monkeypatch.setenv("OPTDESIGN_COMPILE", "background")
    started = []
    monkeypatch.setattr(compiled, "_start_background", started.append)
    with pytest.warns(compiled.CompileWarning, match="virtual machine"):
        assert compiled.external(f, "small_large", lambda name: pytest.fail("C written")) is None
    assert not started and not list(cache.glob("*.so"))
    (failed,) = cache.glob("*.failed")
    assert "(serialized) is more than this cache compiles" in failed.read_text()


def test_a_failed_compile_is_said_once_by_a_command_and_its_workers(cache):
    """A command's forked workers meet the same failed entry (the helper's four-bar: its phase-1
    NLP over the size limit, met by the command and by each worker): one line per run, not one
    per process; another run (another process group) says it again."""
    import multiprocessing

    cache.mkdir(parents=True)
    key = "nlpsol-" + "0" * 32
    (cache / f"{key}.failed").write_text("OSError: too large (a stand-in)\n")
    ctx = multiprocessing.get_context("fork")
    said = ctx.Queue()

    def worker():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert compiled._failed_recently(key)
        said.put(sum("failed" in str(w.message) for w in caught))

    procs = [ctx.Process(target=worker) for _ in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(30)
        assert p.exitcode == 0
    assert sorted(said.get(timeout=5) for _ in procs) == [0, 0, 1]
    # another run: a process in a new session (process group) says it again
    code = textwrap.dedent(f"""
        import warnings
        from optdesign.model import compiled
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert compiled._failed_recently({key!r})
        print(sum("failed" in str(w.message) for w in caught))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, start_new_session=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=60)
    assert out.stdout.strip() == "1", out.stderr


@pytest.mark.parametrize("scene", ["seed1_slider_crank", "ventilator_squeeze"])
def test_assembly_check_compiled_equals_the_virtual_machine(cache, scene):
    """The assembly check's evaluations at many sweep values (kinematics/mapped.py, compiled by
    the mechanism's compile_function: model/mapped.py's, as an analysis sets it) give the virtual
    machine's numbers bit for bit, at the samples and with the margins' derivatives, over
    geometries of which some do not assemble: the check's decisions do not depend on the cache."""
    from optdesign.kinematics.assembly import AssemblyCheck
    from optdesign.kinematics.mechanism import Mechanism
    from optdesign.model.mapped import compiled_function

    rng = np.random.default_rng(3)
    fast, plain = (Mechanism(load(ROOT / "problems" / f"{scene}.toml")) for _ in range(2))
    fast.compile_function = compiled_function
    p0, s_values = fast.parameter_values, fast.stroke()
    P = p0 * (1 + 0.15 * rng.uniform(-1, 1, size=(12, len(p0))))
    checks = [AssemblyCheck(m) for m in (fast, plain)]
    found = [check.many(s_values, P) for check in checks]
    assert [str(x) for x in found[0]] == [str(x) for x in found[1]]
    s, rows = np.tile(s_values, len(P)), np.repeat(P, len(s_values), axis=0)
    for key in ("sampled", "derivatives"):
        mine, reference = (check._maps[key] for check in checks)
        assert mine.func.is_a("External") and not reference.func.is_a("External"), key
        for a, b in zip(mine(s, rows), reference(s, rows)):
            assert np.array_equal(a, b, equal_nan=True), key


def test_a_loop_scenes_graphs_are_not_compiled_and_nothing_is_said(cache):
    """A scene with a loop closed by Newton's method (MX graphs calling CasADi's Newton, which
    it cannot write as C): its analysis evaluates on the virtual machine without trying to
    compile (which failed, said so once per Function and left failure notes in the cache)."""
    from test_analysis_many import LOOP

    import optdesign

    with warnings.catch_warnings():
        warnings.simplefilter("error", compiled.CompileWarning)
        analysis = Analysis(optdesign.loads(LOOP, "loop"))
        analysis.run()
    assert not analysis.certified.derivatives.func.is_a("External")
    assert not list(cache.glob("*.failed"))
