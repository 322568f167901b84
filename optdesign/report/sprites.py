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

import re

import numpy as np

_NUMBER = re.compile(r"^[-+\u2212]?[0-9.]+([eE][-+]?[0-9]+)?$")


class TextSprites:
    """Draw the artists of animation frames on ``canvas`` (an Agg canvas, drawn once before),
    texts that repeat from their sprites (see the module's docstring)."""

    def __init__(self, canvas):
        self.canvas = canvas
        self.seen: dict = {}       # key -> times drawn the ordinary way
        self.sprites: dict = {}    # key -> (pixels, offset)
        self._scratch = None
        self._word = None          # the text artist that draw_line moves from word to word
        self._widths: dict = {}    # (font, dpi) -> {word: width in pixels}

    def draw(self, artist):
        renderer = self.canvas.get_renderer()
        try:
            key = _key(artist)
            if key is not None and artist.get_visible():
                anchor = _anchor(artist, renderer)
        except AttributeError:   # a matplotlib without the private pieces used here: draw it plainly
            key = None
        if key is None or not artist.get_visible():
            artist.draw(renderer)
            return
        if anchor is None:        # an annotation whose point is outside its axes: not drawn
            return
        self._draw(artist, key, anchor, renderer)

    def _draw(self, artist, key, anchor, renderer):
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
        pixels, (dx, dy) = self.sprites[key]
        gc = renderer.new_gc()
        artist._set_gc_clip(gc)   # (present when _make succeeded: it drew the artist)
        renderer.draw_image(gc, int(round(anchor[0] + dx)), int(round(anchor[1] + dy)), pixels)
        gc.restore()

    def draw_line(self, artist):
        """Draw ``artist``, a text of one line, not rotated (an animation's caption that changes
        in every frame), word by word and numbers digit by digit, each piece from its sprite
        once it has come back (:meth:`draw`), placed by the advances of the pieces before it
        (the font's widths; kerning across a space or between digits is nil).  A text of
        another kind is drawn as :meth:`draw` does."""
        from matplotlib.text import Text
        from matplotlib.transforms import IdentityTransform

        text = artist.get_text()
        renderer = self.canvas.get_renderer()
        if ("\n" in text or artist.get_rotation() != 0 or artist.get_bbox_patch() is not None
                or artist.get_ha() not in ("left", "center", "right") or artist.get_va() not in ("bottom", "baseline")):
            self.draw(artist)
            return
        anchor = _anchor(artist, renderer)
        if anchor is None or not text.strip():
            return
        prop = artist.get_fontproperties()
        widths = self._widths.setdefault((hash(prop), renderer.dpi), {})

        def ink(s):
            return renderer.get_text_width_height_descent(s, prop, ismath=False)[0]

        def width(s):   # the advance of a piece: its ink's width between two bars less theirs
            if s not in widths:
                widths[s] = ink(f"|{s}|") - widths.setdefault("||", ink("||"))
            return widths[s]

        pieces = text.split(" ")
        starts = np.cumsum([0.0] + [width(p) + width(" ") if p else width(" ") for p in pieces])
        total = starts[-1] - width(" ")
        left = anchor[0] - {"left": 0.0, "center": 0.5, "right": 1.0}[artist.get_ha()] * total
        baseline = anchor[1]
        if artist.get_va() == "bottom":   # matplotlib sets a line's bottom at the descent of "lp"
            baseline += renderer.get_text_width_height_descent("lp", prop, ismath=False)[2]
        # whole pixels: every piece then has the same phase on the pixel grid, in its sprite and
        # wherever it is copied to (the font's advances are whole pixels: hinted)
        left, baseline = round(left), round(baseline)
        if self._word is None:
            self._word = Text(0, 0, "", transform=IdentityTransform(), ha="left", va="baseline")
            self._word.set_figure(artist.figure)
        word = self._word
        word.update_from(artist)
        word.set_ha("left")
        word.set_va("baseline")
        word.set_transform(IdentityTransform())
        word.set_text("x")
        style = _key(word)   # what every piece shares (the text aside): one key computed per line
        for piece, start in zip(pieces, starts):
            # a number changes from frame to frame: it is drawn digit by digit (ten sprites)
            parts = list(piece) if _NUMBER.match(piece) else [piece] if piece else []
            for part in parts:
                word.set_text(part)
                word.set_position((left + start, baseline))
                self._draw(word, (style, part), (left + start, baseline), renderer)
                start += width(part)
        if len(widths) > 500:   # numbers come and go: keep the words
            widths.clear()

    def _make(self, artist, anchor, renderer):
        """The sprite of ``artist``: its pixels drawn alone (unclipped) and their lower-left
        corner's offset from its anchor, in pixels; False when the canvas cuts it or it lies
        outside the canvas (then it is drawn the ordinary way and tried again later)."""
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
            return False          # nothing of it on the canvas here (outside it): tried again later
        r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        if r0 == 0 or c0 == 0 or r1 == alpha.shape[0] or c1 == alpha.shape[1]:
            return False          # cut by the canvas' edge here: drawn the ordinary way, tried again later
        # draw_image places an image by its lower-left corner, y up from the canvas' bottom, and
        # takes its rows bottom first
        pixels = buf[r0:r1, c0:c1][::-1].copy()    # a copy: the scratch canvas is drawn over next
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
