"""docs/papers.md follows from docs/papers.json by the page's rules (benchmarks.papers_page)."""

import json
import re
import subprocess

import pytest

from benchmarks import papers
from benchmarks.papers_common import CLAIM_VERDICTS, DIRECTION, NOT_REPRODUCED, REPRODUCED, Claim, Row, printed
from benchmarks.papers_page import FORMAT, dump, load, record, render
from benchmarks.papers_runs import ROOT

PAGE, DATA = ROOT / "docs" / "papers.md", ROOT / "docs" / "papers.json"


def _prov(**kw):
    p = {"budget": "smoke", "started": "2026-01-01 00:00:00 UTC", "wall_s": 12.3, "cpu_s": 20.0, "cpu_self_s": 15.0,
         "cpu_children_s": 5.0, "commit": "abc+dirty", "machine": "cpu x", "seeds": "1, 2", "budgets": "tiny"}
    return {**p, **kw}


def _claims():
    miss = [Row(f"cell {i}", "Table 2.5", "1.0", "cmd b", printed("1.0"), (3.0,) * 5) for i in range(20)]
    return [Claim("a", "Paper A", "one number", "section 1", [Row("r", "Table 1", "1.1", "cmd a", printed("1.1"),
                                                                    (1.1,) * 5, (True,) * 5, direction="d")]),
            Claim("b", "Paper B", "a table of twenty cells", "Table 2.5", miss),
            Claim("c", "Paper C", "a sentence", "Fig. 9", [Row("s", "Fig. 9", "'negligible'", "cmd c", None, (0.1,) * 5,
                                                              (True,) * 5, direction="small")])]


def test_committed_page_is_drawn_from_the_committed_json():
    """Every verdict and every printed number of docs/papers.md follows from docs/papers.json: the page is
    the record drawn by the rules (re-drawing it gives the same text), and the verdicts the record stores
    are those the rules compute from its per-seed values."""
    data, claims = load(DATA)
    assert PAGE.read_text() == render(data, claims)
    stored = json.loads(DATA.read_text())["claims"]
    assert [c["verdict"] for c in stored] == [c.verdict for c in claims]
    assert [[r["verdict"] for r in c["rows"]] for c in stored] == [[r.verdict for r in c.rows] for c in claims]
    assert all(len(r.values) >= 5 for c in claims for r in c.rows)  # every row over at least five seeds


def test_committed_page_comes_from_a_clean_commit_of_this_history_at_the_reduced_or_full_budget():
    data, _ = load(DATA)
    p = data["provenance"]
    assert p["budget"] in ("reduced", "full")
    assert re.fullmatch(r"[0-9a-f]{40}", p["commit"]), p["commit"]  # no +dirty: the code of a commit
    try:
        anc = subprocess.run(["git", "merge-base", "--is-ancestor", p["commit"], "HEAD"], cwd=ROOT,
                             capture_output=True)
    except OSError:
        pytest.skip("no git")
    if anc.returncode not in (0, 1):
        pytest.skip("not a git checkout with that history")
    assert anc.returncode == 0, f"the page's commit {p['commit']} is not in this branch's history"


def test_counts_at_the_top_are_by_claim_not_by_row(tmp_path):
    claims = _claims()
    assert [c.verdict for c in claims] == [REPRODUCED, NOT_REPRODUCED, DIRECTION]
    dump(record(claims, _prov()), tmp_path / "p.json")
    text = render(*load(tmp_path / "p.json"))
    assert "## Summary: 3 claims" in text
    assert f"**{REPRODUCED}**: 1; **{DIRECTION}**: 1; **{CLAIM_VERDICTS[2]}**: 0; **{NOT_REPRODUCED}**: 1" in text
    assert "| 20 not reproduced |" in text  # the table's cells counted in its claim's line
    assert text.index("## Verdict rules") < text.index("## Summary") < text.index("## Claims and their rows")
    assert text.count('<a id="b"></a>') == 1 and text.count("| cell ") == 20
    assert "- wall time: 12 s; CPU time: 20 s (this process 15 s, worker processes 5 s)" in text
    assert "- commit: abc+dirty" in text and "- machine: cpu x" in text


def test_a_record_with_other_values_draws_other_verdicts(tmp_path):
    """The page's verdicts come from the values: change a seed in the JSON and the re-drawn page changes."""
    dump(record(_claims(), _prov()), tmp_path / "p.json")
    raw = json.loads((tmp_path / "p.json").read_text())
    raw["claims"][0]["rows"][0]["values"] = [1.1, 1.1, 5.0, 5.0, 5.0]  # median outside: direction only
    (tmp_path / "q.json").write_text(json.dumps(raw))
    data, claims = load(tmp_path / "q.json")
    assert claims[0].verdict == DIRECTION
    assert f"**{REPRODUCED}**: 0; **{DIRECTION}**: 2" in render(data, claims)


def test_non_finite_values_are_strict_json_and_a_foreign_file_is_refused(tmp_path):
    c = [Claim("a", "P", "t", "w", [Row("r", "w", "1", "cmd", printed("1"), (float("nan"), 1.0, 1.0, 1.0, 1.0))])]
    dump(record(c, _prov(wall_s=float("inf"))), tmp_path / "p.json")
    text = (tmp_path / "p.json").read_text()
    assert "NaN" not in text and '"nan"' in text
    _, back = load(tmp_path / "p.json")
    assert back[0].rows[0].ours().endswith("1 diverged)")
    (tmp_path / "x.json").write_text(json.dumps({"format": "other"}))
    with pytest.raises(ValueError, match=FORMAT):
        load(tmp_path / "x.json")


def test_bad_out_path_is_one_error_line(tmp_path, capsys):
    assert papers.main(["--smoke", "--out", str(tmp_path / "nowhere" / "p.md")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --out:") and err.count("\n") == 1
