"""The drive train behind the reduced model: a gearbox and motor behind a rotary drive, a
hydraulic cylinder as a linear one.

Rotary (seed 1's drive torque T_S at drive speed omega_S = qd, acceleration eps_S = qdd,
through a gearbox of ratio i = motor speed / drive speed and efficiency eta_g):

    motor speed          omega_m = i qd
    motor acceleration   eps_m   = i qdd
    load at the motor    T_g     = c_g T_S / i     (c_g = 1/eta_g while the motor drives,
                                                    eta_g while power flows back)
    motor torque         T_m     = T_g + J_r eps_m = c_g T_S / (i) + J_r i qdd

The inertia ratio is J_load / (i^2 J_r) with J_load = I_zS (the reduced inertia at the drive),
and the classical optimal ratio, which minimises the motor torque that accelerates a pure
inertia J_load (d/di (J_load/i + J_r i) = 0), is i* = sqrt(J_load / J_r).

Linear (drive force F_S > 0 pushes, i.e. extends the cylinder; length q, speed qd):

    bore for the push     D >= sqrt(4 F_push / (pi p))
    annulus for the pull  pi/4 (D^2 - d^2) >= F_pull / p
    Euler buckling        F_push <= pi^2 E I / (S (K L)^2),  I = pi d^4 / 64, L = the
                          pin-to-pin length at full extension (the longest over the stroke:
                          q is monotone there, so at one of its ends)
    rod for buckling      d >= (64 S F_push (K L)^2 / (pi^3 E))^(1/4)
    pump flow             Q = A_bore qd while extending, A_annulus |qd| while retracting
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..scene.expressions import constant_value


def gear_outputs(model, mech, drive_load, smoothing=0.0) -> dict:
    """Motor-side expressions (rotary drive with a [gearbox]): motor_speed, motor_acceleration
    and motor_load_torque (T_g = c_g T_S / i) of the drive load ``drive_load`` = T_S."""
    gearbox = mech.scene.gearbox
    ratio = mech.value(gearbox.ratio, "[gearbox] ratio")
    out = {"motor_speed": ratio * model.qd, "motor_acceleration": ratio * model.qdd}
    eta = None if gearbox.efficiency is None else mech.resolved.fixed_value(gearbox.efficiency)
    if gearbox.efficiency is None or eta == 1.0:
        c_g = 1.0
    else:
        eta = mech.value(gearbox.efficiency, "[gearbox] efficiency")
        if model.flow == "driving":
            c_g = 1 / eta
        elif model.flow == "braking":
            c_g = eta
        elif smoothing > 0:
            c_g = (1 / eta + eta) / 2 + (1 / eta - eta) / 2 * ca.tanh(drive_load * model.flow_speed / smoothing)
        else:
            c_g = ca.if_else(drive_load * model.flow_speed >= 0, 1 / eta, eta)
    out["motor_load_torque"] = c_g * drive_load / ratio
    return out


def gear_factor_at_rest(mech, flow) -> float:
    """c_g of a hold (the drive at rest): 1/eta_g 'driving', eta_g 'braking'."""
    gearbox = mech.scene.gearbox
    if gearbox is None or gearbox.efficiency is None:
        return 1.0
    eta = mech.resolved.constant(gearbox.efficiency, "[gearbox] efficiency")
    return 1 / eta if flow == "driving" else eta


def motor_numbers(motor, values) -> dict:
    """A motor's numbers (inertia, rated_torque, peak_torque, max_speed) at ``values``."""
    return {k: constant_value(getattr(motor, k), values, f"[[motors]] {motor.name}.{k}")
            for k in ("inertia", "rated_torque", "peak_torque", "max_speed")}


def full_extension(mech):
    """The actuator's pin-to-pin length at full extension: the longer one of its lengths at the
    stroke's two ends (q is monotone over a stroke without a dead centre), as an expression of p."""
    r = mech.resolved
    ends = [ca.substitute(mech.q, mech.s, ca.DM(v)) if mech.sym is ca.SX else ca.substitute(mech.q, mech.s, v)
            for v in (r.start, r.stop)]
    return ca.fmax(ends[0], ends[1])


def cylinder_outputs(mech, drive_load) -> dict:
    """Per-sample cylinder quantities: rod_buckling (utilisation F_push S (K L)^2 64 / (pi^3
    E d^4), <= 1 holds) when [cylinder] gives the rod; the full-extension length."""
    cyl = mech.scene.cylinder
    out = {"full_extension": full_extension(mech) + 0 * mech.s}
    if cyl.rod is not None:
        E = mech.value(cyl.modulus, "[cylinder] modulus")
        S = mech.value(cyl.buckling_safety, "[cylinder] buckling_safety")
        K = mech.value(cyl.length_factor, "[cylinder] length_factor")
        d = mech.value(cyl.rod, "[cylinder] rod")
        out["rod_buckling"] = drive_load * S * (K * out["full_extension"]) ** 2 * 64 / (math.pi**3 * E * d**4)
    return out


def euler_force(modulus, rod, length, length_factor=1.0) -> float:
    """Euler's critical load pi^2 E I / (K L)^2 of a round rod of diameter ``rod``."""
    return math.pi**2 * modulus * (math.pi * rod**4 / 64) / (length_factor * length) ** 2


def cylinder_sizing(values_of, push, pull, full_length, peak_extend_speed, peak_retract_speed) -> dict:
    """The cylinder's sizes from the peak push and pull forces [N] over every case, the
    full-extension length [m] and the peak extending and retracting speeds [m/s].
    ``values_of(key)`` gives a [cylinder] number (None when the key is absent)."""
    p, E = values_of("pressure"), values_of("modulus")
    S, K = values_of("buckling_safety"), values_of("length_factor")
    rod_given, bore_given = values_of("rod"), values_of("bore")
    push, pull = max(push, 0.0), max(pull, 0.0)
    rod_needed = (64 * S * push * (K * full_length) ** 2 / (math.pi**3 * E)) ** 0.25
    rod = rod_needed if rod_given is None else rod_given
    bore_needed = max(math.sqrt(4 * push / (math.pi * p)), math.sqrt(4 * pull / (math.pi * p) + rod**2))
    out = {"pressure": p, "peak_push": push, "peak_pull": pull, "full_extension": full_length,
           "bore_needed": bore_needed, "rod_needed_buckling": rod_needed, "rod": rod,
           "euler_force": euler_force(E, rod, full_length, K),
           "buckling_utilisation": push * S / euler_force(E, rod, full_length, K)}
    if bore_given is None and not bore_needed > rod:
        # nothing pulls and the rod given is thicker than the push needs: any bore larger than the
        # rod holds, so no bore (nor its pressures and pump flow) follows from the forces
        out["bore_undetermined"] = (f"any bore larger than the rod ({rod:.6g} m): nothing pulls, and the push alone "
                                    f"needs {math.sqrt(4 * push / (math.pi * p)):.6g} m; give [cylinder] bore for the "
                                    "pressures and the pump flow")
        return out
    bore = bore_needed if bore_given is None else bore_given
    area, annulus = math.pi * bore**2 / 4, math.pi * (bore**2 - rod**2) / 4
    out.update(bore=bore, pressure_push=push / area, pressure_pull=pull / annulus if pull > 0 else 0.0,
               pump_flow=max(area * peak_extend_speed, annulus * peak_retract_speed))
    return out


def pump_flow(qd, bore, rod) -> np.ndarray:
    """The pump flow [m^3/s] at cylinder speed ``qd``: bore area while extending, annulus
    while retracting."""
    qd = np.asarray(qd, float)
    return np.where(qd >= 0, math.pi * bore**2 / 4 * qd, math.pi * (bore**2 - rod**2) / 4 * -qd)
