"""Load cases in the design problem (issue 16): the objective over every case, the drive
train's constraints, and the RMS over the duty cycle's time.

The objective (``[objective] minimise``) of a scene with [[cases]] is a sum of terms with
non-negative coefficients, each

* ``peak(NAME)``: the peak |NAME| over every case and the continuous stroke (min-max over the
  cases: one epigraph variable t with -t <= NAME_c(s_j) <= t for every case c; each case's
  peak is certified as a scene's peak is), or ``peak(NAME, CASE)`` over one case;
* ``rms_time(NAME)``: the RMS of NAME over the duty cycle's time (holds and dwells included),
  with the integral on each case's sample grid by the rule of :mod:`optdesign.model.duty`
  (its weights are numbers for a profile, which is the same motion for every design; at a
  constant drive speed they follow the design's drive coordinate).

NAME is a case's column (drive, power, static_load, motor_torque with one motor, motor_load_torque,
motor_speed, rod_buckling, a [quantities] name); e.g. ``"peak(motor_torque) + 2*rms_time(motor_torque)"``.

Constraints added by the drive train, for every case at every sample (certified over the
continuous stroke like the scene's own): with one motor, ``motor peak torque`` |T_m| <=
peak_torque and ``motor speed`` |omega_m| <= max_speed, and ``motor rated torque``, the RMS of
T_m over the cycle <= rated_torque (one row: a cycle constraint); with a [cylinder] rod,
``rod buckling`` (push force times the safety factor over Euler's load at full extension <= 1).

Each case's rows are the case model's (:class:`optdesign.model.cases.CaseModel`) with the
scene's parameter vector p replaced by the case's (its overrides put in), so that every row is
a function of (s, p) as the problem's rows are.  The functions take the problem (``pb``) and
read or set its attributes, as :mod:`.rows` and :mod:`.nlp` do.
"""
from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np

from ..errors import SceneError
from ..model.case_results import case_nodes
from ..model.cases import CaseModel
from ..model.duty import time_weights
from ..model.profiles import case_profile
from ..model.train import cylinder_outputs, gear_factor_at_rest, motor_numbers
from ..scene.expressions import evaluate
from .bounds import numeric_bounds

_TERM = re.compile(r"^\s*(?:(\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+)\s*\*\s*)?(peak|rms_time)\s*\(\s*([A-Za-z_]\w*)"
                   r"\s*(?:,\s*(?:\"([^\"]+)\"|'([^']+)'|([^)]+?)))?\s*\)\s*$")
NAMES = ("drive", "power", "static_load", "motor_torque", "motor_load_torque", "motor_speed", "rod_buckling")


def parse_objective(text, case_names, path="<python>", quantities=()):
    """The terms of a cases objective: [(coefficient, 'peak'|'rms_time', NAME, case or None)],
    or None when ``text`` is not of that form (a stroke expression then); errors name the
    scene's ``path``.  NAME is a case's column (:data:`NAMES`) or one of the scene's
    ``quantities`` ([quantities] names)."""
    terms = []
    parts = _split(text)
    odd = [part.strip() for part in parts if not _TERM.match(part)]
    if odd and len(odd) < len(parts):   # some terms of the form, some not: say which
        raise SceneError(f"{path}: [objective] minimise = {text!r}: {odd[0]!r} is not a term of a load-case "
                         "objective; expected a sum of peak(NAME), peak(NAME, CASE) and rms_time(NAME), each "
                         "with an optional coefficient >= 0 (e.g. \"2*peak(drive) + rms_time(drive)\")")
    train_only = re.fullmatch(r"\s*(rms|rms_sweep)\s*\(\s*(motor_torque|motor_load_torque|motor_speed|rod_buckling)\s*\)\s*",
                              text)
    if train_only:   # a drive train's column exists per case only, and over time
        raise SceneError(f"{path}: [objective] minimise = {text!r}: {train_only.group(2)} is a load case's column, "
                         f"which {train_only.group(1)}(...) (the nominal [drive] state over the sweep) does not have; "
                         f"its RMS over the duty cycle's time is rms_time({train_only.group(2)})")
    # not a sum of terms, yet rms_time (only a cases objective has it) or a peak term subtracted
    # ('peak(length(D, B))' alone is the nominal state's peak, handled with the plain objectives)
    if odd and (re.search(r"\brms_time\s*\(", text) or re.search(r"(\)\s*-|-\s*[\d.eE]*\s*\*?\s*peak\s*\()", text)):
        raise SceneError(f"{path}: [objective] minimise = {text!r}: expected a sum of peak(NAME), peak(NAME, CASE) "
                         "and rms_time(NAME), each with an optional coefficient >= 0 (e.g. \"2*peak(drive) + "
                         "rms_time(drive)\")" + ("; a term may not be subtracted (minimising -peak(...) would "
                                                  "maximise it)" if "-" in text else ""))
    for part in parts:
        m = _TERM.match(part)
        if not m:
            return None
        coef = float(m.group(1)) if m.group(1) else 1.0
        case = m.group(4) or m.group(5) or (m.group(6).strip() if m.group(6) else None)
        if m.group(3) not in NAMES + tuple(quantities):
            raise SceneError(f"{path}: [objective] minimise = {text!r}: {m.group(3)!r} is not a column of a load case; "
                             f"expected one of {', '.join(NAMES + tuple(quantities))}")
        if case is not None and case not in case_names:
            raise SceneError(f"{path}: [objective] minimise = {text!r}: no case {case!r}; cases: {', '.join(case_names)}")
        if case is not None and m.group(2) == "rms_time":
            raise SceneError(f"{path}: [objective] minimise = {text!r}: rms_time is over the whole duty cycle, not one case")
        terms.append((coef, m.group(2), m.group(3), case))
    return terms or None


def _split(text):
    """The '+'-separated terms of ``text`` (not splitting inside parentheses or numbers' exponents)."""
    parts, depth, last = [], 0, 0
    for i, ch in enumerate(text):
        depth += ch == "("
        depth -= ch == ")"
        if ch == "+" and depth == 0 and not (i > 0 and text[i - 1] in "eE" and text[i - 2:i - 1].isdigit()):
            parts.append(text[last:i])
            last = i + 1
    return parts + [text[last:]]


# --- rows -----------------------------------------------------------------------------------
def case_models(pb) -> list:
    """The cases' models, built once, with the power-flow switch smoothed like the problem's; a
    case along a law in time with a symbol tau for its time (``pb.case_times``; :func:`in_sweep`
    puts its inverse tau(s) in, the continuous check certifies in tau: ``pb.in_time``)."""
    if getattr(pb, "case_models", None) is None:
        models, pb.case_times = [], []
        for case in pb.scene.cases:
            cm = CaseModel(pb.mech, case)
            tau = None
            if cm.profile is not None and cm.profile.in_time:
                tau = pb.mech.sym.sym(f"tau_{len(pb.case_times)}")
                pb.case_times.append((tau, cm.profile))
            if cm.model.uses_efficiency and cm.model.flow == "auto":
                f = pb.mech.function("power", {"power": cm.model.u * cm.model.flow_speed})
                p_case = cm.case_parameters(pb.mech.parameter_values)
                power = np.abs(np.asarray(f.map(len(pb.s_grid))(pb.s_grid[None, :], p_case)))
                width = pb.settings.efficiency_smoothing * max(float(np.nanmax(power)), 1e-12)
                cm = CaseModel(pb.mech, case, efficiency_smoothing=width, time=tau)
            elif tau is not None:   # (tau(s) at a rest defeats the enclosure, certify.py)
                cm = CaseModel(pb.mech, case, time=tau)
            models.append(cm)
        pb.case_models = models
    return pb.case_models


def in_sweep(pb, exprs) -> list:
    """``exprs`` (a list) with each law in time's tau replaced by its inverse tau(s): graphs of (s, p)."""
    times = getattr(pb, "case_times", ())
    if not times:
        return list(exprs)
    return ca.substitute(list(exprs), [tau for tau, _ in times], [profile.tau_at(pb.mech.s) for _, profile in times])


def _motor(pb):
    """The one motor's numbers (rotor inertia J_r ...), or None."""
    if len(pb.scene.motors) != 1:
        return None
    return motor_numbers(pb.scene.motors[0], pb.mech.resolved.values)


def case_outputs(pb, cm) -> dict:
    """A case's named per-sample expressions of (s, p), p the scene's vector."""
    out = cm.outputs()
    motor = _motor(pb)
    if motor is not None:
        out["motor_torque"] = out["motor_load_torque"] + motor["inertia"] * out["motor_acceleration"]
    out["hold_load"] = cm.static_load() + 0 * pb.mech.s
    if "rod_buckling" in out:   # at a hold: linear in the (pushing) force, this per newton
        out["hold_rod"] = cylinder_outputs(pb.mech, 1.0)["rod_buckling"]   # (cycle_integrals)
    out.update({name: q + 0 * pb.mech.s for name, q in pb.mech.quantities.items()})   # [quantities], in the case
    names = list(out)
    p = pb.mech.p
    exprs = ca.substitute([out[k] for k in names], [p], [cm.case_parameters(p)]) if cm.case.overrides else \
        [out[k] for k in names]
    return dict(zip(names, exprs))


def case_constraints(pb, cm) -> dict:
    """The scene's constraints of case ``cm`` (:meth:`CaseModel.constraints`) as rows of (s, p),
    p the scene's vector (the case's parameters put in)."""
    out = cm.outputs()
    motor = _motor(pb)
    if motor is not None:
        out["motor_torque"] = out["motor_load_torque"] + motor["inertia"] * out["motor_acceleration"]
    exprs = cm.constraints(out)
    if not exprs or not cm.case.overrides:
        return exprs
    names = list(exprs)
    p = pb.mech.p
    return dict(zip(names, ca.substitute([exprs[k] for k in names], [p], [cm.case_parameters(p)])))


def case_objective_rows(pb, rows, Block, k_ref) -> bool:
    """The objective's rows for a scene with [[cases]] (False when the objective is a stroke
    expression, which the plain problem handles).  Sets objective_kind ('peak', 'rms_time' or
    'mix'), objective_quantity and objective_fraction (the first peak case's), the peak blocks
    (one per case), case_peaks (the other cases' epigraph rows), time_terms.  ``Block`` is
    :class:`.rows.Block`, ``k_ref()`` the scale of k = dq/ds (:mod:`.rows` passes both)."""
    names = [c.name for c in pb.scene.cases]
    terms = parse_objective(pb.objective_text, names, pb.scene.path, [q.name for q in pb.scene.quantities])
    if terms is None:
        return False
    models = case_models(pb)
    pb.case_rows = {cm.name: {} for cm in models}   # case name -> {column: row}
    pb.case_terms = terms
    peaks = [t for t in terms if t[1] == "peak"]
    if len(terms) == 1 and peaks and peaks[0][0] == 1.0:
        pb.objective_kind = "peak"
    elif len(terms) == 1 and not peaks and terms[0][0] == 1.0:
        pb.objective_kind = "rms_time"
    else:
        pb.objective_kind = "mix"
    if len(peaks) > 1:
        raise SceneError(f"{pb.scene.path}: [objective] minimise = {pb.objective_text!r}: at most one peak(...) term (one epigraph)")
    pb.case_peaks = []
    pb.time_terms = [t for t in terms if t[1] == "rms_time"]
    first = True
    if peaks:
        _, _, what, only = peaks[0]
        for cm in models:
            if only is not None and cm.name != only:
                continue
            out = case_outputs(pb, cm)
            _need(pb, out, what)
            value = len(rows)
            rows.append(out[what])
            fraction = None
            if what in ("drive", "power"):
                n, d = cm.model.drive_numerator(k_ref())
                if what == "power":
                    n = n * cm.model.qd
                if cm.case.overrides:
                    n, d = ca.substitute([n, d], [pb.mech.p], [cm.case_parameters(pb.mech.p)])
                fraction = (len(rows), len(rows) + 1)
                rows += [n, d]
            name = f"{pb.objective_text} in case {cm.name!r}"
            block = Block(name, "peak", value, -math.inf, math.inf, 1.0)
            if first:
                pb.objective_quantity, pb.objective_fraction = value, fraction
                pb.blocks.insert(0, block)
                first = False
            else:
                pb.blocks.append(block)
                pb.case_peaks.append((name, value, fraction))
    for _, _, what, _ in pb.time_terms:
        for cm in models:
            out = case_outputs(pb, cm)
            _need(pb, out, what)
            if what not in pb.case_rows[cm.name]:
                pb.case_rows[cm.name][what] = len(rows)
                rows.append(out[what])
        if first:  # the objective's scale: its quantity in the first case
            pb.objective_quantity = pb.case_rows[models[0].name][what]
            pb.blocks.insert(0, Block(pb.objective_text, "rms_time", pb.objective_quantity, -math.inf, math.inf, 1.0))
            first = False
    return True


def _need(pb, out, what):
    if what not in out:
        why = {"motor_torque": "one [[motors]] entry (with a catalogue, optimise one motor at a time)",
               "motor_load_torque": "a [gearbox]", "motor_speed": "a [gearbox]",
               "rod_buckling": "a [cylinder] with its rod"}.get(what, "")
        raise SceneError(f"{pb.scene.path}: [objective] minimise = {pb.objective_text!r}: {what!r} needs {why}")


def case_constraint_rows(pb, rows, Block):
    """The drive train's constraints for every case (see the module's doc): per-sample blocks,
    and the rows the cycle constraint integrates.  Sets cycle_constraints."""
    pb.cycle_constraints = []
    if not pb.scene.cases:
        return
    models = case_models(pb)
    if getattr(pb, "case_rows", None) is None:
        pb.case_rows = {}
    motor = _motor(pb)
    per_sample = []   # (constraint, case, expression, lower, upper)
    for cm in models:
        out = case_outputs(pb, cm)
        for name, expr in case_constraints(pb, cm).items():   # the scene's, per case
            c = next(c for c in pb.scene.constraints if c.name == name)
            lo, hi = numeric_bounds(pb.mech.resolved, c)
            per_sample.append((name, cm.name, expr, lo, hi))
        if motor is not None:
            per_sample.append(("motor peak torque", cm.name, out["motor_torque"], -motor["peak_torque"], motor["peak_torque"]))
            per_sample.append(("motor speed", cm.name, out["motor_speed"], -motor["max_speed"], motor["max_speed"]))
            if "motor_torque" not in pb.case_rows.setdefault(cm.name, {}):  # for the cycle constraint
                pb.case_rows[cm.name]["motor_torque"] = len(rows)
                rows.append(out["motor_torque"])
        if "rod_buckling" in out:
            per_sample.append(("rod buckling", cm.name, out["rod_buckling"], -math.inf, 1.0))
        for k in ("hold_load", "hold_rod")[:1 + ("hold_rod" in out)]:
            pb.case_rows.setdefault(cm.name, {})[k] = len(rows)
            rows.append(out[k])
        if "q" not in pb.case_rows[cm.name]:
            pb.case_rows[cm.name]["q"] = len(rows)
            rows.append(pb.mech.q)
    for name, cases, expr, lo, hi in _distinct(pb, per_sample):
        which = f"case {cases[0]!r}" if len(cases) == 1 else "cases " + ", ".join(map(repr, cases))
        pb.blocks.append(Block(f"{name} in {which}", "constraint", len(rows), lo, hi, 1.0))
        rows.append(expr)
    if motor is not None:
        pb.cycle_constraints.append(("motor rated torque", "motor_torque", motor["rated_torque"]))


def _distinct(pb, per_sample):
    """The per-sample constraints with the cases whose rows are the same merged into one (the
    motor speed of cases that differ only in their payload: the same row twice would make the
    constraint Jacobian rank-deficient).  Same = equal on the scene's samples at the start
    design, to 1e-12 of their size.  [(name, [cases], expression, lower, upper)]"""
    if not per_sample:
        return []
    exprs = in_sweep(pb, [e for _, _, e, _, _ in per_sample])
    f = pb.mech.function("case_constraints", {f"c{j}": e for j, e in enumerate(exprs)})
    mapped = f.map(len(pb.s_grid))(pb.s_grid[None, :], pb.mech.parameter_values)
    values = [np.asarray(v, float).ravel() for v in (mapped if isinstance(mapped, (list, tuple)) else [mapped])]
    out = []
    for j, (name, case, expr, lo, hi) in enumerate(per_sample):
        scale = max(float(np.max(np.abs(values[j]))), 1e-300)
        same = next((o for o in out if o[0] == name and np.max(np.abs(values[o[5]] - values[j])) <= 1e-12 * scale), None)
        if same is not None:
            same[1].append(case)
        else:
            out.append([name, [case], expr, lo, hi, j])
    return [tuple(o[:5]) for o in out]


# --- the cycle in time ----------------------------------------------------------------------
def case_grid(mech) -> np.ndarray:
    """The scene's samples plus every case profile's phase boundaries (from both sides) and
    s-curve jerk nodes: where the cases' loads jump or bend, for the continuous check."""
    r, stroke = mech.resolved, mech.stroke()
    nodes = [case_nodes(stroke, case_profile(mech.scene, c, r.start, r.stop, r.values))[0] for c in mech.scene.cases]
    grid = np.unique(np.concatenate(nodes + [stroke]))
    return grid if stroke[-1] > stroke[0] else grid[::-1]


def on_case_break(pb, s) -> bool:
    """True when ``s`` is (within 1e-6 of the stroke) a phase boundary of a case's profile, where
    a case's load kinks or jumps: an extreme there is a one-sided one, at a sweep value that is
    the same for every design, not a stationary point to follow."""
    if not pb.scene.cases:
        return False
    if getattr(pb, "_case_breaks", None) is None:
        r = pb.mech.resolved
        breaks = [case_profile(pb.scene, c, r.start, r.stop, r.values) for c in pb.scene.cases]
        pb._case_breaks = np.concatenate([np.zeros(0)] + [b.breakpoints() for b in breaks if b is not None])
    span = abs(pb.s_grid[-1] - pb.s_grid[0])
    return bool(pb._case_breaks.size) and float(np.min(np.abs(pb._case_breaks - s))) <= 1e-6 * span


def at_points(pb):
    """The quantity rows at the NLP's sample points, for an MX NLP: the per-point Function mapped
    over the points.  Not expanded to SX (nor are the cycle's maps, :func:`cycle_integrals`): the
    map keeps the NLP's graph small, so that it builds in a second and compiles (crane_luffing_drive
    per motor: 40.8 MB serialized -> 0.43 MB, built in 13-19 s -> 1 s, 669 MB of C that could not be
    compiled -> 5.1 MB compiled in 18 s; 4 starts of the 7.5 kW motor 47 s of CPU -> 39 s on the
    virtual machine, 14 s compiled; press_servo_cycle, whose expanded NLP did not compile either, 6
    starts 3.9 -> 2.0 s; the same optima to the last digit)."""
    return pb.quantity.map(pb.n_points)


def needs_mx(pb) -> bool:
    """True when the NLP holds the cycle's integrals: mapped over many samples, in MX (inlined
    into SX, crane_luffing_drive's build took 55 s and its constraint Jacobian 69 ms)."""
    return pb.objective_kind in ("rms_time", "mix") or bool(getattr(pb, "cycle_constraints", ()))


def _time_plan(pb):
    """Per case: its sample nodes, and the weights of the time integral when they are numbers
    (a profile); built once."""
    if getattr(pb, "_time_plan", None) is None:
        plan = {}
        for cm in case_models(pb):
            nodes, _ = case_nodes(pb.mech.stroke(), cm.profile)
            if cm.profile is not None:
                t = cm.profile.times(nodes)
                plan[cm.name] = (nodes, time_weights(nodes, t, cm.profile), cm.profile.duration)
            elif cm.acceleration != 0.0:
                raise SceneError(f"{pb.scene.path}: [[cases]] {cm.name!r} runs at the constant [drive] speed with an "
                                 "acceleration: no motion in time, so no RMS over time; give it a profile")
            else:
                plan[cm.name] = (nodes, None, abs(cm.speed))
        pb._time_plan = plan
    return pb._time_plan


def _cycle(pb):
    from ..model.duty import DutyCycle

    return DutyCycle(pb.scene, case_models(pb))


def cycle_integrals(pb, p, quantities):
    """(T, {name: int name^2 dt over the cycle}) as expressions of p (MX): each case's samples'
    quantities weighted by the rule, holds' static loads, dwells' time."""
    plan = _time_plan(pb)
    cycle = _cycle(pb)
    values, durations = {}, {}
    for name, Q, rows in _cycle_rows(pb, p, quantities, {st.case for st in cycle.steps if st.kind != "dwell"}):
        nodes, weights, speed_or_T = plan[name]
        if weights is None:    # constant drive speed: the trapezoid rule in time, t = |q - q0| / v
            dt = ca.fabs(Q[rows["q"], 1:] - Q[rows["q"], :-1]) / speed_or_T
            w = ca.horzcat(dt, 0) / 2 + ca.horzcat(0, dt) / 2
            durations[name] = ca.sum2(dt)
        else:
            w, durations[name] = ca.DM(weights).T, speed_or_T
        values[name] = {k: ca.sum2(w * Q[rows[k], :] ** 2) for k in quantities}
        values[name]["hold"] = Q[rows["hold_load"], 0], Q[rows["hold_load"], -1]
        values[name]["ends"] = {k: (Q[rows[k], 0], Q[rows[k], -1]) for k in rows}   # (a [quantities] name at a hold)
    T, sums = 0, {k: 0 for k in quantities}
    models = {cm.name: cm for cm in case_models(pb)}
    named = [k for k in quantities if k in pb.mech.quantities]
    if named and any(st.kind == "dwell" for st in cycle.steps):
        raise SceneError(f"{pb.scene.path}: [objective] minimise = {pb.objective_text!r}: the RMS over time of "
                         f"[quantities] {named[0]} needs its value at every moment of the cycle, and a dwell (idle) "
                         "has no position; hold there instead ({ hold = SECONDS, case = NAME }) or use peak(...)")
    for st in cycle.steps:
        if st.kind == "case":
            n = cycle.count(st)
            T = T + n * durations[st.case]
            for k in quantities:
                sums[k] = sums[k] + n * values[st.case][k]
            continue
        duration = pb.mech.resolved.constant(st.duration, f"[duty] cycle[{st.index}]")
        T = T + duration
        if st.kind == "hold":
            cm = models[st.case]
            begin_first = cm.begins_at(pb.k_sign) == pb.mech.resolved.start   # the nodes run from [sweep] from
            first, last = values[st.case]["hold"]
            end = (st.at == "end") == begin_first   # the hold at the nodes' last
            load = last if end else first
            eta = cm.model.eta if cm.model.uses_efficiency else 1.0
            load = load * (1 / eta if st.efficiency == "driving" else eta)
            for k in quantities:   # at rest: the drive and static load the held load, no power, no speed
                if k in ("drive", "static_load"):
                    sums[k] = sums[k] + load**2 * duration
                elif k == "rod_buckling":   # the rod's utilisation under the held (pushing) load
                    sums[k] = sums[k] + (ca.fmax(load, 0) * values[st.case]["ends"]["hold_rod"][1 if end else 0]) ** 2 * duration
                elif k in named:
                    sums[k] = sums[k] + values[st.case]["ends"][k][1 if end else 0] ** 2 * duration
                elif k in ("motor_torque", "motor_load_torque"):
                    ratio = evaluate(pb.scene.gearbox.ratio, pb.mech.resolved.environment(p), {}, "[gearbox] ratio")
                    sums[k] = sums[k] + (gear_factor_at_rest(pb.mech, st.efficiency) * load / ratio) ** 2 * duration
    return T, sums


def _cycle_rows(pb, p, quantities, used):
    """(case name, Q, {row name: index in Q}) of each case in ``used``: the rows its integrals
    need (MX, rows x its nodes).  Cases whose nodes are nearly the same (one profile run both
    ways, with and without the payload: the nodes differ only at the profile's phase
    boundaries) are evaluated by one mapped Function of all their rows on the union of their
    nodes, each case taking its own, so that the kinematics they share is computed once per
    node (CSE), not once per case (crane_luffing_drive's four duty cases)."""
    plan = _time_plan(pb)
    groups = []   # [union of the nodes, [case names]]
    for name in (n for n in plan if n in used):
        nodes = plan[name][0]
        for group in groups:
            union = np.union1d(group[0], nodes)
            if len(union) <= max(len(group[0]), len(nodes)) * 1.1:   # a few nodes more, not another grid
                group[0], group[1] = union, group[1] + [name]
                break
        else:
            groups.append([np.unique(nodes), [name]])
    for j, (union, names) in enumerate(groups):
        # only the rows each case's integrals need, at its samples
        extra = ["hold_load", "q"] + ["hold_rod"] * ("rod_buckling" in quantities)
        needed = {name: [k for k in dict.fromkeys(list(quantities) + extra) if k in pb.case_rows[name]] for name in names}
        f = pb.mech.function(f"cycle_rows_{j}", {f"{c}:{k}": pb.rows[pb.case_rows[c][k]]
                                                 for c in names for k in needed[c]})
        out = iter(f.map(len(union)).call([ca.DM(union).T, p]))   # not expanded: see at_points
        for name in names:
            columns = np.searchsorted(union, plan[name][0]).tolist()   # its nodes, in its order
            Q = ca.vertcat(*[next(out) for _ in needed[name]])
            yield name, Q[:, columns], {k: i for i, k in enumerate(needed[name])}


def case_nlp(pb, Q, p, t, f, add, every):
    """The cases' part of the NLP (called by :func:`.nlp.build_nlp`): the other cases' epigraph
    rows, the cycle constraints, and the objective for 'rms_time' and 'mix'.  Returns f."""
    for name, value, fraction in getattr(pb, "case_peaks", ()):
        if fraction is not None:
            num, den = (Q[i, :].T for i in fraction)
            v, bound = num / pb.f_ref, t * den
        else:
            v, bound = Q[value, :].T / pb.f_ref, t
        add(name, "peak", ca.vertcat(v - bound, -v - bound), -math.inf, 0.0, points=np.r_[every, every])
    quantities = sorted({w for _, _, w, _ in getattr(pb, "time_terms", ())} |
                        {k for _, k, _ in getattr(pb, "cycle_constraints", ())})
    if not quantities:
        return f
    # an MX NLP: the start screening (design/starts.py) ranks such a problem's starts by a
    # quadrature of its objective quantity over the sweep, with this many panels
    if not hasattr(pb, "rms_panels"):
        pb.rms_panels = pb.settings.rms_panels
    T, sums = cycle_integrals(pb, p, quantities)
    for name, key, limit in pb.cycle_constraints:
        rms = ca.sqrt(sums[key] / T)
        add(name, "cycle constraint", rms / limit, -math.inf, 1.0, limit)
    if pb.objective_kind == "rms_time":
        return sums[pb.time_terms[0][2]] / T / pb.f_ref**2
    if pb.objective_kind != "mix":   # one peak term, or a plain objective beside the cycle constraints
        return f
    total = 0
    for coef, kind, what, _ in pb.case_terms:
        total = total + coef * (t * pb.f_ref if kind == "peak" else ca.sqrt(sums[what] / T))
    return total / pb.f_ref


def time_rms(pb, sol) -> float:
    """The objective of 'rms_time' or 'mix' at a solution, in physical units."""
    if pb.objective_kind == "rms_time":
        return pb.f_ref * math.sqrt(max(sol.f, 0.0))
    return pb.f_ref * sol.f
