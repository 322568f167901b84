"""Design studies (optdesign.study.study): cases, ids, the journal, resuming, and the numbers.

References are independent of the study code: the front doors analyse() and optimise() on
scene.with_parameters(...) (a fresh build per case, where the study re-runs one build with new
parameter values), and a scaling law of the seed-1 jib: its only massive body is the point
mass mC at the tip, so the drive force is mC times a function of the geometry (F_S = m_zS a_S +
F_Su - dF_S, every term proportional to mC) and no constraint involves mC; hence the optimal
design does not depend on mC and the optimal peak force is proportional to it.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import optdesign
from optdesign.errors import OptdesignError, SceneError
from optdesign.design import optimise
from optdesign.study import Study, grid, pareto, together, values
from optdesign.study import read_csv
from optdesign.study.journal import JOURNAL, Journal

ROOT = Path(__file__).resolve().parents[1]
JIB = ROOT / "problems" / "seed1_jib.toml"
JIB_DESIGN = ROOT / "problems" / "seed1_jib_design.toml"
CRANE = ROOT / "problems" / "truck_crane.toml"


@pytest.fixture(scope="module")
def jib_design():
    return optdesign.load(JIB_DESIGN)


# --- cases and ids ---------------------------------------------------------------------------
def test_cases_are_the_product_of_the_axes_last_fastest_with_chains(jib_design):
    study = Study(jib_design, [values("mC", [300, 500]), grid("l", 3.5, 4.5, 3)], chain=2)
    cases = study.cases()
    assert [dict(c.overrides) for c in cases] == [{"mC": m, "l": l} for m in (300.0, 500.0) for l in (3.5, 4.0, 4.5)]
    # chains run along the last axis, cut every `chain` cases, restarting at each outer value
    assert [(c.chain, c.link) for c in cases] == [(0, 0), (0, 1), (1, 0), (2, 0), (2, 1), (3, 0)]
    assert len({c.id for c in cases}) == 6
    # ids depend on the content only: the same study gives the same ids, another seed others
    assert [c.id for c in Study(jib_design, study.axes, chain=2).cases()] == [c.id for c in cases]
    other = Study(jib_design, study.axes, chain=2, seed=1).cases()
    assert not {c.id for c in other} & {c.id for c in cases}
    # without warm starts every case is its own chain
    assert [c.link for c in Study(jib_design, study.axes, warm=False).cases()] == [0] * 6


def test_together_and_pareto_axes(jib_design):
    study = Study(jib_design, [pareto("cylinder stroke", [1.0, 1.2]), together([{"mC": 400, "l": 4}, {"mC": 450, "l": 4.2}])])
    # the pareto axis is moved last; its side is the constraint's only bound (max)
    assert [a.kind for a in study.axes] == ["together", "pareto"]
    assert study.input_columns == ["mC", "l", "bound:cylinder stroke:max"]
    c = study.cases()[1]
    assert dict(c.overrides) == {"mC": 400.0, "l": 4.0} and c.bounds == (("cylinder stroke", "max", 1.2),)


@pytest.mark.parametrize("make, message", [
    (lambda s: Study(s, [values("mX", [1])]), "no parameter 'mX'"),
    (lambda s: Study(s, [pareto("transmission angle", [0.5])]), "both a min and a max"),
    (lambda s: Study(s, [pareto("transmision angle", [0.5], "min")]), "did you mean 'transmission angle'"),
    (lambda s: Study(s, [values("mC", [1]), values("mC", [2])]), "on two axes"),
    (lambda s: Study(s, [pareto("cylinder stroke", [1])], mode="analyse"), "needs mode 'optimise'"),
    (lambda s: Study(s, [values("mC", [1])], starts=0), "starts must be at least 1"),
])
def test_bad_studies_fail_early_with_a_clear_message(jib_design, make, message):
    with pytest.raises(SceneError, match=message):
        make(jib_design)


# --- numbers ------------------------------------------------------------------------------------
def test_analyse_cases_equal_fresh_analyses_and_scale_with_the_mass(tmp_path):
    scene = optdesign.load(JIB)
    masses = [250.0, 500.0, 1000.0]
    result = Study(scene, [values("mC", masses)], mode="analyse").run(out=tmp_path, workers=1, figures=False)
    assert result.complete and result.computed == 3
    peaks = result.column("peak:drive")
    for m, peak, row in zip(masses, peaks, result.rows):
        fresh = optdesign.analyse(scene.with_parameters(mC=m))
        assert peak == pytest.approx(fresh.peaks["drive"], rel=1e-12)  # same graph, other build: round-off only
        assert row["peak:static_load"] == pytest.approx(fresh.peaks["static_load"], rel=1e-12)
    # F_S is proportional to the only mass, mC (module docstring): to round-off
    assert peaks / masses == pytest.approx([peaks[0] / masses[0]] * 3, rel=1e-12)


def test_optimise_cases_equal_fresh_optimisations_and_obey_the_mass_scaling(tmp_path, jib_design):
    masses = [250.0, 500.0, 1000.0]
    result = Study(jib_design, [values("mC", masses)], starts=2).run(out=tmp_path, workers=1, figures=False)
    rows = result.rows
    assert all(r["success"] for r in rows)
    assert [r["warm"] for r in rows] == [False, True, True]    # one chain along the mass
    for m, r in zip(masses, rows):
        fresh = optimise(jib_design.with_parameters(mC=m), starts=2)
        # both certified over the continuous stroke; IPOPT tol 1e-10 on the scaled problem
        assert r["objective"] == pytest.approx(fresh.objective, rel=1e-7)
        for name in ("e", "b"):
            assert r[f"design:{name}"] == pytest.approx(fresh.design[name], abs=1e-6)
    # optimal design independent of mC, optimal peak proportional to it (module docstring)
    for r in rows[1:]:
        assert r["design:e"] == pytest.approx(rows[0]["design:e"], abs=1e-6)
        assert r["design:b"] == pytest.approx(rows[0]["design:b"], abs=1e-6)
    ratio = [r["objective"] / m for r, m in zip(rows, masses)]
    assert ratio == pytest.approx([ratio[0]] * 3, rel=1e-7)
    # the sensitivity d objective / d mC is the same ratio (the objective is linear in mC)
    assert rows[1]["sensitivity:mC"] == pytest.approx(ratio[1], rel=1e-5)


def test_pareto_front_by_epsilon_constraint(tmp_path, jib_design):
    """Relaxing a bound can only lower the optimum; where the bound is active the achieved
    value sits on it."""
    bounds = [0.9, 1.0, 1.1, 1.2, 1.5]
    result = Study(jib_design, [pareto("cylinder stroke", bounds)], starts=3).run(out=tmp_path, workers=1)
    rows = result.rows
    assert all(r["success"] for r in rows)
    objective = [r["objective"] for r in rows]
    for a, b in zip(objective, objective[1:]):
        assert b <= a * (1 + 1e-8)
    achieved = [r["constraint:cylinder stroke"] for r in rows]
    for eps, got, r in zip(bounds, achieved, rows):
        assert got <= eps + 1e-6
        if r["multiplier:cylinder stroke"] != 0:
            assert got == pytest.approx(eps, abs=1e-6)
    assert achieved[0] == pytest.approx(0.9, abs=1e-6) and objective[0] > objective[-1] * 1.05
    front = read_csv(tmp_path / "pareto.csv")
    assert [float(r["objective"]) for r in front] == sorted(float(r["objective"]) for r in front)[::-1]
    assert (tmp_path / "pareto.png").stat().st_size > 10_000 and (tmp_path / "study.png").exists()


# --- journal, CSV, resume ------------------------------------------------------------------------
def test_csv_holds_exact_numbers(tmp_path):
    scene = optdesign.load(JIB)
    result = Study(scene, [values("mC", [333.3, 777.7])], mode="analyse").run(out=tmp_path, workers=1, figures=False)
    rows = read_csv(tmp_path / "cases.csv")
    for r, mine in zip(rows, result.rows):
        assert float(r["mC"]) == mine["mC"]
        assert float(r["peak:drive"]) == mine["peak:drive"]   # repr round-trips exactly


def test_journal_ignores_and_cuts_a_torn_last_line(tmp_path):
    with Journal(tmp_path) as j:
        j.add({"id": "a", "row": {"x": 1.0}, "x": None})
        j.add({"id": "b", "row": {"x": 0.1 + 0.2}, "x": [1e-300, 3.0]})
    good = (tmp_path / JOURNAL).read_bytes()
    with open(tmp_path / JOURNAL, "ab") as fh:
        fh.write(b'{"id": "c", "row": {"x": 1.')   # a process killed in the middle of a write
    with Journal(tmp_path) as j:
        assert set(j.records) == {"a", "b"}
        assert j.records["b"]["row"]["x"] == 0.1 + 0.2 and j.records["b"]["x"] == [1e-300, 3.0]
        assert (tmp_path / JOURNAL).read_bytes() == good
        j.add({"id": "c", "row": {}, "x": None})
    lines = (tmp_path / JOURNAL).read_text().splitlines()
    assert [json.loads(line)["id"] for line in lines] == ["a", "b", "c"]


def test_a_second_run_in_the_same_folder_is_refused_while_the_first_runs(tmp_path):
    with Journal(tmp_path):
        with pytest.raises(OptdesignError, match="another study is running"):
            Journal(tmp_path).__enter__()


def test_resume_skips_finished_cases_and_gives_the_same_csv(tmp_path, jib_design):
    study = Study(jib_design, [values("mC", [300, 400, 500, 600])], starts=2, chain=2)
    first = study.run(out=tmp_path, workers=1, figures=False)
    csv_first = (tmp_path / "cases.csv").read_bytes()
    again = study.run(out=tmp_path, workers=1, figures=False)
    assert (again.computed, again.reused) == (0, 4)
    assert (tmp_path / "cases.csv").read_bytes() == csv_first
    # lose the last two records (the second chain's cases): only those are computed again,
    # the second one warm-started from the first's journalled optimum, to the same bytes
    lines = (tmp_path / JOURNAL).read_text().splitlines(keepends=True)
    (tmp_path / JOURNAL).write_text("".join(lines[:2]))
    resumed = study.run(out=tmp_path, workers=1, figures=False)
    assert (resumed.computed, resumed.reused) == (2, 2)
    assert (tmp_path / "cases.csv").read_bytes() == csv_first
    # a changed study in the same folder reuses exactly the cases it shares
    bigger = Study(jib_design, [values("mC", [300, 400, 500, 600, 700, 800])], starts=2, chain=2)
    more = bigger.run(out=tmp_path, workers=1, figures=False)
    assert (more.computed, more.reused) == (2, 4)
    assert first.complete and more.complete and len(more.rows) == 6
    restarted = study.run(out=tmp_path, workers=1, figures=False, restart=True)
    assert (restarted.computed, restarted.reused) == (4, 0)


def test_failed_cases_are_finished_cases_with_a_reason(tmp_path):
    """A case whose mechanism cannot run its stroke is a finished case that failed, recorded
    with its reason, and the study goes on."""
    scene = optdesign.load(JIB)
    # psi = +60 deg puts D above the jib: the dead centre (cylinder along the jib) falls in the stroke
    result = Study(scene, [values("psi", ["-60 deg", "30 deg"])], mode="analyse").run(out=tmp_path, workers=1, figures=False)
    ok, bad = result.rows
    assert ok["success"] and not bad["success"] and bad["status"].startswith("error: ")
    assert math.isnan(result.column("peak:drive")[1])
