"""Second-order Taylor arithmetic in numpy, for the library scenes' independent references.

A :class:`T2` carries a quantity and its first and second derivatives with respect to the
sweep s, (f, df/ds, d2f/ds2), each a numpy array (one entry per sample, broadcast against the
design where a reference evaluates many designs at once).  The elementary rules (sum,
product, quotient, chain rule with f' and f'') are written out here, so a reference built on
T2 shares nothing with optdesign (which differentiates its CasADi graphs): a position written
as a closed form of s carries its exact velocity and acceleration ratios with it.

:func:`drive_load` is Lagrange's equation for one coordinate, written here from the physics
(not from optdesign): kinetic energy 1/2 M_s sd^2 with M_s = sum m |dr/ds|^2 + I (dphi/ds)^2,
generalised static load Q_s = dV/ds - sum F.dr/ds - sum T dphi/ds, drive coordinate q(s) with
k = dq/ds; the drive runs at qd, qdd, so sd = qd/k and sdd = (qdd - k' sd^2)/k; the ideal
drive load u follows from the power balance u qd = d/dt(1/2 M_s sd^2) + Q_s sd:

    u = (M_s sdd + 1/2 M_s' sd^2 + Q_s) / k,

and the efficiency rule of docs/scenes.md: the drive load is u/eta while the drive delivers
power (u qd >= 0), u eta while power flows back into it.
"""
from __future__ import annotations

import numpy as np


class T2:
    """(value, d/ds, d2/ds2) of a quantity along the sweep."""

    __slots__ = ("v", "d", "dd")
    __array_priority__ = 1000  # numpy arrays defer to T2's operators

    def __init__(self, v, d=0.0, dd=0.0):
        self.v, self.d, self.dd = np.asarray(v, float), np.asarray(d, float), np.asarray(dd, float)

    @staticmethod
    def variable(s):
        """The sweep itself: ds/ds = 1."""
        s = np.asarray(s, float)
        return T2(s, np.ones_like(s), np.zeros_like(s))

    # --- arithmetic ---
    def __add__(self, o):
        o = lift(o)
        return T2(self.v + o.v, self.d + o.d, self.dd + o.dd)

    __radd__ = __add__

    def __neg__(self):
        return T2(-self.v, -self.d, -self.dd)

    def __sub__(self, o):
        return self + (-lift(o))

    def __rsub__(self, o):
        return lift(o) - self

    def __mul__(self, o):
        o = lift(o)
        return T2(self.v * o.v, self.d * o.v + self.v * o.d, self.dd * o.v + 2 * self.d * o.d + self.v * o.dd)

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = lift(o)
        w = self.v / o.v
        w1 = (self.d - w * o.d) / o.v
        w2 = (self.dd - 2 * w1 * o.d - w * o.dd) / o.v
        return T2(w, w1, w2)

    def __rtruediv__(self, o):
        return lift(o) / self

    def __pow__(self, n):
        n = float(n)
        return self._chain(self.v**n, n * self.v ** (n - 1), n * (n - 1) * self.v ** (n - 2))

    def _chain(self, f, f1, f2):
        """g = f(self) from f, f' and f'' at self's value."""
        return T2(f, f1 * self.d, f2 * self.d**2 + f1 * self.dd)


def lift(x) -> T2:
    return x if isinstance(x, T2) else T2(x, 0.0, 0.0)


def sqrt(u):
    u = lift(u)
    r = np.sqrt(u.v)
    return u._chain(r, 0.5 / r, -0.25 / (r * u.v))


def sin(u):
    u = lift(u)
    return u._chain(np.sin(u.v), np.cos(u.v), -np.sin(u.v))


def cos(u):
    u = lift(u)
    return u._chain(np.cos(u.v), -np.sin(u.v), -np.cos(u.v))


def exp(u):
    u = lift(u)
    e = np.exp(u.v)
    return u._chain(e, e, e)


def acos(u):
    u = lift(u)
    w = 1.0 - u.v**2
    return u._chain(np.arccos(u.v), -1 / np.sqrt(w), -u.v / w**1.5)


def asin(u):
    u = lift(u)
    w = 1.0 - u.v**2
    return u._chain(np.arcsin(u.v), 1 / np.sqrt(w), u.v / w**1.5)


def atan2(y, x):
    """The angle of the vector (x, y): d = (x y' - y x')/r^2, dd from the quotient rule."""
    y, x = lift(y), lift(x)
    r2 = x.v**2 + y.v**2
    num = x.v * y.d - y.v * x.d
    num1 = x.v * y.dd - y.v * x.dd          # the x'y' terms cancel
    r2_1 = 2 * (x.v * x.d + y.v * y.d)
    return T2(np.arctan2(y.v, x.v), num / r2, (num1 * r2 - num * r2_1) / r2**2)


def logistic(u):
    """1/(1 + exp(-u)), with its derivatives (written out: the scenes switch loads with it)."""
    u = lift(u)
    f = 1.0 / (1.0 + np.exp(-u.v))
    return u._chain(f, f * (1 - f), f * (1 - f) * (1 - 2 * f))


# --- plane geometry on T2 pairs ---
def norm(P):
    return sqrt(P[0] * P[0] + P[1] * P[1])


def sub(P, Q):
    return (P[0] - Q[0], P[1] - Q[1])


def angle_of(P, Q):
    """Direction of P -> Q from the global x axis."""
    return atan2(Q[1] - P[1], Q[0] - P[0])


def angle_at(P, Q, R):
    """The angle at Q between Q->P and Q->R, 0 .. pi (values only, numpy)."""
    u = (P[0].v - Q[0].v, P[1].v - Q[1].v)
    w = (R[0].v - Q[0].v, R[1].v - Q[1].v)
    return np.arctan2(np.abs(u[0] * w[1] - u[1] * w[0]), u[0] * w[0] + u[1] * w[1])


def value(P):
    return (P[0].v, P[1].v)


# --- the reduced model (Lagrange for one coordinate) ---
def drive_load(bodies, q, qd, qdd, eta=None, g=None):
    """The drive torque or force at each sample, and its parts.

    ``bodies``: dicts with ``com`` (T2 pair) and ``mass``, and/or ``phi`` (T2 body angle) and
    ``inertia``, and optional ``force`` (pair of plain values, global components, at the
    centre of mass) and ``torque``; ``q``: the drive coordinate (T2).  Returns
    (drive, parts) with parts {"u": ideal load, "M_s", "Q_s", "k", "c"}."""
    M_s = 0.0
    M_s1 = 0.0
    Q_s = 0.0
    for b in bodies:
        m = b.get("mass", 0.0)
        if np.any(np.asarray(m) != 0):
            x, y = b["com"]
            M_s = M_s + m * (x.d**2 + y.d**2)
            M_s1 = M_s1 + 2 * m * (x.d * x.dd + y.d * y.dd)
            if g:
                Q_s = Q_s + m * g * y.d
        inertia = b.get("inertia", 0.0)
        if np.any(np.asarray(inertia) != 0):
            phi = b["phi"]
            M_s = M_s + inertia * phi.d**2
            M_s1 = M_s1 + 2 * inertia * phi.d * phi.dd
        if "force" in b:
            x, y = b["com"]
            fx, fy = b["force"]
            Q_s = Q_s - (fx * x.d + fy * y.d)
        if "torque" in b:
            Q_s = Q_s - b["torque"] * b["phi"].d
    k, k1 = q.d, q.dd
    sd = qd / k
    sdd = (qdd - k1 * sd**2) / k
    u = (M_s * sdd + 0.5 * M_s1 * sd**2 + Q_s) / k
    if eta is None or eta == 1.0:
        c = np.ones_like(u)
    else:
        c = np.where(u * qd >= 0, 1.0 / eta, eta)
    return c * u, {"u": u, "M_s": M_s, "Q_s": Q_s, "k": k, "c": c}
