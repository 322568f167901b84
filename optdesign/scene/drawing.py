"""The optional ``[drawing]`` table: what the engineering drawings need that the mechanism does
not say.  Only the drawings read it; the model never does.

``helpers`` names points that only construct others (a point above a piston that gives its
frame's x axis, a point 1 m along a platform that keeps it level): they are not drawn as links
or joints.  Without the table the drawing infers them (``optdesign.report.topology``); the key
is for the cases the inference gets wrong."""
from __future__ import annotations

from dataclasses import dataclass

from .values import check_point, set_field
from .where import Where, fail, near_miss, show

DRAWING_KEYS = ("helpers",)


@dataclass(frozen=True)
class Drawing:
    """How drawings show a scene: ``helpers``, points used only to construct others (no bar,
    no joint circle; the preview of ``optdesign draw`` still labels them)."""

    helpers: tuple = ()

    def __post_init__(self):
        where = Where("drawing", key="helpers")
        if not isinstance(self.helpers, (list, tuple)):
            fail(where, f"expected a list of point names, e.g. helpers = [\"U\"], found {show(self.helpers)}")
        set_field(self, "helpers", tuple(check_point(p, where) for p in self.helpers))

    def check(self, points, path=None):
        """Every helper must be a point of the scene (``points``: the names built)."""
        for p in self.helpers:
            if p not in points:
                fail(Where("drawing", key="helpers"), f"unknown point {p!r}" + near_miss(p, points)
                     + f" (the scene's points: {', '.join(points)})", path=path)
