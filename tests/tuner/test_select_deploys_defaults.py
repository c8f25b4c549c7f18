"""When the held-out selection finds the defaults better than every tuned candidate, the run deploys the
defaults and says so in one line (terminal, ``show``, report warnings, dashboard, ``export`` all print
:func:`tuner.verdict.defaults_verdict`)."""

from __future__ import annotations

import pytest

from objectives.attitude.objective import FilterObjective
from tuner.config import config_from_dict
from tuner.run import run
from tuner.rundir import RunDir
from tuner.verdict import defaults_verdict

DATA = [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "rate_hz": 200, "seed": s}} for s in (1, 2, 3, 4)]


def test_the_line_of_a_selection_that_chose_the_defaults():
    sel = {"holdout": "fold-0", "defaults_chosen": True, "defaults": {"holdout_fitness": 1.2},
           "candidates": [{"holdout_fitness": 1.5}, {"holdout_fitness": 1.4}]}
    line = defaults_verdict({"selection": sel, "test_fitness": 1.0, "defaults_test_fitness": 1.0})
    assert line == ("tuning does not help on the held-out fold fold-0 (1.2 vs best tuned 1.4): the run deploys "
                    "the defaults (the held-out selection chose them)")
    assert defaults_verdict({"selection": {**sel, "defaults_chosen": False}}) is None


def test_a_run_whose_search_range_misses_the_defaults_deploys_them_and_says_so(tmp_path, capsys):
    from tuner.cli import main

    # Madgwick's default gain (beta ~0.04) is far below this range: every tuned candidate is worse held out
    raw = {"name": "sel", "seed": 2, "output": str(tmp_path / "runs"),
           "parameters": {"beta": {"low": 2.0, "high": 5.0}},
           "objective": {"kind": "filter", "filter": "madgwick", "metric": "broad_mean_rmse", "data": DATA},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
           "validation": {"select": {"top_k": 2, "holdout": 0.5}}}
    res = run(config_from_dict(raw), quiet=True, report=True)
    best = RunDir(res.run_dir).best()
    defaults = FilterObjective("madgwick", DATA).default_params()
    assert best.params["beta"] == pytest.approx(defaults["beta"])
    sel = best.evaluation["selection"]
    assert sel["defaults_chosen"] and all(c["holdout_fitness"] > sel["defaults"]["holdout_fitness"]
                                          for c in sel["candidates"])
    line = defaults_verdict(best.evaluation)
    assert line.startswith("tuning does not help on the held-out fold") and "deploys the defaults" in line
    capsys.readouterr()
    assert main(["show", str(res.run_dir)]) == 0
    assert line in capsys.readouterr().out
    assert line in (res.run_dir / "report.md").read_text()
