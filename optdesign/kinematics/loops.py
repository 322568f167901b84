"""Seed 2's transmission matrices, and loops closed by Newton's method (CasADi rootfinder).

A chain of k links starts at joint A_1.  Link i turns by phi_i relative to link i-1 and the
position of a point with coordinates (a, b) in link k's frame is (seed 2, eq. 1.5)

    [x, y, 1]^T = T_1 T_2 ... T_k [a, b, 1]^T,   T_i = [[c_i, -s_i, L_{i-1}], [s_i, c_i, 0], [0, 0, 1]]

with L_0 = 0 (here the base joint's position enters as a translation in front of T_1).  Joint
A_{i+1} is (L_i, 0) in link i's frame.  Unknown relative angles are solved from the closure:
a joint coincides with a ground point (closed loop) or lies on a line (semi-closed loop).
Derivatives through the solve come from CasADi (implicit function theorem), so velocities and
accelerations need none of seed 2's derivative matrices T', T''.
"""
import casadi as ca

from .constructions import perp
from ..scene.expressions import evaluate


def transmission_matrix(phi, length_before):
    """Seed 2, eq. (1.2): rotation by phi after a shift of L_{i-1} along the previous x axis."""
    c, s = ca.cos(phi), ca.sin(phi)
    return ca.vertcat(
        ca.horzcat(c, -s, length_before),
        ca.horzcat(s, c, 0),
        ca.horzcat(0, 0, 1),
    )


def chain_joints(base, angles, lengths):
    """Positions of joints A_2 ... A_{k+1} of the chain (each 2 x 1)."""
    frame = ca.vertcat(ca.horzcat(1, 0, base[0]), ca.horzcat(0, 1, base[1]), ca.horzcat(0, 0, 1))
    joints, before = [], 0
    for phi, length in zip(angles, lengths):
        frame = ca.mtimes(frame, transmission_matrix(phi, before))
        joints.append(ca.mtimes(frame, ca.vertcat(length, 0, 1))[:2])
        before = length
    return joints


class LoopGraph:
    """The graph of one ``Loop`` construction: joints, unknown angles, residual, margin (the
    closure Jacobian's determinant) and its scale."""

    def __init__(self, loop, env, points, s, p, where):
        self.loop = loop
        names = list(loop.unknowns)
        u = ca.MX.sym(f"{loop.name}_unknowns", len(names))
        local = dict(env)
        local.update({n: u[i] for i, n in enumerate(names)})

        def ev(expr, what):
            return evaluate(expr, local, points, f"{where}.{what}")

        angles = [ev(a, f"angles[{i}]") for i, a in enumerate(loop.angles)]
        lengths = [ev(a, f"lengths[{i}]") for i, a in enumerate(loop.lengths)]
        joints = chain_joints(points[loop.base], angles, lengths)
        self.unknown_names = names
        if loop.closure is None:
            self.solution = None
            self.joints = joints
            self.residual = ca.MX(0)
            self.margin = self.margin_scale = None
            return
        residual, end = self._closure(joints, local, points, where)
        guess = ca.vertcat(*[evaluate(loop.unknowns[n], env, points, f"{where}.unknowns.{n}") for n in names])
        g = ca.Function(f"closure_{loop.name}", [u, s, p], [residual])
        solver = ca.rootfinder(
            f"newton_{loop.name}", "newton", g,
            {"error_on_fail": False, "abstol": 1e-14, "abstolStep": 1e-14, "max_iter": 50},
        )
        solution = solver(guess, s, p)
        joint_fn = ca.Function(f"joints_{loop.name}", [u, s, p], [ca.horzcat(*joints)])
        placed = joint_fn(solution, s, p)
        self.solution = solution
        self.joints = [placed[:, i] for i in range(len(joints))]
        self.residual = ca.norm_inf(g(solution, s, p))
        # the closure's Jacobian stays regular where the loop assembles; its determinant is the
        # smooth margin (a change of sign means the loop passed a singular, locking position).
        # Its scale is the product of the lengths of the closing point's velocities per unknown
        # (Hadamard's bound): the relative margin is the sine of the angle between them, or for
        # a line closure the cosine of the angle between the point's path and the line.
        moves = ca.jacobian(end, u)
        size = 1
        for j in range(len(names)):
            size = size * ca.norm_2(moves[:, j])
        jacobian = ca.Function(f"closure_jacobian_{loop.name}", [u, s, p], [ca.det(ca.jacobian(residual, u)), size])
        self.margin, self.margin_scale = jacobian(solution, s, p)

    def _closure(self, joints, local, points, where):
        cl = self.loop.closure
        end = joints[list(self.loop.joints).index(cl.point)]
        if cl.fixed is not None:
            return end - points[cl.fixed], end
        angle = evaluate(cl.angle, local, points, f"{where}.closure.line")
        direction = ca.vertcat(ca.cos(angle), ca.sin(angle))
        return ca.dot(perp(direction), end - points[cl.origin]), end
