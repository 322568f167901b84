"""Lean models (issue 3, deliverable 4): what a scene does not use is not built, and its
results have no column for it.

The seed-1 jib is dressed up to a FULL scene that uses every term (weight, an extra force and
torque, a moment of inertia, acceleration, speed, efficiency eta < 1).  Each variant leaves out
one thing; its compiled stroke function (analysis.Analysis(scene).function) must have fewer
instructions and nodes than the full one, and the columns of that term must be absent from
the AnalysisResult, from the JSON (optdesign.report.analysis.analysis_json: per-sample keys, units, seed
names) and from the table header (optdesign.report.analysis.analysis_table), while the full scene has
them.  The LEAN scene leaves out everything at once: no gravity, no moment of inertia, eta = 1,
zero acceleration (only the mass and the speed remain).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from optdesign.model.analysis import Analysis
from optdesign.report.analysis import analysis_json, analysis_table
from optdesign.scene.file import load

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
TERM_COLUMNS = ("reduced_inertia", "reduced_inertia_dq", "static_load", "inertia_term", "velocity_term",
                "power", "efficiency_factor")


def jib():
    return load(PROBLEMS / "seed1_jib.toml")


def change(scene, body=None, drive=None, **fields):
    """A copy of ``scene`` with the first body's and the drive's fields replaced."""
    if body:
        fields["bodies"] = (dataclasses.replace(scene.bodies[0], **body),) + scene.bodies[1:]
    if drive:
        fields["drive"] = dataclasses.replace(scene.drive, **drive)
    return dataclasses.replace(scene, **fields)


def full_scene():
    """The jib using every term of the model."""
    return change(jib(), body=dict(inertia=800.0, force=(1500.0, 0.0), torque=-2500.0),
                  drive=dict(efficiency=0.9, acceleration=0.2, speed=0.1))


FULL = full_scene()
NO_LOADS = dict(body=dict(force=None, torque=None), gravity=None)
# variant -> (changes to the full scene, columns that must go, body ratios that must go)
VARIANTS = {
    "no loads": (NO_LOADS, {"static_load"}, set()),
    "eta = 1": (dict(drive=dict(efficiency=None)), {"efficiency_factor"}, set()),
    "zero acceleration": (dict(drive=dict(acceleration=0.0)), {"inertia_term"}, {"a_C0"}),
    "zero speed": (dict(drive=dict(speed=0.0, efficiency=None)),
                   {"velocity_term", "power", "efficiency_factor"}, {"delta_a_C"}),
    "no moment of inertia": (dict(body=dict(inertia=None)), set(), {"R_e"}),
    "no mass, no inertia": (dict(body=dict(mass=None, inertia=None)),
                            {"reduced_inertia", "reduced_inertia_dq", "inertia_term", "velocity_term"},
                            {"i_v", "di_v_dq", "R_e", "a_C0", "delta_a_C", "a_C"}),
    "lean": (dict(gravity=None, body=dict(inertia=None, force=None, torque=None),
                  drive=dict(efficiency=None, acceleration=0.0)),
             {"static_load", "inertia_term", "efficiency_factor"}, {"R_e", "a_C0"}),
}


def size(scene):
    """(instructions, nodes) of the compiled stroke function of ``scene``."""
    f = Analysis(scene).function
    return f.n_instructions(), f.n_nodes()


def keys_everywhere(result):
    """Column names as seen by the result, the JSON and the table; body ratio names."""
    data = analysis_json(result)
    sample = data["samples"][0]
    header = analysis_table(result).splitlines()[0].split()
    body_keys = set()
    for ratios in result.bodies.values():
        body_keys |= set(ratios)
    json_body_keys = set()
    for ratios in sample.get("bodies", {}).values():
        json_body_keys |= set(ratios)
    return {
        "result": set(result.columns), "json": set(sample), "units": set(data["units"]),
        "seed_names": set(data["seed_names"]), "table": set(header),
    }, body_keys, json_body_keys


def test_full_scene_has_every_column():
    result = Analysis(FULL).run()
    views, body_keys, json_body_keys = keys_everywhere(result)
    for where, keys in views.items():
        expected = set(TERM_COLUMNS) | {"drive"}
        if where in ("units", "seed_names"):
            expected -= {"efficiency_factor"} | ({"power"} if where == "seed_names" else set())
        assert expected <= keys, f"full scene: {where} lacks {sorted(expected - keys)}"
    assert {"i_v", "di_v_dq", "R_e", "a_C0", "delta_a_C", "a_C"} <= body_keys
    assert body_keys == json_body_keys


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_leaving_a_term_out_shrinks_the_graph_and_the_report(variant):
    changes, gone, gone_ratios = VARIANTS[variant]
    scene = change(FULL, **changes)
    full_n, full_nodes = size(FULL)
    n, nodes = size(scene)
    assert n < full_n and nodes < full_nodes, \
        f"{variant}: graph not smaller ({n} vs {full_n} instructions, {nodes} vs {full_nodes} nodes)"
    result = Analysis(scene).run()
    views, body_keys, json_body_keys = keys_everywhere(result)
    for where, keys in views.items():
        assert not (gone & keys), f"{variant}: {where} still has {sorted(gone & keys)}"
        kept = (set(TERM_COLUMNS) - gone) & keys_everywhere(Analysis(FULL).run())[0][where]
        assert kept <= keys, f"{variant}: {where} lost {sorted(kept - keys)}"
    assert not (gone_ratios & body_keys), f"{variant}: body ratios still have {sorted(gone_ratios & body_keys)}"
    assert body_keys == json_body_keys
    assert np.all(np.isfinite(result.columns["drive"]))


def test_lean_scene_values_match_the_full_model_with_the_terms_set_to_zero():
    """Leaving terms out changes no number: the lean jib's drive force equals the full model
    evaluated with the same terms zeroed by value (gravity 0, inertia 0, eta 1, acceleration 0,
    written as expressions of a design parameter so that they are built, not left out)."""
    lean = change(FULL, **VARIANTS["lean"][0])
    zeroed = change(FULL, gravity=dataclasses.replace(FULL.gravity, g="0*e"),
                    body=dict(inertia="0*e", force=("0*e", "0*e"), torque="0*e"),
                    drive=dict(efficiency="1 + 0*e", acceleration="0*e"))
    lean_result, zeroed_result = Analysis(lean).run(), Analysis(zeroed).run()
    assert size(zeroed)[0] > size(lean)[0]
    assert {"static_load", "inertia_term", "efficiency_factor"} <= set(zeroed_result.columns)
    for key in lean_result.columns:
        np.testing.assert_allclose(lean_result.columns[key], zeroed_result.columns[key], rtol=1e-13, atol=0,
                                   err_msg=key)
