"""A run whose held-out or CV scores are worse for the tuned values than for the defaults says so in one line:
at the end of the run, in ``tuner show``, the report's warnings, the dashboard and ``tuner export``."""

import dataclasses
import math

import pytest

from tests.conftest import run_tuner
from tuner.verdict import defaults_verdict, optimistic_note


def test_verdict_compares_only_scores_on_unseen_data():
    assert defaults_verdict({}) is None and defaults_verdict(None) is None
    # the tuning score always favours the tuned values: it is not a reason
    assert defaults_verdict({"train_fitness": 3.0, "defaults_train_fitness": 2.0}) is None
    assert defaults_verdict({"test_fitness": 1.0, "defaults_test_fitness": 1.2, "cv_fitness": 1.5,
                             "defaults_cv_fitness": 1.5}) is None  # better held out, equal in CV
    line = defaults_verdict({"test_fitness": 2.52, "defaults_test_fitness": 2.46})
    assert line.startswith("tuned is worse than the defaults") and "held-out 2.52 vs defaults 2.46" in line
    assert "best.yaml holds the tuned values" in line and "\n" not in line
    both = defaults_verdict({"test_fitness": 2.0, "defaults_test_fitness": 1.0, "cv_fitness": 1.63,
                             "defaults_cv_fitness": 1.33, "selection": {"defaults_chosen": True}})
    assert "held-out 2 vs defaults 1; CV 1.63 vs defaults 1.33" in both and "deploys the defaults" in both
    assert defaults_verdict({"cv_fitness": math.nan, "defaults_cv_fitness": 1.0}) is None  # no score, no claim
    assert defaults_verdict({"cv_fitness": 2.0, "defaults_cv_fitness": math.inf}) is None  # failed defaults
    assert optimistic_note(None) is None and "optimistic" in optimistic_note("the 16 BROAD trials")


@pytest.fixture(scope="module")
def worse_run(tmp_path_factory):
    """A tiny run whose best.yaml records CV scores worse than its defaults' (as validation writes them)."""
    from tuner.config import config_from_dict
    from tuner.run import run
    from tuner.rundir import RunDir

    tmp = tmp_path_factory.mktemp("verdict")
    raw = {"name": "v", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    out = run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "runs" / "v", quiet=True, report=False).run_dir
    rd = RunDir(out)
    best = rd.best()
    rd.write_best(dataclasses.replace(best, evaluation={**best.evaluation, "cv_fitness": 1.63,
                                                         "defaults_cv_fitness": 1.33}))
    return out


def test_show_report_dashboard_and_export_say_it(worse_run):
    from tuner.bounds import run_warnings
    from tuner.dashboard import collect_runs
    from tuner.export import provenance

    expected = "tuned is worse than the defaults on data the search did not see (CV 1.63 vs defaults 1.33)"
    shown = run_tuner("show", str(worse_run))
    assert shown.returncode == 0 and f"warning: {expected}" in shown.stdout
    assert [w.kind for w in run_warnings(worse_run) if w.message.startswith(expected)] == ["defaults"]
    rows = collect_runs(worse_run.parent)
    assert rows[0]["status"] == "finished; tuned worse than defaults"
    exported = run_tuner("export", str(worse_run), "--format", "yaml")
    assert exported.returncode == 0 and f"warning: {expected}" in exported.stderr
    assert provenance(worse_run)["warning"].startswith(expected)


def test_end_of_run_says_it(worse_run, capsys):
    from tuner.commands.run import print_result
    from tuner.run import RunResult
    from tuner.rundir import RunDir

    best = RunDir(worse_run).best()
    print_result(RunResult(worse_run, "finished", best, 8, 2, "done", {}))
    assert "warning: tuned is worse than the defaults" in capsys.readouterr().out


def test_chosen_on_makes_the_report_say_the_cv_is_optimistic(tmp_path):
    from tuner.config import ConfigError, config_from_dict
    from tuner.report import write_run_report
    from tuner.run import run

    raw = {"name": "o", "seed": 1, "objective": {"kind": "function", "function": "sphere", "dim": 2},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"},
           "validation": {"chosen_on": "the 16 shared BROAD trials"}}
    cfg = config_from_dict(raw, base_dir=tmp_path)
    assert cfg.validation.chosen_on == "the 16 shared BROAD trials" and not cfg.validation.active
    with pytest.raises(ConfigError, match=r"validation\.chosen_on: expected a text"):
        config_from_dict({**raw, "validation": {"chosen_on": 3}}, base_dir=tmp_path)
    out = run(cfg, run_dir=tmp_path / "o", quiet=True, report=False).run_dir
    write_run_report(out)
    md = (out / "report.md").read_text()
    assert "**optimistic CV**: the config's fixed options and search ranges were chosen on the 16 shared BROAD " \
           "trials" in md
    plain = run(config_from_dict({k: v for k, v in raw.items() if k != "validation"}, base_dir=tmp_path),
                run_dir=tmp_path / "p", quiet=True, report=False).run_dir
    write_run_report(plain)
    assert "optimistic CV" not in (plain / "report.md").read_text()
