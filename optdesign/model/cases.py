"""Load cases: the reduced model of each [[cases]] entry, at its parameters and along its motion.

:class:`CaseModel` builds one case's graphs: the drive's speed and acceleration from the case's
profile (or the constant [drive] speed), seed 1's model with them at every sweep value, its
power-flow rule, and the drive train behind it (motor side of a [gearbox], a [cylinder]'s rod
buckling).  Its parameters are the mechanism's parameter vector p with the case's overrides
put in (:meth:`CaseModel.case_parameters`): one graph serves every case, only p differs.

:class:`CaseAnalysis` evaluates every case over the stroke (:mod:`.duty` integrates over time)
for :func:`optdesign.model.analysis.analyse`.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..scene.cases import CASE_COLUMNS, Case, case_values
from ..scene.expressions import evaluate
from .case_results import LOAD, CasesResult, _motor_key
from .case_runs import finish_columns, run_many
from .certified import CertifiedPeaks
from .duty import PEAK_KEYS, DutyCycle
from .joints import PEAKED
from ..kinematics.mapped import MappedFunction
from .mapped import compiled_function
from .profiles import constant_motion, case_profile
from .reduction import ReducedModel
from .time_integrals import INTEGRAND_COLUMNS
from .train import cylinder_outputs, gear_outputs, motor_numbers


class CaseModel:
    """One load case of a scene: its motion, its reduced model and drive train as CasADi
    expressions of (s, p), p the mechanism's parameter vector read as the case's parameters."""

    def __init__(self, mech, case: Case, efficiency_smoothing: float = 0.0, time=None):
        """``time``: a symbol tau for a law in time's fraction of its duration, used in place of
        the law's inverse at s (:meth:`.profiles.MotionProfile.graphs`): the graphs then hold
        both s and tau, and s = profile.sweep_at(tau) makes them graphs of tau alone."""
        r = mech.resolved
        self.mech, self.case, self.name, self.time = mech, case, case.name, time
        self.values = case_values(mech.scene, case, r.values)
        self.profile = case_profile(mech.scene, case, r.start, r.stop, r.values)
        motion = (self.profile.motion(mech, time=time) if self.profile is not None
                  else constant_motion(mech, case))
        self.model = ReducedModel(mech, efficiency_smoothing, motion=motion, flow=case.efficiency)
        self.smoothing = efficiency_smoothing
        if self.profile is None:
            self.speed = float(evaluate(mech.scene.drive.speed, self.values, {}, "[drive] speed"))
            self.acceleration = float(evaluate(mech.scene.drive.acceleration, self.values, {}, "[drive] acceleration"))

    def outputs(self) -> dict:
        """Named expressions per sample: the sweep's rate (with a profile) and the time (closed
        form), the drive's speed and acceleration, seed 1's quantities, the drive train's."""
        m, mech = self.model, self.mech
        out = {}
        if self.profile is not None:
            sd, sdd, _, t = self.profile.graphs(mech.s, lambda e: mech.value(e, "[profiles] speed"), self.time)
            out["sd"], out["sdd"] = sd, sdd + 0 * mech.s
            if self.profile.shape.motion_law is not None:   # a law in time: its jerk in closed form
                out["jerk"] = self.profile.jerk(mech.s, self.time)
            if t is not None:
                out["t"] = t
        out["drive_speed"] = m.qd + 0 * mech.s
        out["drive_acceleration"] = m.qdd + 0 * mech.s
        out.update(m.outputs())
        if "power" not in out:
            out["power"] = out["drive"] * m.qd
        if mech.scene.gearbox is not None:
            out.update(gear_outputs(m, mech, out["drive"], self.smoothing))
        if mech.scene.cylinder is not None:
            out.update(cylinder_outputs(mech, ca.fmax(out["drive"], 0.0)))
        return out

    def constraints(self, outputs) -> dict:
        """The scene's constraints that hold in this case and use its columns (or name it), as
        expressions of (s, p): each expr with the case's columns ``outputs`` as names."""
        from ..scene.cases import is_case_constraint

        from .quantities import environment   # the joint forces in this case (model/joints.py)

        columns = {k: v for k, v in outputs.items() if k in CASE_COLUMNS}
        return {c.name: evaluate(c.expr, {**environment(self.model, c.expr), **columns}, self.mech.points,
                                 f"[[constraints]] {c.name}")
                for c in self.mech.scene.constraints
                if is_case_constraint(self.mech.scene, c) and c.case in (None, self.name)}

    def static_load(self):
        """The ideal (eta = 1) static reduced load Q_q (T_Su or F_Su) at (s, p), or 0: a hold's
        load before the efficiency."""
        return self.model.Q_q if self.model.has_static else 0 * self.mech.s

    # --- parameters ---
    def case_parameters(self, p):
        """The case's parameter vector from the scene's p (numbers or CasADi): each overridden
        leaf replaced by its override evaluated with the scene's parameters."""
        r = self.mech.resolved
        if not self.case.overrides:
            return p
        env = r.environment(p)
        parts = []
        for i, name in enumerate(r.leaf_names):
            if name in self.case.overrides:
                parts.append(evaluate(self.case.overrides[name], env, {}, f"[[cases]] {self.name}.set.{name}"))
            else:
                parts.append(p[i])
        if isinstance(p, (ca.SX, ca.MX)):
            return ca.vertcat(*parts)
        return np.array([float(v) for v in parts])

    # --- time ---
    def begins_at(self, k_sign) -> float:
        """The sweep value where the motion begins (for a constant drive speed: where the sign of
        the speed and of k = dq/ds send it from)."""
        r = self.mech.resolved
        if self.profile is not None:
            return self.profile.s_begin
        forward = self.case.sign * math.copysign(1.0, self.speed) * k_sign > 0
        return r.start if forward else r.stop


class CaseAnalysis:
    """Every case of a scene over the stroke, compiled once (under :class:`optdesign.model.analysis.Analysis`)."""

    def __init__(self, mech, s_values, joints=False, certify=True, compile=False):
        """``joints``: each case's joint forces too (columns pin_force(P), ...: model/joints.py),
        their peaks certified over the continuous stroke unless ``certify`` is False;
        ``compile``: the cases' columns from the disk cache of compiled code
        (:func:`~.mapped.compiled_function`: the same numbers, several times faster)."""
        self.mech = mech
        self.s_values = np.asarray(s_values, float)
        self.cases = [CaseModel(mech, c) for c in mech.scene.cases]
        self.functions, self.pin_peaks = [], []   # pin_peaks: each case's pin forces (CertifiedPeaks), or None
        self._compile, self._integrand_graphs, self._integrands = compile, [], {}
        motor = motor_numbers(mech.scene.motors[0], mech.resolved.values) if len(mech.scene.motors) == 1 else None
        self.motor_inertias = ({m.name: motor_numbers(m, mech.resolved.values)["inertia"] for m in mech.scene.motors}
                               if mech.scene.gearbox is not None else {})
        for cm in self.cases:
            outs = self._outputs(cm, motor, joints)
            # the peaks over the continuous stroke, certified: seed 1's quantities, the drive
            # train's, each motor's torque T_g + J_r eps_m (whether it fits) and the pins' forces;
            # along a law in time as graphs of its time tau (smooth at a rest, where its
            # inverse tau(s), in the graphs of s, is not: the ventilator's enclosure never closed)
            if certify and cm.profile is not None and cm.profile.in_time:
                tau = mech.sym.sym("tau")
                in_time = CaseModel(mech, cm.case, time=tau)
                rows = self._peak_rows(self._outputs(in_time, motor, joints), in_time.model)
                self.pin_peaks.append(CertifiedPeaks(mech, rows, time=(tau, cm.profile)) if rows else None)
            else:
                rows = self._peak_rows(outs, cm.model)
                self.pin_peaks.append(CertifiedPeaks(mech, rows) if rows and certify else None)
            outs["q"], outs["k"] = mech.q, mech.ds(mech.q)
            outs["hold_load"] = cm.static_load() + 0 * mech.s
            self.quantities = tuple(k for k in mech.quantities if k not in outs)   # [quantities], as columns
            outs.update({k: mech.quantities[k] + 0 * mech.s for k in self.quantities})
            self.functions.append((list(outs), MappedFunction(mech.function(f"case_{len(self.functions)}", outs),
                                                                    compile=compiled_function if compile else None)))
            self._integrand_graphs.append({k: outs[k] for k in (*INTEGRAND_COLUMNS, *self.quantities) if k in outs})
        self.duty = DutyCycle(mech.scene, self.cases)

    def integrands(self, c):
        """Case c's columns that its integrals over time read (:data:`.time_integrals.INTEGRAND_COLUMNS`
        and the [quantities]): (names, function), built on first use.  The same graphs as the
        case's own columns (each output the same operations on the same operands: the same
        numbers), without the others, which the adaptive quadrature's thousands of nodes need not
        pay for (crane_luffing_drive: 20 columns, 5 of them read, 0.6 of the time per node)."""
        if c not in self._integrands:
            outs = self._integrand_graphs[c]
            self._integrands[c] = (list(outs), MappedFunction(self.mech.function(f"case_{c}_integrands", outs),
                                                              compile=compiled_function if self._compile else None))
        return self._integrands[c]

    def _outputs(self, cm, motor, joints) -> dict:
        """Case ``cm``'s columns as graphs: its outputs, the one motor's torque, its constraints
        and (``joints``) its joint forces."""
        outs = cm.outputs()
        if motor is not None:
            outs["motor_torque"] = outs["motor_load_torque"] + motor["inertia"] * outs["motor_acceleration"]
        for name, expr in cm.constraints(outs).items():
            outs[f"constraint:{name}"] = expr + 0 * self.mech.s
        if joints:
            outs.update(_joint_outputs(cm, self.mech))
        return outs

    def _peak_rows(self, outs, model) -> dict:
        """The rows whose peaks are certified, from a case's columns ``outs`` and ``model``
        (with motors, its reduced inertia without the efficiency: the load inertia)."""
        rows = {k: outs[k] for k in PEAK_KEYS if k in outs and not (k == "motor_torque" and self.motor_inertias)}
        rows.update({_motor_key(name): outs["motor_load_torque"] + J * outs["motor_acceleration"]
                     for name, J in self.motor_inertias.items()})
        rows.update({k: v for k, v in outs.items() if k.startswith(PEAKED)})
        if self.motor_inertias and "reduced_inertia" in outs:
            rows[LOAD] = model.M_q + 0 * self.mech.s
        return rows

    def run(self, p_values) -> "CasesResult":
        """Every case, the governing case of each peak, the duty cycle and the drive train at
        the parameter vector ``p_values`` (the batch of one of :meth:`run_many`)."""
        found = self.run_many(np.asarray(p_values, float).ravel()[None, :])[0]
        if isinstance(found, Exception):
            raise found
        return found

    def run_many(self, P) -> list:
        """:meth:`run` of every row of ``P`` (cases x parameters): per row its
        :class:`CasesResult` or the OptdesignError that stopped it, each bit for bit what the row
        alone gives (:func:`.case_runs.run_many`)."""
        return run_many(self, P)

    def _evaluate(self, cm, names, function, nodes, p_case):
        """Case ``cm``'s outputs at ``nodes`` with its parameters ``p_case`` (q unwrapped for a
        crank, a law's checks) and its times (:func:`.case_runs.finish_columns`)."""
        values = dict(zip(names, (np.asarray(v, float).ravel() for v in function(nodes, p_case))))
        return finish_columns(self, cm, names, function, nodes, p_case, values)[:2]


def _joint_outputs(cm, mech) -> dict:
    """A case's joint forces (model/joints.py) as columns, or none where the structure cannot be
    derived (analyse's joints_note says why)."""
    from .joint_structure import JointStructureError
    from .quantities import joint_forces

    try:
        return {k: v + 0 * mech.s for k, v in joint_forces(cm.model).outputs().items()}
    except JointStructureError:
        return {}
