"""The NLP's rows: a construction that does not move with the sweep gives one assembly-margin
row, not one per sample point (repeated rows are degenerate and cost time), and adding such a
construction, inactive at the optimum, leaves the optimum unchanged."""
from pathlib import Path

import optdesign
from optdesign.design import DesignProblem
from optdesign.optimise import optimise

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
