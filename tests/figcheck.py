"""What makes a figure readable, checked on the Figure object with matplotlib's own extents.

:func:`figure_problems` draws a figure (Agg) and lists, in words, what a reader would
trip over; ``assert_readable(fig)`` fails a test with that list.  Checked:

- the figure has a title (a suptitle, or a title on every panel); titles and axis
  labels lie inside the figure;
- every panel has a y label, and an x label where its x tick labels show;
- no tick label in the ``4×10^1`` or ``10^1`` form (log axes get plain numbers);
- every legend lies inside the figure, and either inside its own panel or clear of
  every panel's data area; it covers no tick label, axis label or title; a legend
  inside a panel covers no data point (line vertices, markers, bars).
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.patches import Rectangle

PIXEL = 1.0     # px: slack for rounding at the edges of boxes


def _inside(inner, outer) -> bool:
    return (inner.x0 >= outer.x0 - PIXEL and inner.y0 >= outer.y0 - PIXEL
            and inner.x1 <= outer.x1 + PIXEL and inner.y1 <= outer.y1 + PIXEL)


def _overlap(a, b) -> bool:
    return (min(a.x1, b.x1) - max(a.x0, b.x0) > PIXEL) and (min(a.y1, b.y1) - max(a.y0, b.y0) > PIXEL)


def _panels(fig) -> list:
    """Visible axes that carry data, with their secondary axes (twin/secondary y)."""
    out = []
    for ax in fig.axes:
        if ax.get_visible() and ax.axison:
            out.append(ax)
            out += [c for c in ax.child_axes if c.get_visible()]
    return out


def _texts(ax, renderer) -> list[tuple[str, object]]:
    """(what, bbox) of the tick labels, axis labels and titles of one axes."""
    out = []
    for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "y")):
        for lab in axis.get_ticklabels(which="both"):
            if lab.get_visible() and lab.get_text():
                out.append((f"{name} tick label {lab.get_text()!r}", lab.get_window_extent(renderer)))
        if axis.label.get_visible() and axis.label.get_text():
            out.append((f"{name} label", axis.label.get_window_extent(renderer)))
    for title in (ax.title, ax._left_title, ax._right_title):
        if title.get_text():
            out.append(("title", title.get_window_extent(renderer)))
    return out


def _title(ax) -> str:
    return ax.title.get_text() or ax._left_title.get_text() or ax._right_title.get_text()


def _shows_x_ticks(ax) -> bool:
    return any(t.get_visible() and t.get_text() for t in ax.xaxis.get_ticklabels())


def _data_points(ax) -> np.ndarray:
    """Display coordinates of an axes' line vertices and markers."""
    pts = []
    for line in ax.get_lines():
        if not line.get_visible():
            continue
        xy = line.get_xydata()
        if xy.size:
            xy = xy[np.all(np.isfinite(xy), axis=1)]
            pts.append(line.get_transform().transform(xy))
    for coll in ax.collections:
        off = coll.get_offsets()
        if coll.get_visible() and len(off) and type(coll).__name__ == "PathCollection":
            pts.append(coll.get_offset_transform().transform(np.asarray(off, float)))
    return np.vstack(pts) if pts else np.empty((0, 2))


def _covered_points(ax, box) -> int:
    xy = _data_points(ax)
    inside = ((xy[:, 0] > box.x0 + PIXEL) & (xy[:, 0] < box.x1 - PIXEL)
              & (xy[:, 1] > box.y0 + PIXEL) & (xy[:, 1] < box.y1 - PIXEL))
    return int(inside.sum())


def _covered_bars(ax, box, renderer) -> int:
    return sum(1 for p in ax.patches if isinstance(p, Rectangle) and p.get_visible()
               and p.get_label() != "_nolegend_" and _overlap(p.get_window_extent(renderer), box))


def _legend_problems(fig, renderer, panels, where: str, legend, own) -> list[str]:
    box = legend.get_window_extent(renderer)
    out = []
    if not _inside(box, fig.bbox):
        out.append(f"{where}: legend runs off the figure")
    if own is not None and _inside(box, own.get_window_extent(renderer)):
        n = _covered_points(own, box) + _covered_bars(own, box, renderer)
        if n:
            out.append(f"{where}: legend covers {n} data point(s) of its panel")
    else:
        hit = [i for i, ax in enumerate(panels) if _overlap(box, ax.get_window_extent(renderer))]
        if hit:
            out.append(f"{where}: legend neither inside its panel nor clear of the data area "
                       f"(overlaps panel(s) {hit})")
    for i, ax in enumerate(panels):
        for what, tb in _texts(ax, renderer):
            if _overlap(box, tb):
                out.append(f"{where}: legend covers panel {i}'s {what}")
    sup = fig._suptitle
    if sup is not None and sup.get_text() and _overlap(box, sup.get_window_extent(renderer)):
        out.append(f"{where}: legend covers the figure's title")
    return out


def figure_problems(fig) -> list[str]:
    """Everything that makes ``fig`` hard to read, in words (empty: readable).

    Parameters
    ----------
    fig : matplotlib.figure.Figure

    Returns
    -------
    list of str
    """
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    panels = _panels(fig)
    out = []
    if not panels:
        return ["no visible axes"]
    sup = fig._suptitle
    if not (sup is not None and sup.get_text()) and not all(_title(ax) for ax in panels if ax in fig.axes):
        out.append("no title: neither a suptitle nor a title on every panel")
    if sup is not None and sup.get_text() and not _inside(sup.get_window_extent(renderer), fig.bbox):
        out.append("the figure's title runs off the figure")
    for i, ax in enumerate(panels):
        name = f"panel {i} ({_title(ax) or 'untitled'!r:.60})"
        for what, box in _texts(ax, renderer):
            if "tick" not in what and not _inside(box, fig.bbox):
                out.append(f"{name}: its {what} runs off the figure")
        if not ax.get_ylabel() and any(t.get_text() for t in ax.yaxis.get_ticklabels()):
            out.append(f"{name}: no y label")
        if not ax.get_xlabel() and _shows_x_ticks(ax):
            out.append(f"{name}: no x label")
        for axis in (ax.xaxis, ax.yaxis):
            for lab in axis.get_ticklabels(which="both"):
                if any(s in lab.get_text() for s in ("times", "×10", "^{")):
                    out.append(f"{name}: tick label {lab.get_text()!r} is not a plain number")
                    break
        leg = ax.get_legend()
        if leg is not None and leg.get_visible():
            out += _legend_problems(fig, renderer, panels, name, leg, ax)
    for j, leg in enumerate(fig.legends):
        out += _legend_problems(fig, renderer, panels, f"figure legend {j}", leg, None)
    return out


def assert_readable(fig) -> None:
    """Fail with the list of :func:`figure_problems` when there is any."""
    problems = figure_problems(fig)
    assert not problems, "figure is hard to read:\n  " + "\n  ".join(problems)


def line_labels(fig) -> list[str]:
    """Every legend entry's text in a figure (axes and figure legends)."""
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None] + list(fig.legends)
    return [t.get_text() for leg in legends for t in leg.get_texts()]


__all__ = ["figure_problems", "assert_readable", "line_labels"]
