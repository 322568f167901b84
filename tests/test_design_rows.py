"""The NLP's rows: a construction that does not move with the sweep gives one assembly-margin
row, not one per sample point (repeated rows are degenerate and cost time), and adding such a
construction, inactive at the optimum, leaves the optimum unchanged.  Stroke aggregates and the
dead-centre guard have rows at the stroke's ends and the slots only; a slot may sit on a base
point for them, and the rows that would repeat that point are left free."""
import math
from pathlib import Path

import numpy as np

import optdesign
from optdesign.design.problem import DesignProblem
from optdesign.design.multistart import optimise
from optdesign.design.solver import Solver

TRUCK = Path(__file__).resolve().parents[1] / "problems" / "truck_crane.toml"


def truck_with_fixed_dyad():
    """The truck crane plus a dyad A-K-D (|AK| = xD + 1.5, |KD| = 1) on the column: it moves
    with the design, not with the boom angle, and assembles for |AD| in [xD + 0.5, xD + 2.5]."""
    text = TRUCK.read_text().replace(
        'B = { attach = ["A", "T", "b", "-f"] }',
        'B = { attach = ["A", "T", "b", "-f"] }\nK = { dyad = ["A", "xD + 1.5", "D", "1.0"], side = "left" }', 1)
    assert "K = { dyad" in text
    return optdesign.loads(text, "truck_with_fixed_dyad.toml")


def test_a_fixed_construction_has_one_margin_row():
    pb = DesignProblem(truck_with_fixed_dyad())
    rows = {name: n for name, _, _, n in pb.g_blocks}
    assert rows["assembly of K"] == 1
    assert rows["transmission angle"] == pb.n_points  # a per-sample constraint: one row per point


def test_an_inactive_fixed_construction_leaves_the_optimum():
    plain = optimise(optdesign.load(TRUCK), starts=6, seed=0)
    extra = optimise(truck_with_fixed_dyad(), starts=6, seed=0)
    assert plain.success and extra.success
    assert abs(extra.objective - plain.objective) <= 1e-8 * plain.objective
    assert extra.constraints["assembly of K"]["active"] is None


# --- blocks imposed at the stroke's ends and the slots only ----------------------------------
CRANK_PRESS = TRUCK.parent / "crank_press_peak.toml"


def test_aggregates_and_the_dead_centre_guard_have_rows_at_the_ends_and_slots_only():
    pb = DesignProblem(optdesign.load(TRUCK))
    nb, n = len(pb.base_points), pb.n_points
    rows = {name: n_rows for name, _, _, n_rows in pb.g_blocks}
    sparse = [0, nb - 1, *range(nb, n)]
    for name in ("__aggregate_0", "__aggregate_1", "dead centre"):
        assert rows[name] == 2 + pb.settings.slots
        assert list(pb.g_points[name]) == sparse
    assert rows["peak(drive)"] == 2 * n and list(pb.g_points["peak(drive)"]) == [*range(n), *range(n)]
    assert rows["transmission angle"] == n


def test_a_slot_on_a_base_point_frees_the_rows_that_repeat_that_point():
    pb = DesignProblem(optdesign.load(TRUCK))
    nb = len(pb.base_points)
    plain = np.r_[pb.base_points, pb.initial_slots]
    lbg, ubg = pb.row_bounds(plain)
    assert np.array_equal(lbg, pb.lbg) and np.array_equal(ubg, pb.ubg)
    on_base = plain.copy()
    on_base[nb] = pb.base_points[5]          # the first slot on an interior base point
    lbg, ubg = pb.row_bounds(on_base)
    freed = {name: [] for name, *_ in pb.g_blocks}
    for name, _, start, n in pb.g_blocks:
        for i in range(n):
            if lbg[start + i] == -np.inf and ubg[start + i] == np.inf and not (
                    pb.lbg[start + i] == -np.inf and pb.ubg[start + i] == np.inf):
                freed[name].append(int(pb.g_points[name][i]))
    # the epigraph (both sides) and the per-sample constraint repeat base point 5 at the slot;
    # the aggregates and the dead-centre guard are not imposed at base point 5: kept
    assert freed == {"peak(drive)": [nb, nb], "transmission angle": [nb], "__aggregate_0": [], "__aggregate_1": [],
                     "cylinder length ratio": [], "dead centre": []}


def test_an_aggregate_whose_extremum_is_on_an_interior_base_point_is_held_there():
    """The crank press's ram pin depth max(-y(C)) is largest at bottom dead centre, phi = 0,
    which is the middle base point: the exchange puts a slot there, and the depth at the
    optimum, from the slider-crank's closed form sqrt((l + r)^2 - e^2), meets its bound 0.46 m."""
    scene = optdesign.load(CRANK_PRESS)
    pb = DesignProblem(scene)
    assert np.isclose(pb.base_points[len(pb.base_points) // 2], 0.0, atol=1e-15)
    sol = Solver(pb).solve(pb.start)
    assert sol.success
    slots = sol.s_points[len(pb.base_points):]
    assert np.min(np.abs(slots)) <= 1e-9
    l, e = (float(sol.x[pb.design_names.index(n)]) for n in ("l", "e"))
    H = 0.10
    r = H / 2 * math.sqrt(1 - 4 * e ** 2 / (4 * l ** 2 - H ** 2))
    depth = math.sqrt((l + r) ** 2 - e ** 2)
    assert depth <= 0.46 * (1 + 1e-8)
    assert depth >= 0.46 * (1 - 1e-6)      # active: the optimum presses against it
