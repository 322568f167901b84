"""Reading scene files (TOML) into :class:`~optdesign.scene.scene.Scene` objects.

Every error names the file, the line where the item can be found, the table and key, what was
found and what was expected; an unknown key or name suggests its near miss.  The format is
documented in ``docs/scenes.md``.  The reader only checks the shape of the file (tables, keys,
lists); the scene objects check values and cross references, and this module adds the line.
"""
from __future__ import annotations

import os
import numbers
import re
import tomllib
from pathlib import Path

from ..errors import ArgumentError, OptdesignError, SceneError
from .elements import (DRIVE_PINS, Body, Constraint, Drive, Gravity, Objective, Parameter, Simulation,
                       Sweep)
from .drawing import DRAWING_KEYS, Drawing
from .file_sizing import SIZING_KEYS, read_sizing
from .forces import FORCE_KEYS, read_force
from .points import Attach, Closure, Dyad, Fixed, Loop, Polar, Slider
from .quantities import read_quantities
from .scene import Scene
from .simulation import read_phases
from .where import ARRAY_TABLES, Where, located_error, near_miss

TOP_KEYS = ("title", "source", "parameters", "sweep", "points", "bodies", "forces", "gravity", "drive",
            "constraints", "objective", "reference", "simulation", "drawing", "quantities") + SIZING_KEYS
REQUIRED_TOP = {"title": "a string naming the scene", "sweep": "the table [sweep] (the stroke)",
                "points": "the table [points] (the constructions)"}
CLOSED_FORM = {cls.KIND: cls for cls in (Fixed, Polar, Dyad, Slider, Attach)}
KINDS = tuple(CLOSED_FORM) + ("loop",)
CONSTRUCTION_KEYS = {
    "fixed": ("fixed",),
    "polar": ("polar",),
    "dyad": ("dyad", "side"),
    "slider": ("slider", "side"),
    "attach": ("attach",),
    "loop": ("loop", "lengths", "angles", "joints", "unknowns", "closure"),
}
SWEEP_KEYS = ("name", "from", "to", "samples", "rate", "acceleration")
BODY_KEYS = ("name", "frame", "mass", "com", "inertia", "force", "torque")
CONSTRAINT_KEYS = ("name", "expr", "min", "max", "case")
SIMULATION_KEYS = ("start", "speed", "t_end", "samples", "integrator", "tolerance", "motor", "phases")


def load(path, overrides: dict | None = None) -> Scene:
    """Load a scene file; ``overrides`` (name -> number or expression) replace parameters, as
    ``--set NAME=VALUE`` does on the command line."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"load: path: expected a file path (str or pathlib.Path), found {type(path).__name__} "
                        f"{path!r:.60}" + ("; for a scene's text use optdesign.loads(text)" if isinstance(path, bytes) else ""))
    if isinstance(path, str) and ("\n" in path or re.match(r"\s*(title\s*=|\[)", path)):
        raise ArgumentError(f"load: path: {path[:40]!r}... is the text of a scene, not a file path; use "
                            "optdesign.loads(text) for text")
    if overrides is not None and not isinstance(overrides, dict):
        raise TypeError(f"load: overrides: expected a dict {{name: value}}, found {type(overrides).__name__} "
                        f"{overrides!r:.60}")
    for name, value in (overrides or {}).items():
        if not isinstance(name, str) or isinstance(value, bool) or not isinstance(value, (numbers.Real, str)):
            raise TypeError(f"load: overrides: {name!r}: expected a number or an expression string (as "
                            f"--set {name}=VALUE), found {type(value).__name__} {value!r:.60}")
    path = Path(path)
    if path.exists() and not (path.is_file() or path.is_dir()):
        raise SceneError(f"{path}: not a regular file (a pipe or a device); give the path of a scene file")
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file; check the path (scenes ship in problems/)") from None
    except (IsADirectoryError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot read it as a scene file ({exc})") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene file ({exc.strerror or exc})") from None
    scene = loads(text, str(path))
    return scene.with_parameters(**overrides) if overrides else scene


def loads(text: str, path: str = "<string>") -> Scene:
    """Parse a scene from TOML text; ``path`` names it in errors."""
    if not isinstance(text, str):
        hint = {bytes: "; decode it first (data.decode())", bytearray: "; decode it first (data.decode())"}.get(
            type(text), "; for a file use optdesign.load(path)" if isinstance(text, os.PathLike) else "")
        raise TypeError(f"loads: text: expected the scene's TOML text as a str, found {type(text).__name__}{hint}")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise _syntax_error(exc, text, path) from None
    try:
        return _Reader().scene(data, path)
    except OptdesignError as exc:
        raise _with_line(exc, _Lines(text), path) from None


def _syntax_error(exc, text, path):
    """A TOML syntax error with its line, and a hint for a name given twice."""
    message = str(exc)
    m = re.search(r"at line (\d+)", message)
    line = int(m.group(1)) if m else None
    head = f"{path}, line {line}" if line else path
    hint = ""
    if "overwrite" in message or "declare" in message:
        source = text.splitlines()[line - 1] if line and line <= len(text.splitlines()) else ""
        key = re.match(r"\s*\[*\s*([^=\]]+?)\s*[=\]]", source)
        name = f"{key.group(1)!r} " if key else ""
        hint = (f": {name}is defined twice in the same table; every key, point and parameter "
                "name must be unique, so rename or remove one of them")
    if not hint and line and line <= len(text.splitlines()):  # mP = 15 t: a number with a unit
        from .unit_hints import toml_hint

        hint = toml_hint(text.splitlines()[line - 1])
    exc2 = SceneError(f"{head}: TOML syntax error: {message}{hint}")
    exc2.where, exc2.detail, exc2.path, exc2.line = None, f"TOML syntax error: {message}{hint}", path, line
    return exc2


def _with_line(exc, lines, path):
    """The same error, its message led by the file name and the line of its item."""
    where = getattr(exc, "where", None)
    detail = getattr(exc, "detail", None)
    if detail is None:
        message = str(exc)
        return type(exc)(message if message.startswith(path) else f"{path}: {message}")
    line = lines.find(where) if isinstance(where, Where) else None
    head = f"{path}, line {line}" if line else path
    out = type(exc)(f"{head}: {where}: {detail}" if where else f"{head}: {detail}")
    out.where, out.detail, out.path, out.line = where, detail, path, line
    return out


class _Lines:
    """Where keys and tables sit in the TOML text (best effort, for messages only).

    Records the line of every ``[table]``/``[[table]]`` header and of every ``key =`` at the
    start of a line, per table (and per element of an array of tables, whose ``name = "..."``
    identifies it)."""

    _HEADER = re.compile(r"^\s*(\[\[?)\s*([^\[\]#]+?)\s*\]\]?\s*(#.*)?$")
    _KEY = re.compile(r"""^\s*("[^"]*"|'[^']*'|[A-Za-z0-9_-]+)\s*(?:\.[^=]*)?=\s*(.*)$""")

    def __init__(self, text):
        self.headers, self.keys, self.names = {}, {}, {}
        table, index, count = "", 0, {}
        for no, line in enumerate(text.splitlines(), 1):
            m = self._HEADER.match(line)
            if m:
                table = re.sub(r"\s*\.\s*", ".", m.group(2)).replace('"', "").replace("'", "")
                index = count[table] = count.get(table, -1) + 1 if m.group(1) == "[[" else 0
                self.headers.setdefault((table, index), no)
                continue
            m = self._KEY.match(line)
            if m:
                key = m.group(1).strip("\"'")
                self.keys.setdefault((table, index, key), no)
                value = re.match(r"""\s*["']([^"']*)["']""", m.group(2))
                if key == "name" and table in ARRAY_TABLES and value:
                    self.names.setdefault((table, value.group(1)), index)

    def find(self, where: Where):
        table, item = where.table, where.item
        key = re.split(r"[\s\[.]", where.key)[0] if where.key else None
        if not table:
            return self.keys.get(("", 0, key)) or self.headers.get((key, 0)) or next(
                (no for (t, _), no in sorted(self.headers.items(), key=lambda kv: kv[1])
                 if t.startswith(f"{key}.")), None)
        if table in ARRAY_TABLES:
            index = self.names.get((table, item), where.index)
            if index is None:
                return self.headers.get((table, 0)) if item is None else None
            return self.keys.get((table, index, key)) or self.headers.get((table, index))
        if item is not None:
            sub = f"{table}.{item}"
            found = (self.keys.get((sub, 0, key)) if key else None) or self.headers.get((sub, 0)) \
                or self.keys.get((table, 0, item))
            if found:
                return found
        return (self.keys.get((table, 0, key)) if key else None) or self.headers.get((table, 0))


class _Reader:
    """TOML data (dicts and lists) -> scene objects; checks tables, keys and list shapes."""

    def check_keys(self, where, data, allowed):
        """``data`` must be a table whose keys are all in ``allowed``."""
        if not isinstance(data, dict):
            _raise(where, f"expected a table, found {data!r}")
        for key in data:
            if key not in allowed:
                _raise(where.at(f"{where.key}.{key}" if where.key else key), f"unknown key {key!r}" + (
                    near_miss(key, allowed) or f"; expected one of: {', '.join(allowed)}"))

    # --- tables ---
    def scene(self, data, path):
        for key in data:
            if key not in TOP_KEYS:
                _raise(Where("", key=key), f"unknown top-level table or key {key!r}" + (
                    near_miss(key, TOP_KEYS) or f"; expected one of: {', '.join(TOP_KEYS)}"))
        for key, what in REQUIRED_TOP.items():
            if key not in data:
                _raise(None, f"missing {'key' if key == 'title' else 'table'} {key!r}: expected {what}")
        return Scene(
            title=data["title"],
            source=data.get("source", ""),
            parameters=self.parameters(data.get("parameters", {})),
            sweep=self.sweep(data["sweep"]),
            points=self.points(data["points"]),
            bodies=self.array("bodies", data.get("bodies", []), BODY_KEYS, self.body),
            forces=self.array("forces", data.get("forces", []), FORCE_KEYS, read_force),
            gravity=self.gravity(data["gravity"]) if "gravity" in data else None,
            drive=self.drive(data["drive"]) if "drive" in data else None,
            constraints=self.array("constraints", data.get("constraints", []), CONSTRAINT_KEYS, self.constraint),
            objective=self.objective(data["objective"]) if "objective" in data else None,
            reference=data.get("reference", {}),
            path=path,
            simulation=self.simulation(data["simulation"]) if "simulation" in data else None,
            drawing=self.drawing(data["drawing"]) if "drawing" in data else None,
            quantities=read_quantities(data["quantities"]) if "quantities" in data else (),
            **read_sizing(self, data),
        )

    def parameters(self, data):
        self.check_keys(Where("parameters"), data, list(data))
        out = []
        for name, spec in data.items():
            if isinstance(spec, dict):
                self.check_keys(Where("parameters", name), spec, ("value", "min", "max"))
                if "value" not in spec:
                    _raise(Where("parameters", name, "value"),
                           "missing key 'value': expected the start value of the design variable")
                out.append(Parameter(name, spec["value"], spec.get("min"), spec.get("max")))
            else:
                out.append(Parameter(name, spec))
        return out

    def sweep(self, data):
        self.check_keys(Where("sweep"), data, SWEEP_KEYS)
        return Sweep(data.get("name"), data.get("from"), data.get("to"), data.get("samples"),
                     data.get("rate"), data.get("acceleration"))

    def points(self, data):
        if not isinstance(data, dict):
            _raise(Where("points"), f"expected a table of constructions, found {data!r}")
        return [self.construction(name, spec) for name, spec in data.items()]

    def construction(self, name, spec):
        where = Where("points", name)
        if not isinstance(spec, dict):
            _raise(where, f"expected a construction such as {{ fixed = [0, 0] }}, found {spec!r}")
        kinds = [k for k in spec if k in KINDS]
        if len(kinds) != 1:
            found = ", ".join(map(repr, kinds or spec)) or "nothing"
            hint = "" if kinds else near_miss(next(iter(spec), ""), KINDS)
            _raise(where, f"expected exactly one construction kind ({', '.join(KINDS)}), found {found}{hint}")
        kind = kinds[0]
        self.check_keys(where, spec, CONSTRUCTION_KEYS[kind])
        if kind == "loop":
            return self.loop(name, spec)
        cls = CLOSED_FORM[kind]
        items = spec[kind]
        if not isinstance(items, list) or len(items) != len(cls.ROLES):
            _raise(where.at(kind), f"expected {kind} = {cls.form()} ({len(cls.ROLES)} items), found {items!r}")
        extra = {"side": spec.get("side")} if "side" in CONSTRUCTION_KEYS[kind] else {}
        return cls(name, *items, **extra)

    def loop(self, name, spec):
        where = Where("points", name)
        closure = None
        if "closure" in spec:
            c = spec["closure"]
            self.check_keys(where.at("closure"), c, ("point", "fixed", "line"))
            if "point" not in c:
                _raise(where.at("closure"), "missing key 'point': expected the loop joint that closes it")
            line = c.get("line")
            if line is not None and (not isinstance(line, list) or len(line) != 2):
                _raise(where.at("closure"), f"expected line = [origin point, angle], found {line!r}")
            closure = Closure(c["point"], c.get("fixed"), line[0] if line else None, line[1] if line else None)
        return Loop(name, spec["loop"], spec.get("lengths"), spec.get("angles"), spec.get("joints"),
                    spec.get("unknowns", {}), closure)

    def array(self, table, data, allowed, build):
        """An array of tables ([[bodies]], [[constraints]]): each a table with a name."""
        if not isinstance(data, list):
            _raise(Where(table), f"expected an array of tables [[{table}]], found a single table or value")
        out = []
        for i, item in enumerate(data):
            where = Where(table, item.get("name") if isinstance(item, dict) else None, index=i)
            self.check_keys(where, item, allowed)
            for key in ("name",) + {"bodies": ("frame",), "constraints": ("expr",), "forces": ("kind",)}.get(table, ()):
                if key not in item:
                    _raise(where.at(key), f"missing key {key!r}")
            out.append(build(item))
        return out

    def body(self, b):
        return Body(b["name"], b["frame"], b.get("mass"), b.get("com"), b.get("inertia"),
                    b.get("force"), b.get("torque"))

    def constraint(self, c):
        return Constraint(c["name"], c["expr"], c.get("min"), c.get("max"), c.get("case"))

    def gravity(self, data):
        self.check_keys(Where("gravity"), data, ("g",))
        return Gravity(data.get("g"))

    def drive(self, data):
        where = Where("drive")
        if not isinstance(data, dict):
            _raise(where, f"expected a table, found {data!r}")
        kind = data.get("type")
        pins = DRIVE_PINS.get(kind)
        allowed = ("type", pins or "crank", "speed", "acceleration", "efficiency", "law", "inertia")
        if pins is None:
            Drive(kind, None, None, None)  # raises: missing or unknown type, with the near miss
        self.check_keys(where, data, allowed)
        return Drive(kind, data.get(pins), data.get("speed"), data.get("acceleration"), data.get("efficiency"),
                     data.get("law"), data.get("inertia"))

    def simulation(self, data):
        self.check_keys(Where("simulation"), data, SIMULATION_KEYS)
        defaults = {f.name: f.default for f in Simulation.__dataclass_fields__.values()}
        return Simulation(data.get("start"), data.get("speed"), data.get("t_end"),
                          data.get("samples", defaults["samples"]), data.get("integrator", defaults["integrator"]),
                          data.get("tolerance"), read_phases(data["phases"]) if "phases" in data else (),
                          data.get("motor"))

    def drawing(self, data):
        self.check_keys(Where("drawing"), data, DRAWING_KEYS)
        return Drawing(data.get("helpers", ()))

    def objective(self, data):
        self.check_keys(Where("objective"), data, ("minimise",))
        return Objective(data.get("minimise"))


def _raise(where, detail):
    raise located_error(SceneError, where, detail)
