"""Shared pieces of the plots over the stroke: a constraint's bounds drawn as lines with the
feasible side shaded, and a marked peak."""
from __future__ import annotations

import numpy as np

FEASIBLE = "#2ca02c"
BOUND = "#444444"


def bound_lines(ax, lower=None, upper=None, label=True):
    """Dashed lines at ``lower``/``upper`` and the feasible side between them shaded (to the
    edge of the plot where one is missing); the axis limits keep the data and both bounds."""
    ax.relim()
    ax.autoscale_view()
    lo, hi = ax.get_ylim()
    values = [v for v in (lower, upper) if v is not None]
    if not values:
        return
    lo, hi = min([lo] + values), max([hi] + values)
    pad = 0.06 * (hi - lo or 1.0)
    lo, hi = lo - pad, hi + pad
    a = lower if lower is not None else lo
    b = upper if upper is not None else hi
    ax.axhspan(a, b, color=FEASIBLE, alpha=0.09, lw=0, zorder=0)
    for v, name in ((lower, "min"), (upper, "max")):
        if v is not None:
            ax.axhline(v, color=BOUND, ls="--", lw=0.9, zorder=1)
            if label:
                ax.annotate(f"{name} {v:.4g}", (1.0, v), xycoords=("axes fraction", "data"), xytext=(-2, 2),
                            textcoords="offset points", ha="right", va="bottom", fontsize=7, color=BOUND)
    ax.set_ylim(lo, hi)


def mark_peak(ax, x, y, text, colour="#d62728"):
    """A triangle at (x, y) with ``text`` beside it and a thin vertical line: the governing
    position.  The text leans away from the nearer side of the plot (see :func:`headroom`)."""
    if not (np.isfinite(x) and np.isfinite(y)):
        return
    x0, x1 = ax.get_xlim()
    where = (x - x0) / (x1 - x0) if x1 != x0 else 0.5
    ha = "right" if where > 0.75 else "left" if where < 0.25 else "center"
    up = y >= 0
    ax.axvline(x, color=colour, lw=0.7, ls=":", zorder=1)
    ax.plot([x], [y], "v" if up else "^", color=colour, ms=7, zorder=5)
    ax.annotate(text, (x, y), xytext=(0, 9 if up else -9), textcoords="offset points", ha=ha,
                va="bottom" if up else "top", fontsize=7, color=colour, zorder=5,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))


def headroom(ax, fraction=0.14):
    """Room above and below the data for the marks' texts (call after plotting everything)."""
    ax.relim()
    ax.autoscale_view()
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo - fraction * (hi - lo), hi + fraction * (hi - lo))
