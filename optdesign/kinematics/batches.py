"""Cases of a batch that a computation cannot tell apart.

A batch of cases (:meth:`optdesign.model.analysis.Analysis.run_many`) differs in leaf parameter
values only.  A check whose graphs depend on some parameters alone (the assembly margins and
dq/ds on the geometry, not on a mass or a load) gives the same numbers for two cases equal in
those: it runs once per group of such cases, and each case gets its group's result, exactly what
its own run would give (the check's functions see nothing else)."""
from __future__ import annotations

import casadi as ca
import numpy as np


def parameters_used(mech, *exprs) -> np.ndarray:
    """Indices of the parameters (of ``mech.p``) that any of ``exprs`` depends on."""
    used = np.zeros(mech.p.numel(), bool)
    for expr in exprs:
        if isinstance(expr, (ca.SX, ca.MX)) and expr.numel():
            used |= np.asarray(ca.which_depends(ca.vec(expr), mech.p, 1, False), bool)
    return np.flatnonzero(used)


def same_cases(P, used) -> list:
    """Groups of the cases (rows of ``P``) equal bit for bit in the parameters ``used``: a list
    of (first case, [its cases]), in the order of their first cases."""
    P = np.atleast_2d(np.asarray(P, float))
    if len(P) == 1:
        return [(0, [0])]
    keys = np.ascontiguousarray(P[:, used]).view(np.uint64)
    if keys.shape[1] == 0:
        return [(0, list(range(len(P))))]
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    groups = {}
    for i, g in enumerate(inverse.tolist()):
        groups.setdefault(g, []).append(i)
    return sorted(((int(first[g]), members) for g, members in groups.items()), key=lambda x: x[0])
