"""Numbers for drawings: where every point, centre of mass, slider guide and load is at chosen
positions of the stroke, and where the stroke stops assembling.

Unlike :func:`optdesign.kinematics.kinematics`, which refuses a stroke that does not assemble,
:class:`Geometry` evaluates any sweep value: a construction that cannot assemble there gives
NaN for its point and those built on it, and :meth:`Frames.failure` names the first such
construction (``optdesign draw`` shows a scene while it is being written)."""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..kinematics import constructions as geo
from ..kinematics.mechanism import LOCKUP_MARGIN, Mechanism
from ..scene import Attach, Loop, ResolvedScene, Slider


@dataclass
class Frames:
    """Positions at the sweep values ``s`` (arrays over samples, first axis).

    ``points``: name -> (n, 2); ``feet``: attach point -> (n, 2), its foot on the frame's x
    axis (the point with b = 0); ``coms``: body -> (n, 2); ``guides``: slider or line-closed
    loop -> (origin point, angles (n,)); ``forces``: body -> (n, 2) applied force; ``torques``:
    body -> (n,); ``masses``: body -> mass (kg); ``g``: gravity or 0; ``q``: drive coordinate
    (n,); ``failed``: (n,) name of the first construction that does not assemble, or ''."""

    s: np.ndarray
    points: dict
    feet: dict
    coms: dict
    guides: dict
    forces: dict
    torques: dict
    masses: dict
    g: float
    q: np.ndarray
    failed: np.ndarray

    @property
    def assembled(self) -> np.ndarray:
        return self.failed == ""

    def at(self, i) -> "Frames":
        """The frame of sample ``i`` alone (arrays of length 1)."""
        pick = lambda d: {k: v[i:i + 1] for k, v in d.items()}  # noqa: E731
        return Frames(self.s[i:i + 1], pick(self.points), pick(self.feet), pick(self.coms),
                      {k: (o, a[i:i + 1]) for k, (o, a) in self.guides.items()}, pick(self.forces),
                      pick(self.torques), self.masses, self.g, self.q[i:i + 1], self.failed[i:i + 1])

    def extent(self) -> float:
        """The size of the drawing: the diagonal of the box around every assembled point."""
        ok = self.assembled
        xy = np.concatenate([v[ok] for v in self.points.values()] + [np.zeros((0, 2))])
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if not len(xy):
            return 1.0
        d = float(np.hypot(*(xy.max(axis=0) - xy.min(axis=0))))
        return d if d > 0 else 1.0


class Geometry:
    """The drawing's graphs of one scene (a Scene or ResolvedScene), built once."""

    def __init__(self, scene):
        self.mech = mech = Mechanism(scene)
        self.resolved: ResolvedScene = mech.resolved
        self.scene = sc = mech.scene
        outs = {f"P:{n}": r for n, r in mech.points.items()}
        for c in sc.points:
            if isinstance(c, Attach):
                o, x = mech.points[c.origin], mech.points[c.toward]
                outs[f"F:{c.name}"] = geo.attach(o, x, mech.value(c.a), 0)
            elif isinstance(c, Slider):
                outs[f"G:{c.name}"] = mech.value(c.angle)
            elif isinstance(c, Loop) and c.closure is not None and c.closure.origin is not None:
                outs[f"G:{c.name}"] = mech.value(c.closure.angle)
        for b in sc.bodies:
            if b.name in mech.body_com:
                outs[f"C:{b.name}"] = mech.body_com[b.name]
            if b.force is not None:
                outs[f"f:{b.name}"] = ca.vertcat(*(mech.value(e) for e in b.force))
            if b.torque is not None:
                outs[f"t:{b.name}"] = mech.value(b.torque)
            if b.mass is not None:
                outs[f"m:{b.name}"] = mech.value(b.mass)
        outs["g"] = mech.value(sc.gravity.g) if sc.gravity is not None else ca.DM(0)
        outs["q"] = mech.q
        self._order = [m for m in mech.margins if m.kind != "loop"]
        for i, m in enumerate(self._order):
            outs[f"M:{i}"] = m.expr / m.scale
        for j, loop in enumerate(mech.loops):
            if loop.solution is not None:
                outs[f"R:{j}"] = loop.residual
        self.names = list(outs)
        self.function = mech.function("drawing", outs)
        self._maps = {}
        self._jacobian = None

    def frames(self, s_values, p_values=None) -> Frames:
        """Positions at ``s_values`` (a NaN where a construction does not assemble)."""
        s = np.atleast_1d(np.asarray(s_values, float))
        p = self.mech.parameter_values if p_values is None else np.asarray(p_values, float)
        n = len(s)
        if n not in self._maps:
            self._maps[n] = self.function.map(n)
        with np.errstate(invalid="ignore"):
            raw = self._maps[n](s=s[None, :], p=p)
        res = {k: np.asarray(v, float) for k, v in raw.items()}
        vec = lambda k: res[k].reshape(2, n).T if res[k].size == 2 * n else np.tile(res[k].reshape(1, 2), (n, 1))  # noqa: E731
        row = lambda k: np.broadcast_to(res[k].ravel(), (n,)).copy()  # noqa: E731
        sc = self.scene
        failed = np.full(n, "", dtype=object)
        for i, m in enumerate(self._order):
            bad = ~(row(f"M:{i}") > LOCKUP_MARGIN) & (failed == "")
            failed[bad] = f"{m.construction} ({m.kind})"
        size = max(1.0, float(np.nanmax(np.abs(np.concatenate([vec(f"P:{k}") for k in self.mech.points])),
                                        initial=1.0)))
        for j, loop in enumerate(self.mech.loops):
            if loop.solution is not None:
                bad = ~(row(f"R:{j}") <= 1e-9 * size) & (failed == "")
                failed[bad] = f"{loop.loop.name} (loop)"
        points = {k: vec(f"P:{k}") for k in self.mech.points}
        # the points built on a construction that does not assemble are NaN already (sqrt of a
        # negative margin); a loop that does not close gives finite nonsense: blank its joints
        for j, loop in enumerate(self.mech.loops):
            if loop.solution is not None:
                bad = ~(row(f"R:{j}") <= 1e-9 * size)
                for name in loop.loop.joints:
                    points[name][bad] = np.nan
        guides = {}
        for c in sc.points:
            if f"G:{c.name}" in res:
                origin = c.origin if isinstance(c, Slider) else c.closure.origin
                guides[c.name] = (origin, row(f"G:{c.name}"))
        masses = {b.name: float(np.ravel(res[f"m:{b.name}"])[0]) for b in sc.bodies if f"m:{b.name}" in res}
        return Frames(
            s=s, points=points,
            feet={k[2:]: vec(k) for k in res if k.startswith("F:")},
            coms={k[2:]: vec(k) for k in res if k.startswith("C:")},
            guides=guides,
            forces={k[2:]: vec(k) for k in res if k.startswith("f:")},
            torques={k[2:]: row(k) for k in res if k.startswith("t:")},
            masses=masses, g=float(np.ravel(res["g"])[0]), q=row("q"), failed=failed)

    def stroke(self, samples=None) -> np.ndarray:
        return self.resolved.stroke(samples)

    def point_derivatives(self, s, names, p_values=None) -> dict:
        """d point / d parameter and d2 point / d parameter2 for the leaf parameters ``names``
        at sweep value ``s``: name -> {point -> (first (2,), second (2,))}."""
        mech = self.mech
        if self._jacobian is None:
            stacked = ca.vertcat(*mech.points.values()) if mech.points else ca.DM.zeros(0, 1)
            jac = ca.jacobian(stacked, mech.p)
            second = ca.horzcat(*[ca.jacobian(jac[:, i], mech.p)[:, i] for i in range(mech.p.numel())])
            self._jacobian = mech.function("point_derivatives", {"J": jac, "H": second})
        p = mech.parameter_values if p_values is None else np.asarray(p_values, float)
        with np.errstate(invalid="ignore"):
            out = self._jacobian(s=s, p=p)
        J, H = np.asarray(out["J"], float), np.asarray(out["H"], float)
        result = {}
        for name in names:
            i = mech.parameter_names.index(name)
            result[name] = {pt: (J[2 * k:2 * k + 2, i], H[2 * k:2 * k + 2, i]) for k, pt in enumerate(mech.points)}
        return result
