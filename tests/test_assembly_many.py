"""The assembly check of many geometries at once (kinematics/assembly.py, AssemblyCheck.many: the
samples of every geometry in one call, the margins' continuous minima of all of them in one branch
and bound): each geometry's result is the one it gives alone, in any batch, and it holds against an
independent numpy model.

The family: Sobol four-bars of problems/ventilator_squeeze.toml (crank a, coupler b, rocker c;
frame d = 0.1; the sweep is the rocker's angle psi over 100 .. 130 deg, B the dyad of A (a) and C
(b)), most of which do not assemble over part of the stroke.  Reference: B assembles at psi
exactly when |a - b| <= |AC| <= a + b, AC = D + c (cos psi, sin psi); on a dense grid of psi the
first point where it does not is bracketed, the crossing found by brentq, and the check's error
must name B at that crossing (or at the stroke's start when it fails there); a four-bar that
assembles over the whole dense grid with room to spare must pass."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.stats import qmc

import optdesign
from optdesign.model.analysis import Analysis

from test_motion_output import SCENE as VENT_SCENE

BOX = {"a": (0.018, 0.032), "b": (0.08, 0.12), "c": (0.065, 0.095)}
D = 0.10


def _margin(psi, a, b, c):
    """(|AC|^2 - (a - b)^2) ((a + b)^2 - |AC|^2): > 0 where B assembles."""
    ac2 = (D + c * np.cos(psi)) ** 2 + (c * np.sin(psi)) ** 2
    return (ac2 - (a - b) ** 2) * ((a + b) ** 2 - ac2)


def _text(found):
    if isinstance(found, optdesign.OptdesignError):
        return f"error {found.construction} {found.s!r}: {found}"
    narrow, notes = found
    return repr((narrow, sorted(notes.items())))


def check_family(n, seed):
    analysis = Analysis(optdesign.load(VENT_SCENE))
    names = list(analysis.mech.parameter_names)
    unit = qmc.Sobol(len(BOX), seed=seed).random(n)
    P = np.tile(analysis.mech.parameter_values, (n, 1))
    for j, (name, (lo, hi)) in enumerate(BOX.items()):
        P[:, names.index(name)] = lo + (hi - lo) * unit[:, j]
    s = analysis.s_values
    check = analysis.assembly
    together = [_text(x) for x in check.many(s, P)]
    alone = [_text(check.many(s, P[[i]])[0]) for i in range(n)]
    assert together == alone
    order = np.arange(n)[::-3]
    assert [_text(x) for x in check.many(s, P[order])] == [alone[i] for i in order]
    # against the numpy model
    psi = np.linspace(s[0], s[-1], 20001)
    failed = passed = 0
    for i, found in enumerate(check.many(s, P)):
        a, b, c = (P[i, names.index(k)] for k in ("a", "b", "c"))
        m = _margin(psi, a, b, c)
        scale = (a + b) ** 2 * (D + c) ** 2
        bad = np.flatnonzero(m <= 0)
        if not bad.size:
            if m.min() > 1e-6 * scale:   # with room to spare: it must pass
                assert not isinstance(found, optdesign.OptdesignError), (i, found)
                passed += 1
            continue
        assert isinstance(found, optdesign.AssemblyError) and found.construction == "B", (i, found)
        k = int(bad[0])
        if k == 0:
            assert found.s == s[0], (i, found.s)
        else:
            root = brentq(lambda x: _margin(x, a, b, c), psi[k - 1], psi[k], xtol=1e-15)
            assert abs(found.s - root) <= 1e-9, (i, found.s, root)
        failed += 1
    assert failed >= n // 4 and passed >= 2, (failed, passed)


def test_a_batch_of_four_bars_gives_each_its_own_assembly_check():
    check_family(16, seed=4)


@pytest.mark.slow
def test_a_sobol_family_of_four_bars_assembly_checked_in_one_batch():
    check_family(128, seed=11)
