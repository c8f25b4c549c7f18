"""Markdown -> HTML rendering: escaping, link sanitising, embedded images, .md -> .html links, tables."""

import base64
import html.parser
import re

import numpy as np
import pytest

from tuner.render import fmt_num, markdown_to_html, md_escape, md_table, render_page

EVIL = [
    "[click](javascript:alert(1))",
    "[click](JaVaScRiPt:alert(1))",
    "[click](java\tscript:alert(1))",
    "[click](vbscript:msgbox(1))",
    "[click](data:text/html;base64,PHNjcmlwdD5hbGVydCgxKTwvc2NyaXB0Pg==)",
    "![x](data:image/svg+xml;base64,PHN2ZyBvbmxvYWQ9YWxlcnQoMSk+)",
    "<script>alert(1)</script>",
    "<img src=x onerror=alert(1)>",
    "<a href='javascript:alert(1)'>x</a>",
    "[x][r]\n\n[r]: javascript:alert(1)",
    "<javascript:alert(1)>",
]


class _Tags(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags, self.attrs = [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.attrs += [(tag, k, v or "") for k, v in attrs]


def _parse(page: str) -> _Tags:
    t = _Tags()
    t.feed(page)
    return t


def _assert_inert(page: str) -> None:
    t = _parse(page)
    assert "script" not in t.tags
    _assert_inert_attrs(t)


def _assert_inert_attrs(t: _Tags) -> None:
    """No event handler attribute, no script or data URL (but PNG images) in a link or source."""
    for tag, k, v in t.attrs:
        assert not k.startswith("on"), (tag, k, v)
        if k in ("href", "src"):
            scheme = re.sub(r"[\x00-\x20]", "", v).lower()
            assert not scheme.startswith(("javascript:", "vbscript:")), (tag, k, v)
            assert not scheme.startswith("data:") or scheme.startswith("data:image/png;base64,"), (tag, k, v)


@pytest.mark.parametrize("evil", EVIL)
def test_raw_markdown_attacks_render_inert(evil):
    _assert_inert(markdown_to_html(evil))


@pytest.mark.parametrize("evil", EVIL)
def test_escaped_text_shows_literally(evil):
    """A name passed through md_escape renders as exactly its text (one line)."""
    out = markdown_to_html(md_escape(evil))
    _assert_inert(out)
    text = re.sub(r"<[^>]+>", "", out)
    import html as _h

    assert _h.unescape(text).strip() == " ".join(evil.splitlines())


def test_table_cells_escape_pipes_and_markup():
    t = md_table([["a|b", "[x](javascript:1)", 4.5e-9]], ["name", "link", "value"])
    out = markdown_to_html(t)
    _assert_inert(out)
    assert out.count("<td") == 3 and "a|b" in out and "4.5e-09" in out


def test_multiline_value_does_not_break_a_table():
    t = md_table([["summary", "line one\nline two | x"], ["next", 1.0]], ["name", "value"])
    out = markdown_to_html(t)
    assert out.count("<tr>") == 3  # head + 2 rows
    assert 'style="text-align:left"' in out
    assert "line two" not in out and "line one ..." in out


def test_links_to_md_reports_point_to_html_and_tables_scroll():
    out = markdown_to_html("[run](jobs/a/report.md) [anchor](jobs/a/report.md#figures) [web](https://x.org/a.md)\n\n"
                           "| a |\n|---|\n| 1 |\n")
    assert 'href="jobs/a/report.html"' in out and 'href="jobs/a/report.html#figures"' in out
    assert 'href="https://x.org/a.md"' in out
    assert '<div class="table-scroll">\n<table>' in out


def test_images_embedded_only_from_inside_the_directory(tmp_path):
    from PIL import Image

    d = tmp_path / "run"
    (d / "figures").mkdir(parents=True)
    Image.fromarray(np.full((10, 20, 3), 200, np.uint8)).save(d / "figures" / "a b.png")
    Image.fromarray(np.zeros((5, 5, 3), np.uint8)).save(tmp_path / "outside.png")
    out = markdown_to_html("![fig](figures/a%20b.png)\n\n![out](../outside.png)\n\n![gone](figures/none.png)\n\n"
                           "![remote](https://example.org/x.png)", d)
    srcs = re.findall(r'src="([^"]+)"', out)
    assert len(srcs) == 1 and srcs[0].startswith("data:image/png;base64,")
    assert base64.b64decode(srcs[0].split(",", 1)[1]) == (d / "figures" / "a b.png").read_bytes()
    assert out.count("figure not available") == 3


def test_page_refresh_only_when_asked_and_title_escaped():
    live = render_page("# x", None, "<b>t</b>", refresh_s=7)
    final = render_page("# x", None, "t")
    assert '<meta http-equiv="refresh" content="7">' in live and "http-equiv=\"refresh\"" not in final
    assert "<title>&lt;b&gt;t&lt;/b&gt;</title>" in live
    assert "Content-Security-Policy" in final and "script-src" not in final
    with pytest.raises(ValueError, match="refresh_s"):
        render_page("", None, "t", refresh_s=0)


@pytest.mark.parametrize("v, text", [(4.5e-9, "4.5e-09"), (0.0, "0"), (123456789.0, "1.23457e+08"), (7, "7"),
                                     (float("inf"), "inf"), (float("nan"), "nan"), ("abc", "abc"), (True, "True")])
def test_fmt_num_keeps_significant_digits(v, text):
    assert fmt_num(v) == text
