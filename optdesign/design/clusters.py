"""Distinct local optima among the starts' results.

Two converged starts ended at the same local optimum when their certified objectives agree
within ``VALUE_REL`` (relative) and their designs within ``DESIGN_TOL`` of each variable's
range (the design scaled to [0, 1] by its bounds).  Starts are taken best first (ties by
index) and each joins the first optimum it matches (that optimum's best start represents it),
so the list does not depend on the order the starts ran in.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

VALUE_REL = 1e-6
DESIGN_TOL = 1e-3


@dataclass(frozen=True)
class LocalOptimum:
    """One distinct local optimum: its certified objective, design (of its best start) and the
    indices of the starts that ended there."""

    value: float
    design: dict
    starts: tuple

    def as_dict(self) -> dict:
        return {"value": self.value, "design": dict(self.design), "starts": list(self.starts),
                "count": len(self.starts)}


def local_optima(pb, reports, solutions) -> tuple:
    """The distinct local optima of the converged starts, best first."""
    done = sorted((r.objective, r.index, i) for i, r in enumerate(reports) if r.success and r.objective is not None)
    groups = []  # [value, z, design, [start indices]]
    for value, index, i in done:
        x = np.clip(solutions[i].x, pb.lower, pb.upper)
        z = pb.to_z(x)
        for g in groups:
            if (abs(value - g[0]) <= VALUE_REL * max(abs(g[0]), 1e-300)
                    and np.max(np.abs(z - g[1]), initial=0.0) <= DESIGN_TOL):
                g[3].append(index)
                break
        else:
            groups.append([value, z, dict(zip(pb.design_names, map(float, x))), [index]])
    return tuple(LocalOptimum(v, d, tuple(sorted(s))) for v, _, d, s in groups)


def few(count: int, total: int) -> bool:
    """Whether the best optimum was reached by few of the starts: by fewer than a quarter of
    them, or by a single start of several (the summary then asks for more starts)."""
    return total > 1 and (count < 2 or 4 * count < total)
