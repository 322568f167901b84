"""A motor catalogue's optimum analysed once (report/design_cases.optimum_analysis with the
catalogue, model/case_runs.one_motor): the chosen motor's analysis is taken from the analysis of
the scene with every motor at the chosen design, which the motors table of result.json needs
anyway.  The reference is the scene with that motor alone analysed apart (what the command did
before): every number the same, and result.json and summary.txt the same text.

The scene is tests/test_cases_optimise.py's crank with a gearbox and its catalogue of three
motors (tiny, small, large; small is the smallest that fits)."""
from __future__ import annotations

import dataclasses
import types

import numpy as np
import pytest

from optdesign.design.catalogue import optimise_catalogue, with_motor
from optdesign.model.analysis import analyse
from optdesign.model.case_runs import one_motor
from optdesign.report import design, design_cases, drive_train

from test_catalogue_retries import crank


def same(a, b, path="") -> list:
    """Where two analysis results differ (their timings aside; a dict's keys in any order): a
    list of paths."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return [d for f in dataclasses.fields(a) if f.name != "timings"
                for d in same(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")]
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return [f"{path}: keys {sorted(a)} != {sorted(b)}"]
        return [d for k in a for d in same(a[k], b[k], f"{path}/{k}")]
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return [] if np.array_equal(a, b, equal_nan=True) else [path]
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)) and len(a) == len(b):
        return [d for k, (x, y) in enumerate(zip(a, b)) for d in same(x, y, f"{path}[{k}]")]
    return [] if a == b or (a != a and b != b) else [f"{path}: {a!r} != {b!r}"]


def _catalogue(i):
    """A catalogue of the crank's three motors that chose 'small' at the ratio ``i`` (stand-ins
    for the result and the catalogue: what the analyses read of them)."""
    scene = crank()
    small = next(m for m in scene.motors if m.name == "small")
    result = types.SimpleNamespace(success=True, scene=with_motor(scene, small), design={"i": i})
    return result, types.SimpleNamespace(best=result, motors=scene.motors, chosen="small")


def test_the_chosen_motors_analysis_is_the_one_made_apart():
    """At i = 40 the small and large motors fit (small is the smallest)."""
    result, catalogue = _catalogue(40.0)
    design_cases._LAST[:], drive_train._LAST[:] = [None, None], [None, None]
    shared = design_cases.optimum_analysis(result, catalogue)
    assert drive_train._LAST[0] is catalogue   # taken from the catalogue's analysis
    apart = analyse(result.scene.with_parameters(**result.design))
    assert shared.scene == apart.scene
    assert same(shared, apart) == []
    assert design_cases.optimum_analysis(result, catalogue) is shared   # kept


def test_a_motor_that_is_not_the_smallest_fitting_at_the_design():
    """At i = 40 the large motor fits too, but the catalogue's analysis shows the small one's
    torque as the cases' motor_torque: one_motor gives the large one's, as the scene with the
    large motor alone does."""
    result, catalogue = _catalogue(40.0)
    whole = analyse(dataclasses.replace(result.scene, motors=tuple(catalogue.motors)).with_parameters(i=40.0))
    assert whole.cases.train["shown"] == "small" and whole.cases.train["motors"]["large"]["fits"]
    large = next(m for m in catalogue.motors if m.name == "large")
    apart = analyse(with_motor(whole.scene, large))
    assert same(one_motor(whole.cases, "large"), apart.cases) == []
    assert not np.array_equal(whole.cases.cases["loaded up"].columns["motor_torque"],
                              apart.cases.cases["loaded up"].columns["motor_torque"])


@pytest.mark.slow   # an optimisation of the catalogue (20-45 s); the two tests above are the fast siblings
def test_result_json_and_summary_are_those_of_the_analyses_made_apart():
    """The command's result.json and summary.txt, with the one shared analysis, are the text
    they are with the chosen motor's analysis and the catalogue's made apart."""
    catalogue = optimise_catalogue(crank(), starts=1)
    result = catalogue.best
    assert catalogue.chosen == "small" and result.success
    design_cases._LAST[:], drive_train._LAST[:] = [None, None], [None, None]
    design_cases.optimum_analysis(result, catalogue)
    json_shared = design.to_json(design.result_json(result, catalogue))
    summary_shared = design.result_summary(result, catalogue)
    apart = analyse(result.scene.with_parameters(**result.design))
    whole = analyse(dataclasses.replace(result.scene, motors=tuple(catalogue.motors)).with_parameters(**result.design))
    design_cases._LAST[:], drive_train._LAST[:] = [result, apart], [catalogue, whole]   # the two made apart
    assert design.to_json(design.result_json(result, catalogue)) == json_shared
    assert design.result_summary(result, catalogue) == summary_shared


def test_the_start_without_its_cases_is_the_nominal_state_of_the_whole():
    """The figures of an optimisation's start need its nominal state alone
    (report/design_figures.write_figures: Analysis(scene, cases=False)): every number of it is
    that of the whole analysis, whose load cases are left out."""
    from optdesign.model.analysis import Analysis

    scene = crank()
    nominal, whole = Analysis(scene, cases=False).run(), Analysis(scene).run()
    assert nominal.cases is None and whole.cases is not None
    assert same(nominal, dataclasses.replace(whole, cases=None)) == []
