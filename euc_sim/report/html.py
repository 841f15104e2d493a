"""One HTML page template for every report: ride, rides, diagnosis and the demo.

A title, a first screen of key figures, then sections of paragraphs, tables and inline
interactive Plotly figures, in one file that opens offline (map tiles are the only fetch).
Text is escaped, links pass :func:`safe_href`, and a Content-Security-Policy
(:func:`policy`) runs only the page's own scripts.  Builders return HTML fragments;
:func:`page` joins them and :func:`write_page` writes ``DIR/index.html`` atomically.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import html
import json
import re
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import plotly.io as pio
from plotly.offline import get_plotlyjs

from euc_sim.io import atomic_write
from euc_sim.report.figures import OSM_TILES

__all__ = ["KeyFigure", "key_figures", "paragraph", "table", "figure", "section", "page",
           "write_page", "columns", "lead", "box", "markdown", "safe_href", "policy", "PLOTLY_CONFIG"]

#: Plotly's options on every figure: no logo, no link to Plotly's cloud, PNG export kept.
PLOTLY_CONFIG = {"displaylogo": False, "responsive": True, "showLink": False}

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0 auto;max-width:1240px;
padding:12px 20px;color:#1d2330;line-height:1.45}
h1{font-size:1.5em;margin:.2em 0 .1em}h2{font-size:1.2em;margin:.8em 0 .3em}
.sub{color:#5a6270;margin:0 0 .6em}
.kf{display:grid;grid-template-columns:repeat(auto-fill,minmax(180px,1fr));gap:8px;margin:.5em 0}
.kf>div{background:#f3f5f8;border-radius:6px;padding:5px 10px}
.kf .v{font-size:1.3em;font-weight:600;line-height:1.25}.kf .l{font-size:.82em;color:#5a6270}
.kf .n{font-size:.76em;color:#5a6270;line-height:1.3}
.kf>.warn{background:#fff3e0}.kf>.bad{background:#fde7e9}.kf>.good{background:#e8f5e9}
details{border-top:1px solid #dde1e7;padding:.3em 0}summary{cursor:pointer;font-weight:600;font-size:1.1em}
table{border-collapse:collapse;margin:.4em 0;font-size:.92em}
td,th{border-bottom:1px solid #e3e6eb;padding:3px 8px;text-align:left}th{background:#f3f5f8}
td.num{text-align:right;font-variant-numeric:tabular-nums}
.fig{width:100%;min-height:320px}
.cols{display:grid;grid-template-columns:1fr 1fr;gap:12px}
.lead{font-size:1.02em;margin:.3em 0 .5em}.lead b{font-weight:600}
code{background:#f3f5f8;padding:0 3px;border-radius:3px;font-size:.92em}
.box{background:#eef3fb;border-radius:6px;padding:2px 12px;margin:.5em 0}.box h2{margin:.3em 0 .1em}
.box p,.box ul{margin:.2em 0}
details>div{padding:0 0 0 12px}details h3{font-size:1.02em;margin:.8em 0 .2em}
"""


@dataclass(frozen=True)
class KeyFigure:
    """One number on the first screen: ``label`` ("Distance"), ``value`` with unit ("12.4 km"), a short ``note``,
    ``tone`` (``""``, ``"good"``, ``"warn"``, ``"bad"``)."""

    label: str
    value: str
    note: str = ""
    tone: str = ""


def _esc(text: object) -> str:
    return html.escape(str(text), quote=True)


def key_figures(items: Iterable[KeyFigure]) -> str:
    """The first screen's tiles, as an HTML fragment."""
    tiles = []
    for k in items:
        cls = f' class="{_esc(k.tone)}"' if k.tone else ""
        note = f'<div class="n">{_esc(k.note)}</div>' if k.note else ""
        tiles.append(f'<div{cls}><div class="l">{_esc(k.label)}</div>'
                     f'<div class="v">{_esc(k.value)}</div>{note}</div>')
    return f'<div class="kf">{"".join(tiles)}</div>'


def paragraph(text: str) -> str:
    """A paragraph of plain text (escaped)."""
    return f"<p>{_esc(text)}</p>"


def table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A table; cells that are numbers (int/float) are right-aligned as written."""
    head = "".join(f"<th>{_esc(h)}</th>" for h in header)
    body = []
    for row in rows:
        cells = "".join(
            f'<td class="num">{_esc(c)}</td>' if isinstance(c, (int, float)) else f"<td>{_esc(c)}</td>"
            for c in row)
        body.append(f"<tr>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def figure(fig, div_id: str, height: int = 380) -> str:
    """An interactive Plotly figure (object or spec dict), data inline, in element ``div_id`` (letters, digits,
    ``_``, ``-``), ``height`` px."""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]*", div_id):
        raise ValueError(f"figure id {div_id!r}: expected letters, digits, '_' and '-'")
    spec = pio.to_json(fig, validate=False) if not isinstance(fig, dict) else json.dumps(fig)
    # "</script" or "<!--" inside a script element would end it or change how it ends:
    # JSON has "<" only inside strings, where "\u003c" is the same character
    spec = spec.replace("<", "\\u003c")
    with _WRITTEN_LOCK:                         # valid JSON: policy() need not parse it again
        _WRITTEN[spec] = None
        while len(_WRITTEN) > 64:
            del _WRITTEN[next(iter(_WRITTEN))]
    tiles = ' data-map="waiting"' if _is_map(fig) else ""
    return (f'<div id="{div_id}" class="fig"{tiles} style="height:{int(height)}px"></div>'
            f'<script>(function(){{var f={spec};'
            f'Plotly.newPlot("{div_id}",f.data,f.layout||{{}},{json.dumps(PLOTLY_CONFIG)});}})();</script>')


#: The latest figures' JSON as :func:`figure` wrote it (insertion order: the oldest leave first).
_WRITTEN: dict[str, None] = {}
_WRITTEN_LOCK = threading.Lock()


def _is_map(fig) -> bool:
    """Whether ``fig`` draws on map tiles (a ``map`` subplot: :func:`page` then hides it where none loads)."""
    layout = fig.get("layout", {}) if isinstance(fig, dict) else fig.layout.to_plotly_json()
    return "map" in layout


def section(title: str, body: str, folded: bool = False) -> str:
    """A section; ``folded`` ones are closed ``<details>`` a reader opens."""
    if folded:
        return f"<details><summary>{_esc(title)}</summary>{body}</details>"
    return f"<section><h2>{_esc(title)}</h2>{body}</section>"


def page(title: str, subtitle: str, body: Sequence[str]) -> str:
    """The whole page: styles, Plotly's script where a :func:`figure` draws, then the fragments, under its
    :func:`policy`."""
    main = "".join(body)
    plotly = f"<script>{_plotly_js()}</script>" if 'Plotly.newPlot("' in main else ""
    guard = f"<script>{_MAP_GUARD}</script>" if 'data-map="' in main else ""
    rest = (f"<style>{_STYLE}</style>{plotly}</head><body>"
            f"<h1>{_esc(title)}</h1><p class=\"sub\">{_esc(subtitle)}</p>"
            f"{main}{guard}</body></html>")
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f'<meta http-equiv="Content-Security-Policy" content="{policy(rest)}">'
            "<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">"
            f"<title>{_esc(title)}</title>{rest}")


@functools.lru_cache(maxsize=1)
def _plotly_js() -> str:
    return get_plotlyjs().replace("</script", "<\\/script")


#: s a map is given to draw one tile; a map that has drawn none by then (offline, a tile server
#: down, MapLibre's worker refused from ``file://``) is hidden, and the figure beside it widens.
MAP_WAIT_S = 8.0
#: The script that does it (hashed like the figures' by :func:`policy`): it reads MapLibre's
#: "data" events and its tiles' states, and hides an empty map's column.
_MAP_GUARD = (
    "(function(){function drawn(m){if(m._tileDrawn)return true;var st=m.style||{},c=st.tileManagers"
    "||st.sourceCaches||{};for(var k in c){var t=(c[k]||{})._tiles||{};for(var i in t){if(t[i].state"
    "==='loaded')return true;}}return false;}function hide(gd){var box=gd.parentNode,cols=box&&box.parentNode;"
    "if(cols&&cols.classList.contains('cols')){box.style.display='none';cols.style.gridTemplateColumns='1fr';}"
    "else{gd.style.display='none';}gd.setAttribute('data-map','hidden');window.dispatchEvent(new Event('resize'));}"
    "function watch(gd,since){var s=gd._fullLayout&&gd._fullLayout.map&&gd._fullLayout.map._subplot,"
    "m=s&&s.map;if(m&&!m._tileWatch){m._tileWatch=true;m.on('data',function(e){if(e.tile)m._tileDrawn=true;});}"
    "if(m&&drawn(m)){gd.setAttribute('data-map','drawn');return;}"
    "if(Date.now()-since>" + str(int(MAP_WAIT_S * 1000)) + "){hide(gd);return;}"
    "setTimeout(function(){watch(gd,since);},250);}var t0=Date.now();"
    "document.querySelectorAll('.fig').forEach(function(gd){if(gd.getAttribute('data-map')!==null)watch(gd,t0);});})();")
#: The script :func:`figure` writes: a JSON literal handed to Plotly, nothing else.
_FIGURE_SCRIPT = re.compile(r'\(function\(\)\{var f=(.*);Plotly\.newPlot\("[A-Za-z][A-Za-z0-9_-]*",f\.data,'
                            r"f\.layout\|\|\{\}," + re.escape(json.dumps(PLOTLY_CONFIG)) + r"\);\}\)\(\);", re.S)


def _scripts(markup: str) -> list[str]:
    """The text of every ``<script>…</script>`` in ``markup``, in order (a closed one only)."""
    out, i, plotly = [], 0, _plotly_js()
    while (a := markup.find("<script>", i)) >= 0:
        if markup.startswith(plotly, a + 8) and markup.startswith("</script>", b := a + 8 + len(plotly)):
            out.append(plotly)                 # the one object: hashed once, not copied a page
        elif (b := markup.find("</script>", a + 8)) >= 0:
            out.append(markup[a + 8:b])
        else:
            break
        i = b + 9
    return out


@functools.lru_cache(maxsize=1)
def _plotly_styles() -> tuple[str, ...]:
    """The style sheets Plotly's script inserts (read once: the script is 4.8 MB): the text of
    each ``.textContent='…'`` (or ``"…"``) without a backslash, MapLibre's style sheet among them."""
    js, out, i = _plotly_js(), [], 0
    while (k := js.find(".textContent=", i)) >= 0:
        q, a = js[k + 13:k + 14], k + 14
        end = js.find(q, a) if q in ("'", '"') else -1
        if end >= 0 and "\\" not in js[a:end]:
            out.append(js[a:end])
            i = end + 1
        else:
            i = k + 1
    return tuple(out)


@functools.lru_cache(maxsize=16)          # Plotly's script (4.8 MB) is hashed once, not once a page
def _sha256(text: str) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode("utf-8")).digest()).decode("ascii") + "'"


def _own_script(text: str) -> bool:
    """Whether ``text`` is Plotly's script or one :func:`figure` wrote (its data valid JSON)."""
    if text in (_plotly_js(), _MAP_GUARD):
        return True
    m = _FIGURE_SCRIPT.fullmatch(text)
    try:
        return m is not None and (m[1] in _WRITTEN or json.loads(m[1]) is not None)
    except ValueError:
        return False


def policy(markup: str) -> str:
    """The Content-Security-Policy of a page whose markup (after ``<head>``) is ``markup``.

    Nothing by default; scripts and styles by SHA-256 (Plotly's, each :func:`figure`'s, the
    page's), style attributes, ``data:`` and ``blob:`` images; the map's tiles
    (:data:`euc_sim.report.figures.OSM_TILES`) only where a figure uses them.
    """
    scripts = [s for s in _scripts(markup) if _own_script(s)]
    styles = [_STYLE, *_plotly_styles()]
    img = fetch = ""
    urls = [v for u in OSM_TILES["source"] for v in (u, u.replace("/", "\\u002f"))]    # as JSON may write it
    if any(u in s for s in scripts if s != _plotly_js() for u in urls):
        img = "".join(f" https://{h}" for h in sorted({u.split("/")[2] for u in OSM_TILES["source"]}))
        fetch = f"; connect-src{img}; worker-src blob:"
    return (f"default-src 'none'; script-src {' '.join(dict.fromkeys(map(_sha256, scripts)))}; "
            f"style-src {' '.join(dict.fromkeys(map(_sha256, styles)))}; style-src-attr 'unsafe-inline'; "
            f"img-src data: blob:{img}{fetch}; base-uri 'none'; form-action 'none'")


def write_page(folder: str | Path, text: str) -> Path:
    """Write ``folder/index.html`` atomically (the folder is created); returns its path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    # Plotly's script, where the page inlines it, from its UTF-8 kept once (a page with any
    # character beyond Latin-1 would otherwise widen and encode its 4.8 MB again)
    a = text.find("<script>") + 8
    cut = (a, a + len(_plotly_js())) if a >= 8 and text.startswith(_plotly_js(), a) else (len(text), len(text))
    data = b"".join([text[:cut[0]].encode("utf-8"), _plotly_utf8() if cut[1] > cut[0] else b"",
                     text[cut[1]:].encode("utf-8")])
    return atomic_write(folder / "index.html", lambda p: p.write_bytes(data))


@functools.lru_cache(maxsize=1)
def _plotly_utf8() -> bytes:
    return _plotly_js().encode("utf-8")


def columns(*fragments: str) -> str:
    """Fragments side by side (two columns)."""
    return f'<div class="cols">{"".join(f"<div>{f}</div>" for f in fragments)}</div>'


def box(title: str, body: str) -> str:
    """A highlighted block of the first screen: a heading and an HTML fragment."""
    return f'<section class="box"><h2>{_esc(title)}</h2>{body}</section>'


def lead(sentences: Sequence[str]) -> str:
    """The verdict under the title: a few sentences, plain text (escaped)."""
    return f'<p class="lead">{" ".join(_esc(s) for s in sentences)}</p>'


_INLINE = [(re.compile(r"\*\*(.+?)\*\*"), r"<b>\1</b>"), (re.compile(r"`([^`]+)`"), r"<code>\1</code>")]
_LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)]*)\)")
#: A Markdown line that is one image: its target.
_IMAGE_LINE = re.compile(r"!\[[^\]]*\]\(([^)]*)\)")
#: Where a page may link: the web (http, https), a place on the page, or a file the report
#: wrote beside it (a relative path of plain names: no scheme, no "..", no leading "/").
_HREF = re.compile(r"https?://[a-z0-9.-]+(:[0-9]+)?([/?#][\w.~:/?#@!$&'()*+,;=%-]*)?"
                   r"|#[\w.-]*|([\w-][\w.-]*/)*([\w-][\w.-]*)?", re.ASCII | re.IGNORECASE)


def safe_href(url: str) -> str | None:
    """``url`` where a page may link to it (:data:`_HREF`), else None (the caller shows it as text)."""
    return url if url and _HREF.fullmatch(url) else None


def _format(text: str) -> str:
    out = _esc(text)
    for rx, rep in _INLINE:
        out = rx.sub(rep, out)
    return out


def _inline(text: str) -> str:
    """One line of Markdown as HTML: ``**bold**``, ```code```, safe links (an image becomes a link); the rest
    escaped."""
    text = text.replace("\0", "")
    links: list[str] = []

    def link(m: re.Match) -> str:
        href = safe_href(m[3])
        if href is None or not (m[1] or m[2]):
            return m[0]
        label = f"figure: {_format(m[2])}" if m[1] else _format(m[2])
        links.append(f'<a href="{_esc(href)}">{label}</a>')
        return f"\0{len(links) - 1}\0"

    out = _format(_LINK.sub(link, text))
    return re.sub(r"\0(\d+)\0", lambda m: links[int(m[1])], out)


def _md_table(rows: list[str]) -> str:
    cells = [[c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", r.strip())[1:-1]] for r in rows]
    body = [c for c in cells[1:] if not all(set(x) <= set("-: ") for x in c)]
    head = "".join(f"<th>{_inline(h)}</th>" for h in cells[0])
    trs = "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>" for r in body)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{trs}</tbody></table>"


def markdown(lines: Sequence[str], figures: Mapping[str, tuple] | None = None) -> str:
    """Markdown lines as HTML: headings, paragraphs, lists, tables.

    An image whose target is a key of ``figures`` (``{target: (Plotly figure, height px)}``) is
    drawn by :func:`figure`; other images become links to their file.
    """
    out, block, kind = [], [], None
    figures = figures or {}

    def flush():
        if not block:
            return
        if kind == "ul":
            out.append("<ul>" + "".join(f"<li>{_inline(x[2:])}</li>" for x in block) + "</ul>")
        elif kind == "table":
            out.append(_md_table(block))
        else:
            out.append(f"<p>{_inline(' '.join(block))}</p>")
        block.clear()

    for raw in "\n".join(lines).split("\n"):
        line = raw.rstrip()
        drawn = _IMAGE_LINE.fullmatch(line)
        if drawn and drawn[1] in figures:
            flush()
            kind = None
            out.append(figure(figures[drawn[1]][0], drawn[1], figures[drawn[1]][1]))
            continue
        k = ("h" if line.startswith("#") else "ul" if line.startswith("- ") else
             "table" if line.startswith("|") else None if not line else "p")
        if k != kind or k in ("h", None):
            flush()
        kind = k
        if k == "h":
            out.append(f"<h3>{_inline(line.lstrip('#').strip())}</h3>")
        elif k is not None:
            block.append(line)
    flush()
    return "".join(out)


def image(path: str | Path, caption: str) -> str:
    """A PNG or SVG figure inline (a data URI: the page fetches nothing), with its caption."""
    path = Path(path)
    kind = {".png": "image/png", ".svg": "image/svg+xml"}.get(path.suffix.lower())
    if kind is None:
        raise ValueError(f"image {path}: expected a .png or .svg file")
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f'<figure><img src="data:{kind};base64,{data}" alt="{_esc(caption)}" style="max-width:100%">'
            f"<figcaption>{_esc(caption)}</figcaption></figure>")
