"""Markdown reports to self-contained, safe HTML pages, and the text helpers reports share.

Why markdown-it-py and not Jinja2: the reports are written as Markdown first (``report.md`` is kept
for terminals, diffs and Git hosting) and the HTML page must say exactly the same thing. A Markdown
parser turns that one source into HTML; Jinja2 would need a second, hand-kept HTML version of every
report. markdown-it-py is CommonMark-exact (tables through its GFM rule), has no dependencies beyond
``mdurl``, and gives the two hooks safety needs: raw HTML in the source is disabled (``html: False``,
so ``<script>`` arrives as text) and every link and image URL passes :func:`_link_allowed` before it
is rendered. The page around the body is a fixed template (:data:`PAGE`) whose few substitutions are
escaped with :func:`html.escape`.

Safety rules of the rendered page:

- links: relative paths, ``#anchors``, ``http(s):`` and ``mailto:`` only; ``javascript:``,
  ``vbscript:``, ``data:``, ``file:`` and any other scheme are refused (the link stays as text);
- images: only files inside the report's directory are embedded, as ``data:image/...;base64`` URIs
  created here; any other image (remote, ``data:`` in the source, missing file) becomes its alt text;
- relative links to ``*.md`` reports point to the ``*.html`` page written beside them;
- a Content-Security-Policy allows no script, no remote resource, images only as ``data:``.

An interactive page (:mod:`tuner.interactive`, when plotly is installed) differs in three ways only:
its policy allows scripts from the page's own folder (``script-src 'self'``: ``plotly.min.js`` and
``tuner_report.js`` beside the page; still no inline script, no remote resource), its data is one
``<script type="application/json">`` block (JSON with ``<``, ``>`` and ``&`` written as JSON unicode
escapes, so no text in it can close the block), and a Markdown source line that is exactly
``{{plot:NAME}}`` (``NAME`` of letters, digits and ``-``) outside a code block becomes an empty
``<div class="tuner-plot" data-plot="NAME">`` the script fills. The line is swapped for a random token
before rendering, so text escaped with :func:`md_escape` (a backslash before each brace, shown as
``{{plot:x}}``) never becomes a slot.

Names, descriptions and string values that go into the Markdown are escaped with :func:`md_escape`
so that they are shown literally in both the Markdown and the HTML.
"""

from __future__ import annotations

import base64
import html
import math
import re
from pathlib import Path
from typing import Any

__all__ = ["markdown_to_html", "render_page", "write_html", "md_escape", "md_table", "md_path", "fmt_num",
           "write_text_atomic", "PAGE", "json_for_html"]

_IMAGE_TYPES = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".svg": "image/svg+xml",
                ".gif": "image/gif", ".webp": "image/webp"}
_SAFE_SCHEMES = ("http", "https", "mailto")

CSS = """
:root { --fg: #1f2328; --muted: #59636e; --line: #d1d9e0; --head: #f6f8fa; --accent: #0969da; }
* { box-sizing: border-box; }
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; color: var(--fg); margin: 0;
       line-height: 1.45; overflow-wrap: anywhere; }
main { max-width: 1120px; margin: 0 auto; padding: 1.2em 1.5em 3em; }
h1 { font-size: 1.6em; border-bottom: 1px solid var(--line); padding-bottom: .3em; }
h2 { font-size: 1.25em; margin-top: 1.8em; border-bottom: 1px solid var(--line); padding-bottom: .2em; }
h3 { font-size: 1.05em; }
a { color: var(--accent); }
code { background: var(--head); padding: .1em .3em; border-radius: 4px; font-size: .9em; }
pre { background: var(--head); padding: .7em 1em; border-radius: 6px; overflow-x: auto; max-width: 100%;
      font-size: .85em; line-height: 1.3; overflow-wrap: normal; }
pre code { background: none; padding: 0; }
.table-scroll { display: inline-block; max-width: 100%; overflow-x: auto; margin: .6em 0;
                border: 1px solid var(--line); border-radius: 6px; vertical-align: top; }
table { border-collapse: collapse; font-size: .85em; font-variant-numeric: tabular-nums; }
th, td { border-bottom: 1px solid var(--line); padding: 4px 10px; text-align: right; vertical-align: top;
         overflow-wrap: normal; }
th { white-space: nowrap; }
th { background: var(--head); position: sticky; top: 0; }
td:first-child, th:first-child { text-align: left; white-space: nowrap; }
tbody tr:hover { background: #f0f6ff; }
th.sortable { cursor: pointer; }
th[aria-sort=ascending]::after { content: " \25B2"; font-size: .7em; }
th[aria-sort=descending]::after { content: " \25BC"; font-size: .7em; }
.tuner-plot { width: 100%; min-height: 120px; margin: .6em 0; }
.tuner-plot .slice { display: inline-block; width: 33%; min-width: 300px; max-width: 100%; vertical-align: top; }
@media (max-width: 700px) { .tuner-plot .slice { width: 100%; min-width: 0; } }
.controls { margin: .5em 0; }
.controls select, .controls input { font: inherit; max-width: 100%; }
.muted { color: var(--muted); }
td.txt, th.txt { text-align: left; white-space: nowrap; }
td:first-child, td.txt.name { white-space: normal; overflow-wrap: anywhere; min-width: 8em; max-width: 22em; }
img { max-width: 100%; height: auto; display: block; margin: .8em auto; }
.missing-image { color: var(--muted); font-style: italic; }
.status { display: inline-block; padding: .15em .7em; border-radius: 1em; font-weight: 600;
          background: var(--head); border: 1px solid var(--line); }
.live { background: #fff8c5; border: 1px solid #d4a72c; border-radius: 6px; padding: .5em 1em; }
blockquote { margin: 1em 0; padding: .4em 1em; border-left: 4px solid #d4a72c; background: #fff8c5;
             color: var(--fg); }
footer { color: var(--muted); font-size: .8em; border-top: 1px solid var(--line); margin-top: 3em;
         padding-top: .6em; }
"""

PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta http-equiv="Content-Security-Policy" content="{csp}">
{refresh}<title>{title}</title>
<style>{css}</style>
{scripts}</head>
<body>
<main>
{body}
<footer>{footer}</footer>
</main>
</body>
</html>
"""


# --- text helpers --------------------------------------------------------------------------------
_MD_SPECIAL = re.compile(r"([\\`*\[\]<>|!~&#{}])")


def md_escape(text: Any) -> str:
    """``text`` as literal Markdown inline text (one line; no link, image, emphasis or HTML in it).

    Backslash-escapes the characters that could start markup (CommonMark allows a backslash before
    any ASCII punctuation), underscores that are not inside a word, and flattens line breaks.
    """
    s = " ".join(str(text).splitlines())
    s = _MD_SPECIAL.sub(r"\\\1", s)
    s = re.sub(r"(?<![0-9A-Za-z])_|_(?![0-9A-Za-z])", r"\\_", s)
    return s


def md_path(path: str) -> str:
    """A relative path as a Markdown link destination (percent-encoded: spaces, parentheses)."""
    from urllib.parse import quote

    return quote(path, safe="/#-_.~")


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write to a temporary file and rename: a reader (a reloading browser) sees the old or the new file
    (:func:`tuner.safe_io.write_atomic`: no link of either kind written through, no temporary file left)."""
    from tuner.safe_io import write_atomic

    return write_atomic(Path(path), text, fsync=False)


def fmt_num(v: Any, digits: int = 6) -> str:
    """A number with ``digits`` significant digits (``4.5e-09``, never ``0.0``); other values as text."""
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, int):
        return str(v)
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v)
    if math.isnan(f):
        return "nan"
    if math.isinf(f):
        return "inf" if f > 0 else "-inf"
    return f"{f:.{digits}g}"


def md_table(rows: list[list[Any]], head: list[Any], digits: int = 4) -> str:
    """A Markdown table; every cell is escaped, numbers get ``digits`` significant digits.

    Columns of numbers are right-aligned, others left-aligned. Multi-line strings do not belong in a
    table: they are shown up to their first line break with an ellipsis (reports put them in code
    blocks outside tables).
    """
    def cell(v: Any) -> str:
        if v is None:
            return ""
        if isinstance(v, str):
            lines = v.splitlines() or [""]
            return md_escape(lines[0] + (" ..." if len(lines) > 1 else ""))
        return md_escape(fmt_num(v, digits))

    def numeric(v: Any) -> bool:
        return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))

    if not rows:
        return "(no rows)"
    align = ["---:" if all(numeric(r[j]) for r in rows) else ":---" for j in range(len(head))]
    out = ["| " + " | ".join(cell(h) for h in head) + " |", "|" + "|".join(align) + "|"]
    out += ["| " + " | ".join(cell(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


# --- Markdown -> HTML ----------------------------------------------------------------------------
def _link_allowed(url: str) -> bool:
    """Relative URLs, anchors, http(s) and mailto; every other scheme (javascript:, data:...) refused."""
    s = re.sub(r"[\x00-\x20\x7f]", "", url).lower()
    m = re.match(r"^([a-z][a-z0-9+.\-]*):", s)
    return m is None or m.group(1) in _SAFE_SCHEMES


def _is_relative(url: str) -> bool:
    return re.match(r"^[a-zA-Z][a-zA-Z0-9+.\-]*:", url) is None and not url.startswith(("//", "/", "#"))


def _md_to_html_link(url: str) -> str:
    """``jobs/x/report.md#a`` -> ``jobs/x/report.html#a`` for relative links; others unchanged."""
    if not _is_relative(url):
        return url
    m = re.match(r"^([^?#]*)\.md([?#].*)?$", url)
    return f"{m.group(1)}.html{m.group(2) or ''}" if m else url


def _parser(base_dir: Path | None):
    from markdown_it import MarkdownIt

    md = MarkdownIt("commonmark", {"html": False}).enable("table")
    md.validateLink = _link_allowed  # instance attribute shadows the permissive default
    base = Path(base_dir).resolve() if base_dir is not None else None

    def image(self, tokens, idx, options, env):
        tok = tokens[idx]
        alt = self.renderInlineAsText(tok.children or [], options, env)
        src = tok.attrGet("src") or ""
        data = _embed(src, base)
        if data is None:
            return f'<span class="missing-image">[figure not available: {html.escape(alt)}]</span>'
        return f'<img src="{data}" alt="{html.escape(alt)}" loading="eager">'

    def link_open(self, tokens, idx, options, env):
        tok = tokens[idx]
        tok.attrSet("href", _md_to_html_link(tok.attrGet("href") or ""))
        if not _is_relative(tok.attrGet("href") or "#"):
            tok.attrSet("rel", "noopener noreferrer")
        return self.renderToken(tokens, idx, options, env)

    md.add_render_rule("image", image)
    md.add_render_rule("link_open", link_open)
    md.add_render_rule("table_open", lambda self, t, i, o, e: '<div class="table-scroll">\n<table>\n')
    md.add_render_rule("table_close", lambda self, t, i, o, e: "</table>\n</div>\n")
    return md


def _embed(src: str, base: Path | None) -> str | None:
    """A ``data:`` URI of the image file ``src`` inside ``base``; ``None`` for anything else."""
    from urllib.parse import unquote

    if base is None or not src or not _is_relative(src):
        return None
    p = (base / unquote(src.split("#")[0].split("?")[0])).resolve()
    mime = _IMAGE_TYPES.get(p.suffix.lower())
    if mime is None or base not in p.parents:
        return None
    from tuner.safe_io import UnsafeFile, read_bytes

    try:
        data = read_bytes(p)  # a regular file only: a FIFO named figures/x.png would block a plain read
    except (UnsafeFile, OSError):
        return None
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def markdown_to_html(markdown: str, base_dir: str | Path | None = None) -> str:
    """The HTML body of a Markdown report (see the module docstring for what is allowed).

    Parameters
    ----------
    markdown : str
        CommonMark with GFM tables.
    base_dir : path, optional
        Directory relative image paths are resolved against (and confined to); without it no image
        is embedded.
    """
    return _parser(Path(base_dir) if base_dir is not None else None).render(markdown)


_SCRIPT_NAME = re.compile(r"^[A-Za-z0-9_.-]+\.js$")
_PLOT_SLOT = re.compile(r"^\{\{plot:([A-Za-z0-9-]+)\}\}$", re.M)


def json_for_html(data: Any) -> str:
    """``data`` as JSON safe inside ``<script type="application/json">`` (NaN and infinities as null)."""
    import json

    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        return v

    text = json.dumps(clean(data), allow_nan=False, separators=(",", ":"))
    return text.replace("&", "\\u0026").replace("<", "\\u003c").replace(">", "\\u003e")


def render_page(markdown: str, base_dir: str | Path | None, title: str, refresh_s: float | None = None,
                footer: str = "", scripts: tuple[str, ...] = (), data: Any = None) -> str:
    """A complete, self-contained HTML page of ``markdown``.

    ``refresh_s`` adds ``<meta http-equiv="refresh">`` so that a browser reloads the page (the live
    view of a running run); ``None`` for a final report. ``scripts`` (file names beside the page) and
    ``data`` make an interactive page (module docstring); without them the page has no script at all.
    """
    refresh = ""
    if refresh_s is not None:
        if not (math.isfinite(refresh_s) and refresh_s > 0):
            raise ValueError(f"refresh_s: expected a positive number of seconds, got {refresh_s!r}")
        refresh = f'<meta http-equiv="refresh" content="{int(math.ceil(refresh_s))}">\n'
    token = ""
    if scripts:
        import secrets

        token = f"tunerslot{secrets.token_hex(8)}x"
        markdown = _PLOT_SLOT.sub(lambda m: token + m.group(1), markdown)
    body = markdown_to_html(markdown, base_dir)
    script_src, tags = "", ""
    if scripts:
        bad = [s for s in scripts if not _SCRIPT_NAME.match(s)]
        if bad:
            raise ValueError(f"scripts: expected plain .js file names beside the page, got {bad}")
        script_src = " script-src 'self';"
        if data is not None:
            tags += f'<script type="application/json" id="tuner-data">{json_for_html(data)}</script>\n'
        tags += "".join(f'<script src="{s}" defer></script>\n' for s in scripts)
        body = re.sub(f"<p>{token}([A-Za-z0-9-]+)</p>", lambda m: f'<div class="tuner-plot" id="plot-{m.group(1)}" '
                      f'data-plot="{m.group(1)}"></div>', body)
        body = re.sub(f"{token}([A-Za-z0-9-]+)", r"{{plot:\1}}", body)  # a slot line in a code block stays text
    return PAGE.format(refresh=refresh, title=html.escape(title), css=CSS, body=body, footer=html.escape(footer),
                       csp=f"default-src 'none';{script_src} img-src data:; style-src 'unsafe-inline'", scripts=tags)


def write_html(path: str | Path, markdown: str, base_dir: str | Path, title: str | None = None,
               refresh_s: float | None = None, footer: str = "written by tuner", scripts: tuple[str, ...] = (),
               data: Any = None) -> Path:
    """Write :func:`render_page` of ``markdown`` to ``path`` atomically (a watching browser never sees half)."""
    path = Path(path)
    page = render_page(markdown, base_dir, title or f"{path.parent.name} report", refresh_s, footer, scripts, data)
    return write_text_atomic(path, page)
