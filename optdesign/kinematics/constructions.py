"""Closed-form constructions of points as CasADi expressions, each with its assembly margin.

Every function takes and returns 2 x 1 CasADi vectors; a margin is a smooth expression that is
positive where the construction assembles and negative where it cannot (so the optimiser can
constrain it and the analysis can say where it fails).  No division by a quantity that can
vanish on an assembling geometry, except the distance of a dyad's two centres.
"""
import casadi as ca


def perp(d):
    """d turned by +90 degrees."""
    return ca.vertcat(-d[1], d[0])


def polar(centre, length, angle):
    """centre + length * (cos angle, sin angle): seed 2's transmission matrix T with L = 0."""
    return centre + length * ca.vertcat(ca.cos(angle), ca.sin(angle))


def dyad(p, length_p, q, length_q, side):
    """RRR dyad: the intersection of circles (p, length_p) and (q, length_q) to the ``side``
    ('left' or 'right') of p -> q.  Margin: 4 d^2 Lp^2 - (d^2 + Lp^2 - Lq^2)^2 >= 0, which is
    (2 d h)^2 with h the distance of the point from the line p q."""
    d = q - p
    d2 = ca.sumsqr(d)
    along = d2 + length_p**2 - length_q**2
    margin = 4 * d2 * length_p**2 - along**2
    sign = 1.0 if side == "left" else -1.0
    point = p + (along * d + sign * ca.sqrt(margin) * perp(d)) / (2 * d2)
    return point, margin


def slider(p, length, origin, angle, side):
    """RRP dyad: the point on the line through ``origin`` at ``angle`` at distance ``length``
    from ``p``; 'ahead' is further along the line's direction.  Margin: L^2 - dist(p, line)^2."""
    u = ca.vertcat(ca.cos(angle), ca.sin(angle))
    w = origin - p
    uw = ca.dot(u, w)
    margin = length**2 - (ca.dot(perp(u), w)) ** 2
    sign = 1.0 if side == "ahead" else -1.0
    t = -uw + sign * ca.sqrt(margin)
    return origin + t * u, margin


def attach(origin, toward, a, b):
    """The point with coordinates (a, b) in the frame at ``origin`` with x axis to ``toward``."""
    d = toward - origin
    n = ca.sqrt(ca.sumsqr(d))
    ex = d / n
    return origin + a * ex + b * perp(ex)


def frame_angle(origin, toward):
    """The angle of the x axis of the frame origin -> toward."""
    d = toward - origin
    return ca.atan2(d[1], d[0])
