"""Repeated runs (``repeats: N``, ``tuner run --repeats N``): each repeat is the plain run of its seed, serial equals
parallel, a killed repeated run resumes to the uninterrupted result, the deployed repeat follows the stated rule
(held-out score, else the median fitness), the spread and its warning are computed by their rules, and every
command reads the parent directory."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

import tuner
from tuner.cli import main
from tuner.config import ConfigError, config_from_dict
from tuner.records import RepeatEntry, Spread
from tuner.repeats import repeat_config
from tuner.repeats import run as run_repeats
from tuner.run import run
from tuner.rundir import RunDir
from tuner.spread import SPREAD_WARN, choose, spread_of, spread_warning

ROOT = Path(__file__).resolve().parents[2]


def _raw(tmp_path, **kw):
    raw = {"name": "f", "seed": 5, "objective": {"kind": "function", "function": "rosenbrock", "dim": 3},
           "optimizer": {"method": "pso", "population": 6, "generations": 4},
           "parallel": {"backend": "serial"}, "output": str(tmp_path / "runs"), "repeats": 3}
    raw.update(kw)
    return raw


def _cfg(tmp_path, **kw):
    return config_from_dict(_raw(tmp_path, **kw), source=str(tmp_path / "f.yaml"), base_dir=tmp_path)


def _history(d: Path) -> pd.DataFrame:
    return pd.read_csv(d / "history.csv", keep_default_na=False).drop(columns="seconds")


def _entry(i, fit, held=None, key=""):
    return RepeatEntry(i, 10 + i, f"repeats/seed-{10 + i}", "finished", 5, 0, fit, {}, held, key)


# --- the rules ------------------------------------------------------------------------------------
def test_choice_is_the_median_never_the_luckiest():
    odd = [_entry(0, 3.0), _entry(1, 1.0), _entry(2, 2.0)]
    assert choose(odd)[:2] == (2, "median_fitness")  # fitness 2.0: the median of 1, 2, 3
    even = [_entry(0, 1.0), _entry(1, 4.0), _entry(2, 2.0), _entry(3, 3.0)]
    assert choose(even)[0] == 3  # the worse of the two middle ones (2.0, 3.0)
    assert choose([_entry(0, 1.0), _entry(1, 2.0)])[0] == 1  # of two, never the luckiest


def test_choice_by_held_out_score_when_every_repeat_has_one():
    entries = [_entry(0, 1.0, 9.0, "test_fitness"), _entry(1, 2.0, 4.0, "test_fitness"),
               _entry(2, 3.0, 6.0, "test_fitness")]
    assert choose(entries) == (1, "held_out", "test_fitness")
    entries[2] = _entry(2, 3.0)  # one repeat without a held-out score: the median fitness decides
    assert choose(entries)[1] == "median_fitness"


def test_spread_warning_rule():
    narrow = Spread(1.0, 0.95, 1.05, 5)  # spread 0.1 against a gain of 1.0
    assert spread_warning(narrow, 2.0) == (1.0, "")
    wide = Spread(1.0, 0.5, 1.0 + 0.5, 5)  # spread 1.0 > SPREAD_WARN x gain 1.0
    gain, text = spread_warning(wide, 2.0)
    assert gain == 1.0 and "spreads over 1" in text and 1.0 > SPREAD_WARN * gain
    assert "no better than the defaults" in spread_warning(narrow, 0.9)[1]
    assert spread_warning(narrow, None) == (None, "")  # nothing to compare the spread with
    s = spread_of([3.0, 1.0, 2.0, 4.0], unit=lambda v: v / 10)
    assert (s.median, s.low, s.high, s.n) == (2.5, 1.0, 4.0, 4) and s.range_share == pytest.approx(0.3)


def test_repeats_key_is_checked(tmp_path):
    for bad in (0, -2, 1001, "three", 2.5):
        with pytest.raises(ConfigError, match="repeats"):
            _cfg(tmp_path, repeats=bad)
    assert "repeats" not in _cfg(tmp_path, repeats=1).raw  # one run: the plain job's config and hash


# --- the driver -----------------------------------------------------------------------------------
def test_each_repeat_is_the_plain_run_of_its_seed(tmp_path):
    cfg = _cfg(tmp_path)
    res = run_repeats(cfg, run_dir=tmp_path / "rep", quiet=True, report=False)
    assert res.status == "finished" and res.repeats.complete and res.repeats.seeds == (5, 6, 7)
    for seed in (5, 6, 7):
        alone = run(repeat_config(cfg, seed), run_dir=tmp_path / f"alone{seed}", quiet=True, report=False)
        pd.testing.assert_frame_equal(_history(tmp_path / "rep" / "repeats" / f"seed-{seed}"), _history(alone.run_dir))
    rep = RunDir(tmp_path / "rep").repeats()
    fits = sorted(e.fitness for e in rep.entries)
    assert rep.chosen_entry.fitness == fits[1] and rep.chosen_by == "median_fitness"
    best = yaml.safe_load((tmp_path / "rep" / "best.yaml").read_text())
    assert best["run"] == f"repeats/seed-{rep.chosen_entry.seed}" and best["fitness"] == fits[1]
    meta = json.loads((tmp_path / "rep" / "meta.json").read_text())
    assert meta["n_evals"] == sum(e.n_evals for e in rep.entries) and meta["status"] == "finished"


def test_serial_equals_parallel(tmp_path):
    serial = run_repeats(_cfg(tmp_path), run_dir=tmp_path / "s", quiet=True, report=False)
    par = run_repeats(_cfg(tmp_path, parallel={"backend": "loky", "n_jobs": 2}), run_dir=tmp_path / "p", quiet=True,
                      report=False)
    for e in serial.repeats.entries:
        pd.testing.assert_frame_equal(_history(tmp_path / "s" / e.run), _history(tmp_path / "p" / e.run))
    assert serial.repeats.chosen == par.repeats.chosen
    assert serial.repeats.fitness == par.repeats.fitness


@pytest.mark.slow
def test_killed_repeated_run_resumes_to_the_uninterrupted_result(tmp_path):
    whole = run_repeats(_cfg(tmp_path), run_dir=tmp_path / "whole", quiet=True, report=False)
    job = tmp_path / "f.yaml"
    job.write_text(yaml.safe_dump(_raw(tmp_path)))
    env = {**os.environ, "NUMBA_CACHE_DIR": os.environ.get("NUMBA_CACHE_DIR", str(ROOT / ".cache/numba"))}
    for k in (7, 23, 41):  # inside the first, the second and the third repeat
        d = tmp_path / f"killed{k}"
        p = subprocess.run([sys.executable, "-m", "tuner", "run", str(job), "--run-dir", str(d), "--no-report", "-q"],
                           env={**env, "TUNER_FAULT_KILL_AT_WRITE": str(k)}, capture_output=True, text=True)
        assert p.returncode == 137, p.stderr
        p = subprocess.run([sys.executable, "-m", "tuner", "resume", str(d), "--no-report", "-q"], env=env,
                           capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        for e in whole.repeats.entries:
            pd.testing.assert_frame_equal(_history(d / e.run), _history(tmp_path / "whole" / e.run))
        rep = RunDir(d).repeats()
        assert rep.chosen == whole.repeats.chosen and rep.fitness == whole.repeats.fitness
        assert yaml.safe_load((d / "best.yaml").read_text()) == yaml.safe_load((tmp_path / "whole" / "best.yaml")
                                                                               .read_text())


def test_interrupted_repeat_is_resumed_through_the_parent(tmp_path, monkeypatch):
    """A Ctrl-C in the second repeat: the parent is 'interrupted', its hint names the parent, resume finishes."""
    import tuner.run as run_mod

    cfg = _cfg(tmp_path)
    whole = run_repeats(cfg, run_dir=tmp_path / "whole", quiet=True, report=False)
    calls = {"n": 0}
    real = run_mod.Run._conclude

    def stop_second(self, *a, **kw):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return real(self, *a, **kw)

    monkeypatch.setattr(run_mod.Run, "_conclude", stop_second)
    lines = []
    res = run_repeats(cfg, run_dir=tmp_path / "cut", progress=lines.append, report=False)
    monkeypatch.undo()
    assert res.status == "interrupted" and json.loads((tmp_path / "cut" / "meta.json").read_text())["status"] == \
        "interrupted"
    assert not res.repeats.complete and res.repeats.chosen is None
    assert main(["resume", str(tmp_path / "cut"), "-q", "--no-report"]) == 0
    assert RunDir(tmp_path / "cut").repeats().fitness == whole.repeats.fitness


@pytest.mark.slow
def test_filter_job_deploys_by_held_out_score_and_every_command_reads_it(tmp_path, capsys):
    raw = {"name": "mw", "seed": 3, "repeats": 2, "output": str(tmp_path / "runs"),
           "objective": {"kind": "filter", "filter": "madgwick", "warmup_s": 1.0,
                         "data": {"train": [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "rate_hz": 200,
                                                           "seed": 1}}],
                                  "test": [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "rate_hz": 200,
                                                          "seed": 9}}]}},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    job = tmp_path / "mw.yaml"
    job.write_text(yaml.safe_dump(raw))
    d = tmp_path / "mw"
    assert main(["run", str(job), "--run-dir", str(d), "-q"]) == 0
    out = capsys.readouterr().out
    rep = RunDir(d).repeats()
    assert rep.chosen_by == "held_out" and rep.held_out_key == "test_fitness"
    assert rep.chosen_entry.held_out == min(e.held_out for e in rep.entries)
    assert "repeats:    2 seeds" in out and "<- chosen" in out and rep.defaults_fitness is not None
    assert main(["show", str(d)]) == 0
    shown = capsys.readouterr().out
    assert "held out:" in shown and f"seed {rep.chosen_entry.seed}" in shown
    assert main(["show", str(d), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["repeats"]["chosen"] == rep.chosen
    assert main(["export", str(d), "--format", "yaml"]) == 0
    exported = yaml.safe_load(capsys.readouterr().out)
    chosen_best = yaml.safe_load((d / rep.chosen_entry.run / "best.yaml").read_text())
    assert exported["params"]["beta"] == chosen_best["params"]["beta"]
    assert exported["seed"] == rep.chosen_entry.seed and exported["repeat"]["run"] == rep.chosen_entry.run
    assert main(["evaluate", str(d)]) == 0
    assert "fitness:" in capsys.readouterr().out
    r = tuner.load(d)
    assert r.repeats.chosen == rep.chosen and r.fitness == chosen_best["fitness"] and len(r.history) == 8
    report = (d / "report.md").read_text()
    assert "## Repeats" in report and "(deployed)" in report and (d / "figures" / "repeats_convergence.png").exists()


@pytest.mark.slow
def test_controller_job_repeats(tmp_path):
    cfg = config_from_dict({"name": "pid", "seed": 1, "repeats": 2, "output": str(tmp_path / "runs"),
                            "objective": {"kind": "closed_loop", "controller": "pid", "profile": "thesis_2s",
                                          "duration_s": 2.0},
                            "optimizer": {"method": "pso", "population": 4, "generations": 1},
                            "parallel": {"backend": "serial"}}, source=str(tmp_path / "pid.yaml"), base_dir=tmp_path)
    res = tuner.tune(cfg, run_dir=tmp_path / "pid", progress=False, report=False)
    assert res.repeats is not None and res.repeats.complete and res.repeats.n == 2
    assert res.params == RunDir(tmp_path / "pid" / res.repeats.chosen_entry.run).best().params


def test_tune_repeats_keyword_and_sweep_file_refuses_it(tmp_path, capsys):
    res = tuner.tune(_raw(tmp_path, repeats=1), repeats=2, run_dir=tmp_path / "t", progress=False, report=False)
    assert res.repeats.n == 2
    with pytest.raises(ConfigError, match="repeats"):
        tuner.tune(_raw(tmp_path), repeats=0, run_dir=tmp_path / "t0", progress=False)
    assert main(["run", str(ROOT / "configs" / "demo.yaml"), "--repeats", "2"]) == 2
    assert "--repeats" in capsys.readouterr().err


def test_dashboard_lists_a_repeated_run_once_with_its_spread(tmp_path):
    from tuner.dashboard import collect_runs

    run_repeats(_cfg(tmp_path), run_dir=tmp_path / "runs" / "rep", quiet=True, report=False)
    rows = collect_runs(tmp_path / "runs")
    assert [r["name"] for r in rows] == ["rep"]  # its repeats are not listed as runs of their own
    rep = RunDir(tmp_path / "runs" / "rep").repeats()
    assert "3 seeds" in rows[0]["status"] and rows[0]["best"] == rep.chosen_entry.fitness


def test_sweep_ranking_shows_the_spread_over_seeds():
    from tuner.sweep import ranking_lines, summarize

    df = pd.DataFrame([{"method": "a", "seed": s, "status": "finished", "best_fitness": f}
                       for s, f in ((1, 3.0), (2, 1.0), (3, 2.0))])
    summ = summarize(df)
    assert summ.loc["a", ("best_fitness", "min")] == 1.0 and summ.loc["a", ("best_fitness", "max")] == 3.0
    assert "(seeds 1 .. 3, 3 runs)" in "\n".join(ranking_lines(df))
