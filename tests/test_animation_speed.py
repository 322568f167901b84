"""The animation's shortcuts draw what the plain drawing draws (issue 18: the optimise command
fast where the user waits): the ground drawn once into the background, the repeated texts
copied from sprites (optdesign/report/sprites.py), the MP4 encoded from the GIF's own frames
while they are drawn.  References: the same frames drawn artist by artist with matplotlib, and
the GIF's frames read back from the MP4."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import optdesign
from optdesign.report import animate as animation
from optdesign.report import drawing, sprites

from figure_checks import gif_frames

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
EXCAVATOR = PROBLEMS / "lib_excavator_boom.toml"


def _raw_frames(monkeypatch, tmp_path, scene, frames, plain=False):
    """The RGB frames as drawn (before the GIF's palette); ``plain``: every artist drawn by
    matplotlib, each frame whole: no sprites, the static parts drawn again in every frame over
    the same background."""
    kept = []
    with monkeypatch.context() as m:
        m.setattr(animation, "write_gif", lambda images, path, fps: kept.extend(images))
        if plain:
            m.setattr(sprites.TextSprites, "draw", lambda self, artist: artist.draw(self.canvas.get_renderer()))
            original = drawing.draw_mechanism

            def everything(*args, parts="all", **kwargs):
                # the background keeps only the axes; each frame draws the whole mechanism
                return None if parts == "static" else original(*args, **kwargs, parts="all")

            m.setattr(animation, "draw_mechanism", everything)
        animation.animate(scene, [tmp_path / f"{'plain' if plain else 'fast'}.gif"], frames=frames)
    return [np.asarray(k)[..., :3].astype(int) for k in kept]


def _near(mask, other, r=2):
    """Each True pixel of ``mask`` within ``r`` pixels of a True pixel of ``other``."""
    grown = np.zeros_like(other)
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            grown |= np.roll(np.roll(other, dy, axis=0), dx, axis=1)
    return bool(np.all(grown[mask]))


def test_frames_equal_the_plain_drawing(monkeypatch, tmp_path):
    scene = optdesign.load(EXCAVATOR)
    fast = _raw_frames(monkeypatch, tmp_path, scene, 8)
    plain = _raw_frames(monkeypatch, tmp_path, scene, 8, plain=True)
    assert len(fast) == len(plain) == 8
    # the first frame draws every text the ordinary way (a text becomes a sprite when it comes
    # back): the same pixels but where a grid line crosses the ground, which is now drawn with
    # the axes (under the grid, as in a figure drawn whole) rather than over them
    assert (np.abs(fast[0] - plain[0]).sum(axis=2) > 0).sum() < 40
    for i, (a, b) in enumerate(zip(fast, plain)):
        assert a.shape == b.shape
        diff = np.abs(a - b).sum(axis=2) > 60
        # a copied text lands on the whole pixel nearest its place: its edges move by up to half
        # a pixel, nothing else changes
        assert diff.mean() < 0.004, (i, diff.mean())
        ink = np.abs(b - 255).sum(axis=2) > 60      # everything drawn, texts included
        assert _near(diff, ink), i


def test_sprite_matches_the_text_drawn_at_its_place():
    """A text copied to other places: its pixels within a pixel of the text drawn there."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    def draw(use_sprites, x, y):
        fig = Figure(figsize=(3, 2), dpi=80)
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_axes([0, 0, 1, 1])
        ax.set_xlim(0, 3)
        ax.set_ylim(0, 2)
        ax.set_axis_off()
        canvas.draw()
        texts = sprites.TextSprites(canvas)
        image = None
        for px, py in ((0.4, 0.3), (0.5, 0.5), (x, y)):   # the third time from the sprite
            canvas.draw()
            t = ax.text(px, py, "boom: 1900 kg", fontsize=7, color="#2b6e3f",
                        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.75))
            (texts.draw if use_sprites else (lambda a: a.draw(canvas.get_renderer())))(t)
            image = np.asarray(canvas.buffer_rgba())[..., :3].astype(int)
            t.remove()
        return image

    for x, y in ((1.3, 1.1), (2.01, 0.377), (0.7, 1.6)):
        fast, plain = draw(True, x, y), draw(False, x, y)
        dark_fast, dark_plain = (np.abs(im - 255).sum(axis=2) > 200 for im in (fast, plain))   # the glyphs' cores
        assert _near(dark_fast, dark_plain, 1) and _near(dark_plain, dark_fast, 1)
        ink_fast = np.argwhere(np.abs(fast - 255).sum(axis=2) > 30)
        ink_plain = np.argwhere(np.abs(plain - 255).sum(axis=2) > 30)
        assert len(ink_plain) > 50
        np.testing.assert_allclose(ink_fast.min(axis=0), ink_plain.min(axis=0), atol=1)
        np.testing.assert_allclose(ink_fast.max(axis=0), ink_plain.max(axis=0), atol=1)
        assert abs(len(ink_fast) - len(ink_plain)) <= 0.1 * len(ink_plain)


def test_text_cut_by_the_canvas_is_not_kept_as_a_sprite():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2), dpi=80)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_xlim(0, 3)
    ax.set_ylim(0, 2)
    canvas.draw()
    texts = sprites.TextSprites(canvas)
    for y in (-0.02, -0.02, 1.0):   # half below the canvas twice: no sprite of a cut text
        t = ax.text(1.0, y, "25.5 kN", fontsize=8, clip_on=False)
        texts.draw(t)
        t.remove()
    (sprite,) = texts.sprites.values()
    pixels, _ = sprite
    assert pixels.shape[0] >= 6            # the whole text's height, made at y = 1.0


@pytest.mark.skipif(shutil.which("ffmpeg") is None or shutil.which("ffprobe") is None, reason="ffmpeg is not on PATH")
def test_mp4_holds_the_gifs_frames(tmp_path):
    scene = optdesign.load(EXCAVATOR)
    gif, mp4 = animation.animate(scene, [tmp_path / "a.gif", tmp_path / "a.mp4"], frames=6)
    frames = gif_frames(gif)
    h, w = frames[0].shape[:2]
    raw = subprocess.run(["ffmpeg", "-v", "error", "-i", str(mp4), "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
                         capture_output=True, check=True).stdout
    hh, ww = h + h % 2, w + w % 2                 # padded to even sizes for yuv420p
    video = np.frombuffer(raw, np.uint8).reshape(-1, hh, ww, 3)[:, :h, :w].astype(int)
    assert len(video) == 6
    for a, b in zip(video, frames):
        # H.264 at its default quality and a 255-colour GIF: the same picture to within their losses
        assert np.mean(np.abs(a - b.astype(int))) < 6
    # consecutive video frames differ as the GIF's do (the mechanism moves)
    assert np.mean(np.abs(video[0] - video[-1])) > 1
    assert not list(tmp_path.glob(".*"))          # no temporary file left


def test_failed_mp4_leaves_no_file(tmp_path, monkeypatch):
    """An ffmpeg that fails after writing part of its file (a stand-in first on PATH, so that the
    test runs with or without a real ffmpeg): a specific error, no MP4 and no temporary file."""
    fake = tmp_path / "bin" / "ffmpeg"
    fake.parent.mkdir()
    fake.write_text('#!/bin/sh\nfor last; do :; done\nprintf partial > "$last"\nhead -c 100000 >/dev/null\n'
                    'echo "Unknown encoder" >&2\nexit 1\n')
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{fake.parent}:{os.environ['PATH']}")
    assert shutil.which("ffmpeg") == str(fake)
    out = tmp_path / "out"
    out.mkdir()
    scene = optdesign.load(EXCAVATOR)
    with pytest.raises(optdesign.OptdesignError, match="ffmpeg could not write .*Unknown encoder"):
        animation.animate(scene, [out / "a.gif", out / "a.mp4"], frames=3)
    assert not (out / "a.mp4").exists()
    assert not [p for p in out.iterdir() if p.name != "a.gif"]   # no temporary file left


def test_caption_word_by_word_equals_the_caption_drawn_whole():
    """draw_line (words and digits from sprites) against matplotlib drawing the whole line, over
    frames whose numbers change: the same glyphs within a pixel of the same places."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 1), dpi=80)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes([0, 0, 1, 0.5])
    ax.set_axis_off()
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    caption = ax.text(0.5, 1.01, "", transform=ax.transAxes, ha="center", va="bottom", fontsize=8.5, animated=True)
    texts = sprites.TextSprites(canvas)
    for i in range(12):
        caption.set_text(f"theta = {-2.414 + i * 1.37:.4g} deg   drive force {310.2 + i * 3.3:.4g} kN   "
                         f"transmission {21.6 + i / 7:.3g} deg")
        canvas.restore_region(background)
        ax.draw_artist(caption)
        plain = np.asarray(canvas.buffer_rgba())[..., :3].astype(int)
        canvas.restore_region(background)
        texts.draw_line(caption)
        fast = np.asarray(canvas.buffer_rgba())[..., :3].astype(int)
        dark_fast, dark_plain = (np.abs(im - 255).sum(axis=2) > 300 for im in (fast, plain))
        grey_fast, grey_plain = (np.abs(im - 255).sum(axis=2) > 60 for im in (fast, plain))
        assert dark_plain.sum() > 200
        # each glyph's core lies on the other's ink, within a pixel (rounded to whole pixels)
        assert _near(dark_fast, grey_plain, 1) and _near(dark_plain, grey_fast, 1), i
        ink_fast, ink_plain = (np.argwhere(np.abs(im - 255).sum(axis=2) > 30) for im in (fast, plain))
        np.testing.assert_allclose(ink_fast.min(axis=0), ink_plain.min(axis=0), atol=1)
        np.testing.assert_allclose(ink_fast.max(axis=0), ink_plain.max(axis=0), atol=1)
    assert len(texts.sprites) >= 10            # the digits, the point and the words came back as sprites


def test_text_outside_the_canvas_comes_back_when_inside():
    """A text met twice outside the canvas (an arrow's value below the figure in the first
    frames) is drawn where it later lies inside, not remembered as nothing."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2), dpi=80)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_xlim(0, 3)
    ax.set_ylim(0, 2)
    ax.set_axis_off()
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    texts = sprites.TextSprites(canvas)
    for y in (-1.0, -1.0, 1.0, 0.5):
        canvas.restore_region(background)
        t = ax.text(1.0, y, "25.5 kN", fontsize=8, clip_on=False)
        texts.draw(t)
        t.remove()
    ink = np.abs(np.asarray(canvas.buffer_rgba())[..., :3].astype(int) - 255).sum(axis=2) > 100
    assert ink.sum() > 20
    rows = np.flatnonzero(ink.any(axis=1))
    assert abs(rows.mean() - 0.75 * 160) < 12      # at y = 0.5 of 2 (rows counted from the top)
