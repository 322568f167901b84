"""The force elements of a scene ([[forces]]: :mod:`optdesign.scene.forces`) as CasADi graphs of
(s, p), and their share of the reduced model's load by virtual work.

An element between points P and Q of length L(s) with tension T (positive pulling P and Q
together) does the virtual work -T dL: its generalised load on the sweep coordinate is
Q_s = T dL/ds (the sign of :class:`~optdesign.model.reduction.ReducedModel`'s Q_s = dV/ds - sum
F . dr/ds).  A torsion spring with torque M (turning B back towards its reference angle
relative to A) gives Q_s = M dtheta/ds.  A damper's tension c dL/dt = c dL/ds sd gives
Q_s = c (dL/ds)^2 sd: kept apart as the damping coefficient D_s (Q_s = D_s sd), since the
motion in time (:mod:`optdesign.dynamics.equations`) has its own sd.
"""
from __future__ import annotations

import casadi as ca


class ForceLoads:
    """The [[forces]] of ``mech``'s scene: per element its length (or angle) and tension (or
    torque) graphs; ``static_s`` (the position-dependent elements' Q_s, or None) and
    ``damping_s`` (D_s, or None)."""

    def __init__(self, mech):
        self.mech = mech
        self.elements = {}
        static, damping = 0, 0
        for f in mech.scene.forces:
            where = f"[[forces]] {f.name}"
            value = lambda key: mech.value(f.number(key), f"{where}.{key}")  # noqa: E731
            if f.kind == "torsion":
                e = self._torsion(f, value)
            else:
                p, q = (mech.points[n] for n in f.between)
                length = ca.sqrt(ca.sumsqr(q - p))
                e = {"kind": f.kind, "length": length, "length_s": mech.ds(length)}
                if f.kind == "damper":
                    e["damping"] = value("rate")
                    damping = damping + e["damping"] * e["length_s"] ** 2
                    self.elements[f.name] = e
                    continue
                e["tension"] = _tension(f, value, length)
            static = static + e["tension"] * e["length_s"]
            self.elements[f.name] = e
        self.static_s = None if isinstance(static, int) else static
        self.damping_s = None if isinstance(damping, int) else damping

    def _torsion(self, f, value):
        mech = self.mech
        angles = [mech.body_angle[b] for b in f.bodies]
        relative = angles[-1] - (angles[0] if len(angles) == 2 else 0)
        reference = value("free_angle" if f.number("free_angle") is not None else "angle")
        preload = value("preload") if f.number("preload") is not None else 0
        turned = relative - reference
        theta = ca.atan2(ca.sin(turned), ca.cos(turned))  # within half a turn of the reference
        return {"kind": "torsion", "length": theta + reference, "length_s": mech.ds(relative),
                "tension": preload + value("rate") * theta}

    def tension(self, name, sd):
        """The element's tension (torque for a torsion spring) at the sweep rate ``sd``."""
        e = self.elements[name]
        if "damping" in e:
            return e["damping"] * e["length_s"] * sd
        return e["tension"]


def _tension(f, value, length):
    """The tension of a spring, gas spring or constant force at ``length``."""
    if f.kind == "constant":
        return value("tension")
    if f.kind == "spring":
        if f.number("free_length") is not None:
            return value("rate") * (length - value("free_length"))
        return value("preload") + value("rate") * (length - value("length"))
    extended = value("extended_length")
    if f.table is None:
        force, compressed, progression = value("extended_force"), value("compressed_length"), value("progression")
        return -force * (1 + (progression - 1) * (extended - length) / (extended - compressed))
    return -_piecewise_linear(extended - length, f.table)


def _piecewise_linear(x, table):
    """The polyline through the table's rows at x, its end segments extended beyond them:
    y0 + m0 (x - x0) + sum over the inner rows of the slope's change times max(x - x_i, 0)."""
    xs, ys = zip(*table)
    slopes = [(ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i]) for i in range(len(xs) - 1)]
    out = ys[0] + slopes[0] * (x - xs[0])
    for i in range(1, len(slopes)):
        out = out + (slopes[i] - slopes[i - 1]) * ca.fmax(x - xs[i], 0)
    return out
