"""Checks of the values handed to the front doors (``analyse(scene, samples)``,
``optimise(starts=..., seed=...)``, ``simulate(t_end=...)``, ``Study(...)``) and of what they
would cost, one way each: the command line's options go through the same functions
(:mod:`optdesign.cli.common`).

A wrong type is a ``TypeError`` naming the argument; a wrong value (not finite, out of range,
too large to fit in this machine's memory) is an :class:`~optdesign.errors.ArgumentError`
(an ``OptdesignError`` and a ``ValueError``), whose message names the argument, what was found
and what is allowed; for sizes, the estimate of what they would need.  Here, in the lowest layer
that holds code, so that every front door can use them.
"""
from __future__ import annotations

import math
import numbers
import os

from ..errors import ArgumentError


def _type_name(value) -> str:
    return type(value).__name__


def _found(name: str, expected: str, found) -> ArgumentError:
    return ArgumentError(f"{name + ': ' if name else ''}expected {expected}, found {found}")


def whole(name: str, value, minimum: int = 1, maximum: int | None = None, shown: str | None = None) -> int:
    """``value`` as an int >= ``minimum`` (and <= ``maximum``): an int, a numpy integer, or a
    float with a whole value (``1e4``); anything else (a bool, a string, None) is a TypeError.
    ``shown``: how to show the value in the message (the command line's text)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a whole number, found {_type_name(value)} {_short(value)}")
    expected = f"a whole number >= {minimum}" + (f" and <= {maximum:,}" if maximum is not None else "")
    if not isinstance(value, numbers.Integral):
        v = float(value)
        if not (math.isfinite(v) and v.is_integer()):
            raise _found(name, expected, shown or repr(value))
        value = v
    value = int(value)
    if value < minimum or (maximum is not None and value > maximum):
        raise _found(name, expected, shown or f"{value:,}")
    return value


def real(name: str, value, *, above: float | None = None, below: float | None = None,
         at_least: float | None = None, at_most: float | None = None, shown: str | None = None) -> float:
    """``value`` as a finite float, > ``above``, >= ``at_least``, < ``below`` and <= ``at_most``
    where given."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a number, found {_type_name(value)} {_short(value)}")
    parts = [f"> {above:g}" if above is not None else "", f">= {at_least:g}" if at_least is not None else "",
             f"< {below:g}" if below is not None else "", f"<= {at_most:g}" if at_most is not None else ""]
    expected = "a finite number" + (" " + " and ".join(p for p in parts if p) if any(parts) else "")
    try:
        v = float(value)
    except OverflowError:
        raise _found(name, expected, shown or f"{value} (too large for a float)") from None
    if (not math.isfinite(v) or (above is not None and not v > above)
            or (at_least is not None and not v >= at_least) or (below is not None and not v < below)
            or (at_most is not None and not v <= at_most)):
        raise _found(name, expected, shown or f"{v:g}")
    return v


# --- sizes ---------------------------------------------------------------------------------------
def available_memory() -> int:
    """Bytes of memory this machine has: the kernel's MemTotal, capped by a cgroup (container)
    limit when there is one.  The whole memory, not what is free at this instant: a size is
    refused only when it could never fit, never because other programs happen to use memory
    now (a 201-sample analyse was refused on a busy machine with MemAvailable near zero)."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemTotal:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            avail = 1 << 62                       # unknown: no limit from here
    for limit_file in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(limit_file) as fh:
                limit = fh.read().strip()
        except OSError:
            continue
        if limit.isdigit() and int(limit) < 1 << 60:
            avail = min(avail, int(limit))
        break
    return avail


def size_text(n_bytes: float) -> str:
    for unit, scale in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n_bytes >= scale:
            return f"{n_bytes / scale:.3g} {unit}"
    return f"{n_bytes:.0f} bytes"


def fits_in_memory(name: str, count: int, bytes_each: float, unit: str, advice: str = "") -> None:
    """An :class:`ArgumentError` when ``count`` items of about ``bytes_each`` bytes would not fit
    in the memory available; the message gives the estimate."""
    need = float(count) * float(bytes_each)
    have = available_memory()
    if need > have:
        raise ArgumentError(f"{name} = {count:,}: would need about {size_text(need)} of memory "
                            f"({size_text(bytes_each)} per {unit}), more than the {size_text(have)} "
                            f"this machine has" + (f"; {advice}" if advice else ""))


def within_time(name: str, count: float, seconds_each: float, limit_s: float, unit: str, advice: str = "") -> None:
    """An :class:`ArgumentError` when ``count`` units of about ``seconds_each`` would take more
    than ``limit_s``; the message gives the estimate."""
    need = float(count) * float(seconds_each)
    if need > limit_s:
        raise ArgumentError(f"{name}: {count:,.0f} {unit} would take about {_duration(need)} "
                            f"(~{seconds_each * 1e6:.3g} us per {unit.rstrip('s')}); at most "
                            f"{limit_s / seconds_each:,.0f} {unit} (about {_duration(limit_s)})"
                            + (f"; {advice}" if advice else ""))


def _duration(seconds: float) -> str:
    for unit, scale in (("years", 365.25 * 86400), ("days", 86400), ("hours", 3600), ("minutes", 60)):
        if seconds >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds:.3g} s"




# --- the sizes of the front doors ----------------------------------------------------------------------
def sample_bytes(scene) -> int:
    """Memory per sample of the stroke (analyse, kinematics): measured 1.3-2.9 kB on the shipped
    scenes (numpy work arrays of the vectorised model, columns, ratios), estimated from above."""
    return 1000 + 300 * len(scene.bodies) + 50 * len(scene.points) + 100 * len(scene.constraints)


def stroke_samples(scene, samples) -> int:
    """The number of samples of a stroke: a whole number >= 2 that fits in memory."""
    n = whole("samples", samples, 2)
    fits_in_memory("samples", n, sample_bytes(scene), "sample", "use fewer samples (--samples)")
    return n


def scene_argument(function: str, scene, *kinds):
    """``scene`` when it is a :class:`~optdesign.scene.scene.Scene` (or one of ``kinds``, e.g. a
    ``ResolvedScene``); else a TypeError that says how to get one."""
    from .scene import Scene

    if isinstance(scene, (Scene, *kinds)):
        return scene
    hint = ""
    if isinstance(scene, (str, os.PathLike)):
        hint = f"; load the file first: {function}(optdesign.load({str(scene)!r}))"
    raise TypeError(f"{function}: scene: expected a Scene (from optdesign.load(path) or optdesign.loads(text)), "
                    f"found {_type_name(scene)} {_short(scene)}{hint}")


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


START_BYTES = 4000        # one start of optimise: its point, screening candidates and report (~1-2 kB)


def optimise_arguments(scene, starts, seed, workers):
    """(starts, seed, workers) of :func:`optdesign.design.optimise`, checked."""
    starts = whole("starts", starts, 1)
    seed = whole("seed", seed, 0)
    workers = whole("workers", workers, 1)
    n = sum(1 for p in scene.parameters if p.is_design)
    fits_in_memory("starts", starts, START_BYTES + 64 * n, "start", "use fewer starts (--starts)")
    return starts, seed, workers


RK4_STEP_S = 12.6e-6      # one RK4 step of a small scene (sim_bar: 1.5 million steps in 18.9 s)
RK4_LIMIT_S = 1800.0      # at most half an hour of RK4 steps in one run
OUTPUT_SAMPLE_BYTES = 400  # one output sample of simulate: states, columns, their copies


def simulation_arguments(tolerance, samples, t_end, steps):
    """(tolerance, samples, t_end, steps) of a simulation run, checked: a tolerance in (0, 0.1]
    (as [simulation] tolerance), a
    finite end time > 0, samples >= 2 that fit in memory, RK4 steps >= 2 that end in time."""
    tolerance = real("tolerance", tolerance, above=0.0, at_most=0.1)
    samples = whole("samples", samples, 2)
    fits_in_memory("samples", samples, OUTPUT_SAMPLE_BYTES, "output sample", "use fewer samples (--samples)")
    t_end = real("t_end", t_end, above=0.0)
    if steps is not None:
        steps = whole("steps", steps, 2)
        total = 1.5 * steps * (samples - 1)      # the run and its half-step error estimate
        within_time(f"steps = {steps:,} per output sample x {samples - 1:,} intervals", total, RK4_STEP_S,
                    RK4_LIMIT_S, "RK4 steps", "use fewer steps per sample (--steps) or the implicit integrator (bdf)")
    return tolerance, samples, t_end, steps


# one study case in the client: its Case (~280 B), its journal index (~150 B) and its row, held
# column by column for the result (optdesign/study/rows.py: 8 B per number, COLUMN_BYTES per
# column with a margin for strings and values apart); measured with tracemalloc over a resumed
# study of the truck crane (rows of 25 columns): 654 B per case at 20,000 cases (3.3 kB when
# rows were dicts) (tests/test_study_scale.py checks the estimate against it)
CASE_BYTES, COLUMN_BYTES = 600, 16


def study_cases(name: str, count: int, columns: int = 25) -> int:
    """A number of study cases (or values on one axis) whose rows of ``columns`` columns fit in
    memory."""
    fits_in_memory(name, count, CASE_BYTES + COLUMN_BYTES * columns, "case", "use fewer values or split the study")
    return count


# one frame of an animation at 80 dpi: its RGBA image (840 x 416 for the jib) held until the GIF
# is written, and the GIF's palette copy; measured: 200 frames of seed1_jib 750 MB against 149 MB
# for 10, 39.5 s against 11.5 s (GIF and MP4): 3.2 MB and 0.15 s per frame
FRAME_BYTES = 3.2e6
FRAME_S = 0.15
FRAMES_LIMIT_S = 1800.0   # at most half an hour of drawing


def animation_frames(frames, dpi=80) -> int:
    """The number of frames of an animation: a whole number >= 2 whose images fit in memory
    and that are drawn within half an hour (both scale with the square of ``dpi``)."""
    frames = whole("frames", frames, 2)
    scale = (float(dpi) / 80.0) ** 2
    advice = "use fewer frames (--frames)"
    fits_in_memory("frames", frames, FRAME_BYTES * scale, "frame", advice)
    within_time(f"frames = {frames:,}", frames, FRAME_S * scale, FRAMES_LIMIT_S, "frames", advice)
    return frames


__all__ = ["whole", "real", "available_memory", "fits_in_memory", "within_time", "size_text", "stroke_samples",
           "scene_argument", "optimise_arguments", "simulation_arguments", "study_cases", "animation_frames"]
