"""Quantities over time: each case's stroke in time, and the duty cycle (cases, holds, dwells).

The integral over time, on the sample grid.  For a quantity g sampled at a case's sweep values
s_0, s_1, ... (the scene's samples plus the profile's phase boundaries, each taken from both
sides), the integral over the stroke's time is the exact integral of g's linear interpolant
between neighbouring samples, taken against the profile's exact time law:

    int g dt = sum over intervals [s_i, s_i+1] of  g_i W_i + g_i+1 W'_i,
    W'_i = int (s - s_i)/(s_i+1 - s_i) dt(s),   W_i = (t_i+1 - t_i) - W'_i,

with dt = ds / V(s), V the profile's sweep speed, W'_i by tanh-sinh quadrature (exact to
round-off, also in the first and last interval, where V vanishes like a square or cube root).
The rule is exact for g linear in s between samples and for any g that is constant; since the
phase boundaries are samples, g is smooth on every interval (it jumps only where the profile's
acceleration does), and the error falls as the square of the sample spacing
(benchmarks/evr_time.py measures it against a fine grid).  For a case at the constant [drive]
speed the time is linear in the drive coordinate q, and the rule is the trapezoid rule in time
(W_i = W'_i = (t_i+1 - t_i)/2).

Over the cycle, with T the cycle time (every step's duration: a case's stroke times its repeat
count, holds and dwells):

    RMS over time     sqrt(1/T * (sum of int T_S^2 dt over the cases' strokes + sum of
                      T_hold^2 * hold time)),   dwells adding time only; of a [quantities]
                      name likewise, a hold at its value there (none with a dwell: idle,
                      the mechanism has no known position)
    energy per cycle  sum of int P dt (P = T_S qd; negative where power flows back)
    mean power        energy per cycle / T

A hold keeps the drive at rest at one end of a case's motion: its load is the static reduced
load there, T_hold = c Q_q with c = 1/eta ('driving', the default) or eta ('braking'); through
a gearbox, c_g T_hold / i at the motor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..scene.expressions import evaluate
from .profiles import speed_function, tanh_sinh
from .time_integrals import rms_error
from .train import gear_factor_at_rest, motor_numbers

KEPT_WEIGHTS = 32   # a case model's time weights kept for the node sets last used (CaseTimes.of)
SHARED_WEIGHTS = 64   # of every case model (shared_weights)
PEAK_KEYS = ("drive", "static_load", "reduced_inertia", "power", "motor_torque", "motor_load_torque",
             "motor_speed", "rod_buckling")


@dataclass(frozen=True)
class CaseTimes:
    """Times at a case's samples and the weights of the time integral, one per sample (None
    when the case has no motion in time: a constant drive speed with an acceleration)."""

    t: np.ndarray
    duration: float
    weights: np.ndarray | None
    note: str = ""
    work_weights: np.ndarray | None = None   # with a profile: int P dt = work_weights . (T_S k sigma)

    @classmethod
    def of(cls, cm, nodes, values):
        """The times and weights of case model ``cm`` at its sample ``nodes`` (``values``: its
        evaluated outputs, with ``t`` for a closed-form profile, ``q``, ``k``)."""
        profile = cm.profile
        if profile is None:
            if cm.acceleration != 0.0:
                t = np.full(len(nodes), math.nan)
                return cls(t, math.nan, None, f"case {cm.name!r} runs at the constant [drive] speed with an "
                                              "acceleration: no motion in time; give it a profile")
            begin = cm.begins_at(np.sign(values["k"][0]))
            q_begin = values["q"][int(np.argmin(np.abs(nodes - begin)))]
            t = np.abs(values["q"] - q_begin) / abs(cm.speed)
            return cls(t, float(np.max(t)), time_weights(nodes, t))
        t = np.asarray(values["t"] if "t" in values else profile.times(nodes), float)
        speed = np.abs(np.asarray(values["sd"], float))
        # the weights are a function of the nodes, their times, the sweep speed there and the
        # profile alone (the same for every design whose case runs on these: an optimisation's
        # checks at each start's solution), kept per case model: the numbers computed before
        nodes = np.asarray(nodes, float)
        key = (nodes.tobytes(), t.tobytes(), speed.tobytes())
        kept = cm.__dict__.setdefault("_time_weights", {})
        if key not in kept:
            if len(kept) >= KEPT_WEIGHTS:
                kept.pop(next(iter(kept)))
            kept[key] = shared_weights(profile, nodes, t, speed, key)
        weights, work = kept[key]
        return cls(t, profile.duration, weights.copy(), "", work.copy())

    def integral(self, g) -> float:
        """int g dt over the stroke (the module's rule)."""
        return float(np.dot(self.weights, np.asarray(g, float)))

    def work(self, drive, k, sign, power) -> float:
        """int P dt of a power P = drive * qd: with a profile the work int drive dq (P = drive k
        sigma V, and V dt = ds), ``sign`` = sigma; without one int ``power`` dt."""
        if self.work_weights is None:
            return self.integral(power)
        return float(np.dot(self.work_weights, np.asarray(drive, float) * np.asarray(k, float) * sign))


_SHARED = {}   # shared_weights': (profile's numbers, nodes, t, speed) -> (time weights, work weights)


def shared_weights(profile, nodes, t, speed, key) -> tuple:
    """(time weights, work weights) of a profile at ``nodes`` (``key``: the bytes of nodes, t,
    speed), computed once per process for every case model on a profile of the same numbers: the
    cases of one profile and direction (crane_luffing_drive's three luffing in), and every
    problem of a scene made again (a catalogue's motors, which differ in their limits alone:
    tanh-sinh weights were a fifth of each motor's build).  Kept under the profile's shape and
    ends (its repr: every number, exactly), which are all the weights read of it; a law
    (a speed expression of the case's parameters, or a motion law) is not shared."""
    shape = profile.shape
    if shape.kind == "law" or shape.motion_law is not None:
        return time_weights(nodes, t, profile), work_weights(nodes, t, profile, speed)
    key = (repr((shape, profile.s_begin, profile.s_end)), *key)
    found = _SHARED.get(key)   # (no lock: a process forked while another thread held it would wait for ever)
    if found is None:
        found = (time_weights(nodes, t, profile), work_weights(nodes, t, profile, speed))
        while len(_SHARED) >= SHARED_WEIGHTS:
            try:
                _SHARED.pop(next(iter(_SHARED)), None)
            except (RuntimeError, StopIteration):   # changed by another thread meanwhile: look again
                pass
        _SHARED[key] = found
    return found


def time_weights(nodes, t, profile=None) -> np.ndarray:
    """Per sample, its weight in int g dt (the module's rule): the trapezoid rule in time
    without a profile; with one, g linear in s on each interval against the exact time law,
    and Simpson's rule in time on an s-curve's jerk segments (their samples evenly spaced in
    time)."""
    nodes, t = np.asarray(nodes, float), np.asarray(t, float)
    dt = np.abs(np.diff(t))
    w = np.zeros(len(nodes))
    if profile is not None and profile.shape.motion_law is not None:
        return law_weights(nodes, profile)
    if profile is None:
        np.add.at(w, np.arange(len(dt)), dt / 2)
        np.add.at(w, np.arange(1, len(dt) + 1), dt / 2)
        return w
    lo, hi = np.minimum(nodes[:-1], nodes[1:]), np.maximum(nodes[:-1], nodes[1:])
    width = np.where(hi > lo, hi - lo, 1.0)
    if profile.law_speed is not None:
        def integrand(s, d_lo, d_hi):
            return d_lo / width[:, None] / profile.law_speed(s.ravel()).reshape(s.shape)
    else:
        speed = speed_function(profile)
        sigma, begin, end = profile.sigma, profile.s_begin, profile.s_end

        def integrand(s, d_lo, d_hi):
            # the distances from the motion's two ends, each exact next to its own end
            if sigma > 0:
                x, y = (lo - begin)[:, None] + d_lo, (end - hi)[:, None] + d_hi
            else:
                x, y = (begin - hi)[:, None] + d_hi, (lo - end)[:, None] + d_lo
            return d_lo / width[:, None] / speed(x, y)
    w_upper = tanh_sinh(integrand, lo, hi)         # int (s - lo)/(hi - lo) dt per interval
    upper_first = nodes[:-1] > nodes[1:]           # the interval's first sample is its upper end
    w_first = np.where(upper_first, w_upper, dt - w_upper)
    mid = 0.5 * (lo + hi)
    taken = np.zeros(len(dt), bool)
    for s_lo, s_hi, _ in profile.jerk_segments():  # smooth in t, not in s: in time
        margin = 1e-12 * (s_hi - s_lo)   # (an interval across its end, between a breakpoint's two nodes, is not in it)
        idx = np.flatnonzero((mid > s_lo + margin) & (mid < s_hi - margin))
        if idx.size:
            taken[idx] = True
            w[idx[0]:idx[-1] + 2] += quadratic_weights(t[idx[0]:idx[-1] + 2])
    free = np.flatnonzero(~taken)
    np.add.at(w, free, w_first[free])
    np.add.at(w, free + 1, dt[free] - w_first[free])
    return w


def work_weights(nodes, t, profile, speed) -> np.ndarray:
    """Per sample, its weight in int P dt = int (T_S k sigma) V dt = int (T_S k sigma) ds: the
    trapezoid rule in s (exact for T_S k linear in s), and on an s-curve's jerk segments, where
    P is smooth in time but not in s, the quadratic rule in time on P (the weight times V)."""
    nodes = np.asarray(nodes, float)
    if profile.shape.motion_law is not None:
        return law_weights(nodes, profile) * np.asarray(speed, float)
    ds = np.abs(np.diff(nodes))
    mid = 0.5 * (nodes[:-1] + nodes[1:])
    taken = np.zeros(len(ds), bool)
    w = np.zeros(len(nodes))
    for s_lo, s_hi, _ in profile.jerk_segments():
        margin = 1e-12 * (s_hi - s_lo)   # (an interval across its end, between a breakpoint's two nodes, is not in it)
        idx = np.flatnonzero((mid > s_lo + margin) & (mid < s_hi - margin))
        if idx.size:
            taken[idx] = True
            w[idx[0]:idx[-1] + 2] += quadratic_weights(t[idx[0]:idx[-1] + 2]) * speed[idx[0]:idx[-1] + 2]
    free = np.flatnonzero(~taken)
    np.add.at(w, free, ds[free] / 2)
    np.add.at(w, free + 1, ds[free] / 2)
    return w


def law_weights(nodes, profile) -> np.ndarray:
    """A law in time: Boole's rule in time on its nodes evenly spaced in time
    (:meth:`~.profiles.MotionProfile.law_nodes`, within each piece, where the integrand is
    smooth in time), as Richardson's (16 S_h - S_2h)/15 of Simpson's rule on them and on every
    other one (error h^6: 1e-11 of the ventilator's RMS at 96 nodes); the scene's other samples
    weigh 0."""
    grid = profile.law_nodes()
    tol = 1e-12 * profile.length
    order = np.argsort(nodes)
    found = np.searchsorted(nodes[order], grid)
    chosen = []
    for g, i in zip(grid, found):   # the case's node at each law node (a sample where one fell on it)
        near = [j for j in (i - 1, i) if 0 <= j < len(nodes) and abs(nodes[order][j] - g) <= tol]
        if not near:
            raise ValueError(f"law node {g!r} is not among the case's samples")
        chosen.append(order[near[0]])
    times = profile.law_times()   # (a dwell's nodes are one sample: their weights add up)
    w, coarse = np.zeros(len(nodes)), np.zeros(len(chosen))
    coarse[::2] = quadratic_weights(times[::2])
    np.add.at(w, chosen, (16 * quadratic_weights(times) - coarse) / 15)
    return w


def quadratic_weights(t) -> np.ndarray:
    """Weights of int g dt over [t_0, t_n] from piecewise quadratic interpolation in t: pairs
    of intervals (Simpson's rule, for uneven spacing too), the last interval of an odd count
    from the quadratic through the last three samples.  Exact for g quadratic in t."""
    t = np.asarray(t, float)
    n = len(t) - 1
    w = np.zeros(n + 1)
    if n == 1:
        return np.abs(np.diff(t)).repeat(2) / 2
    for i in range(0, n - 1, 2):
        w[i:i + 3] += _lagrange_integrals(t[i:i + 3], t[i], t[i + 2])
    if n % 2:
        w[n - 2:n + 1] += _lagrange_integrals(t[n - 2:n + 1], t[n - 1], t[n])
    return w


def _trapezoid_weights(nodes, a, b):
    """int_a^b by the trapezoid rule on the interval(s) of ``nodes`` inside [a, b] (a and b are
    nodes): for three times too close together for a quadratic through them."""
    out = np.zeros(3)
    for j in range(2):
        if min(a, b) <= min(nodes[j], nodes[j + 1]) and max(nodes[j], nodes[j + 1]) <= max(a, b):
            half = abs(nodes[j + 1] - nodes[j]) / 2
            out[j] += half
            out[j + 1] += half
    return out


def _lagrange_integrals(nodes, a, b):
    """int_a^b of the three Lagrange basis polynomials on ``nodes`` (in |dt|: time may run
    either way along the samples).  In time from ``nodes[0]``: the antiderivative's cubes of
    the absolute times (a slow stroke's 15,708 s) cancelled to weights of +-13,090 s where the
    intervals were 1e-4 s (an RMS of a negative square: a traceback)."""
    c = nodes[0]
    nodes, a, b = np.asarray(nodes, float) - c, a - c, b - c
    gaps = np.abs(np.diff(nodes))
    if not gaps.min() > 1e-9 * gaps.max():     # times that coincide (a jerk phase of 1e-11 s): no quadratic
        return _trapezoid_weights(nodes, a, b)
    out = np.zeros(3)
    for i in range(3):
        tj, tk = (nodes[j] for j in range(3) if j != i)

        def anti(t):
            return t**3 / 3 - (tj + tk) * t**2 / 2 + tj * tk * t
        out[i] = (anti(b) - anti(a)) / ((nodes[i] - tj) * (nodes[i] - tk))
    return out if b >= a else -out


def case_integrals(times: CaseTimes, columns: dict, sigma: float = 1.0, quantities=()) -> dict:
    """Integrals of a case over its stroke's time: drive_squared (int T_S^2 dt), energy (int P
    dt; ``sigma`` the direction of the profile's sweep), energy_driving (int max(P, 0) dt), rms_time (sqrt(drive_squared / duration)), and with
    a gearbox the motor's three (load torque^2, load torque * acceleration, acceleration^2) from
    which any rotor inertia's RMS follows; and ``squared:NAME`` of each of the ``quantities``
    ([quantities] names, columns of the case)."""
    if times.weights is None:
        return {}
    with np.errstate(over="ignore", invalid="ignore"):   # a load beyond 1e154 squared: named by finite.check_cases
        out = _integrals(times, columns, sigma)
        out.update({f"squared:{q}": times.integral(columns[q] ** 2) for q in quantities})
        return out


def _integrals(times, columns, sigma):
    drive = columns["drive"]
    power = columns.get("power", np.zeros_like(drive))
    k, sign = columns["k"], sigma
    out = {"drive_squared": times.integral(drive**2), "energy": times.work(drive, k, sign, power),
           "energy_driving": times.work(np.where(drive * k * sign >= 0, drive, 0.0), k, sign, np.maximum(power, 0.0))}
    out["rms_time"] = math.sqrt(out["drive_squared"] / times.duration) if times.duration > 0 else math.nan
    if "motor_load_torque" in columns:
        tg, acc = columns["motor_load_torque"], columns["motor_acceleration"]
        out.update(motor_load_squared=times.integral(tg**2), motor_load_acceleration=times.integral(tg * acc),
                   motor_acceleration_squared=times.integral(acc**2))
    return out


class DutyCycle:
    """The duty cycle of a scene's cases: [duty] cycle, or every case once in order."""

    def __init__(self, scene, cases):
        self.scene, self.cases = scene, {c.name: c for c in cases}
        self.shares = {}   # without [duty]: each case's weight, its share of the cycle
        if scene.duty is not None:
            self.steps = scene.duty.steps
        else:
            from ..scene.cases import DutyStep

            self.steps = tuple(DutyStep("case", c.name, index=i) for i, c in enumerate(scene.cases))
            values = scene.parameter_values()
            self.shares = {c.name: float(evaluate(c.weight, values, {}, f"[[cases]] {c.name}.weight"))
                           for c in scene.cases if c.weight is not None}

    def count(self, step) -> float:
        """How many times a case step runs in the cycle: its repeat count, times the case's
        weight without [duty]."""
        return step.repeat * self.shares.get(step.case, 1.0)

    def evaluate(self, results, evaluated, p_values, mech=None) -> dict:
        """The cycle's time, RMS over time of the drive load (and of the motor's load torque),
        energy per cycle and mean power, with each step's time and load; ``reason`` instead
        when some case has no motion in time."""
        missing = [n for n, r in results.items() if not r.integrals and any(
            st.case == n for st in self.steps if st.kind == "case")]
        if missing:
            return {"reason": f"case {missing[0]!r} runs at the constant [drive] speed with an acceleration: no "
                              "motion in time, so no RMS over time; give it a profile"}
        steps, T, drive_sq, energy, driving, motor = [], 0.0, 0.0, 0.0, 0.0, np.zeros(3)
        err = dict.fromkeys(("drive_squared", "energy", "time", "motor_load_squared", "motor_load_acceleration",
                             "motor_acceleration_squared"), 0.0)   # the quadrature's error estimates
        mech = mech or next(iter(self.cases.values())).mech
        ratio = self._ratio(mech, p_values)
        # [quantities]: int q^2 dt over the cases, q^2 times a hold's time at its position (a dwell has none)
        squares = dict.fromkeys(k for r in results.values() for k in r.integrals if k.startswith("squared:"))
        squares = {k: [0.0, 0.0] for k in squares}   # value, error
        for st in self.steps:
            if st.kind == "case":
                r = results[st.case]
                n = self.count(st)
                T += n * r.duration
                drive_sq += n * r.integrals["drive_squared"]
                energy += n * r.integrals["energy"]
                driving += n * r.integrals["energy_driving"]
                if ratio is not None:
                    motor += n * np.array([r.integrals[k] for k in ("motor_load_squared", "motor_load_acceleration",
                                                                    "motor_acceleration_squared")])
                for k, e in r.integrals.get("errors", {}).items():
                    if k in err:
                        err[k] += n * e
                for k, pair in squares.items():
                    pair[0] += n * r.integrals[k]
                    pair[1] += n * r.integrals.get("errors", {}).get(k, 0.0)
                steps.append({"kind": "case", "case": st.case, "repeat": int(n) if n == int(n) else n,
                              "time": n * r.duration})
                continue
            duration = float(mech.resolved.constant(st.duration, f"[duty] cycle[{st.index}]"))
            T += duration
            step = {"kind": st.kind, "time": duration}
            if st.kind == "hold":
                cm = self.cases[st.case]
                eta = cm.model.eta if cm.model.uses_efficiency else 1.0
                c = 1 / eta if st.efficiency == "driving" else eta
                load = c * float(evaluated[st.case]["hold"][st.at])
                drive_sq += load * load * duration   # (a product: inf, named by finite.check_cases; ** raised)
                step.update(case=st.case, at=st.at, load=load)
                for k, pair in squares.items():
                    pair[0] += float(evaluated[st.case]["quantities"][k.split(":", 1)[1]][st.at]) ** 2 * duration
                if ratio is not None:
                    motor_load = gear_factor_at_rest(mech, st.efficiency) * load / ratio
                    motor[0] += motor_load * motor_load * duration
                    step["motor_load_torque"] = motor_load
            steps.append(step)
        out = {"cycle_time": T, "steps": steps, "rms_time": {"drive": math.sqrt(drive_sq / T)},
               "energy": energy, "energy_driving": driving, "mean_power": energy / T,
               "integrals": {"drive_squared": drive_sq}}
        if not any(st.kind == "dwell" for st in self.steps):   # (idle somewhere: a quantity's value unknown)
            for k, (value, error) in squares.items():
                out["rms_time"][k.split(":", 1)[1]] = math.sqrt(value / T)
        out["errors"] = {"rms_time": {"drive": rms_error(drive_sq, err["drive_squared"], T, err["time"])},
                         "energy": err["energy"], "mean_power": err["energy"] / T + abs(energy) * err["time"] / T**2}
        for k, (value, error) in squares.items():
            if k.split(":", 1)[1] in out["rms_time"]:
                out["errors"]["rms_time"][k.split(":", 1)[1]] = rms_error(value, error, T, err["time"])
        if ratio is not None:
            out["rms_time"]["motor_load_torque"] = math.sqrt(motor[0] / T)
            out["errors"]["rms_time"]["motor_load_torque"] = rms_error(motor[0], err["motor_load_squared"], T, err["time"])
            out["integrals"].update(motor_load_squared=motor[0], motor_load_acceleration=motor[1],
                                    motor_acceleration_squared=motor[2])
            out["integral_errors"] = {k: err[k] for k in ("motor_load_squared", "motor_load_acceleration",
                                                          "motor_acceleration_squared", "time")}
        return out

    @staticmethod
    def _ratio(mech, p_values):
        if mech.scene.gearbox is None:
            return None
        env = mech.resolved.environment(np.asarray(p_values, float))
        return float(evaluate(mech.scene.gearbox.ratio, env, {}, "[gearbox] ratio"))


def motor_report(scene, values, results, duty, ratio) -> dict:
    """Each motor of [[motors]] against the cases and the cycle: its peak torque (largest |T_g +
    J_r eps_m| over the cases, over the continuous stroke where they certified it; ``peak_sampled``
    over their samples), RMS torque over the cycle, peak speed, whether it fits
    (peak <= peak_torque, RMS <= rated_torque, speed <= max_speed), its inertia ratio J_load /
    (i^2 J_r) and the classical optimal ratio sqrt(J_load / J_r), J_load the largest reduced
    inertia (I_zS / c) over the cases (over the continuous stroke where they certified it;
    ``load_inertia_sampled`` on the samples); and the smallest motor (by rated torque) that fits."""
    if not scene.motors:
        return {}
    j_load = j_sampled = 0.0   # over the continuous stroke where the cases certified it, else the samples'
    for r in results.values():
        if "reduced_inertia" in r.columns:
            c = r.columns.get("efficiency_factor", 1.0)
            sampled = float(np.max(np.abs(r.columns["reduced_inertia"] / c)))
            j_sampled = max(j_sampled, sampled)
            j_load = max(j_load, sampled, r.load_inertia["value"] if r.load_inertia else 0.0)
    speed = max(r.peaks.get("motor_speed", 0.0) for r in results.values())
    motors = {}
    for m in scene.motors:
        num = motor_numbers(m, values)
        J = num["inertia"]
        sampled = max(float(np.max(np.abs(r.columns["motor_load_torque"] + J * r.columns["motor_acceleration"])))
                      for r in results.values())
        # over the continuous stroke where the cases certified it (model/cases.py), else the samples'
        peak = max(max(r.motors[m.name]["peak"] for r in results.values()), sampled)
        entry = {**num, "peak": peak, "peak_sampled": sampled, "peak_speed": speed, "inertia_ratio": j_load / (ratio**2 * J) if J > 0 else math.inf,
                 "optimal_ratio": math.sqrt(j_load / J) if J > 0 else math.inf, "ratio": ratio, "load_inertia": j_load,
                 "load_inertia_sampled": j_sampled}
        if duty and "integrals" in duty:
            a, b, c2 = (duty["integrals"][k] for k in ("motor_load_squared", "motor_load_acceleration",
                                                        "motor_acceleration_squared"))
            entry["rms"] = math.sqrt(max(a + 2 * J * b + J * J * c2, 0.0) / duty["cycle_time"])
            if "integral_errors" in duty:
                ea, eb, ec, et = (duty["integral_errors"][k] for k in ("motor_load_squared", "motor_load_acceleration",
                                                                       "motor_acceleration_squared", "time"))
                entry["rms_error"] = rms_error(max(a + 2 * J * b + J * J * c2, 0.0), ea + 2 * J * eb + J * J * ec,
                                               duty["cycle_time"], et)
        # within 1e-7 of a limit counts as on it (an optimum puts the design there to IPOPT's tolerance)
        slack = 1 + 1e-7
        entry["fits"] = bool(peak <= num["peak_torque"] * slack and speed <= num["max_speed"] * slack
                             and entry.get("rms", 0.0) <= num["rated_torque"] * slack)
        motors[m.name] = entry
    fitting = sorted((e["rated_torque"], name) for name, e in motors.items() if e["fits"])
    return {"motors": motors, "smallest_fitting": fitting[0][1] if fitting else None}


def require_times(duty) -> dict:
    """The duty cycle's quantities, or a SceneError saying why there are none."""
    if "reason" in duty:
        raise SceneError(duty["reason"])
    return duty
