"""Planar kinematics of a scene as CasADi graphs of (sweep value s, parameters p).

:class:`Mechanism` builds every point, body angle and centre of mass, the drive coordinate q(s)
and the assembly margins of every construction.  Derivatives with respect to s (and through
them velocities and accelerations in time) come from CasADi's automatic differentiation.
The graphs are SX (fast, scalar) unless the scene has a Newton-solved loop, which needs MX.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from . import constructions as geo
from .assembly import LOCKUP_MARGIN, AssemblyCheck, fmt_s as _fmt_s  # noqa: F401  (re-exported)
from ..scene import Attach, Dyad, Fixed, Loop, Polar, ResolvedScene, Scene, Slider
from ..scene.arguments import scene_argument
from ..scene.cases import uses_joint_forces
from ..scene.expressions import evaluate
from .loops import LoopGraph


@dataclass(frozen=True)
class Margin:
    """A construction's assembly margin.  For a dyad or slider (``kind`` 'dyad', 'slider') it is
    positive where the construction assembles and negative where it cannot.  For a loop it is
    the determinant of the closure's Jacobian, whose sign depends on the assembly branch: only
    a change of sign or a touch of zero (a singular, locking position) means something.
    ``expr / scale`` is the relative margin that :mod:`.assembly` checks over the stroke."""

    construction: str
    kind: str
    expr: object
    scale: object = None  # the margin's size far from lock-up (dyad 4 d^2 Lp^2, slider L^2,
    #                       loop: the product of the closing point's speeds per unknown)


class Mechanism:
    """The kinematic graphs of one scene (a :class:`~optdesign.scene.Scene`, resolved here, or
    a :class:`~optdesign.scene.ResolvedScene`, kept as ``resolved`` for the layers below).

    ``parameter_names`` and ``parameter_values`` are the leaf parameters (the entries of the
    graphs' parameter vector ``p``) and their numbers; ``env`` maps every parameter and the sweep
    variable to its symbol or expression in the graph."""

    def __init__(self, scene: Scene | ResolvedScene):
        resolved = scene if isinstance(scene, ResolvedScene) else ResolvedScene(scene)
        self.resolved = resolved
        self.scene = scene = resolved.scene
        self.parameter_names = resolved.leaf_names
        self.parameter_values = resolved.leaf_values.copy()
        self.has_loops = any(isinstance(c, Loop) for c in scene.points)
        # compiles the certificate's interval programs (set by the model's layer:
        # optdesign.model.intervals_compiled.compile_program); None: numpy evaluates them
        self.interval_compile = None
        # builds function()'s SX Functions with common subexpressions eliminated, reading them from
        # the cache folder when a run eliminated the same graph (set by the model's layer:
        # optdesign.model.cse.cse_function); None: CasADi eliminates them each time
        self.cse_function = None
        # compiles a Function (s, p) for its evaluations at many sweep values (:class:`.mapped.MappedFunction`:
        # the assembly check's; set by the model's layer: optdesign.model.mapped.compiled_function);
        # None: CasADi's virtual machine evaluates them (the same numbers)
        self.compile_function = None
        sym = ca.MX if self.has_loops else ca.SX
        self.sym = sym
        self.s = sym.sym(scene.sweep.name)
        self.p, env = resolved.symbols(sym)
        env[scene.sweep.name] = self.s
        self.env = env
        self.points: dict = {}
        self._assembly = None
        self.margins: list[Margin] = []
        # a dyad whose two centres meet: its circles (of equal radii) are one circle and its
        # point is not determined; checked with the margins, but no margin of the design problem
        self.centres: list[Margin] = []
        self.loops: list[LoopGraph] = []
        for c in scene.points:
            self._construct(c)
        # [quantities] by name, for text read after the scene (the objective): scene/quantities.py;
        # those of the joint forces are the model's (model/quantities.py)
        self.quantities = {q.name: self.value(q.expr, f"[quantities] {q.name}") for q in scene.quantities
                           if not uses_joint_forces(q.expr)}
        env.update(self.quantities)
        self.body_angle = {}
        self.body_com = {}
        for b in scene.bodies:
            o, x = (self.points[n] for n in b.frame)
            self.body_angle[b.name] = geo.frame_angle(o, x)
            if b.com is not None:
                a, bb = (self.value(e, f"[[bodies]] {b.name}.com") for e in b.com)
                self.body_com[b.name] = geo.attach(o, x, a, bb)
        self.q = self._drive_coordinate()

    # --- building ---
    def value(self, expr, where=""):
        """An expression of the scene evaluated in this mechanism's graph (s, p, points)."""
        return evaluate(expr, self.env, self.points, where)

    def _construct(self, c):
        where = f"[points] {c.name}"
        ev = lambda e, what: self.value(e, f"{where}.{what}")  # noqa: E731
        pts = self.points
        if isinstance(c, Fixed):
            pts[c.name] = ca.vertcat(ev(c.x, "fixed[0]"), ev(c.y, "fixed[1]"))
        elif isinstance(c, Polar):
            pts[c.name] = geo.polar(pts[c.centre], ev(c.length, "polar[1]"), ev(c.angle, "polar[2]"))
        elif isinstance(c, Dyad):
            length_p = ev(c.length_p, "dyad[1]")
            pts[c.name], m = geo.dyad(pts[c.p], length_p, pts[c.q], ev(c.length_q, "dyad[3]"), c.side)
            d2 = ca.sumsqr(pts[c.q] - pts[c.p])
            self.margins.append(Margin(c.name, "dyad", m, 4 * d2 * length_p**2))
            length_q = ev(c.length_q, "dyad[3]")
            self.centres.append(Margin(c.name, "dyad centres", d2, length_p**2 + length_q**2))
        elif isinstance(c, Slider):
            length = ev(c.length, "slider[1]")
            pts[c.name], m = geo.slider(pts[c.p], length, pts[c.origin], ev(c.angle, "slider[3]"), c.side)
            self.margins.append(Margin(c.name, "slider", m, length**2))
        elif isinstance(c, Attach):
            pts[c.name] = geo.attach(pts[c.origin], pts[c.toward], ev(c.a, "attach[2]"), ev(c.b, "attach[3]"))
        elif isinstance(c, Loop):
            graph = LoopGraph(c, self.env, pts, self.s, self.p, where)
            self.loops.append(graph)
            for name, joint in zip(c.joints, graph.joints):
                pts[name] = joint
            if graph.margin is not None:
                self.margins.append(Margin(c.name, "loop", graph.margin, graph.margin_scale))
        else:  # pragma: no cover - the scene validates kinds
            raise TypeError(c)

    def _drive_coordinate(self):
        d = self.scene.drive
        if d is None:
            return self.s
        a, b = (self.points[n] for n in d.pins)
        if d.kind == "rotary":
            return geo.frame_angle(a, b)
        return ca.sqrt(ca.sumsqr(b - a))

    # --- derivatives in s ---
    def ds(self, expr):
        """d expr / ds (exact, by AD)."""
        return ca.jacobian(expr, self.s)

    def function(self, name, outputs: dict) -> ca.Function:
        """A CasADi Function (s, p) -> named outputs.  SX graphs are built with common
        subexpressions eliminated: repeated differentiation duplicates much of the graph
        (level-luffing crane: 3,586 -> 977 instructions per sample, same numbers)."""
        if self.sym is ca.SX and self.cse_function is not None:
            return self.cse_function(name, [self.s, self.p], list(outputs.values()), ["s", "p"], list(outputs))
        opts = {"cse": True} if self.sym is ca.SX else {}
        return ca.Function(name, [self.s, self.p], list(outputs.values()), ["s", "p"], list(outputs), opts)

    # --- the stroke ---
    def stroke(self, samples: int | None = None) -> np.ndarray:
        return self.resolved.stroke(samples)

    def motion(self):
        """Sweep rate and acceleration (sd, sdd) as expressions of (s, p): from the drive's
        speed and acceleration when the scene has a drive, else from the sweep's own rate."""
        sc = self.scene
        if sc.drive is not None:
            qd = self.value(sc.drive.speed, "[drive] speed")
            qdd = self.value(sc.drive.acceleration, "[drive] acceleration")
            k = self.ds(self.q)
            dk = self.ds(k)
            sd = qd / k
            return sd, (qdd - dk * sd**2) / k
        sw = sc.sweep
        sd = 0.0 if sw.rate is None else self.value(sw.rate, "[sweep] rate")
        sdd = 0.0 if sw.acceleration is None else self.value(sw.acceleration, "[sweep] acceleration")
        return sd, sdd

    @property
    def assembly_notes(self) -> dict:
        """Of the last assembly check: construction -> why its margin has no enclosure's proof."""
        return dict(self._assembly.notes) if self._assembly is not None else {}

    def check_assembly(self, s_values, p_values=None) -> list:
        """Raise :class:`AssemblyError` naming the construction and the located sweep value
        where it cannot assemble or reaches its limit position, at the samples or between them
        (:class:`~.assembly.AssemblyCheck`: the margins' continuous minima, certified).  Returns
        the minima narrower than the samples' spacing, (s, width) each."""
        if self._assembly is None:
            self._assembly = AssemblyCheck(self)
        return self._assembly(s_values, self.parameter_values if p_values is None else p_values)


@dataclass(frozen=True)
class KinematicsResult:
    """Positions, velocities and accelerations over the stroke (arrays over samples)."""

    scene: Scene
    s: np.ndarray
    q: np.ndarray
    sd: np.ndarray
    sdd: np.ndarray
    points: dict  # name -> {"x","y","vx","vy","ax","ay"} arrays
    bodies: dict  # name -> {"angle","omega","epsilon"} arrays


def kinematics(scene: Scene | ResolvedScene, samples: int | None = None) -> KinematicsResult:
    """Points and body angles with their rates over the stroke, at the scene's motion."""
    mech = Mechanism(scene_argument("kinematics", scene, ResolvedScene))
    scene = mech.scene
    s_values = mech.stroke(samples)
    mech.check_assembly(s_values)
    sd, sdd = mech.motion()
    outs = {"q": mech.q, "sd": sd, "sdd": sdd}
    for name, r in mech.points.items():
        r_s = mech.ds(r)
        outs[f"P:{name}"] = ca.horzcat(r, r_s * sd, mech.ds(r_s) * sd**2 + r_s * sdd)
    for name, phi in mech.body_angle.items():
        phi_s = mech.ds(phi)
        outs[f"B:{name}"] = ca.vertcat(phi, phi_s * sd, mech.ds(phi_s) * sd**2 + phi_s * sdd)
    f = mech.function("kinematics", outs).map(len(s_values))
    res = {k: np.asarray(v) for k, v in f(s=s_values[None, :], p=mech.parameter_values).items()}
    n = len(s_values)
    points = {}
    for name in mech.points:
        # mapped 2 x 3 blocks lie side by side: columns 3i .. 3i+2 belong to sample i
        m = res[f"P:{name}"].reshape(2, n, 3).transpose(0, 2, 1)
        points[name] = {"x": m[0, 0], "y": m[1, 0], "vx": m[0, 1], "vy": m[1, 1], "ax": m[0, 2], "ay": m[1, 2]}
    bodies = {}
    for name in mech.body_angle:
        m = res[f"B:{name}"]
        bodies[name] = {"angle": np.unwrap(m[0]), "omega": m[1], "epsilon": m[2]}
    _check_finite(scene, s_values, points, bodies)
    q = res["q"].ravel()
    if scene.drive is not None and scene.drive.kind == "rotary":
        q = np.unwrap(q)
    return KinematicsResult(scene, s_values, q, np.broadcast_to(res["sd"].ravel(), (n,)).copy(),
                            np.broadcast_to(res["sdd"].ravel(), (n,)).copy(), points, bodies)


def _check_finite(scene, s_values, points, bodies):
    """Every point's position, velocity and acceleration and every body's angle finite at every
    sample; else a ResultError naming the first point (in the order of construction) or body, the
    quantity and the first sample where it is not (it exited 0, printing NaN)."""
    from ..errors import ResultError

    n = len(s_values)
    items = [(f"[points] {name}", {"position": (v["x"], v["y"]), "velocity": (v["vx"], v["vy"]),
                                    "acceleration": (v["ax"], v["ay"])}) for name, v in points.items()]
    items += [(f"[[bodies]] {name}", {"angle": (v["angle"],), "angular velocity": (v["omega"],),
                                       "angular acceleration": (v["epsilon"],)}) for name, v in bodies.items()]
    for order in ("position", "angle", "velocity", "angular velocity", "acceleration", "angular acceleration"):
        for label, quantities in items:
            if order not in quantities:
                continue
            bad = np.flatnonzero(~np.all([np.isfinite(c) for c in quantities[order]], axis=0))
            if bad.size:
                i = bad[0]
                raise ResultError(
                    f"{label}: its {order} is not finite at {scene.sweep.name} = {s_values[i]:.9g} (sample {i + 1} "
                    f"of {n}; {bad.size} of the {n} samples): its construction is not defined there (e.g. the square "
                    "root of a negative number, or an angle's derivative where it jumps); check its expressions or "
                    "the stroke ([sweep] from/to)")
