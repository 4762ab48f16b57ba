"""One self-contained HTML page: sections of interactive plots, tables and text.

Everything the page needs is inlined (plotly.js once, each figure's data as JSON with typed arrays),
so the file opens offline in any browser and can be archived with the data. Every user string
(file names, configs, labels) goes through :func:`html.escape` or into JSON with ``<``, ``>``
and ``&`` escaped, so no file name or config can inject markup or script.

::

    page = Page("Campaign grid112", meta={"file": "grid112.nc"})
    sec = page.section("FRF matrix", "Measured against exact receptance")
    sec.figure({"data": [...], "layout": {...}})
    sec.table(["posture", "error"], rows)
    page.write("report.html")
"""

from __future__ import annotations

import base64
import gzip
import html
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Page", "Section", "arr", "packed", "script_json", "label"]


def label(s) -> str:
    """A string from a file, safe as plotly text (plotly renders a few HTML tags in labels)."""
    return html.escape(str(s), quote=False)


def arr(a, dtype="f4") -> dict:
    """A numeric array as a plotly.js typed array (``{"dtype", "bdata"}``, base64): a quarter of
    the size of decimal JSON for float32 and decoded without parsing."""
    a = np.ascontiguousarray(np.asarray(a, dtype=dtype).ravel())
    return {"dtype": np.dtype(dtype).str[1:], "bdata": base64.b64encode(a.tobytes()).decode("ascii")}


def packed(a, dtype="i2", *, row: int | None = None) -> dict:
    """A large integer array for a widget, gzip-compressed (``{"dtype", "zdata", "row"}``).

    With ``row``, each run of ``row`` consecutive values (a spectrum along frequency) is stored
    as differences, modulo the integer width, before compression: neighbouring lines of a
    spectrum differ little, so this compresses several times better and decodes exactly. The
    page decompresses with the browser's own ``DecompressionStream`` before the widgets run.
    """
    a = np.ascontiguousarray(np.asarray(a, dtype=dtype).ravel())
    if row:
        r = a.reshape(-1, row)
        a = np.concatenate([r[:, :1], np.diff(r, axis=1)], axis=1).astype(dtype).ravel()  # wraps modulo 2**bits
    return {"dtype": np.dtype(dtype).str[1:], "zdata": base64.b64encode(gzip.compress(a.tobytes(), 6, mtime=0)).decode("ascii"),
            "row": int(row or 0)}


def _json_default(o):
    if isinstance(o, np.ndarray):
        return arr(o) if o.dtype.kind == "f" else _nan_to_none(o.tolist())
    if isinstance(o, np.generic):
        return _nan_to_none(o.item())
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def script_json(obj) -> str:
    """JSON safe inside ``<script type="application/json">``: no ``</script>``, no HTML comment
    openers, no line separators that end a JavaScript string."""
    s = json.dumps(_nan_to_none(obj), default=_json_default, separators=(",", ":"), allow_nan=False)
    return (s.replace("&", "\\u0026").replace("<", "\\u003c").replace(">", "\\u003e")
            .replace("\u2028", "\\u2028").replace("\u2029", "\\u2029"))


def _nan_to_none(obj):
    if isinstance(obj, float) and not np.isfinite(obj):
        return None                          # JSON has no NaN; plotly draws null as a gap
    if isinstance(obj, dict):
        return {k: _nan_to_none(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_nan_to_none(v) for v in obj]
    return obj


@dataclass
class Section:
    """A titled part of a page; blocks render in the order they were added."""

    title: str
    intro: str = ""
    blocks: list = field(default_factory=list)
    part: str = ""
    _page: "Page | None" = field(default=None, repr=False)

    def text(self, s: str) -> "Section":
        """A paragraph of plain text (escaped)."""
        self.blocks.append(f"<p>{html.escape(s)}</p>")
        return self

    def figure(self, fig: dict, *, height: int | None = None, caption: str = "") -> "Section":
        """A plotly figure given as ``{"data": [...], "layout": {...}}`` (numpy arrays allowed);
        a figure without traces becomes a note saying so."""
        if not fig.get("data"):
            return self.text(f"(no data to plot{': ' + caption if caption else ''})")
        key = self._page._next_id("fig")
        lay = dict(fig.get("layout", {}))
        if height:
            lay["height"] = height
        self._page._figures[key] = {"data": fig["data"], "layout": lay}
        # the figure's height reserved before it draws: the page knows what is on screen at once
        h = int(lay.get("height", 450))
        self.blocks.append(f'<div class="rm-plot" id="{key}" style="min-height:{h}px"></div>'
                           + (f'<p class="caption">{html.escape(caption)}</p>' if caption else ""))
        return self

    def table(self, columns, rows, *, caption: str = "") -> "Section":
        """A table of strings or numbers (numbers shown with 4 significant digits)."""
        def cell(v):
            if isinstance(v, (float, np.floating)):
                return "" if not np.isfinite(v) else f"{v:.4g}"
            return html.escape(str(v))

        head = "".join(f"<th>{html.escape(str(c))}</th>" for c in columns)
        body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in r) + "</tr>" for r in rows)
        cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
        self.blocks.append(f'<table class="rm-table">{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>')
        return self

    def code(self, s: str, *, summary: str = "") -> "Section":
        """Preformatted text (a config, a JSON document), folded when a summary is given."""
        pre = f"<pre>{html.escape(s)}</pre>"
        self.blocks.append(f"<details><summary>{html.escape(summary)}</summary>{pre}</details>"
                           if summary else pre)
        return self

    def widget(self, markup: str, data: dict, script: str) -> "Section":
        """A custom interactive block: trusted ``markup`` and ``script`` written by rmbench (never
        user strings), with its data as escaped JSON. The script sees ``ID`` (the block's id
        prefix), ``DATA`` and the page helpers ``rm.decode`` and ``rm.plot``; it returns a
        promise that resolves once its plots have drawn."""
        key = self._page._next_id("w")
        self._page._widgets.append((key, data, script))
        self.blocks.append(f'<div class="rm-widget" id="{key}">{markup.replace("ID", key)}</div>')
        return self


class Page:
    """A self-contained HTML report.

    Parameters
    ----------
    title : str
    meta : dict, optional
        Run metadata shown at the top (file, config, versions, seed, timings); values are
        shown as text, escaped.
    """

    def __init__(self, title: str, meta: dict | None = None):
        self.title = title
        self.meta = dict(meta or {})
        self.sections: list[Section] = []
        self._figures: dict = {}
        self._widgets: list = []
        self._n = 0
        self._part = ""

    def _next_id(self, prefix: str) -> str:
        self._n += 1
        return f"rm-{prefix}{self._n}"

    def section(self, title: str, intro: str = "") -> Section:
        """A new section at the end of the page (in the current part, if any)."""
        s = Section(title, intro, part=self._part, _page=self)
        self.sections.append(s)
        return s

    def part(self, title: str) -> "Page":
        """Start a part: the sections added next are grouped under ``title`` (a report of
        several stages, like the demo's)."""
        self._part = title
        return self

    def html(self) -> str:
        """The whole page as one string."""
        import plotly.offline

        toc, body, part = "", "", None
        for i, s in enumerate(self.sections):
            if s.part != part:
                part = s.part
                if part:
                    toc += f'<li class="rm-part-toc">{html.escape(part)}</li>'
                    body += f'<h2 class="rm-part">{html.escape(part)}</h2>'
            toc += f'<li><a href="#rm-s{i}">{html.escape(s.title)}</a></li>'
            body += (f'<section id="rm-s{i}"><h2>{html.escape(s.title)}</h2>'
                     + (f"<p>{html.escape(s.intro)}</p>" if s.intro else "") + "".join(s.blocks) + "</section>")
        meta = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{_meta_cell(v)}</td></tr>"
                       for k, v in self.meta.items())
        widgets = "".join(
            f'<script type="application/json" id="{k}-data">{script_json(d)}</script>'
            f"<script>rm.widgets.push(['{k}', function(ID, DATA) {{ {js} }}]);</script>"
            for k, d, js in self._widgets)
        return (
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(self.title)}</title>"
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<style>{_CSS}</style>"
            f"<script>{_JS}</script></head><body>"
            f"<header><h1>{html.escape(self.title)}</h1>"
            f'<table class="rm-meta">{meta}</table><nav><ul>{toc}</ul></nav></header>'
            f"<main>{body}</main>"
            f'<script type="application/json" id="rm-figures">{script_json(self._figures)}</script>'
            # plotly.js last: text and tables show while the browser compiles it
            f"{widgets}<script>{plotly.offline.get_plotlyjs()}</script>"
            "<script>rm.start();</script></body></html>\n")

    def write(self, path) -> Path:
        """Write the page (whole or not at all: a temporary file renamed into place)."""
        path = Path(path)
        if path.parent and not path.parent.is_dir():
            from rmbench.errors import InputError

            raise InputError(f"folder for the report does not exist: {path.parent}")
        tmp = path.with_name(f".{path.name}.part")
        try:
            tmp.write_text(self.html(), encoding="utf-8")
            os.replace(tmp, path)
        except OSError as err:
            from rmbench.errors import InputError

            tmp.unlink(missing_ok=True)
            raise InputError(f"cannot write the report {path}: {err.strerror or err}") from None
        return path


def _meta_cell(v) -> str:
    if isinstance(v, (dict, list)):
        return f"<pre>{html.escape(json.dumps(v, indent=1, default=str))}</pre>"
    s = str(v)
    if "\n" in s or len(s) > 160:
        return f"<details><summary>{html.escape(s[:80])}…</summary><pre>{html.escape(s)}</pre></details>"
    return html.escape(s)


_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0;color:#222;background:#fafafa}
header,main{max-width:1300px;margin:auto;padding:0 1.2em}
h1{font-size:1.5em;margin:.8em 0 .3em}h2{font-size:1.2em;border-bottom:1px solid #ccc;padding-top:.6em}
section{background:#fff;padding:.2em 1em 1em;margin:1em 0;border-radius:6px;box-shadow:0 1px 3px #0002}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}
td,th{border:1px solid #ddd;padding:2px 6px;text-align:left;vertical-align:top}
.rm-meta th{background:#f0f0f0}pre{margin:0;white-space:pre-wrap;font-size:.8em;max-height:20em;overflow:auto}
.caption,caption{font-size:.85em;color:#555;caption-side:bottom;text-align:left}
.rm-controls{margin:.5em 0}.rm-controls select{font-size:1em}
nav ul{columns:3;font-size:.9em}.rm-part-toc{list-style:none;font-weight:bold;margin-top:.3em}
h2.rm-part{font-size:1.35em;color:#345;border:none;margin:1.4em 0 0}
"""

# Page helpers: decode typed arrays, draw figures (all at start), run the widgets; sets
# window.rmReady once everything drew, so tests and users' scripts can wait on it.
_JS = r"""
var rm = {widgets: [], errors: []};
rm.decode = function (o) {
  if (!o || ArrayBuffer.isView(o) || o.bdata === undefined) return o;
  var bin = atob(o.bdata), buf = new ArrayBuffer(bin.length), u8 = new Uint8Array(buf);
  for (var i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
  return new rm.T[o.dtype](buf);
};
rm.T = {f4: Float32Array, f8: Float64Array, i2: Int16Array, u1: Uint8Array, i4: Int32Array};
rm.unpack = function (o) {        // gzip + row differences (page.packed) -> typed array
  if (typeof DecompressionStream === 'undefined')
    return Promise.reject(new Error('this browser cannot unpack the report data (needs DecompressionStream: ' +
                                    'Chrome 80+, Firefox 113+, Safari 16.4+)'));
  var bin = atob(o.zdata), u8 = new Uint8Array(bin.length);
  for (var i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
  var ds = new Blob([u8]).stream().pipeThrough(new DecompressionStream('gzip'));
  return new Response(ds).arrayBuffer().then(function (buf) {
    var a = new rm.T[o.dtype](buf), n = o.row;
    if (n) for (var r = 0; r < a.length; r += n)
      for (var k = r + 1; k < r + n; k++) a[k] = a[k - 1] + a[k];   // typed arrays wrap as the encoder did
    return a;
  });
};
rm.prepare = function (obj) {     // replace every packed array inside obj, in place
  var jobs = [];
  (function walk(o) {
    if (!o || typeof o !== 'object' || ArrayBuffer.isView(o)) return;
    Object.keys(o).forEach(function (k) {
      var v = o[k];
      if (v && typeof v === 'object' && v.zdata !== undefined) jobs.push(rm.unpack(v).then(function (a) { o[k] = a; }));
      else walk(v);
    });
  })(obj);
  return Promise.all(jobs).then(function () { return obj; });
};
rm.config = {responsive: true, displaylogo: false};
rm.plot = function (div, data, layout) {
  return Plotly.react(div, data, Object.assign({margin: {t: 40, r: 20, b: 45, l: 60}}, layout), rm.config);
};
rm.start = function () {
  // Each figure and widget draws when it comes near the screen (a long report opens at once);
  // rm.drawAll() draws the rest. window.rmReady: the first screen has drawn.
  rm.t = {start: performance.now()};
  var figs = JSON.parse(document.getElementById('rm-figures').textContent), jobs = {}, done = {};
  Object.keys(figs).forEach(function (k) {
    jobs[k] = function () { return rm.plot(document.getElementById(k), figs[k].data, figs[k].layout); };
  });
  rm.widgets.forEach(function (w) {
    jobs[w[0]] = function () {
      var data = JSON.parse(document.getElementById(w[0] + '-data').textContent);
      return rm.prepare(data).then(function (d) { return w[1](w[0], d); });
    };
  });
  function run(k) {
    if (!done[k]) {
      var t0 = performance.now();
      done[k] = Promise.resolve().then(jobs[k]).then(function () { rm.t[k] = performance.now() - t0; })
                .catch(function (e) {
                  console.error(e);
                  document.getElementById(k).insertAdjacentText('afterbegin', 'This figure could not be drawn: ' + e.message);
                });
    }
    return done[k];
  }
  rm.drawAll = function () { return Promise.all(Object.keys(jobs).map(run)); };
  function ready(p) {
    p.then(function () { rm.t.ready = performance.now(); window.rmReady = true; });
  }
  if (!Object.keys(jobs).length || !('IntersectionObserver' in window)) { ready(rm.drawAll()); return; }
  var first = true;
  var io = new IntersectionObserver(function (entries) {
    var now = [];
    entries.forEach(function (e) {
      if (e.isIntersecting) { now.push(run(e.target.id)); io.unobserve(e.target); }
    });
    if (first) { first = false; ready(Promise.all(now)); }
  }, {rootMargin: '200px'});
  Object.keys(jobs).forEach(function (k) { io.observe(document.getElementById(k)); });
};
rm.undrawn = function () {
  var bad = [];
  document.querySelectorAll('.js-plotly-plot').forEach(function (d) {
    var n = d.querySelectorAll('g.trace, g.hm image, canvas').length;
    if (n === 0) bad.push(d.id || '(unnamed)');
  });
  if (document.querySelectorAll('.rm-plot').length !== document.querySelectorAll('.rm-plot.js-plotly-plot').length)
    bad.push('a figure that never started');
  return bad;
};
"""
