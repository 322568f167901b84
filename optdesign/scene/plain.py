"""Plain data of the result objects (their ``to_dict``): numbers, strings, lists and dicts that
``json.dumps`` takes as they are; arrays as lists, inf and nan as None, dataclasses field by
field, the scene by its title and file.  Here because every layer's results use it and the scene
is the first layer."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np


def plain(value):
    """``value`` as plain data (see the module's docstring)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, Path):
        return str(value)
    for method in ("to_dict", "as_dict"):
        if callable(getattr(value, method, None)):
            return plain(getattr(value, method)())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        if hasattr(value, "title") and hasattr(value, "points"):  # a Scene
            return {"title": value.title, "file": value.path}
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    return str(value)


def result_dict(result, kind, skip=()) -> dict:
    """A result dataclass as plain data: ``kind``, its scene's ``title`` and ``file`` (where it
    has one), then every field but the scene and ``skip``."""
    out = {"kind": kind}
    scene = getattr(result, "scene", None)
    if scene is not None:
        out.update(title=scene.title, file=scene.path)
    for f in dataclasses.fields(result):
        if f.name not in ("scene", *skip):
            out[f.name] = plain(getattr(result, f.name))
    return out
