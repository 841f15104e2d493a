"""Interactive figures every page uses: curves on one time axis, a track on a map, x–y plots.

Pure builders taking arrays in people's units and returning a plain Plotly spec
(``{"data", "layout"}``) with a title, axis titles with units and the legend off the data.
The map draws OpenStreetMap tiles under a track trace that shows without them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from plotly.colors import make_colorscale, sequential

from euc_sim.geo import local_metres

__all__ = ["Panel", "Line", "with_breaks", "thin", "time_panels", "plain_values", "track_map", "track_plain", "xy_figure",
           "OSM_STYLE", "OSM_TILES", "map_zoom", "TURBO", "YL_OR_RD"]

#: A MapLibre style with OpenStreetMap's raster tiles only (no glyphs, no sprites: nothing
#: else is fetched).
OSM_STYLE = {"version": 8, "sources": {},
             "layers": [{"id": "background", "type": "background",
                         "paint": {"background-color": "#eef0f3"}}]}
#: OpenStreetMap's raster tiles, a layer under the traces added once the map has loaded: a
#: tile that cannot load leaves the background, never the track, undrawn.
OSM_TILES = {"sourcetype": "raster", "below": "traces", "sourceattribution": "© OpenStreetMap contributors",
             "source": ["https://tile.openstreetmap.org/{z}/{x}/{y}.png"]}

#: Plotly's own Turbo and YlOrRd as explicit scales (plotly.js knows neither by name).
TURBO = make_colorscale(sequential.Turbo)
YL_OR_RD = make_colorscale(sequential.YlOrRd)

#: Legends under the axes, never on the data nor on the title.
_LEGEND = {"orientation": "h", "yanchor": "top", "y": -0.2, "xanchor": "left", "x": 0.0}
_MARGIN = {"l": 60, "r": 20, "t": 80, "b": 110}


@dataclass(frozen=True)
class Panel:
    """One row of :func:`time_panels`: ``name`` ("Speed"), ``unit`` ("km/h") and ``y`` in it, one per time."""

    name: str
    unit: str
    y: np.ndarray


@dataclass(frozen=True)
class Line:
    """One trace of :func:`xy_figure`: ``mode`` "markers" or "lines"."""

    name: str
    x: np.ndarray
    y: np.ndarray
    mode: str = "markers"
    dash: str = "solid"


def with_breaks(t: np.ndarray, gap: float, *ys: np.ndarray):
    """``t`` then each of ``ys`` with a NaN row inserted wherever ``t`` jumps by more than ``gap``."""
    t = np.asarray(t, float)
    cut = np.flatnonzero(np.diff(t) > gap) + 1
    out = [np.insert(t, cut, np.nan)]
    out += [np.insert(np.asarray(y, float), cut, np.nan) for y in ys]
    return tuple(out)


def thin(n: int, most: int) -> np.ndarray:
    """Indices of at most ``most`` of ``n`` rows, evenly spaced, first and last kept."""
    if n <= most:
        return np.arange(n)
    idx = np.linspace(0, n - 1, most).round().astype(int)      # in order: distinct where it steps
    return idx[np.diff(idx, prepend=-1) != 0]


def plain_values(a, digits: int | None = 5) -> list:
    """Values for a plain Plotly spec, ``digits`` significant digits of the largest (None: as
    they are), NaN as null (a break in the line)."""
    a = np.asarray(a, float)
    finite = np.isfinite(a)
    top = np.nanmax(np.abs(a), initial=0.0, where=finite)
    a = np.round(a, digits - 1 - int(np.floor(np.log10(top)))) if top > 0 and digits else a
    if finite.all():
        return a.tolist()
    return [v if v == v else None for v in np.where(finite, a, np.nan).tolist()]


def time_panels(t_min: np.ndarray, panels: Sequence[Panel], title: str, gap_min: float,
                mark: tuple[float, str] | None = None) -> dict:
    """Quantities stacked on one shared time axis ``t_min`` (min); lines break at jumps over ``gap_min`` (min);
    ``mark``: (min, label)."""
    n, space = len(panels), 0.025
    h = (1.0 - space * (n - 1)) / n
    layout = {"title": {"text": title}, "margin": _MARGIN, "hovermode": "x unified", "height": 140 * n + 110,
              "shapes": [], "annotations": []}
    data = []
    cols = with_breaks(t_min, gap_min, *(p.y for p in panels))
    x = plain_values(cols[0])
    for i, (p, y) in enumerate(zip(panels, cols[1:]), start=1):
        ax = "" if i == 1 else str(i)
        top = 1.0 - (i - 1) * (h + space)
        layout[f"xaxis{ax}"] = {"anchor": f"y{ax}", "domain": [0.0, 1.0]}
        if i < n:
            layout[f"xaxis{ax}"].update(matches=f"x{n}", showticklabels=False)
        layout[f"yaxis{ax}"] = {"anchor": f"x{ax}", "domain": [max(top - h, 0.0), top],
                                "title": {"text": f"{p.name}, {p.unit}", "font": {"size": 11}}}
        data.append({"type": "scatter", "x": x, "y": plain_values(y), "mode": "lines",
                     "name": f"{p.name}, {p.unit}", "line": {"width": 1.2}, "showlegend": False,
                     "hovertemplate": f"%{{y:.1f}} {p.unit}<extra>{p.name}</extra>",
                     "xaxis": f"x{ax}", "yaxis": f"y{ax}"})
        if mark is not None:
            layout["shapes"].append({"type": "line", "x0": mark[0], "x1": mark[0], "xref": f"x{ax}", "y0": 0,
                                     "y1": 1, "yref": f"y{ax} domain",
                                     "line": {"color": "#c62828", "width": 1, "dash": "dot"}})
    layout[f"xaxis{'' if n == 1 else n}"]["title"] = {"text": "time from the start of the log, min"}
    if mark is not None:
        layout["annotations"].append({"x": mark[0], "y": 1.0, "yref": "paper", "text": mark[1],
                                      "showarrow": False, "yanchor": "bottom",
                                      "font": {"color": "#c62828", "size": 11}})
    return {"data": data, "layout": layout}


def map_zoom(lat: np.ndarray, lon: np.ndarray, width_px: float = 600, height_px: float = 440) -> float:
    """The web-map zoom level that fits the track into a map of the given size."""
    lat0 = math.radians(float(np.nanmean(lat)))
    span_x = max(float(np.nanmax(lon) - np.nanmin(lon)), 1e-4)
    span_y = max(float(np.nanmax(lat) - np.nanmin(lat)), 1e-4) / max(math.cos(lat0), 0.1)
    zx = math.log2(360.0 * width_px / 256.0 / span_x)
    zy = math.log2(360.0 * height_px / 256.0 / span_y)
    return float(np.clip(min(zx, zy) - 0.4, 1.0, 18.0))


def track_map(lat: np.ndarray, lon: np.ndarray, value: np.ndarray, value_label: str, title: str,
              mark: tuple[float, float, str] | None = None):
    """The track (``lat``, ``lon`` deg; NaN rows left out) on OpenStreetMap tiles coloured by ``value``
    (``value_label`` with unit); ``mark``: (lat, lon, text)."""
    ok = np.isfinite(lat) & np.isfinite(lon)
    lat, lon, value = lat[ok], lon[ok], np.asarray(value, float)[ok]
    la, lo = plain_values(lat, None), plain_values(lon, None)
    data = [{"type": "scattermap", "lat": la, "lon": lo, "mode": "lines", "line": {"width": 2, "color": "#37474f"},
             "name": "track", "hoverinfo": "skip", "showlegend": False},
            {"type": "scattermap", "lat": la, "lon": lo, "mode": "markers", "name": value_label, "showlegend": False,
             **_coloured_points(value, value_label, 6)}]
    if mark is not None:
        data.append({"type": "scattermap", "lat": [mark[0]], "lon": [mark[1]], "mode": "markers", "name": mark[2],
                     "marker": {"size": 16, "color": "#c62828"}, "hovertext": [mark[2]], "hoverinfo": "text",
                     "showlegend": True})
    layout = {"title": {"text": title}, "margin": {"l": 10, "r": 10, "t": 60, "b": 40},
              "legend": {"orientation": "h", "yanchor": "top", "y": -0.02, "x": 0.0},
              "map": {"style": OSM_STYLE, "layers": [OSM_TILES],
                      "center": {"lat": float(np.mean(lat)), "lon": float(np.mean(lon))}, "zoom": map_zoom(lat, lon)}}
    return {"data": data, "layout": layout}



def _coloured_points(value: np.ndarray, value_label: str, size: int) -> dict:
    """A track's points coloured by ``value``, with its colour bar and hover text (both maps)."""
    return {"marker": {"size": size, "color": plain_values(value), "colorscale": TURBO, "showscale": True,
                       "colorbar": {"title": {"text": value_label, "side": "right"}, "thickness": 14}},
            "hovertemplate": f"%{{marker.color:.0f}} {value_label}<extra></extra>"}

def xy_figure(lines: Sequence[Line], title: str, x_title: str, y_title: str, note: str = "") -> dict:
    """Points and lines against a common x axis; ``note`` is a line under the title (a plain
    Plotly spec)."""
    data = [{"type": "scatter", "x": plain_values(ln.x), "y": plain_values(ln.y), "mode": ln.mode, "name": ln.name,
             **({"marker": {"size": 4, "opacity": 0.45}} if ln.mode == "markers"
                else {"line": {"width": 2, "dash": ln.dash}})} for ln in lines]
    text = title + (f"<br><sup>{note}</sup>" if note else "")
    return {"data": data, "layout": {"title": {"text": text}, "xaxis": {"title": {"text": x_title}},
                                     "yaxis": {"title": {"text": y_title}}, "margin": _MARGIN, "legend": _LEGEND}}


def track_plain(lat: np.ndarray, lon: np.ndarray, value: np.ndarray, value_label: str, title: str,
                mark: tuple[float, float, str] | None = None):
    """The track on plain axes, km east and north of its first point, equal aspect: drawn
    wherever the page opens (no tiles, no WebGL)."""
    ok = np.isfinite(lat) & np.isfinite(lon)
    lat, lon, value = lat[ok], lon[ok], np.asarray(value, float)[ok]

    def xy(la, lo):
        east_north = local_metres(la, lo, (float(lat[0]), float(lon[0]))) / 1000.0
        return east_north[:, 0], east_north[:, 1]

    x, y = xy(lat, lon)
    x, y = plain_values(x), plain_values(y)
    data = [{"type": "scatter", "x": x, "y": y, "mode": "lines", "line": {"width": 1.5, "color": "#90a4ae"},
             "hoverinfo": "skip", "showlegend": False},
            {"type": "scatter", "x": x, "y": y, "mode": "markers", "showlegend": False, "name": value_label,
             **_coloured_points(value, value_label, 5)}]
    if mark is not None:
        mx, my = xy(mark[0], mark[1])
        data.append({"type": "scatter", "x": plain_values(mx), "y": plain_values(my), "mode": "markers",
                     "name": mark[2], "marker": {"size": 16, "color": "#c62828", "symbol": "star"}})
    return {"data": data, "layout": {"title": {"text": title}, "margin": _MARGIN, "legend": _LEGEND,
                                     "xaxis": {"title": {"text": "east of the start, km"}},
                                     "yaxis": {"title": {"text": "north of the start, km"}, "scaleanchor": "x",
                                               "scaleratio": 1}}}
