"""Motion laws in time: the normalised displacement f(tau) of a rise from rest to rest, tau = t/T
in [0, 1], f(0) = 0, f(1) = 1, as cam and servo-motion designers state a segment.

Each law is a sequence of pieces on which the normalised acceleration is a polynomial in
u = tau - tau_start plus a sine and a cosine of omega u; speed and displacement are its exact
integrals from the piece's start values (summed piece by piece as the law is made, then scaled
so that f(1) = 1), so every law is exact to round-off with no constant copied from a table:

=======================  ==================================================================
``cycloidal``            f'' = 2 pi sin(2 pi tau)
``harmonic``             f'' = pi^2/2 cos(pi tau)   (the acceleration jumps at both ends)
``modified-sine``        a sine quarter-wave up over tau in [0, 1/8], a cosine of a third of
                         the frequency down to the mirror image over [1/8, 7/8], a quarter-wave
                         back to 0 over [7/8, 1]
``modified-trapezoid``   sine quarter-waves of period 1/2 over [0, 1/8], [3/8, 5/8] (through
                         0) and [7/8, 1], constant acceleration in between
``polynomial-345``       f = 10 tau^3 - 15 tau^4 + 6 tau^5
``polynomial-4567``      f = 35 tau^4 - 84 tau^5 + 70 tau^6 - 20 tau^7
``polynomial``           the quintic through f(0) = 0, f(1) = 1 with given end speeds and
                         accelerations (normalised: times T/h and T^2/h)
=======================  ==================================================================

A segment of height h and duration T moves x(t) = h f(t/T), at speed h/T f'(tau) and
acceleration h/T^2 f''(tau); its peak speed is C_v h/T and its peak acceleration C_a h/T^2,
C_v = max f' and C_a = max |f''| (:attr:`MotionLaw.peak_speed`, :attr:`MotionLaw.peak_acceleration`,
found on the law itself).  The functions take CasADi symbols or numbers alike.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

LAWS = ("cycloidal", "harmonic", "modified-sine", "modified-trapezoid", "polynomial-345", "polynomial-4567")
GENERAL = "polynomial"
PI = math.pi


@dataclass(frozen=True)
class Piece:
    """The acceleration sum(poly[k] u^k) + sin_amp sin(omega u) + cos_amp cos(omega u) on
    [start, end], u = tau - start; ``v0``, ``f0``: speed and displacement at its start."""

    start: float
    end: float
    poly: tuple = ()
    sin_amp: float = 0.0
    cos_amp: float = 0.0
    omega: float = 1.0
    v0: float = 0.0
    f0: float = 0.0

    def scaled(self, c):
        return Piece(self.start, self.end, tuple(c * a for a in self.poly), c * self.sin_amp, c * self.cos_amp,
                     self.omega, c * self.v0, c * self.f0)

    def derivatives(self, u):
        """(f, f', f'', f''') at u into the piece, in closed form."""
        w, S, C = self.omega, self.sin_amp, self.cos_amp
        wu = w * u
        sin, cos = ca.sin(wu), ca.cos(wu)
        one_minus_cos = 2 * ca.sin(wu / 2) ** 2            # no cancellation near u = 0
        acc = S * sin + C * cos + sum(a * u**k for k, a in enumerate(self.poly))
        jerk = S * w * cos - C * w * sin + sum(k * a * u**(k - 1) for k, a in enumerate(self.poly) if k)
        speed = self.v0 + S * one_minus_cos / w + C * sin / w + sum(a * u**(k + 1) / (k + 1) for k, a in enumerate(self.poly))
        pos = (self.f0 + self.v0 * u + S * _x_minus_sin(wu) / w**2 + C * one_minus_cos / w**2
               + sum(a * u**(k + 2) / ((k + 1) * (k + 2)) for k, a in enumerate(self.poly)))
        return pos, speed, acc, jerk


def _x_minus_sin(x):
    """x - sin(x), by its series where x is small (the difference cancels there)."""
    series = x**3 / 6 * (1 - x**2 / 20 * (1 - x**2 / 42 * (1 - x**2 / 72 * (1 - x**2 / 110 * (1 - x**2 / 156)))))
    if isinstance(x, (int, float)):
        return series if abs(x) < 0.5 else x - math.sin(x)
    return ca.if_else(ca.fabs(x) < 0.5, series, x - ca.sin(x))


class MotionLaw:
    """A law's pieces (see the module's table), its segment boundaries and peak coefficients."""

    def __init__(self, name, pieces):
        self.name = name
        chained, v, f = [], 0.0, 0.0
        for p in pieces:   # the start values of each piece: the previous piece's end
            p = Piece(p.start, p.end, p.poly, p.sin_amp, p.cos_amp, p.omega, v, f)
            chained.append(p)
            pos, v, _, _ = (float(x) for x in p.derivatives(p.end - p.start))
            f = pos
        self.pieces = tuple(q.scaled(1.0 / f) for q in chained)
        tau = np.linspace(0.0, 1.0, 20001)
        _, speed, acc, _ = (np.asarray(v, float) for v in self.evaluate(tau))
        self.peak_speed = float(np.max(speed))            # C_v (refined below)
        self.peak_acceleration = float(np.max(np.abs(acc)))   # C_a
        self.peak_speed, self.peak_acceleration = self._refined(tau, speed, acc)

    @property
    def breaks(self) -> tuple:
        """The tau inside (0, 1) where one piece ends and the next begins."""
        return tuple(p.start for p in self.pieces[1:])

    def derivatives(self, tau):
        """(f, f', f'', f''') at tau in [0, 1] (a CasADi symbol or a number)."""
        out = self.pieces[-1].derivatives(tau - self.pieces[-1].start)
        for p in reversed(self.pieces[:-1]):
            here = p.derivatives(tau - p.start)
            out = tuple(ca.if_else(tau < p.end, a, b) for a, b in zip(here, out))
        return out

    def evaluate(self, tau):
        """(f, f', f'', f''') at an array of tau (numpy): the law's Function built on first use
        and kept (building it takes ~4 ms, and a case in time evaluates its law ~6 times per
        run: the same Function, the same numbers), CasADi's map over the values."""
        fn = self.__dict__.get("_function")
        if fn is None:
            t = ca.SX.sym("t")
            fn = self._function = ca.Function("law", [t], list(self.derivatives(t)))
        return [np.asarray(v, float).ravel() for v in fn.map(np.size(tau))(np.asarray(tau, float)[None, :])]

    def __getstate__(self):
        """The law without :meth:`evaluate`'s Function (not part of a scene's pickle)."""
        return {k: v for k, v in self.__dict__.items() if k != "_function"}

    def _refined(self, tau, speed, acc):
        """C_v and C_a refined by Newton on f'' = 0 and f''' = 0 from the best samples."""
        t = ca.SX.sym("t")
        f, v, a, j = self.derivatives(t)
        out = []
        for g, values in ((v, speed), (ca.fabs(a), np.abs(acc))):
            dg, ddg = ca.jacobian(g, t), ca.jacobian(ca.jacobian(g, t), t)
            fn = ca.Function("g", [t], [g, dg, ddg])
            x = float(tau[int(np.argmax(values))])
            best = float(np.max(values))
            for _ in range(30):
                _, d1, d2 = (float(z) for z in fn(x))
                if d2 >= 0 or not math.isfinite(d1 / d2):
                    break
                x = min(max(x - d1 / d2, 0.0), 1.0)
            best = max(best, float(fn(x)[0]))
            out.append(best)
        return tuple(out)

    def inverse(self, u, steps=16, newton=6):
        """tau with f(tau) = u in [0, 1] (f increasing): bisection to 2^-steps, then Newton (to
        round-off wherever u is more than 1e-9 from a rest's end, where f grows like tau^2 or
        faster; closer, within 2^-steps); 0 and 1 at the ends exactly."""
        lo, hi = 0.0 * u, 1.0 + 0.0 * u
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            below = self.derivatives(mid)[0] < u
            lo, hi = ca.if_else(below, mid, lo), ca.if_else(below, hi, mid)
        tau = 0.5 * (lo + hi)
        for _ in range(newton):   # from within 2^-steps of the root: no bracket needed
            f, df, _, _ = self.derivatives(tau)
            tau = tau - (f - u) / ca.fmax(df, 1e-300)
        return ca.if_else(u <= 0, 0.0, ca.if_else(u >= 1, 1.0, tau))


def _piece(start, end, **kw):
    return Piece(start, end, **kw)


@functools.lru_cache(maxsize=None)
def standard(name) -> MotionLaw:
    """One of :data:`LAWS`."""
    q = 4 * PI        # a quarter-wave over 1/8
    pieces = {
        "cycloidal": [_piece(0.0, 1.0, sin_amp=1.0, omega=2 * PI)],
        "harmonic": [_piece(0.0, 1.0, cos_amp=1.0, omega=PI)],
        "modified-sine": [_piece(0.0, 0.125, sin_amp=1.0, omega=q), _piece(0.125, 0.875, cos_amp=1.0, omega=q / 3),
                          _piece(0.875, 1.0, cos_amp=-1.0, omega=q)],
        "modified-trapezoid": [_piece(0.0, 0.125, sin_amp=1.0, omega=q), _piece(0.125, 0.375, poly=(1.0,)),
                               _piece(0.375, 0.625, cos_amp=1.0, omega=q), _piece(0.625, 0.875, poly=(-1.0,)),
                               _piece(0.875, 1.0, cos_amp=-1.0, omega=q)],
        "polynomial-345": [_piece(0.0, 1.0, poly=(0.0, 60.0, -180.0, 120.0))],
        "polynomial-4567": [_piece(0.0, 1.0, poly=(0.0, 0.0, 420.0, -1680.0, 2100.0, -840.0))],
    }[name]
    return MotionLaw(name, pieces)


def general(v0, v1, a0, a1) -> MotionLaw:
    """The quintic f with f(0) = 0, f(1) = 1, f'(0) = v0, f'(1) = v1, f''(0) = a0, f''(1) = a1
    (normalised end speeds and accelerations)."""
    # f = v0 t + a0/2 t^2 + c3 t^3 + c4 t^4 + c5 t^5: three conditions at tau = 1
    m = np.array([[1.0, 1.0, 1.0], [3.0, 4.0, 5.0], [6.0, 12.0, 20.0]])
    rhs = np.array([1.0 - v0 - a0 / 2, v1 - v0 - a0, a1 - a0])
    c3, c4, c5 = np.linalg.solve(m, rhs)
    law = MotionLaw.__new__(MotionLaw)   # its start speed is v0: one piece, no scaling
    law.name = GENERAL
    law.pieces = (Piece(0.0, 1.0, poly=(a0, 6 * c3, 12 * c4, 20 * c5), v0=v0, f0=0.0),)
    tau = np.linspace(0.0, 1.0, 20001)
    _, speed, acc, _ = law.evaluate(tau)
    law.peak_speed, law.peak_acceleration = law._refined(tau, speed, acc)
    law.min_speed = float(np.min(speed))
    law.min_speed_at = float(tau[int(np.argmin(speed))])
    return law


class Chain(MotionLaw):
    """Motion laws and dwells one after another along one motion (:mod:`.segments`), as one
    law of the normalised time tau = t/T over the whole motion (T: every segment's and dwell's
    time), f the fraction of the motion's length: each law segment g from rest at fraction F_a
    to rest at F_b over [tau_a, tau_b] is f = F_a + (F_b - F_a) g((tau - tau_a)/(tau_b - tau_a)),
    each of g's pieces rescaled in closed form (its acceleration, frequencies and start values);
    a dwell is a piece at rest.  ``parts``: ("law", MotionLaw, to, seconds) and ("dwell", None,
    at, seconds), positions as sweep values on the motion from ``begin`` to ``end``."""

    def __init__(self, parts, begin, end):
        self.name = "segments"
        length, sigma = abs(end - begin), (1.0 if end > begin else -1.0)
        self.time = float(sum(p[3] for p in parts))
        pieces, tau, here = [], 0.0, 0.0
        self.segments, self.rests, self.stops = [], [], []   # (F_a, F_b, tau_a, tau_b, law); (tau_a, tau_b, s); s
        for i, (kind, law, position, seconds) in enumerate(parts):
            tau_b = 1.0 if i == len(parts) - 1 else tau + seconds / self.time
            d = tau_b - tau
            if kind == "dwell":
                pieces.append(Piece(tau, tau_b, f0=here))
                self.rests.append((tau, tau_b, position))
            else:
                f_b = 1.0 if position == end else sigma * (position - begin) / length
                h = f_b - here
                for p in law.pieces:
                    pieces.append(Piece(tau + d * p.start, tau + d * p.end, tuple(h / d**2 * a / d**k for k, a in enumerate(p.poly)),
                                        h / d**2 * p.sin_amp, h / d**2 * p.cos_amp, p.omega / d, h / d * p.v0, here + h * p.f0))
                self.segments.append((here, f_b, tau, tau_b, law))
                if position != end:
                    self.stops.append(position)
                here = f_b
            tau = tau_b
        self.pieces = tuple(pieces)
        self.peak_speed = max(law.peak_speed * (b - a) / (tb - ta) for a, b, ta, tb, law in self.segments)
        self.peak_acceleration = max(law.peak_acceleration * (b - a) / (tb - ta) ** 2 for a, b, ta, tb, law in self.segments)

    def inverse(self, u, steps=16, newton=6):
        """tau at the fraction u of the motion: in the law segment that reaches u (at a stop
        exactly, the time it is reached: a dwell there follows)."""
        out = None
        for f_a, f_b, tau_a, tau_b, law in reversed(self.segments):
            v = (u - f_a) / (f_b - f_a)
            here = ca.if_else(v >= 1, tau_b, tau_a + (tau_b - tau_a) * law.inverse(v, steps, newton))
            out = here if out is None else ca.if_else(u <= f_b, here, out)
        return out
