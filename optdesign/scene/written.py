"""How a scene wrote its angles: with ``deg`` or with ``pi``, which the commands that show a
value to a person follow (the numbers themselves are SI radians either way)."""
from __future__ import annotations


def written_in_deg(*exprs) -> bool:
    """True when any of the expressions (or their source texts) was written with ``deg``."""
    for e in exprs:
        text = getattr(e, "source", e)
        if isinstance(text, str) and "deg" in text:
            return True
    return False


def sweep_unit(scene) -> str:
    """The sweep's unit for a person: 'deg' when [sweep] from/to were written in deg, 'rad'
    when with pi, else '' (a length or a time: the scene does not say)."""
    sw = scene.sweep
    if written_in_deg(sw.start, sw.stop):
        return "deg"
    if any("pi" in getattr(e, "source", "") for e in (sw.start, sw.stop)):
        return "rad"
    return ""
