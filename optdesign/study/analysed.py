"""The rows of a batch of analyse cases made column by column (:func:`analyse`): no row dict
per case on the worker.

A batch's cases that share a build are analysed together, up to :data:`CHUNK` at a time (one
:meth:`~optdesign.model.analysis.Analysis.run_many` and one
:meth:`~optdesign.model.analysis.Analysis.sweep_rms_many` each); the cases whose figures have the same
names (most of a batch: one shape) give their row's values a column at a time.  A row's keys, in
their order, and its values are those the row dict of the case alone has (a key made twice keeps
its first place and its last value, as a dict's update does), so that the journal's lines and
cases.csv's cells do not depend on the batch: :func:`rows` gives the dicts, :func:`.tasks.batch_blocks`
the blocks of rows with equal keys that :func:`.blocks.blocks` makes from them."""
from __future__ import annotations

# cases analysed together at most, a batch's more in turn: the arrays over cases x samples of a
# larger call outgrow the processor's caches.  A batch of truck-crane cases cost, per case, 1.16x
# (2,048 cases) and 1.29x (4,096) in one call what it cost in calls of 512 (process CPU, medians
# of 8-10 interleaved rounds in one process, load ~1, 2026-11-29; calls of 256 no cheaper than
# 512); the blocks and rows are the same, value for value, whatever the calls' sizes
CHUNK = 512


def analyse(prepared: list) -> list:
    """Pieces ``(positions, keys, columns)`` covering the prepared analyse cases
    (:func:`.tasks.prepare_all`): ``columns[k][j]`` is the value of ``keys[k]`` in the row of case
    ``positions[j]``; the cases that share a built analysis analysed together, :data:`CHUNK` at
    a time."""
    from ..errors import OptdesignError

    failed, groups = [], {}
    for i, (task, model, scene) in enumerate(prepared):
        if isinstance(model, OptdesignError):
            failed.append((i, model))
            continue
        if type(scene) is not dict:   # a case scene (or None): its values
            try:
                scene = leaf_values(model.mech.parameter_names, scene, model.mech.parameter_values)
            except OptdesignError as exc:
                failed.append((i, exc))
                continue
        groups.setdefault(id(model), (model, [], []))
        groups[id(model)][1].append(i)
        groups[id(model)][2].append(scene)
    pieces = [_failed_piece(failed)] if failed else []
    for analysis, where, values in groups.values():
        for a in range(0, len(where), CHUNK):   # cases x samples arrays that stay in the cache
            at_, P = where[a:a + CHUNK], _parameters(analysis, values[a:a + CHUNK])
            pieces += [([at_[j] for j in at], keys, columns) for at, keys, columns in _columns(analysis, P)]
    return pieces


def _parameters(analysis, values):
    """The leaf values of cases (cases x parameters): ``values[j]`` case j's, or a dict of the
    numbers it sets (the others keep the build's: :func:`leaf_values`), set a column at
    a time for the cases that set the same names."""
    import numpy as np

    names = analysis.mech.parameter_names
    P = np.tile(np.asarray(analysis.mech.parameter_values, float), (len(values), 1))
    same = {}
    for j, v in enumerate(values):
        if type(v) is dict:
            same.setdefault(tuple(v), []).append(j)
        else:
            P[j] = v
    for keys, js in same.items():
        for name in keys:
            for k in (k for k, n in enumerate(names) if n == name):
                P[js, k] = [values[j][name] for j in js]
    return P


def rows(pieces: list, n: int) -> list:
    """The row dicts of cases 0 .. n-1 from :func:`analyse`'s pieces."""
    out = [None] * n
    for positions, keys, columns in pieces:
        for j, values in zip(positions, zip(*columns)):
            out[j] = dict(zip(keys, values))
    return out


def case_rows(analysis, P) -> list:
    """The row dicts of the cases ``P`` (leaf values, cases x parameters) of one built analysis."""
    return rows(_columns(analysis, P), len(P))


def _failed_piece(failed) -> tuple:
    """The pieces' form of failed cases [(position, OptdesignError)]: their _failed rows."""
    made = [failed_row(exc) for _, exc in failed]
    keys = tuple(made[0])
    return [i for i, _ in failed], keys, [[row[k] for row in made] for k in keys]


def _columns(analysis, P) -> list:
    """Pieces ``(case numbers in P, keys, columns)`` of the cases ``P`` (leaf values, cases x
    parameters) of one built analysis, cases with the same names of figures together."""
    import numpy as np

    P = np.array(P, float).reshape(len(P), -1)
    runs = analysis.run_many(P)
    live = [i for i, r in enumerate(runs) if r.error is None]
    rms = dict(zip(live, analysis.sweep_rms_many(P[live]) if live else []))
    failed, shapes, extra = [], {}, {}
    for i, res in enumerate(runs):
        if res.error is not None:
            failed.append((i, res.error))
            continue
        extra[i] = _cases_row(res.cases) if res.cases is not None else {}
        why = not_certified(res)
        if why:
            extra[i] = {"not_certified": why, **extra[i]}
        if res.batch is not None:   # a certified case's figures as its batch's columns (the same names)
            shape = (id(res.batch[0]), id(res.batch[2]), tuple(rms[i]), tuple(extra[i]))
        else:
            shape = (tuple(res.peaks), tuple(res.peak_at), tuple(res.peaks_sampled), tuple(rms[i]),
                     tuple(res.constraint_extremes), tuple(res.stroke), tuple(extra[i]))
        shapes.setdefault(shape, []).append(i)
    pieces = [_failed_piece(failed)] if failed else []
    for shape, where in shapes.items():
        rs = [runs[i] for i in where]
        # the row of the case alone, its keys in this order: a dict (a key made twice keeps its
        # first place and takes its last value)
        named = {"status": ["ok"] * len(rs), "success": [True] * len(rs)}
        if len(shape) == 4:
            _batch_columns(named, [r.batch for r in rs], rms, where, shape[2])
        else:
            peaks, at, sampled, rms_names, extremes, stroke, _ = shape
            # peaks and constraint extremes over the continuous stroke (certified), with where they
            # lie and the samples' own values beside them
            named.update({f"peak:{k}": [r.peaks[k] for r in rs] for k in peaks})
            named.update({f"peak_at:{k}": [r.peak_at[k]["s"] for r in rs] for k in at})
            named.update({f"peak_sampled:{k}": [r.peaks_sampled[k] for r in rs] for k in sampled})
            # rms over the continuous sweep (adaptive quadrature, model/analysis.Analysis.sweep_rms)
            named.update({f"rms:{k}": [rms[i][k][0] for i in where] for k in rms_names})
            for name in extremes:
                named[f"constraint:{name}:min"] = [r.constraint_extremes[name]["min"] for r in rs]
                named[f"constraint:{name}:max"] = [r.constraint_extremes[name]["max"] for r in rs]
            named.update({f"constraint:{name}": [float(r.stroke[name]) for r in rs] for name in stroke})
        named.update({k: [extra[i][k] for i in where] for k in shape[-1]})
        pieces.append((where, tuple(named), list(named.values())))
    return pieces


def _batch_columns(named, batch, rms, where, rms_names):
    """:func:`_columns`'s columns of certified cases of one batch (their ``CaseRun.batch``: the
    batch's figures, the case's number, its Found and its place there; the same figures and
    Found for all), as the figures give them column by column (model/runs.py's
    ``_Figures.columns``, beside ``_Figures.made``: the values of the cases' dicts)."""
    figures, found = batch[0][0], batch[0][2]
    peaks, sampled, extremes, stroke = figures.columns(found, [(i, c) for _, i, _, c in batch])
    named.update({f"peak:{name}": values for name, values, _ in peaks})
    named.update({f"peak_at:{name}": at for name, _, at in peaks})
    named.update({f"peak_sampled:{k}": values for k, values in sampled})
    named.update({f"rms:{k}": [rms[i][k][0] for i in where] for k in rms_names})
    for name, low, high in extremes:
        named[f"constraint:{name}:min"] = low
        named[f"constraint:{name}:max"] = high
    named.update({f"constraint:{name}": values for name, values in stroke})


def not_certified(res) -> str:
    """Why some figures of an analysed case (a :class:`~optdesign.model.runs.CaseRun`) are not
    certified, as ``analyse`` prints them (report/analysis.certificate_lines: "NAME: note", its
    load cases' as "case 'NAME' NAME: note"), joined by "; "; "" when every figure is (a study's
    row then has no ``not_certified`` cell).  A batch's case is read from its batch's notes and
    its certificates made only when one is there."""
    if res.batch is not None:
        figures, i, found, c = res.batch
        if not (any(found.notes[c]) or figures.notes[i] or figures.dead[i]):
            certificates = {}
        else:
            certificates = res.certificates
    else:
        certificates = res.certificates or {}
    parts = [f"{k}: {c['note']}" for k, c in certificates.items() if c["note"]]
    if res.cases is not None:
        parts += [f"case {name!r} {k}: {c['note']}" for name, case in res.cases.cases.items()
                  for k, c in (case.certificates or {}).items() if c["note"]]
    return "; ".join(parts)


def _cases_row(cases) -> dict:
    """A scene's load cases in an analyse study's row (the peaks above are the nominal state's, at
    the [drive] speed and acceleration): each peak's governing case and value, the duty cycle's
    RMS over time and energy, each motor's fit, the cylinder's sizes."""
    row = {}
    for key, g in cases.governing.items():
        row[f"case_peak:{key}"], row[f"case_peak_case:{key}"] = g["value"], g["case"]
    duty = cases.duty
    row.update({f"cycle_rms:{k}": v for k, v in duty.get("rms_time", {}).items()})
    if "energy" in duty:
        row["cycle:time"], row["cycle:energy"] = duty["cycle_time"], duty["energy"]
    train = cases.train
    for name, m in train.get("motors", {}).items():
        row[f"motor_fits:{name}"] = bool(m["fits"])
    if "smallest_fitting" in train:
        row["smallest_motor"] = train["smallest_fitting"] or "none"
    for key in ("bore", "bore_needed", "rod", "rod_needed_buckling", "buckling_utilisation", "pump_flow"):
        if key in train:
            row[f"cylinder:{key}"] = train[key]
    return row


def failed_row(exc) -> dict:
    """The row of a case that failed on purpose (an OptdesignError): its reason."""
    return {"status": f"error: {exc}", "success": False}


def leaf_values(names, scene, default):
    """Values of the leaf parameters ``names`` in ``scene`` (``default`` when there is no case
    scene; ``default`` with the numbers of the overrides when ``scene`` is a dict of them: a leaf
    set to a number has that value in the case's scene, and the others keep the build's)."""
    if scene is None:
        return default
    import numpy as np

    if isinstance(scene, dict):
        return np.array([scene.get(n, v) for n, v in zip(names, np.asarray(default, float))], dtype=float)
    values = scene.parameter_values()
    return np.array([values[n] for n in names], dtype=float)
