"""Texts of an animation drawn once and then copied: a joint's name, a body's mass, a weight's
value come back in every frame with the same string and style, only elsewhere; laying out and
rasterising a text glyph by glyph costs about a millisecond (matplotlib 3.11's Agg), copying
its pixels a few microseconds.

:class:`TextSprites` draws an artist the ordinary way until the same text (string, font,
colour, rotation, alignment, box) is met a second time; then the text alone is drawn once on a
transparent canvas of the figure's size, its pixels kept (the sprite) with their offset from
the text's anchor, and from then on the sprite is composited at the new anchor (rounded to the
pixel; the artist's clipping kept).  Anything else (a text that changes, an arrow, a patch) is
drawn as before."""
from __future__ import annotations

import numpy as np


class TextSprites:
    """Draw the artists of animation frames on ``canvas`` (an Agg canvas, drawn once before),
    texts that repeat from their sprites (see the module's docstring)."""

    def __init__(self, canvas):
        self.canvas = canvas
        self.seen: dict = {}       # key -> times drawn the ordinary way
        self.sprites: dict = {}    # key -> (pixels, offset) or None (nothing visible)
        self._scratch = None

    def draw(self, artist):
        renderer = self.canvas.get_renderer()
        key = _key(artist)
        if key is None or not artist.get_visible():
            artist.draw(renderer)
            return
        anchor = _anchor(artist, renderer)
        if anchor is None:        # an annotation whose point is outside its axes: not drawn
            return
        if key not in self.sprites:
            if self.seen.get(key, 0) < 1:
                self.seen[key] = self.seen.get(key, 0) + 1
                artist.draw(renderer)
                return
            sprite = self._make(artist, anchor, renderer)
            if sprite is False:
                artist.draw(renderer)
                return
            self.sprites[key] = sprite
        sprite = self.sprites[key]
        if sprite is None:
            return
        pixels, (dx, dy) = sprite
        gc = renderer.new_gc()
        artist._set_gc_clip(gc)
        renderer.draw_image(gc, int(round(anchor[0] + dx)), int(round(anchor[1] + dy)), pixels)
        gc.restore()

    def _make(self, artist, anchor, renderer):
        """The sprite of ``artist``: its pixels drawn alone (unclipped) and their lower-left
        corner's offset from its anchor, in pixels; None when nothing of it is visible, False
        when the canvas cuts it."""
        from matplotlib.backends.backend_agg import RendererAgg

        if self._scratch is None or (self._scratch.width, self._scratch.height) != (renderer.width, renderer.height):
            self._scratch = RendererAgg(renderer.width, renderer.height, renderer.dpi)
        scratch = self._scratch
        scratch.clear()
        clip = artist.get_clip_on()
        artist.set_clip_on(False)
        try:
            artist.draw(scratch)
        finally:
            artist.set_clip_on(clip)
            artist._renderer = renderer
        buf = np.asarray(scratch.buffer_rgba())
        alpha = buf[..., 3]
        rows, cols = np.flatnonzero(alpha.any(axis=1)), np.flatnonzero(alpha.any(axis=0))
        if not len(rows):
            return None
        r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        if r0 == 0 or c0 == 0 or r1 == alpha.shape[0] or c1 == alpha.shape[1]:
            return False          # cut by the canvas' edge here: drawn the ordinary way, tried again later
        # draw_image places an image by its lower-left corner, y up from the canvas' bottom, and
        # takes its rows bottom first
        pixels = np.ascontiguousarray(buf[r0:r1, c0:c1][::-1])
        return pixels, (c0 - anchor[0], renderer.height - r1 - anchor[1])


def _key(artist):
    """What a text's pixels depend on besides its position, or None for an artist that is not
    a plain text (an annotation with an arrow, an empty text, any other artist)."""
    from matplotlib.colors import to_rgba
    from matplotlib.text import Annotation, Text

    if not isinstance(artist, Text) or artist.get_text() == "" or artist.get_usetex():
        return None
    if isinstance(artist, Annotation) and artist.arrow_patch is not None:
        return None
    if artist.get_path_effects():
        return None
    box = artist.get_bbox_patch()
    box_key = None
    if box is not None:
        style = box.get_boxstyle()
        box_key = (type(style).__name__, tuple(sorted(vars(style).items())), box.get_facecolor(),
                   box.get_edgecolor(), box.get_linewidth(), box.get_linestyle(), box.get_alpha(), box.get_fill())
    return (type(artist).__name__, artist.get_text(), hash(artist.get_fontproperties()), to_rgba(artist.get_color()),
            artist.get_alpha(), artist.get_rotation(), artist.get_rotation_mode(), artist.get_ha(),
            artist.get_va(), getattr(artist, "_multialignment", None), getattr(artist, "_linespacing", None),
            artist.get_antialiased(),
            box_key)


def _anchor(artist, renderer):
    """The text's anchor in display pixels (y up), as Text.draw places it; None when an
    annotation is not drawn (its point outside the axes)."""
    from matplotlib.text import Annotation

    if isinstance(artist, Annotation):
        if not artist._check_xy(renderer):
            return None
        artist.update_positions(renderer)
    x, y = artist.get_transform().transform(artist.get_unitless_position())
    if not (np.isfinite(x) and np.isfinite(y)):
        return None
    return float(x), float(y)
