"""Fixed layouts for the figures drawn most often (the engineering drawing, the animation):
margins computed once from the texts around the axes (titles' lines, the widest tick label,
axis labels) instead of matplotlib's constrained layout, which measures every text of the
figure at every draw (a third of a drawing's time).  Axes with an equal scale keep it inside
their cell (adjustable box, centred)."""
from __future__ import annotations

pt = 1 / 72                      # a point in inches
TICKS = (3.5 + 3.5) * pt          # tick length and pad


def ytick_width(ax, renderer, size) -> float:
    """The widest y tick label of ``ax`` that is shown, in inches (font size ``size`` pt)."""
    from matplotlib.font_manager import FontProperties

    font = FontProperties(size=size)
    formatter, locs = ax.yaxis.get_major_formatter(), ax.get_yticks()
    lo, hi = sorted(ax.get_ylim())
    widest = 0.0
    for text, loc in zip(formatter.format_ticks(locs) if len(locs) else [], locs):
        if text and lo - 1e-9 * (hi - lo) <= loc <= hi + 1e-9 * (hi - lo):
            widest = max(widest, renderer.get_text_width_height_descent(text, font, ismath=False)[0])
    return widest / renderer.dpi


def animation_layout(fig, mech_ax, side, suptitle_lines, tick_size=7, label_size=8, caption_size=8.5):
    """The animation's axes: the mechanism on the left (its caption above it), the ``side``
    axes (traces over the stroke, one above the other, each with its y and x labels) on the
    right, sharing the width 1.25 : 1."""
    W, H = fig.get_size_inches()
    renderer = fig.canvas.get_renderer()
    pad = 4 * pt
    top = pad + suptitle_lines * 9.5 * 1.25 * pt + pad
    split = W * 1.25 / 2.25 if side else W
    left = pad + ytick_width(mech_ax, renderer, tick_size) + TICKS
    bottom = pad + tick_size * 1.25 * pt + TICKS
    caption = caption_size * 1.3 * pt + pad
    mech_ax.set_position([left / W, bottom / H, (split - left - pad) / W, (H - top - caption - bottom) / H])
    if not side:
        return
    row = (H - top) / len(side)
    for k, ax in enumerate(side):
        lines = ax.yaxis.label.get_text().count("\n") + 1
        l = split + pad + lines * label_size * 1.25 * pt + 4 * pt + ytick_width(ax, renderer, tick_size) + TICKS
        b = pad + label_size * 1.25 * pt + 4 * pt + tick_size * 1.25 * pt + TICKS
        y0 = H - top - (k + 1) * row
        ax.set_position([l / W, (y0 + b) / H, (W - l - 2 * pad) / W, (row - b - pad) / H])


def fixed_layout(fig, axes, title_lines, suptitle_lines):
    """Place ``axes`` (side by side, one row) by margins computed from the texts around them:
    the suptitle's and titles' lines above, the tick labels and axis labels below and to the
    left (the widest y tick label measured), instead of matplotlib's constrained layout, which
    measures every text of the drawing at every save (a third of the figure's time).  Each
    axes keeps its equal scale inside its cell (adjustable box, centred)."""
    W, H = fig.get_size_inches()
    renderer = fig.canvas.get_renderer()
    widest = max(ytick_width(ax, renderer, 7) for ax in axes)
    # y label (8 pt) + its pad (4 pt) + tick labels + tick pad and length (3.5 + 3.5 pt) + a margin
    left = (4 + 8 * 1.25 + 4 + 3.5 + 3.5) * pt + widest
    right = 8 * pt
    # tick length and pad, tick labels (7 pt), label pad, x label (8 pt), a margin
    bottom = (3.5 + 3.5 + 7 * 1.25 + 4 + 8 * 1.25 + 5) * pt
    top = (4 + suptitle_lines * 10 * 1.2 + (4 if suptitle_lines else 0) + title_lines * 9 * 1.2 + 6) * pt
    cell = W / len(axes)
    margins = [[left, right, bottom, top] for _ in axes]

    def place():
        for k, (ax, (l, r, b, t)) in enumerate(zip(axes, margins)):
            ax.set_position([(k * cell + l) / W, b / H, (cell - l - r) / W, (H - t - b) / H])
            ax.apply_aspect()

    place()
    # texts of the drawing that reach out of their axes (a dimension beside the mechanism, a
    # mass's label) get room: their axes shrink by as much, once
    dpi = renderer.dpi
    for ax, m in zip(axes, margins):
        box = ax.get_window_extent(renderer)
        texts = [t.get_window_extent(renderer) for t in ax.texts if t.get_visible() and t.get_text()]
        if texts:
            m[0] += max(0.0, box.x0 - min(t.x0 for t in texts)) / dpi
            m[1] += max(0.0, max(t.x1 for t in texts) - box.x1) / dpi
            m[2] += max(0.0, box.y0 - min(t.y0 for t in texts)) / dpi
            m[3] += max(0.0, max(t.y1 for t in texts) - box.y1) / dpi
    place()
