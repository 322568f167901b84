"""Optimal peak cylinder force and pivot placement of the truck crane against payload and boom
length: 3 boom lengths x 6 payloads = 18 optimisations, warm-started along the payload.

    python examples/study_truck_crane.py

writes results/study_truck_crane/ (cases.csv, study.png, summary.txt, journal.jsonl) and the
figure results/study_truck_crane/force_and_pivots.png.  Run it again: nothing is recomputed."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import optdesign
from optdesign.study import Study, grid, values

if __name__ == "__main__":
    scene = optdesign.load("problems/truck_crane.toml")
    study = Study(scene, [values("L", [5.0, 6.0, 7.0]), grid("mP", 500, 3000, 6)], starts=8)
    result = study.run(out="results/study_truck_crane")

    fig, (force, rod_eye, base) = plt.subplots(1, 3, figsize=(13, 4))
    for L in (5.0, 6.0, 7.0):
        rows = [r for r in result.rows if r["L"] == L and r["success"]]
        mP = [r["mP"] for r in rows]
        force.plot(mP, [r["objective"] / 1e3 for r in rows], "o-", label=f"boom L = {L:g} m")
        rod_eye.plot(mP, [r["design:b"] for r in rows], "o-", label=f"boom L = {L:g} m")
        base.plot(mP, [r["design:xD"] for r in rows], "o-", label=f"boom L = {L:g} m")
    force.set(ylabel="optimal peak cylinder force [kN]", title="minimum peak cylinder force")
    rod_eye.set(ylabel="rod eye b along the boom [m]", title="optimal rod eye position")
    base.set(ylabel="cylinder base xD [m]", title="optimal base position (yD on its bound -1.8 m)")
    for ax in (force, rod_eye, base):
        ax.set_xlabel("payload mP [kg]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig("results/study_truck_crane/force_and_pivots.png", dpi=120)
    print(f"{len(result.rows)} cases, {result.computed} computed now; see results/study_truck_crane/")
