"""The engineering drawing's fixed layout (optdesign/report/mechanism.py: fixed_layout, which
replaces matplotlib's constrained layout there for speed, issue 18): every label, title and
text of the drawing inside the figure, none over the other panel or over another label,
checked on the drawn figure's own text extents."""
from __future__ import annotations

from pathlib import Path

import pytest

import optdesign
from optdesign.report import mechanism

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def _figure(monkeypatch, tmp_path, scene, long=False):
    kept = []
    monkeypatch.setattr(mechanism, "save_figures", lambda fig, paths: kept.append(fig) or list(paths))
    label = "start (infeasible: transmission angle, and a constraint with a long name)" if long else "start"
    suptitle = scene.title + (" and a long suffix that makes the suptitle wrap onto a second line" if long else "")
    mechanism.mechanism_figure([(label, scene), ("optimum", scene)], [tmp_path / "m.png"], suptitle=suptitle)
    (fig,) = kept
    fig.canvas.draw()
    return fig


def _inside(inner, outer, tol=1.0):
    return (inner.x0 >= outer.x0 - tol and inner.x1 <= outer.x1 + tol and inner.y0 >= outer.y0 - tol
            and inner.y1 <= outer.y1 + tol)


def _overlap(a, b, tol=1.0):
    return a.x0 < b.x1 - tol and b.x0 < a.x1 - tol and a.y0 < b.y1 - tol and b.y0 < a.y1 - tol


@pytest.mark.parametrize("name, long", [("lib_excavator_boom", False), ("lib_toggle_press", True),
                                        ("truck_crane", True), ("lib_scissor_lift", False)])
def test_labels_inside_and_apart(monkeypatch, tmp_path, name, long):
    fig = _figure(monkeypatch, tmp_path, optdesign.load(PROBLEMS / f"{name}.toml"), long)
    r = fig.canvas.get_renderer()
    page = fig.bbox
    left, right = fig.axes
    labels = []
    for ax in fig.axes:
        for text in (ax.xaxis.label, ax.yaxis.label, ax.title):
            box = text.get_window_extent(r)
            assert _inside(box, page), (text.get_text(), box, page)
            labels.append(box)
        (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
        shown = [t for t in ax.get_xticklabels() if x0 <= t.get_position()[0] <= x1]
        shown += [t for t in ax.get_yticklabels() if y0 <= t.get_position()[1] <= y1]
        for tick in shown:       # the tick labels drawn (those within the view)
            if tick.get_visible() and tick.get_text():
                assert _inside(tick.get_window_extent(r), page), tick.get_text()
        for t in ax.texts:      # the drawing's own texts (dimensions, masses, loads, names)
            if t.get_visible() and t.get_text():
                assert _inside(t.get_window_extent(r), page), t.get_text()
    suptitle = fig._suptitle.get_window_extent(r)
    assert _inside(suptitle, page)
    for box in labels:
        assert not _overlap(box, suptitle)
    # the left panel's texts stay out of the right panel and its y label
    right_edge = min(right.get_window_extent(r).x0, right.yaxis.label.get_window_extent(r).x0,
                     *(t.get_window_extent(r).x0 for t in right.get_yticklabels()
                       if t.get_text() and min(right.get_ylim()) <= t.get_position()[1] <= max(right.get_ylim())))
    for t in left.texts:
        if t.get_visible() and t.get_text():
            assert t.get_window_extent(r).x1 <= right_edge + 1, t.get_text()
    # each panel's title above its axes, its x label below
    for ax in fig.axes:
        box = ax.get_window_extent(r)
        assert ax.title.get_window_extent(r).y0 >= box.y1 - 1
        assert ax.xaxis.label.get_window_extent(r).y1 <= box.y0 + 1
