"""rms_time of static_load and rod_buckling in the NLP (design/cases.cycle_integrals) over a
duty cycle with a hold: the held stretch counts the value at rest, as docs/scenes.md's rule says
("a hold counts its value at the hold's position"); it added nothing (issue 27's leftover).

The scene: problems/hatch_cover.toml with the cover held closed for 60 s after closing (the
shipped hold, at the open end, carries no static load: the cover stands upright).  Reference
(tests/ref_hatch_cover.py's geometry, nothing of optdesign): at theta = 0 the static torque
mc g Lc/2 over k = dq/dtheta, through 1/eta (the hold's 'driving' default), is the held
cylinder force; its rod utilisation is that force times the safety over Euler's load at full
extension (the longest |DB| over the stroke).  The moving strokes' part is the NLP's own rule
on each case's rows (the same weights), evaluated here one case at a time."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from optdesign.design.cases import _time_plan, case_models, cycle_integrals
from optdesign.design.problem import DesignProblem
from optdesign.scene import loads

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ref_hatch_cover as ref  # noqa: E402

HOLD = 60.0


@pytest.fixture(scope="module")
def problem():
    text = ref.SCENE.read_text()
    shipped = 'cycle = ["open", { hold = 60, case = "open" }, "close", { dwell = 300 }]'
    assert shipped in text and 'minimise = "peak(drive)"' in text
    text = text.replace(shipped, 'cycle = ["open", "close", { hold = 60, case = "close" }, { dwell = 300 }]')
    text = text.replace('minimise = "peak(drive)"', 'minimise = "rms_time(static_load) + rms_time(rod_buckling) + rms_time(drive)"')
    return DesignProblem(loads(text, str(ref.SCENE)))


def test_a_hold_counts_the_held_static_load_and_rod_utilisation(problem):
    pb = problem
    x = pb.start
    p_num = pb.full_parameters(x)
    p = ca.MX.sym("p", len(p_num))
    quantities = ["static_load", "rod_buckling", "drive"]
    T_sym, sums = cycle_integrals(pb, p, quantities)
    got = dict(zip(["T", *quantities], (float(v) for v in ca.Function("c", [p], [T_sym, *sums.values()])(p_num))))
    plan = _time_plan(pb)
    moving, durations = dict.fromkeys(quantities, 0.0), 0.0
    for cm in case_models(pb):
        if cm.name == "open with snow":   # (not in the cycle)
            continue
        nodes, weights, duration = plan[cm.name]
        rows = pb.case_rows[cm.name]
        f = pb.mech.function("one_case", {k: pb.rows[rows[k]] for k in quantities})
        values = f.map(len(nodes))(nodes[None, :], p_num)
        for k, v in zip(quantities, values):
            moving[k] += float(np.sum(weights * np.asarray(v, float).ravel() ** 2))
        durations += duration
    assert got["T"] == pytest.approx(durations + HOLD + 300, rel=1e-12)
    # the reference: the held force at theta = 0 and its rod utilisation
    xD, yD, b = (float(pb.mech.resolved.values[n]) if n not in pb.design_names else x[pb.design_names.index(n)]
                 for n in ("xD", "yD", "b"))
    Bx, By, Bpx, Bpy = ref.rod_eye(b, 0.0)
    k = ((Bx - xD) * Bpx + (By - yD) * Bpy) / math.hypot(Bx - xD, By - yD)
    force = ref.MC * ref.G * ref.LC / 2 / k / ref.ETA
    longest = float(np.max(ref.length(xD, yD, b, np.linspace(0, ref.L, 20001))))
    euler = math.pi ** 2 * ref.MODULUS * (math.pi * ref.ROD ** 4 / 64) / longest ** 2
    assert force > 1e4
    for key, held in (("drive", force), ("static_load", force), ("rod_buckling", ref.SAFETY * force / euler)):
        assert got[key] - moving[key] == pytest.approx(held ** 2 * HOLD, rel=1e-6), key
