"""Reading scene files (TOML) into :class:`~optdesign.scene.Scene` objects.

Every error names the file, the table and key, the line where it can be found, what was found
and what was expected; an unknown key suggests its near miss.  The format is documented in
``docs/scenes.md``.
"""
from __future__ import annotations

import difflib
import re
import tomllib
from pathlib import Path

from .errors import OptdesignError, SceneError
from .scene import (Attach, Body, Closure, Constraint, Drive, Dyad, Fixed, Gravity, Loop,
                    Objective, Parameter, Polar, Scene, Slider, Sweep)

TOP_KEYS = ("title", "source", "parameters", "sweep", "points", "bodies", "gravity", "drive",
            "constraints", "objective", "reference")
CONSTRUCTION_KEYS = {
    "fixed": ("fixed",),
    "polar": ("polar",),
    "dyad": ("dyad", "side"),
    "slider": ("slider", "side"),
    "attach": ("attach",),
    "loop": ("loop", "lengths", "angles", "joints", "unknowns", "closure"),
}


def load(path, overrides: dict | None = None) -> Scene:
    """Load a scene file; ``overrides`` (name -> number or expression) replace parameters."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file; check the path (scenes ship in problems/)") from None
    scene = loads(text, str(path))
    return scene.with_parameters(**overrides) if overrides else scene


def loads(text: str, path: str = "<string>") -> Scene:
    """Parse a scene from TOML text; ``path`` names it in errors."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: TOML syntax error: {exc}") from None
    reader = _Reader(path, text)
    try:
        return reader.scene(data)
    except SceneError as exc:
        msg = str(exc)
        if not msg.startswith(path):
            msg = f"{path}: {msg}"
        raise SceneError(msg) from None


class _Reader:
    def __init__(self, path, text):
        self.path, self.lines = path, text.splitlines()

    # --- error helpers ---
    def line_of(self, table, key=None, index=None):
        """Best-effort line number of ``key`` in ``table`` (index-th for arrays of tables)."""
        header = re.compile(r"^\s*\[\[?\s*([A-Za-z0-9_.\"' -]+?)\s*\]\]?")
        current, count, start = None, {}, None
        for no, line in enumerate(self.lines, 1):
            m = header.match(line)
            if m:
                current = m.group(1)
                count[current] = count.get(current, -1) + 1
                if current == table and (index is None or count[current] == index):
                    if key is None:
                        return no
                    start = no
                continue
            if start and current == table and (index is None or count[current] == index):
                if re.match(rf"^\s*\"?{re.escape(key)}\"?\s*=", line):
                    return no
        return start

    def fail(self, table, key, message, index=None):
        line = self.line_of(table, key, index)
        where = f"[{table}]" if index is None else f"[[{table}]] #{index + 1}"
        if key:
            where += f" {key}"
        raise SceneError(f"{self.path}: {where}: {message}" + (f" (line {line})" if line else ""))

    def keys(self, table, data, allowed, required=(), index=None, what=None):
        if not isinstance(data, dict):
            self.fail(table, what, f"expected a table, found {data!r}", index)
        for key in data:
            if key not in allowed:
                hint = difflib.get_close_matches(key, allowed, n=1)
                self.fail(table, key, f"unknown key {key!r}"
                          + (f" (did you mean {hint[0]!r}?)" if hint else f"; expected one of {', '.join(allowed)}"),
                          index)
        for key in required:
            if key not in data:
                self.fail(table, what, f"missing key {key!r}", index)

    def guarded(self, table, key, build, index=None):
        """Run ``build``; prefix any scene error from it with the table and line."""
        try:
            return build()
        except OptdesignError as exc:
            self.fail(table, key, str(exc), index)
        except (TypeError, ValueError) as exc:
            self.fail(table, key, f"bad value: {exc}", index)

    def name_list(self, table, key, value, n, what, index=None):
        if not isinstance(value, list) or len(value) != n:
            self.fail(table, key, f"expected {what} ({n} items), found {value!r}", index)
        return value

    # --- tables ---
    def scene(self, data):
        for key in data:
            if key not in TOP_KEYS:
                hint = difflib.get_close_matches(key, TOP_KEYS, n=1)
                line = self.line_of(key) or self.line_of("", key)
                raise SceneError(
                    f"{self.path}: unknown table or key {key!r}"
                    + (f" (did you mean {hint[0]!r}?)" if hint else f"; expected one of {', '.join(TOP_KEYS)}")
                    + (f" (line {line})" if line else "")
                )
        for key in ("title", "sweep", "points"):
            if key not in data:
                raise SceneError(f"{self.path}: missing {'key' if key == 'title' else 'table'} {key!r}")
        if not isinstance(data["title"], str):
            raise SceneError(f"{self.path}: title: expected a string, found {data['title']!r}")
        fields = dict(
            title=data["title"],
            source=str(data.get("source", "")),
            parameters=self.parameters(data.get("parameters", {})),
            sweep=self.sweep(data["sweep"]),
            points=self.points(data["points"]),
            bodies=self.bodies(data.get("bodies", [])),
            gravity=self.gravity(data["gravity"]) if "gravity" in data else None,
            drive=self.drive(data["drive"]) if "drive" in data else None,
            constraints=self.constraints(data.get("constraints", [])),
            objective=self.objective(data["objective"]) if "objective" in data else None,
            reference=data.get("reference", {}),
            path=self.path,
        )
        return Scene(**fields)

    def parameters(self, data):
        self.keys("parameters", data, list(data))
        out = []
        for name, spec in data.items():
            if isinstance(spec, dict):
                self.keys("parameters", spec, ["value", "min", "max"], ["value"], what=name)
                bounds = {}
                for key, attr in (("min", "lower"), ("max", "upper")):
                    if key in spec:
                        bounds[attr] = self.number("parameters", name, spec[key], f"{name}.{key}")
                out.append(self.guarded("parameters", name, lambda: Parameter(name, spec["value"], **bounds)))
            else:
                out.append(self.guarded("parameters", name, lambda: Parameter(name, spec)))
        return out

    def number(self, table, key, value, what):
        from .expressions import constant_value, parse

        try:
            return constant_value(parse(value, what), {}, what)
        except SceneError as exc:
            self.fail(table, key, f"expected a number: {exc}")

    def sweep(self, data):
        self.keys("sweep", data, ["name", "from", "to", "samples", "rate", "acceleration"],
                  ["name", "from", "to", "samples"])
        if not isinstance(data["name"], str) or not re.fullmatch(r"[A-Za-z_]\w*", data["name"]):
            self.fail("sweep", "name", f"expected a name, found {data['name']!r}")
        return self.guarded("sweep", None, lambda: Sweep(
            data["name"], data["from"], data["to"], data["samples"],
            data.get("rate"), data.get("acceleration")))

    def points(self, data):
        if not isinstance(data, dict):
            self.fail("points", None, "expected a table of constructions")
        return [self.construction(name, spec) for name, spec in data.items()]

    def construction(self, name, spec):
        if not isinstance(spec, dict):
            self.fail("points", name, f"expected a table such as {{ fixed = [0, 0] }}, found {spec!r}")
        kinds = [k for k in spec if k in CONSTRUCTION_KEYS]
        if len(kinds) != 1:
            self.fail("points", name,
                      f"expected exactly one construction kind ({', '.join(CONSTRUCTION_KEYS)}), "
                      f"found {kinds or list(spec)}")
        kind = kinds[0]
        self.keys("points", spec, CONSTRUCTION_KEYS[kind], what=name)
        v = spec[kind]
        table = "points"

        def build():
            if kind == "fixed":
                x, y = self.name_list(table, name, v, 2, "[x, y]")
                return Fixed(name, x, y)
            if kind == "polar":
                c, length, angle = self.name_list(table, name, v, 3, "[centre, length, angle]")
                return Polar(name, c, length, angle)
            if kind == "dyad":
                p, lp, q, lq = self.name_list(table, name, v, 4, "[P, length from P, Q, length from Q]")
                return Dyad(name, p, lp, q, lq, self.required(table, name, spec, "side"))
            if kind == "slider":
                p, length, origin, angle = self.name_list(table, name, v, 4, "[P, length, line origin, line angle]")
                return Slider(name, p, length, origin, angle, self.required(table, name, spec, "side"))
            if kind == "attach":
                o, x, a, b = self.name_list(table, name, v, 4, "[origin, toward, a, b]")
                return Attach(name, o, x, a, b)
            return self.loop(name, spec)

        return self.guarded(table, name, build)

    def required(self, table, name, spec, key):
        if key not in spec:
            self.fail(table, name, f"missing key {key!r}")
        return spec[key]

    def loop(self, name, spec):
        for key in ("lengths", "angles", "joints"):
            if not isinstance(spec.get(key), list):
                self.fail("points", name, f"a loop needs {key} = [...] (one per link)")
        closure = None
        if "closure" in spec:
            c = spec["closure"]
            self.keys("points", c, ["point", "fixed", "line"], ["point"], what=f"{name}.closure")
            line = c.get("line")
            if line is not None:
                line = self.name_list("points", name, line, 2, "closure line [origin point, angle]")
            closure = Closure(c["point"], c.get("fixed"), line[0] if line else None, line[1] if line else None)
        unknowns = spec.get("unknowns", {})
        if not isinstance(unknowns, dict):
            self.fail("points", name, "unknowns: expected a table name = initial guess")
        return Loop(name, spec["loop"], spec["lengths"], spec["angles"], spec["joints"], unknowns, closure)

    def bodies(self, data):
        if not isinstance(data, list):
            self.fail("bodies", None, "expected an array of tables [[bodies]]")
        out = []
        allowed = ["name", "frame", "mass", "com", "inertia", "force", "torque"]
        for i, b in enumerate(data):
            self.keys("bodies", b, allowed, ["name", "frame"], index=i)
            out.append(self.guarded("bodies", None, lambda: Body(
                b["name"], b["frame"], b.get("mass"), b.get("com"), b.get("inertia"),
                b.get("force"), b.get("torque")), index=i))
        return out

    def gravity(self, data):
        self.keys("gravity", data, ["g"], ["g"])
        return self.guarded("gravity", "g", lambda: Gravity(data["g"]))

    def drive(self, data):
        if not isinstance(data, dict):
            self.fail("drive", None, "expected a table")
        kind = data.get("type")
        pins_key = {"rotary": "crank", "linear": "between"}.get(kind)
        if pins_key is None:
            self.fail("drive", "type", f"expected 'rotary' or 'linear', found {kind!r}")
        self.keys("drive", data, ["type", pins_key, "speed", "acceleration", "efficiency"],
                  ["type", pins_key, "speed", "acceleration"])
        return self.guarded("drive", None, lambda: Drive(
            kind, data[pins_key], data["speed"], data["acceleration"], data.get("efficiency")))

    def constraints(self, data):
        out = []
        for i, c in enumerate(data):
            self.keys("constraints", c, ["name", "expr", "min", "max"], ["name", "expr"], index=i)
            if "min" not in c and "max" not in c:
                self.fail("constraints", None, "give min, max or both", index=i)
            out.append(self.guarded("constraints", None, lambda: Constraint(
                c["name"], c["expr"], c.get("min"), c.get("max")), index=i))
        names = [c.name for c in out]
        for n in names:
            if names.count(n) > 1:
                self.fail("constraints", None, f"the name {n!r} is used twice")
        return out

    def objective(self, data):
        self.keys("objective", data, ["minimise"], ["minimise"])
        return Objective(data["minimise"])
