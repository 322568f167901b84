"""What was sized, for a person (issue 29): the drive train at the optimum in the units drive
engineers read (docs/figures.md): the gear ratio without a unit beside the motor's and the
output's peak speeds (rad/s and rpm), every catalogue motor at the chosen design with its peak,
RMS, speed and inertia ratio against its limits and whether it fits, the governing case of each
limit; a cylinder's bore and rod (mm), pressures (bar), pump flow (l/min) and buckling
utilisation.  One set of rows (:func:`train_rows`) feeds summary.txt and report.html, from the
numbers result.json holds (``cases``, ``catalogue_at_optimum``)."""
from __future__ import annotations

import math

RPM = 60 / (2 * math.pi)   # rad/s -> rpm
BAR = 1e-5                 # Pa -> bar
MM = 1e3                   # m -> mm
LPM = 6e4                  # m^3/s -> l/min
INERTIA_RATIO_LIMIT = 10.0  # the usual upper limit of J_load/(i^2 J_r) for a servo drive (5 for a dynamic one)


def catalogue_at_optimum(catalogue) -> dict:
    """Every motor of the catalogue at the chosen design and gear ratio (model/train numbers:
    name -> peak, rms, peak_speed, inertia_ratio, fits, ...), or {} without a decided design."""
    analysis = catalogue_analysis(catalogue)
    return {} if analysis is None else dict(analysis.cases.train.get("motors", {}))


def catalogue_analysis(catalogue):
    """The scene with every motor of the catalogue analysed at the chosen design (an
    AnalysisResult), or None without a decided design; the last catalogue's kept: its JSON, its
    summary and the chosen motor's own analysis (report/design_cases.optimum_analysis) share it."""
    import dataclasses

    best = catalogue.best
    if best is None or not best.success or not getattr(catalogue, "motors", ()):
        return None
    if _LAST[0] is not catalogue:
        _LAST[:] = [catalogue, analyse_at(dataclasses.replace(best.scene, motors=tuple(catalogue.motors)), best.design)]
    return _LAST[1]


def keep_catalogue_analysis(catalogue, analysis):
    """``analysis`` is :func:`catalogue_analysis` of ``catalogue`` (made by another process: the
    figure process's, report/figure_process.py)."""
    _LAST[:] = [catalogue, analysis]


_LAST = [None, None]


def prebuild(scene):
    """Build the analysis of ``scene`` before the design is known (:func:`analyse_at` then runs
    it at the design): the figure process does it while the command builds its first problem,
    on the core that is idle then (the catalogue's 4-motor analysis: about 0.7 s of its 1.3 s
    is the build, which parameter values do not change: they are inputs of its graphs).  It is
    run once at the scene's own values too: what a run builds on its first use (its load
    cases' evaluators) is then built as well (the catalogue's run at the design 0.65 -> 0.4 s)."""
    from ..errors import OptdesignError
    from ..model.analysis import Analysis

    build = Analysis(scene)
    try:
        own = build.run()
    except OptdesignError:   # the start does not assemble, say: the design may
        own = None
    _BUILT[:], _RAN[:], _OWN[:] = [build], [], [own]


def analyse_at(scene, design: dict):
    """``analyse(scene.with_parameters(**design))`` (``design``: design variables -> numbers),
    run on the build :func:`prebuild` made of ``scene`` when there is one: the same numbers (a
    build serves every value of the design variables, which are never folded into constants,
    as a study's cases share one: model/analysis.Analysis.run)."""
    import dataclasses

    from ..model.analysis import analyse

    build = next((b for b in _BUILT if b.scene == scene), None)
    names = [] if build is None else list(build.mech.parameter_names)
    if build is None or not all(k in names and isinstance(v, (int, float)) for k, v in design.items()):
        return analyse(scene.with_parameters(**design))
    if _RAN and _RAN[0] is build and _RAN[1] == design:   # made ahead (analyse_ahead)
        return _RAN[2]
    p = build.mech.parameter_values.copy()
    for k, v in design.items():
        p[names.index(k)] = v
    _RAN[:] = [build, dict(design), dataclasses.replace(build.run(p), scene=scene.with_parameters(**design))]
    return _RAN[2]


def analyse_ahead(design: dict):
    """:func:`analyse_at` of the prebuilt scene at ``design`` made now (the optimum's design once
    polished, while the command still certifies and reports it), kept for when it is asked for;
    nothing when there is no build or it fails (it is then made, or its error met, when asked)."""
    if _BUILT:
        try:
            analyse_at(_BUILT[0].scene, design)
        except Exception:   # noqa: BLE001
            pass


def start_analysis(scene):
    """The nominal analysis of ``scene`` at its own values, its [[cases]] left out (an
    optimisation's start, for its figures): the run :func:`prebuild` made at the scene's own
    values when it was of this scene (or of this scene with other [[motors]]: a catalogue's,
    which only the cases' drive train reads), its cases dropped (the nominal state is the same
    computation with or without them), else made now."""
    import dataclasses

    from ..model.analysis import Analysis

    if _OWN and _OWN[0] is not None and _with_motors(_BUILT[0].scene, scene.motors) == scene:
        return dataclasses.replace(_OWN[0], scene=scene, cases=None)
    return Analysis(scene, cases=False).run()


def _with_motors(scene, motors):
    """``scene`` with ``motors``, or None where that is no scene (its [simulation] names a motor
    not among them: a catalogue's, transfer_arm's, whose chosen motor runs the simulation)."""
    import dataclasses

    from ..errors import OptdesignError

    try:
        return dataclasses.replace(scene, motors=motors)
    except OptdesignError:
        return None


_BUILT = []   # the analysis built beforehand (prebuild), in the process that made it
_RAN = []     # its last run: (build, design, AnalysisResult)
_OWN = []     # its run at the scene's own values (None: it failed)


def _speed(v) -> str:
    return f"{v:.4g} rad/s ({v * RPM:.4g} rpm)"


def _at(doc, key, sweep) -> str:
    """'case NAME at SWEEP = VALUE UNIT' of the governing case of quantity ``key``."""
    g = doc.get("cases_governing", {}).get(key)
    if not g:
        return ""
    factor, unit, name = sweep
    return f"case {g['case']!r} at {name} = {g['s'] * factor:.4g}{' ' + unit if unit else ''}"


def train_rows(doc, sweep) -> dict:
    """The drive train of result.json ``doc`` (its ``cases``, ``catalogue_at_optimum``,
    ``chosen_motor``) as rows: {'ratio': [(label, value)], 'motors': [[...]], 'cylinder':
    [(label, value)]}; ``sweep`` = (factor, unit, name) to show the sweep in the unit written.
    Empty without a drive train."""
    train = (doc.get("cases") or {}).get("drive_train") or {}
    doc = dict(doc, cases_governing=(doc.get("cases") or {}).get("governing_cases", {}))
    out = {}
    if "ratio" in train:
        motors = doc.get("catalogue_at_optimum") or train.get("motors", {})
        chosen = doc.get("chosen_motor")   # with a catalogue: the smallest that fits
        m0 = next(iter(train.get("motors", {}).values()), None)   # the motor this design was optimised with
        rows = [("gear ratio i (motor speed / output speed)", f"{train['ratio']:.6g}")]
        if m0 is not None:
            where = _at(doc, "motor_speed", sweep)
            rows += [("peak motor speed", _speed(m0["peak_speed"]) + (f", {where}" if where else "")),
                     ("peak output speed", _speed(m0["peak_speed"] / train["ratio"]))]
        out["ratio"] = rows
        out["motors"] = []
        for name, m in motors.items():
            rms = "-" if "rms" not in m else f"{m['rms']:.4g}"
            out["motors"].append([name + (" (chosen)" if name == chosen else ""), f"{m['peak']:.4g}",
                                  f"{m['peak_torque']:.4g}", rms, f"{m['rated_torque']:.4g}",
                                  f"{m['peak_speed'] * RPM:.4g}", f"{m['max_speed'] * RPM:.4g}",
                                  "-" if not math.isfinite(m["inertia_ratio"]) else f"{m['inertia_ratio']:.3g}",
                                  "yes" if m["fits"] else "no"])
        out["governing"] = [(what, _at(doc, key, sweep)) for what, key in
                            (("motor peak torque", "motor_torque"), ("motor speed", "motor_speed"),
                             ("output peak torque", "drive")) if _at(doc, key, sweep)]
    elif "bore" in train or "bore_undetermined" in train:
        t = train
        sized = "bore" in t   # else no bore follows (a rod without a bore where nothing pulls)
        rows = [("bore", f"{t['bore'] * MM:.4g} mm (needed {t['bore_needed'] * MM:.4g} mm)" if sized
                 else f"undetermined: {t['bore_undetermined']}"),
                ("rod", f"{t['rod'] * MM:.4g} mm (needed for buckling {t['rod_needed_buckling'] * MM:.4g} mm)"),
                ("system pressure", f"{t['pressure'] * BAR:.4g} bar")]
        if sized:
            rows += [("pressure pushing", f"{t['pressure_push'] * BAR:.4g} bar at the peak push "
                                          f"{t['peak_push'] / 1e3:.4g} kN"),
                     ("pressure pulling", f"{t['pressure_pull'] * BAR:.4g} bar at the peak pull "
                                          f"{t['peak_pull'] / 1e3:.4g} kN"),
                     ("pump flow", f"{t['pump_flow'] * LPM:.4g} l/min")]
        rows.append(("buckling utilisation", f"{t['buckling_utilisation']:.3g} (Euler load "
                                             f"{t['euler_force'] / 1e3:.4g} kN at full extension "
                                             f"{t['full_extension'] * MM:.4g} mm)"))
        out["cylinder"] = rows
        out["governing"] = [(what, _at(doc, key, sweep)) for what, key in
                            (("peak cylinder force", "drive"), ("rod buckling", "rod_buckling")) if _at(doc, key, sweep)]
    return out


MOTOR_HEAD = ["motor", "peak torque [N m]", "limit [N m]", "RMS over the cycle [N m]", "rated [N m]",
              "peak speed [rpm]", "max speed [rpm]", "inertia ratio J_load/(i^2 J_r)", "fits"]


def train_summary(doc, sweep) -> list:
    """summary.txt's lines of :func:`train_rows`."""
    rows = train_rows(doc, sweep)
    if not rows:
        return []
    lines = ["drive train at the optimum:"]
    lines += [f"  {label}: {value}" for label, value in rows.get("ratio", []) + rows.get("cylinder", [])]
    if rows.get("motors"):
        lines.append(f"  motors at this design (inertia ratio: usually <= {INERTIA_RATIO_LIMIT:g} for a servo drive):")
        for r in rows["motors"]:
            lines.append(f"    {r[0]}: peak {r[1]} of {r[2]} N m, RMS {r[3]} of rated {r[4]} N m, speed {r[5]} of "
                         f"{r[6]} rpm, inertia ratio {r[7]}: {'fits' if r[8] == 'yes' else 'does not fit'}")
    lines += [f"  governing {what}: {where}" for what, where in rows.get("governing", [])]
    return lines


def catalogue_outcome(outcome, proof) -> str:
    """A catalogue motor's outcome for the page, with the energy proof that decided it (result.json's
    ``proofs``: design/energy_bound.EnergyProof.to_dict) where there is one."""
    if not proof:
        return outcome
    t1, t2 = proof["window_s"]
    return (f"{outcome}: energy proof, case '{proof['case']}' from t = {t1:.4g} to {t2:.4g} s: the load needs "
            f">= {proof['energy_needed_J']:,.0f} J at the motor, the motor gives <= {proof['energy_available_J']:,.0f} J "
            f"({proof['boxes']:,} boxes of {', '.join(proof['variables'])})")


def train_html(doc, sweep, table, escape) -> str:
    """report.html's drive-train section of result.json ``doc`` (tables ``drive-train``,
    ``motors``, ``catalogue``, ``cylinder-sizes``, ``governing``, ``duty``), or '' without a drive train; ``table``
    (id, head, rows, active) and ``escape`` are the page's."""
    rows = train_rows(doc, sweep)
    cases = doc.get("cases") or {}
    if not rows and not cases:
        return ""
    parts = ["<h2>Drive train</h2>"]
    if rows.get("ratio"):
        parts.append(table("drive-train", ["", ""], [list(r) for r in rows["ratio"]]))
    if rows.get("motors"):
        parts.append(f"<p class=\"meta\">Every motor at this design and gear ratio: its peak torque over every case, "
                     f"the RMS of its torque over the duty cycle's time, its peak speed, against its limits; the "
                     f"inertia ratio is usually kept below {INERTIA_RATIO_LIMIT:g} for a servo drive.</p>")
        parts.append(table("motors", MOTOR_HEAD, rows["motors"], [r[0].endswith("(chosen)") for r in rows["motors"]]))
    if doc.get("motors"):   # the catalogue's optimisations: each motor tried
        parts.append("<p class=\"meta\">The catalogue: each motor optimised with its limits, smallest rated torque "
                     "first, until one fits; a motor an energy bound proves cannot fit is decided before its starts "
                     "(design/energy_bound.py).</p>")
        parts.append(table("catalogue", ["motor", "outcome"],
                           [[k, catalogue_outcome(v, (doc.get("proofs") or {}).get(k))] for k, v in doc["motors"].items()],
                           [k == doc.get("chosen_motor") for k in doc["motors"]]))
    if rows.get("cylinder"):
        parts.append(table("cylinder-sizes", ["", ""], [list(r) for r in rows["cylinder"]]))
    if rows.get("governing"):
        parts.append(table("governing", ["limit", "governing case"], [list(r) for r in rows["governing"]]))
    duty = cases.get("duty") or {}
    if "steps" in duty:
        steps = [[j + 1, s["kind"], s.get("case", ""), f"{s['time']:.4g}"] for j, s in enumerate(duty["steps"])]
        parts.append(f"<p class=\"meta\">The duty cycle: {duty['cycle_time']:.6g} s, energy {duty['energy']:.6g} J "
                     f"per cycle, mean power {duty['mean_power']:.6g} W.</p>")
        parts.append(table("duty", ["step", "kind", "case", "time [s]"], steps))
    return "\n".join(parts)
