"""The force at every joint (kinetostatics, issue 30): Newton-Euler on each part of the
mechanism, with the drive load as the closing unknown, as CasADi graphs of (s, p).

The structure (parts, two-force members, pins, sliders) is derived by
:mod:`.joint_structure`.  Each pin is a massless node: every part that meets there takes a
force from it (unknown, 2 components), every member its axial force (unknown, tension
positive), the linear drive's actuator its push (the drive load F_S, unknown), and the node
carries the force elements ([[forces]]) anchored there; the node's balance gives the first
part's force (the ground's, where the ground meets there), or two equations where only members
meet.  A slider's guide pushes across its line (unknown normal force N) and, on a part, holds
it with a moment (unknown M).  A rotary drive turns its crank with the torque T_S (unknown).
Each moving part balances its loads against its inertia (d'Alembert):

    sum F = sum m a_G          sum (r - O) x F + sum couples = sum I eps + (G - O) x m a_G

with a_G = r'' sd^2 + r' sdd, eps = phi'' sd^2 + phi' sdd (' = d/ds) at the model's motion.
The equations are linear in the unknowns; ``casadi.solve`` gives them as graphs of (s, p), so
their derivatives are exact.  The drive load found this way is the ideal (eta = 1) drive load
of the virtual-work route (:class:`~optdesign.model.reduction.ReducedModel`'s ``u``); the joint
forces are those of the ideal mechanism (a drive efficiency below 1 is not split among the
joints).

``pins`` maps each pin (named by its point) to its force on the first party that meets there
(the ground, where it meets there; else the first [[bodies]] entry, in file order; else the
first member): {'x', 'y'} global components [N]; ``parties`` maps each pin to the force on each
party that meets there ((name, force): a part's name, ``link P-Q`` for a two-force member,
``drive`` for a linear drive's actuator), which ``shared`` lists where they differ from one equal
and opposite pair (three or more parties, or a force element or a guide acting on the pin);
``sliders`` maps a slider's point to (normal, moment, force) (the guide's push on the slider, N
along the line's left normal).

Two routes inside the tool (:meth:`JointForces._check_routes`, ``routes``): the drive load from
the joint forces equals the virtual-work one, and the reactions' power sums to zero (ideal
joints do no work in the mechanism's motion: each part's reactions at its own rigid motion, the
links' at their ends, less the loads acting on the pins), else an error.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..errors import SceneError
from .joint_structure import JointStructureError, derive


# the joint forces whose peaks over the stroke are reported and certified (analyse, each case)
PEAKED = ("pin_force(", "slider_normal(", "slider_moment(")


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


class JointForces:
    """The joint forces of one :class:`~optdesign.model.reduction.ReducedModel` (its motion and
    force elements); raises :class:`~.joint_structure.JointStructureError` where the structure
    cannot be derived."""

    def __init__(self, model):
        self.model = model
        self.mech = mech = model.mech
        self.structure = st = derive(mech)
        scene = mech.scene
        k = model.k
        self.sd = model.qd / k
        self.sd2 = model.qd2 / k**2
        self.sdd = (model.qdd - model.dk * self.sd2) / k
        same = st.same
        pos = lambda name: mech.points[name]  # noqa: E731
        # --- the nodes: who meets at each pin --------------------------------------------------
        nodes = {}

        def node(point):
            return nodes.setdefault(same[point], {"parts": [], "members": [], "loads": []})

        for part in st.parts:
            for point in sorted(part.points, key=list(mech.points).index):
                node(point)["parts"].append(part)
        for i, (a, b) in enumerate(st.members):
            node(a)["members"].append((i, b))
            node(b)["members"].append((i, a))
        drive = scene.drive
        if drive.kind == "linear":
            a, b = drive.pins
            node(a)["members"].append(("drive", b))
            node(b)["members"].append(("drive", a))
        # --- the unknowns ---------------------------------------------------------------------
        layout, n = {}, 0
        for p, nd in nodes.items():
            for part in nd["parts"][1:]:
                layout[(p, part.name)] = n
                n += 2
        for i in range(len(st.members)):
            layout[("member", i)] = n
            n += 1
        for point in st.sliders:
            layout[("normal", point)] = n
            n += 1
            carriers = nodes.get(point, {}).get("parts")
            if carriers and carriers[0].name not in st.turning:   # a piston; on a turning part: a roller
                layout[("moment", point)] = n
                n += 1
        for i in range(len(st.telescopes)):
            layout[("telescope", i)] = n
            n += 2
        layout["drive"] = n
        n += 1
        X = mech.sym.sym("joint_unknowns", n)
        self.n_unknowns = n

        def unit(a, b):
            d = pos(b) - pos(a)
            return d / ca.sqrt(ca.sumsqr(d))

        def axial(ref, a, b):  # the force the node at a exerts on the member (a -> b)
            f = X[layout["drive"]] if ref == "drive" else -X[layout[("member", ref)]]
            return f * unit(a, b)

        # --- loads at the nodes: force elements, guides of sliders without a part -------------
        for name, e in model.forces.elements.items():
            f = next(f for f in scene.forces if f.name == name)
            if f.kind == "torsion":
                continue
            a, b = f.between
            tension = model.forces.tension(name, self.sd)
            for here, there in ((a, b), (b, a)):
                node(here)["loads"].append(tension * unit(here, there))
                node(here).setdefault("elements", []).append(tension * unit(here, there))
        normals = {}
        for point, c in st.sliders.items():
            angle = mech.value(c.angle)
            normals[point] = ca.vertcat(-ca.sin(angle), ca.cos(angle))
            if not nodes.get(point, {}).get("parts"):
                node(point)["loads"].append(X[layout[("normal", point)]] * normals[point])
        # --- node balances -------------------------------------------------------------------
        applied = {id(part): [] for part in st.parts}    # (position, force) on each part: the reactions
        couples = {id(part): [] for part in st.parts}
        held = {id(part): [] for part in st.parts}       # the reactions' couples (guides, cylinders)
        equations = []
        self.pins, self.parties, self.shared, self.reaches = {}, {}, [], {}
        power = []   # (force, velocity) of every reaction and of the loads acting on the pins (sign -)

        def link_name(ref):
            return "drive" if ref == "drive" else "link " + "-".join(st.members[ref])

        for p, nd in nodes.items():
            load = sum(nd["loads"][1:], nd["loads"][0]) if nd["loads"] else ca.DM.zeros(2, 1)
            others = [(part, part.name, X[layout[(p, part.name)]: layout[(p, part.name)] + 2])
                      for part in nd["parts"][1:]]
            others += [(None, link_name(ref), axial(ref, p, q)) for ref, q in nd["members"]]
            total = sum((f for _, _, f in others[1:]), others[0][2]) if others else ca.DM.zeros(2, 1)
            if nd["parts"]:
                first = load - total
                applied[id(nd["parts"][0])].append((pos(p), first))
                parties = [(nd["parts"][0].name, first)] + [(n, f) for _, n, f in others]
            else:
                equations.append(total - load)
                first = others[0][2] if others else None
                parties = [(n, f) for _, n, f in others]
            # the points each party reaches from the pin (a part's, a link's other end)
            reach = [part.points for part in nd["parts"]] + [{same[q]} for _, q in nd["members"]]
            for part, _, f in others:
                if part is not None:
                    applied[id(part)].append((pos(p), f))
            v = self._velocity(p)   # the links' ends (the drive's too) move with the pin
            power += [(f, v) for part, _, f in others if part is None] + [(-f, v) for f in nd.get("elements", [])]
            if len(nd["parts"]) + len(nd["members"]) >= 2:
                self.pins[p] = first
                self.parties[p] = parties
                self.reaches[p] = reach
                if len(parties) >= 3 or nd["loads"]:   # the parties' forces are not one equal and opposite pair
                    self.shared.append(p)
        self.sliders = {}
        for point, normal in normals.items():
            force = X[layout[("normal", point)]] * normal
            moment = X[layout[("moment", point)]] if ("moment", point) in layout else 0
            self.sliders[point] = (X[layout[("normal", point)]], moment, force)
            if nodes.get(point, {}).get("parts"):
                part = nodes[point]["parts"][0]
                applied[id(part)].append((pos(point), force))
                couples[id(part)].append(moment)
                held[id(part)].append(moment)
            else:   # a guide at a pin of links alone: its push on the pin
                power.append((force, self._velocity(point)))
        for i, (barrel, rod, a, b) in enumerate(st.telescopes):   # a cylinder: barrel and rod slide on each other
            j = layout[("telescope", i)]
            u = unit(a, b)
            force = X[j] * ca.vertcat(-u[1], u[0])
            applied[id(rod)].append((pos(b), force))
            applied[id(barrel)].append((pos(b), -force))
            couples[id(rod)].append(X[j + 1])
            couples[id(barrel)].append(-X[j + 1])
            held[id(rod)].append(X[j + 1])
            held[id(barrel)].append(-X[j + 1])
            self.sliders[f"{a}-{b}"] = (X[j], X[j + 1], force)
        if drive.kind == "rotary":
            couples[id(st.crank)].append(X[layout["drive"]])
        body_part = {b.name: part for part in st.parts for b in part.bodies}
        for name, e in model.forces.elements.items():
            f = next(f for f in scene.forces if f.name == name)
            if f.kind == "torsion":
                torque = model.forces.tension(name, self.sd)
                couples[id(body_part[f.bodies[-1]])].append(-torque)
                if len(f.bodies) == 2:
                    couples[id(body_part[f.bodies[0]])].append(torque)
        # --- each moving part: d'Alembert ----------------------------------------------------
        g = None if scene.gravity is None else mech.value(scene.gravity.g, "[gravity] g")
        count = 0
        for part in st.parts:
            if not part.moving:
                continue
            count += 1
            origin = pos(part.frame[0])
            force, moment = ca.DM.zeros(2, 1), 0
            for r, f in applied[id(part)]:
                force = force + f
                moment = moment + _cross(r - origin, f)
            for c in couples[id(part)]:
                moment = moment + c
            for b in part.bodies:
                force, moment = self._body(b, origin, g, force, moment)
            equations += [force, moment]
        if not equations:
            raise JointStructureError(f"{scene.path}: no moving part: the joint forces need a body or a link that moves")
        E = ca.vertcat(*equations)
        if E.shape[0] != n:
            held = [part.name for part in st.parts if part.moving and part.name not in st.turning
                    and sum(part in nd["parts"] and len(nd["parts"]) + len(nd["members"]) >= 2
                            for nd in nodes.values()) == 1 and part not in
                    [t[k] for t in st.telescopes for k in (0, 1)]]
            if held:
                raise JointStructureError(
                    f"{scene.path}: [[bodies]] {held[0]!r} does not turn and hangs on one pin: what holds its angle "
                    "(a parallel linkage, a guide) is not in the scene, so the joint forces cannot be derived; "
                    "build that linkage in [points] and [[bodies]] for them")
            raise JointStructureError(
                f"{scene.path}: the derived joint structure has {E.shape[0]} equations (3 per moving part: {count}; "
                f"2 per pin where only links meet) and {n} unknowns (pin forces, link forces, slider reactions, the "
                "drive): it is not the statically determinate structure of a mechanism moved by its drive alone; "
                "declare its links as [[bodies]] (docs/scenes.md, \"Joint forces\")")
        A = ca.jacobian(E, X)
        b = -ca.substitute(E, X, ca.DM.zeros(n, 1))
        solution = ca.solve(A, b)
        self.A = A
        subst = lambda e: ca.substitute(e, X, solution)  # noqa: E731
        self.pins = {p: subst(f) for p, f in self.pins.items() if f is not None}
        self.sliders = {p: tuple(subst(ca.DM(v) if isinstance(v, (int, float)) else v) for v in vals)
                        for p, vals in self.sliders.items()}
        self.parties = {p: [(name, subst(f)) for name, f in parties] for p, parties in self.parties.items()}
        self.drive = subst(X[layout["drive"]])  # the ideal drive load (T_S or F_S at eta = 1)
        # the reactions' power: each part's reactions at its own rigid motion (its frame's origin's
        # velocity and its turning rate), the links' at their ends' velocities, less the power of
        # the loads that act on the pins (force elements, the linear drive's push)
        for part in st.parts:
            if part.moving:
                origin, omega = self._rigid(part)
                for r, f in applied[id(part)]:
                    arm = r - pos(part.frame[0])
                    power.append((f, origin + omega * ca.vertcat(-arm[1], arm[0])))
                power += [(ca.vertcat(m, 0), ca.vertcat(omega, 0)) for m in held[id(part)]]
        terms = [ca.dot(subst(f), v) for f, v in power]
        self.reaction_power = sum(terms[1:], terms[0]) if terms else ca.DM(0)
        self.reaction_power_scale = sum((ca.fabs(t) for t in terms[1:]), ca.fabs(terms[0])) if terms else ca.DM(0)
        self.routes = self._check_routes()   # the two routes' relative errors {'drive', 'power'}

    def party_force(self, pin, toward):
        """The force at ``pin`` on the party that runs from it to the point ``toward`` (the part
        that carries both, the link between them): ``pin_force(P, Q)`` in an expression."""
        same = self.structure.same
        p, q = same.get(pin, pin), same.get(toward, toward)
        if p not in self.parties:
            raise SceneError(f"{self.mech.scene.path}: pin_force({pin}, {toward}): {pin!r} is no pin of the "
                             f"mechanism's joint structure; its pins: {', '.join(sorted(self.parties))}")
        hits = [(name, f) for (name, f), reach in zip(self.parties[p], self.reaches[p]) if q in reach and q != p]
        if len(hits) != 1:
            names = ", ".join(name for name, _ in self.parties[p])
            raise SceneError(f"{self.mech.scene.path}: pin_force({pin}, {toward}): "
                             f"{'no party' if not hits else 'more than one party'} at pin {pin} reaches {toward!r} "
                             f"(its parties: {names}); name a point that one of them alone carries")
        return hits[0][1]

    def _velocity(self, point):
        """The velocity of a point of the mechanism at the model's motion."""
        return self.mech.ds(self.mech.points[point]) * self.sd

    def _rigid(self, part):
        """A moving part's rigid motion: the velocity of its frame's origin and its turning rate."""
        o, x = (self.mech.points[n] for n in part.frame)
        d = x - o
        return self._velocity(part.frame[0]), _cross(d, self.mech.ds(d)) / ca.sumsqr(d) * self.sd

    def _check_routes(self, samples=9, tolerance=1e-9):
        """The two routes inside the tool, at the scene's parameters over the stroke: the drive
        load from the joint forces is the virtual-work one (``model.u``), to ``tolerance`` of its
        peak; the reactions' power (:attr:`reaction_power`: ideal joints do no work) is zero, to
        ``tolerance`` of the sum of its terms' sizes.  Else the derived structure is not the
        scene's mechanism: an error rather than wrong joint forces.  Returns the two relative
        errors {'drive', 'power'} (the tests hold them to 1e-12 on every shipped scene)."""
        mech = self.mech
        s = mech.stroke(samples)
        pins = [ca.sqrt(ca.sumsqr(f)) for f in self.pins.values()]
        f = mech.function("routes", {"ne": self.drive, "vw": self.model.u + 0 * mech.s,
                                     "pins": ca.vertcat(0 * mech.s, *pins), "power": self.reaction_power + 0 * mech.s,
                                     "power_scale": self.reaction_power_scale + 0 * mech.s})
        out = f.map(len(s))(s=s[None, :], p=mech.parameter_values)
        ne, vw, pins, power, size = (np.asarray(out[k], float) for k in ("ne", "vw", "pins", "power", "power_scale"))
        ne, vw = ne.ravel(), vw.ravel()
        # a drive load that vanishes over the stroke (a bar turning at constant speed) is
        # compared on the scale of the pin forces
        scale = max(float(np.max(np.abs(vw))), float(np.max(pins)), 1e-300)
        errors = {"drive": float(np.max(np.abs(ne - vw))) / scale,
                  "power": float(np.max(np.abs(power))) / max(float(np.max(size)), 1e-300)}
        if not errors["drive"] <= tolerance:
            raise JointStructureError(
                f"{mech.scene.path}: the joint structure derived from the scene gives a drive load that is not the "
                f"model's (differs by {errors['drive']:.2g} of its peak): the constructions imply "
                "links that are not the mechanism's; declare its links as [[bodies]]")
        if not errors["power"] <= tolerance:
            raise JointStructureError(
                f"{mech.scene.path}: the reactions of the joint structure derived from the scene do work (their power "
                f"is {errors['power']:.2g} of its terms' sizes): a derived joint is not one of the mechanism's; declare "
                "its links as [[bodies]]")
        return errors

    def _body(self, b, origin, g, force, moment):
        """Add a [[bodies]] entry's weight, applied loads and inertia forces (d'Alembert)."""
        mech, model = self.mech, self.model
        where = f"[[bodies]] {b.name}"
        if b.name in mech.body_com:
            G = mech.body_com[b.name]
            arm = G - origin
            loads = []
            if b.mass is not None:
                m = mech.value(b.mass, f"{where}.mass")
                r_s = mech.ds(G)
                a_G = mech.ds(r_s) * self.sd2 + r_s * self.sdd
                loads.append(-m * a_G)
                if g is not None:
                    loads.append(ca.vertcat(0, -m * g))
            if b.force is not None:
                loads.append(ca.vertcat(*(mech.value(e, f"{where}.force") for e in b.force)))
            for f in loads:
                force = force + f
                moment = moment + _cross(arm, f)
        if b.torque is not None:
            moment = moment + mech.value(b.torque, f"{where}.torque")
        if b.inertia is not None:
            phi_s = mech.ds(mech.body_angle[b.name])
            eps = mech.ds(phi_s) * self.sd2 + phi_s * self.sdd
            moment = moment - mech.value(b.inertia, f"{where}.inertia") * eps
        return force, moment

    def outputs(self) -> dict:
        """Named graphs per sample: ``pin_force(P)`` (magnitude), ``pin_force_x(P)``,
        ``pin_force_y(P)`` for each pin (the force on its first party); at each pin in
        :attr:`shared`, ``pin_force(P, PARTY)`` and its components for each party;
        ``slider_normal(P)``, ``slider_moment(P)`` for each slider."""
        out = {}
        for p, f in self.pins.items():
            out[f"pin_force({p})"] = ca.sqrt(ca.sumsqr(f))
            out[f"pin_force_x({p})"] = f[0]
            out[f"pin_force_y({p})"] = f[1]
        for p in self.shared:
            for party, f in self.parties[p]:
                out[f"pin_force({p}, {party})"] = ca.sqrt(ca.sumsqr(f))
                out[f"pin_force_x({p}, {party})"] = f[0]
                out[f"pin_force_y({p}, {party})"] = f[1]
        for p, (normal, moment, _) in self.sliders.items():
            out[f"slider_normal({p})"] = normal
            out[f"slider_moment({p})"] = moment
        return out
