"""Hangs: an animation's frames are bounded like samples, starts and steps (an animation of
1,000,000 frames ran for more than 90 s before it was killed: every frame's image is held until
the GIF is written, 3.2 MB each); the refusal comes at once, before the analysis, with the
estimate and what to do."""
from __future__ import annotations

import pytest

import optdesign
from optdesign.errors import ArgumentError
from optdesign.scene.arguments import FRAME_BYTES, FRAME_S, FRAMES_LIMIT_S, available_memory

from .util import JIB, cli


def _most_frames() -> int:
    """The ceiling, from the estimates written apart from the check: memory and half an hour."""
    return int(min(available_memory() // FRAME_BYTES, FRAMES_LIMIT_S // FRAME_S))


@pytest.mark.parametrize("frames", ["1000000", "1e9", str(_most_frames() + 1)])
def test_animate_with_too_many_frames_is_refused_at_once(tmp_path, frames):
    code, out, err = cli("animate", JIB, "--frames", frames, "--out", tmp_path / "a.gif", timeout=60)
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    n = int(float(frames))
    assert err.startswith(f"optdesign animate: error: frames"), err
    assert f"{n:,}" in err and "use fewer frames (--frames)" in err, err
    assert ("of memory (3.2 MB per frame)" in err) or ("frames would take about" in err), err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("frames, error", [(10**6, ArgumentError), (_most_frames() + 1, ArgumentError),
                                           (1, ArgumentError), (2.5, ArgumentError), (True, TypeError),
                                           ("36", TypeError)])
def test_animate_from_python_checks_its_frames(tmp_path, frames, error):
    from optdesign.report.animate import animate

    with pytest.raises(error, match=r"^frames"):
        animate(optdesign.load(JIB), [tmp_path / "a.gif"], frames=frames)
    assert not list(tmp_path.iterdir())


def test_the_ceiling_itself_is_allowed():
    from optdesign.scene.arguments import animation_frames

    assert animation_frames(_most_frames()) == _most_frames()
    assert animation_frames(36) == 36
