"""Certified extremes of many cases at once (model/certified.CertifiedExtremes.many): each case's
result is exactly its own one-case result, whatever the other cases of the batch and its
position in it (a study's rows must not depend on how its cases were batched)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.stats import qmc

import optdesign
from optdesign.model.analysis import Analysis

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
VARIED = {"mB": (400.0, 900.0), "mP": (500.0, 3000.0), "xD": (-0.1, 0.6), "yD": (-1.8, -0.9), "b": (0.7, 1.6)}


def sampled(analysis, p):
    """The sampled columns and per-sample constraints of one case, as Analysis.run hands them on."""
    raw = analysis.vectorised(analysis.s_values, p)
    n = len(analysis.s_values)
    values = {k: np.broadcast_to(np.asarray(v, float).ravel(), (n,)).copy() for k, v in raw.items()}
    columns = {k: v for k, v in values.items() if ":" not in k}
    if analysis.scene.drive.kind == "rotary":
        columns["q"] = np.unwrap(columns["q"])
    constraints = {k.split(":", 1)[1]: v for k, v in values.items() if k.startswith("constraint:")}
    return columns, constraints


def stacked(analysis, P):
    """Every case's sampled columns and constraints stacked (name -> N x S)."""
    each = [sampled(analysis, p) for p in P]
    return ({k: np.array([c[k] for c, _ in each]) for k in each[0][0]},
            {k: np.array([c[k] for _, c in each]) for k in each[0][1]})


@pytest.fixture(scope="module")
def crane():
    return Analysis(optdesign.load(PROBLEMS / "truck_crane.toml"))


def crane_parameters(analysis, n, seed):
    mech = analysis.mech
    names = list(mech.parameter_names)
    unit = qmc.Sobol(len(VARIED), seed=seed).random(n)
    P = np.tile(mech.parameter_values, (n, 1))
    for j, (name, (lo, hi)) in enumerate(VARIED.items()):
        P[:, names.index(name)] = lo + (hi - lo) * unit[:, j]
    return P


def test_a_batch_gives_each_case_its_own_result(crane):
    analysis = crane
    P = crane_parameters(analysis, 8, 3)
    columns, constraints = stacked(analysis, P)
    s = analysis.s_values
    together = analysis.certified.many(s, P, columns, constraints)
    alone = [analysis.certified(s, P[i], {k: v[i] for k, v in columns.items()},
                                {k: v[i] for k, v in constraints.items()}) for i in range(len(P))]
    assert together == alone   # bit-identical, certificates included
    # another composition and order: the reversed batch, and a batch of three
    order = [5, 2, 7]
    part = analysis.certified.many(s, P[order], {k: v[order] for k, v in columns.items()},
                                   {k: v[order] for k, v in constraints.items()})
    assert part == [alone[i] for i in order]
    backwards = analysis.certified.many(s, P[::-1], {k: v[::-1] for k, v in columns.items()},
                                        {k: v[::-1] for k, v in constraints.items()})
    assert backwards == alone[::-1]
    for found in alone:   # every one certified
        assert all(c["note"] == "" for c in found["certificates"].values()), found["certificates"]


def test_many_checks_its_arguments(crane):
    analysis = crane
    P = crane_parameters(analysis, 2, 1)
    columns, constraints = stacked(analysis, P)
    with pytest.raises(ValueError, match="narrow"):
        analysis.certified.many(analysis.s_values, P, columns, constraints, narrow=[()])
