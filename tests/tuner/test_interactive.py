"""The interactive page's building blocks (tuner.render, tuner.interactive): the data block cannot be
closed by its content, plot slots come only from the report's own Markdown, and assets are written once."""

import json
import math

import pytest

from tuner.render import json_for_html, md_escape, render_page


def test_data_block_cannot_be_closed_and_nan_is_null():
    text = json_for_html({"name": "</script><script>alert(1)</script>", "x": [1.0, math.nan, math.inf], "&": "<!--"})
    assert "<" not in text and ">" not in text and "&" not in text
    assert json.loads(text) == {"name": "</script><script>alert(1)</script>", "x": [1.0, None, None], "&": "<!--"}


def test_plot_slots_only_from_exact_placeholders():
    md = "{{plot:convergence}}\n\n" + md_escape("{{plot:evil}}") + "\n\n```\n{{plot:code}}\n```\n\ntext {{plot:inline}}"
    page = render_page(md, None, "t", scripts=("plotly.min.js", "tuner_report.js"), data={"a": 1})
    assert page.count('class="tuner-plot"') == 1 and 'data-plot="convergence"' in page
    assert "<p>{{plot:evil}}</p>" in page and "<code>{{plot:code}}" in page  # escaped text stays text
    assert "script-src 'self';" in page and '<script src="tuner_report.js" defer></script>' in page
    static = render_page(md, None, "t")
    assert "<script" not in static and "tuner-plot\"" not in static and "script-src" not in static


@pytest.mark.parametrize("bad", ["https://cdn.example/plotly.js", "../x.js", "a.js onload=x", "x.html"])
def test_only_plain_local_script_names(bad):
    with pytest.raises(ValueError, match="plain .js file names"):
        render_page("x", None, "t", scripts=(bad,))


def test_assets_written_once_and_replaced_when_changed(tmp_path):
    from tuner import interactive

    if not interactive.available():
        pytest.skip("plotly not installed (the report extra)")
    interactive.install_assets(tmp_path)
    js, plotly = tmp_path / "tuner_report.js", tmp_path / "plotly.min.js"
    assert plotly.stat().st_size > 1_000_000 and "tuner-data" in js.read_text()
    from importlib import resources

    with resources.as_file(resources.files("tuner").joinpath("static/tuner_report.js")) as src:
        # never a hard link to the installed files: writing "tampered" below would change the package itself
        assert not plotly.samefile(interactive._plotly_js()) and not js.samefile(src)
    mtime = plotly.stat().st_mtime_ns
    js.write_text("tampered")
    interactive.install_assets(tmp_path)
    assert plotly.stat().st_mtime_ns == mtime and "tuner-data" in js.read_text()


def test_parallel_coordinate_bands_cover_every_rank_once():
    from tuner.plots.parcoords import bands

    for k in (1, 3, 12, 30, 200):
        b = bands(k)
        assert len(b["band"]) == k and b["band"][0] == 4 and b["band"] == sorted(b["band"], reverse=True)
        labels = [lab for lab in b["band_labels"] if lab]
        assert labels[-1].startswith("rank 1") and labels[0].endswith(str(k))


def test_a_run_below_a_folder_with_plotly_links_to_that_copy(tmp_path):
    from tuner import interactive

    if not interactive.available():
        pytest.skip("plotly not installed (the report extra)")
    import shutil

    shutil.copyfile(interactive._plotly_js(), tmp_path / "plotly.min.js")  # its own inode, not the package's
    job = tmp_path / "jobs" / "a"
    job.mkdir(parents=True)
    interactive.install_assets(job)
    assert (job / "plotly.min.js").stat().st_ino == (tmp_path / "plotly.min.js").stat().st_ino
