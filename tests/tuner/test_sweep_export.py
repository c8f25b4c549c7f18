"""Sweeps (kill and re-run), reports (HTML with embedded figures), export formats, the public API."""

import base64
import html.parser
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
import yaml

import tuner
from tests.conftest import run_tuner
from tuner.config import config_from_dict
from tuner.export import export
from tuner.run import run

pytestmark = pytest.mark.slow  # every test here tunes, sweeps or drives a browser

SWEEP = {"sweep": {
    "name": "grid",
    "base": {"name": "f", "seed": 0, "objective": {"kind": "function", "function": "rastrigin", "dim": 3},
             "optimizer": {"method": "pso", "population": 6, "generations": 6}, "parallel": {"backend": "serial"}},
    "variants": {"pso": {}, "de": {"optimizer.method": "de"}},
    "grid": {"objective.function": ["rastrigin", "ackley"]},
    "seeds": [1, 2],
}}


def tuner_cli(*args):
    return run_tuner(*args)


def write_sweep(tmp_path, sleep=0.0):
    doc = json.loads(json.dumps(SWEEP))
    doc["sweep"]["base"]["objective"]["sleep_s"] = sleep
    p = tmp_path / "sweep.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def test_killed_sweep_rerun_gives_the_same_table(tmp_path):
    ref_dir, kill_dir = tmp_path / "ref", tmp_path / "killed"
    # reference: uninterrupted (sleep does not change results, only timing)
    (tmp_path / "a").mkdir()
    p_ref = write_sweep(tmp_path / "a")
    out = tuner_cli("sweep", str(p_ref), "--dir", str(ref_dir), "-q", "--no-report")  # tables only
    assert out.returncode == 0, out.stderr
    ref = pd.read_csv(ref_dir / "results.csv")
    assert len(ref) == 8 and (ref["status"] == "finished").all()

    (tmp_path / "b").mkdir()
    p = write_sweep(tmp_path / "b", sleep=0.01)
    proc = subprocess.Popen([sys.executable, "-m", "tuner", "sweep", str(p), "--dir", str(kill_dir), "-q",
                             "--no-report"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline:
        metas = list((kill_dir / "jobs").glob("*/meta.json")) if (kill_dir / "jobs").exists() else []
        finished = sum(json.loads(m.read_text()).get("status") == "finished" for m in metas if m.stat().st_size)
        if finished >= 3 and len(metas) >= 4:
            break
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    statuses = [json.loads(m.read_text())["status"] for m in (kill_dir / "jobs").glob("*/meta.json")]
    assert statuses.count("finished") < 8, "the sweep must have been killed part-way"
    out = tuner_cli("sweep", str(p), "--dir", str(kill_dir), "-q", "--no-report")
    assert out.returncode == 0, out.stderr
    got = pd.read_csv(kill_dir / "results.csv")
    cols = ["job", "method", "seed", "status", "best_fitness", "n_evals"] + [c for c in ref if c.startswith("param.")]
    pd.testing.assert_frame_equal(ref[cols], got[cols])
    summary_ref = pd.read_csv(ref_dir / "summary.csv")
    summary_got = pd.read_csv(kill_dir / "summary.csv")
    pd.testing.assert_frame_equal(summary_ref, summary_got)
    # show and list
    show = tuner_cli("show", str(kill_dir))
    assert show.returncode == 0 and "pso__function-rastrigin__seed-1" in show.stdout
    lst = tuner_cli("list", "runs", "--dir", str(kill_dir))
    assert lst.returncode == 0 and lst.stdout.count("finished") == 8


def test_sweep_without_report_writes_its_tables_and_tuner_report_writes_every_report_later(tmp_path, capsys):
    """``--no-report``: results.csv and summary.csv, no report of the sweep or of its jobs; ``tuner report
    SWEEP_DIR`` then writes both, and the tables are the ones a sweep with its report writes."""
    from tuner.cli import main

    doc = json.loads(json.dumps(SWEEP))
    doc["sweep"].pop("grid")
    doc["sweep"]["seeds"] = [1]
    (tmp_path / "sweep.yaml").write_text(yaml.safe_dump(doc))
    d = tmp_path / "sw"
    assert main(["sweep", str(tmp_path / "sweep.yaml"), "--dir", str(d), "-q", "--no-report"]) == 0
    out = capsys.readouterr().out
    assert "sweep directory:" in out and "report:" not in out
    assert (d / "results.csv").exists() and (d / "summary.csv").exists()
    assert not list(d.glob("**/report.md")) and not list(d.glob("**/report.html"))
    tables = {f: (d / f).read_text() for f in ("results.csv", "summary.csv")}
    assert main(["report", str(d)]) == 0
    jobs = pd.read_csv(d / "results.csv")["job"]
    assert len(jobs) == 2 and all((d / "jobs" / j / "report.md").exists() for j in jobs)
    assert (d / "report.html").exists() and all(f"jobs/{j}/report.md" in (d / "report.md").read_text() for j in jobs)
    assert {f: (d / f).read_text() for f in tables} == tables


def test_parallel_sweep_in_a_relative_directory_after_a_chdir(tmp_path, monkeypatch):
    """joblib reuses its worker processes, started in the working directory of their time: a sweep with a
    relative ``--dir`` after a chdir (tuner.api in a notebook) still writes its jobs where it is run."""
    doc = json.loads(json.dumps(SWEEP))
    doc["sweep"].pop("grid")
    doc["sweep"]["seeds"] = [1]
    first, second = tmp_path / "first", tmp_path / "second"
    for d in (first, second):
        d.mkdir()
        (d / "sweep.yaml").write_text(yaml.safe_dump(doc))
        monkeypatch.chdir(d)  # the first sweep starts the workers in `first`
        out = run_tuner("sweep", "sweep.yaml", "--dir", "out", "--jobs", "2", "-q", "--no-report")
        assert out.returncode == 0, out.stderr
        assert len(pd.read_csv(d / "out" / "results.csv")) == 2
        assert sorted(p.name for p in (d / "out" / "jobs").iterdir() if p.is_dir()) == ["de__seed-1", "pso__seed-1"]


class _Checker(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.stack, self.images, self.errors = [], [], []

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])
        elif tag not in ("meta", "br", "hr", "link", "input"):
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unbalanced </{tag}> (open: {self.stack[-3:]})")
        else:
            self.stack.pop()


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sw")
    p = write_sweep(tmp)
    out = tuner_cli("sweep", str(p), "--dir", str(tmp / "sweep"), "-q")
    assert out.returncode == 0, out.stderr
    return tmp / "sweep"


def test_html_report_is_well_formed_and_images_decode(sweep_dir):
    import io

    from PIL import Image  # matplotlib depends on pillow

    page = (sweep_dir / "report.html").read_text()
    chk = _Checker()
    chk.feed(page)
    assert not chk.errors and chk.stack == []
    # every figure of report.md, but those the interactive page draws in a plot slot
    assert len(chk.images) == (sweep_dir / "report.md").read_text().count("](figures/") - page.count('data-plot="')
    assert len(chk.images) >= 2
    for src in chk.images:
        assert src.startswith("data:image/png;base64,"), "figures are embedded, no server needed"
        img = Image.open(io.BytesIO(base64.b64decode(src.split(",", 1)[1])))
        img.load()
        assert img.size[0] > 100 and img.size[1] > 100
    md = (sweep_dir / "report.md").read_text()
    assert "## Reproduce" in md and "tuner sweep" in md and "config sha256" in md
    assert "## Ranking" in md


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


@pytest.mark.skipif(_chromium() is None, reason="Chromium not installed (.ci/run installs it)")
def test_headless_browser_screenshot_is_not_blank(sweep_dir, tmp_path):
    from PIL import Image

    shot = tmp_path / "shot.png"
    subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                    "--disable-background-networking", "--disable-component-update", "--disable-sync",
                    f"--user-data-dir={tmp_path / 'profile'}", f"--screenshot={shot}", "--window-size=1200,2000",
                    f"file://{sweep_dir / 'report.html'}"], capture_output=True, timeout=120)
    assert shot.exists()
    arr = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert arr.std() > 5, "the screenshot is blank"
    assert (arr < 128).mean() > 0.005, "no dark pixels: no text or figures rendered"


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("run")
    raw = {"name": "exp", "seed": 1, "objective": {"kind": "filter", "filter": "madgwick",
                                                    "data": [{"synthetic": {"generator": "bench6dof",
                                                                            "duration_s": 4, "seed": 1}}]},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    return run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "r", quiet=True).run_dir


def test_export_yaml_json_python_round_trip(run_dir):
    best = yaml.safe_load((run_dir / "best.yaml").read_text())["params"]
    y = yaml.safe_load(export(run_dir, "yaml"))
    j = json.loads(export(run_dir, "json"))
    ns: dict = {}
    exec(export(run_dir, "python"), ns)
    full = tuner.load_best(run_dir)  # every value of the deployed filter: the searched ones and the rest
    from objectives.attitude.filters.madgwick import Madgwick

    assert set(full) == set(Madgwick.defaults) and full["init"] == "accmag"  # init auto: the run's q0, resolved
    assert {k: full[k] for k in best if k != "init"} == {k: v for k, v in best.items() if k != "init"}
    for doc in (y, j, {"params": ns["PARAMS"], **ns["PROVENANCE"]}):
        assert doc["params"] == full
        assert doc["run"] == run_dir.name and doc["fitness"] > 0 and doc["objective"]["filter"] == "madgwick"


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_header_compiles_and_prints_the_same_values(run_dir, tmp_path):
    header = tmp_path / "tuned.h"
    header.write_text(export(run_dir, "c", prefix="TUNER"))
    best = yaml.safe_load((run_dir / "best.yaml").read_text())["params"]
    prog = tmp_path / "main.c"
    prog.write_text('#include <stdio.h>\n#include "tuned.h"\n'
                    'int main(void) { printf("%.17g\\n", TUNER_BETA);'
                    ' printf("%d\\n", TUNER_VARIANT == TUNER_VARIANT_PAPER);'
                    ' printf("%d\\n", TUNER_USE_MAG); return 0; }\n')
    exe = tmp_path / "main"
    cc = subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-o", str(exe), str(prog)], capture_output=True,
                        text=True, cwd=tmp_path)
    assert cc.returncode == 0, cc.stderr
    out = subprocess.run([str(exe)], capture_output=True, text=True).stdout.split()
    assert float(out[0]) == best["beta"] and int(out[1]) == (best["variant"] == "paper")
    assert int(out[2]) == int(best["use_mag"])


def test_filter_from_run_in_three_lines(run_dir):
    """The README's import example."""
    from objectives.attitude.data.synthetic import synthetic
    from objectives.attitude.filters.madgwick import Madgwick

    flt = Madgwick.from_run(run_dir)
    q = flt.run(synthetic("bench6dof", duration_s=4, seed=1))
    assert flt.values["beta"] == tuner.load_best(run_dir)["beta"]
    assert q.shape[1] == 4 and np.allclose(np.linalg.norm(q, axis=1), 1.0)


def test_parallel_sweep_equals_sequential(sweep_dir, tmp_path):
    p = write_sweep(tmp_path)
    out = tuner_cli("sweep", str(p), "--dir", str(tmp_path / "par"), "--jobs", "2", "-q", "--no-report")
    assert out.returncode == 0, out.stderr
    assert not list((tmp_path / "par").glob("**/report.md"))  # the pool's jobs got --no-report too
    a = pd.read_csv(sweep_dir / "results.csv")
    b = pd.read_csv(tmp_path / "par" / "results.csv")
    cols = ["job", "best_fitness"] + [c for c in a if c.startswith("param.")]
    pd.testing.assert_frame_equal(a[cols], b[cols])
    cmp = tuner_cli("compare", str(sweep_dir / "jobs" / a["job"][0]), str(sweep_dir / "jobs" / a["job"][1]))
    assert cmp.returncode == 0 and "best_fitness" in cmp.stdout and "param.x0" in cmp.stdout
