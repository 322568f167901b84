"""Where an item of a scene sits, and errors that name it.

:class:`Where` spells a place as in the TOML file (table, item, key); :func:`located_error`
makes an error that remembers its place, so that the file reader can add the line number;
:func:`near_miss` and :func:`show` word what was found.  Everything else in the scene package
raises through these.
"""
from __future__ import annotations

import dataclasses
import difflib
from dataclasses import dataclass

from ..errors import SceneError

ARRAY_TABLES = ("bodies", "forces", "constraints", "cases", "motors", "simulation.phases")


@dataclass(frozen=True)
class Where:
    """The place of an item in a scene, spelled as in the TOML file: ``table`` ('sweep',
    'points', 'bodies', ...; '' for the top level), ``item`` (a parameter, point, body or
    constraint name), ``key`` (e.g. 'samples', 'mass', 'polar angle', 'lengths[1]') and, for an
    array of tables whose item has no usable name, its ``index``."""

    table: str
    item: str | None = None
    key: str | None = None
    index: int | None = None

    def __str__(self):
        if not self.table:
            return self.key or "top level"
        array = self.table in ARRAY_TABLES
        text = f"[[{self.table}]]" if array else f"[{self.table}]"
        if self.item is not None:
            text += f" {self.item!r}" if array else f" {self.item}"
        elif self.index is not None:
            text += f" #{self.index + 1}"
        if self.key:
            text += f", {self.key}" if (self.item is not None or self.index is not None) else f" {self.key}"
        return text

    def at(self, key) -> "Where":
        return dataclasses.replace(self, key=key)


def located_error(cls, where, detail, path=None):
    """An error of class ``cls`` that remembers where it happened.

    ``where`` names the item (a string, or any object whose ``str`` does, such as
    :class:`Where`); ``detail`` says what was found and what was expected.  The attributes
    ``where``, ``detail`` and ``path`` let the scene-file reader add the file name and the line
    number without parsing the message."""
    head = f"{path}: " if path else ""
    exc = cls(f"{head}{where}: {detail}" if where else f"{head}{detail}")
    exc.where, exc.detail, exc.path = where, detail, path
    return exc


def fail(where, detail, cls=SceneError, path=None):
    """Raise :func:`located_error` (a :class:`~optdesign.errors.SceneError` unless ``cls``)."""
    raise located_error(cls, where, detail, path)


def near_miss(name, known) -> str:
    """'; did you mean 'X'?' for the closest of ``known``, or ''."""
    hint = difflib.get_close_matches(str(name), [str(k) for k in known], n=1)
    return f"; did you mean {hint[0]!r}?" if hint else ""


def show(value):
    """A value as the TOML file spells it (true/false for booleans), else its repr."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)
