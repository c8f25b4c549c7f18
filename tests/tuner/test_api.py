"""The Python API (tuner/api.py): tune/load mirror `tuner run`, typed per-generation callback, errors as
the CLI's error lines, Result.build() reproducing the run's score, and the README's example run verbatim."""

from __future__ import annotations

import csv
import dataclasses
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

import tuner
from tests.tuner.jobs import unrendered_figures
from tuner.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[2]

JOB = {"name": "api-rosen", "seed": 5, "objective": {"kind": "function", "function": "rosenbrock", "dim": 3},
       "optimizer": {"method": "pso", "population": 6, "generations": 4}, "parallel": {"backend": "serial"}}


@pytest.fixture(autouse=True, scope="module")
def _unrendered_figures():
    """No test here reads a figure (report.html is still written, with the figures' files)."""
    with pytest.MonkeyPatch.context() as mp:
        unrendered_figures(mp)
        yield


@pytest.fixture(scope="module")
def job_run(tmp_path_factory) -> tuner.Result:
    """``tuner.tune(JOB)``, the plain run several tests compare against; they only read it."""
    return tuner.tune(dict(JOB), run_dir=tmp_path_factory.mktemp("api") / "job", progress=False,
                      report=False)


def _write_job(tmp_path: Path, job: dict = JOB) -> Path:
    p = tmp_path / "job.yaml"
    p.write_text(yaml.safe_dump(job))
    return p


def _history(run_dir: Path) -> list[dict[str, str]]:
    """history.csv without its wall-clock column (the only one that may differ between two runs)."""
    with open(run_dir / "history.csv", newline="") as fh:
        return [{k: v for k, v in row.items() if k != "seconds"} for row in csv.DictReader(fh)]


def _files(run_dir: Path) -> set[str]:
    return {str(p.relative_to(run_dir)) for p in run_dir.rglob("*") if p.is_file()}


def test_tune_equals_cli_run(tmp_path, capsys):
    path = _write_job(tmp_path)
    a, b = tmp_path / "cli", tmp_path / "api"
    assert cli_main(["run", str(path), "--seed", "3", "--set", "optimizer.population=5", "--run-dir", str(a),
                     "-q"]) == 0
    res = tuner.tune(path, seed=3, overrides=["optimizer.population=5"], run_dir=b, progress=False)
    assert _files(a) == _files(b) and {"history.csv", "best.yaml", "meta.json", "config.yaml"} <= _files(b)
    assert _history(a) == _history(b) and len(_history(b)) == 5 * 4
    best_a, best_b = (yaml.safe_load((d / "best.yaml").read_text()) for d in (a, b))
    best_a.pop("run"), best_b.pop("run")
    assert best_a == best_b
    assert (a / "config.yaml").read_text() == (b / "config.yaml").read_text()
    # the Result is what the run directory holds
    assert res.status == "finished" and res.run_dir == b.resolve() and res.n_evals == 20
    ok = res.history[res.history["status"] == "ok"]
    assert res.fitness == ok["fitness"].min() == best_b["fitness"]
    assert res.params == best_b["params"] and res.best == best_b["deployment"]["values"]
    pd.testing.assert_frame_equal(res.history, pd.read_csv(b / "history.csv"))
    assert res.validation is None


def test_tune_without_report_equals_cli_run_without_report(tmp_path):
    path = _write_job(tmp_path)
    assert cli_main(["run", str(path), "--run-dir", str(tmp_path / "cli"), "-q", "--no-report"]) == 0
    res = tuner.tune(path, run_dir=tmp_path / "api", progress=False, report=False)
    assert _files(tmp_path / "cli") == _files(res.run_dir) and "report.md" not in _files(res.run_dir)
    assert _history(tmp_path / "cli") == _history(res.run_dir)


def test_dict_and_typed_config_give_the_same_history(tmp_path, job_run):
    from tuner.config import load_config

    path = _write_job(tmp_path)
    r_path = tuner.tune(path, run_dir=tmp_path / "p", progress=False, report=False)
    r_dict = job_run
    r_cfg = tuner.tune(load_config(path), run_dir=tmp_path / "c", progress=False, report=False)
    assert _history(r_path.run_dir) == _history(r_dict.run_dir) == _history(r_cfg.run_dir)
    # seed and n_jobs override a dict and a typed config as they override a file
    r_seed = tuner.tune(load_config(path), seed=9, n_jobs=1, run_dir=tmp_path / "s", progress=False,
                        report=False)
    cli_main(["run", str(path), "--seed", "9", "--n-jobs", "1", "--run-dir", str(tmp_path / "s_cli"), "-q",
             "--no-report"])
    assert _history(r_seed.run_dir) == _history(tmp_path / "s_cli") != _history(r_path.run_dir)


def test_load_gives_the_same_result(tmp_path):
    res = tuner.tune(dict(JOB), run_dir=tmp_path / "r", progress=False)
    again = tuner.load(tmp_path / "r")
    for f in dataclasses.fields(res):
        if f.name != "history":
            assert getattr(again, f.name) == getattr(res, f.name), f.name
    pd.testing.assert_frame_equal(again.history, res.history)
    doc = {"cv_score": 1.5, "gap": 0.25, "folds": [{"name": "a", "score": 1.5}]}
    from tuner.rundir import RunDir

    RunDir(res.run_dir).write_validation(doc)
    assert tuner.load(res.run_dir).validation == doc  # validation.json, as a run with `validation:` writes it
    html = again.report()
    assert html == res.run_dir / "report.html" and html.is_file()


def test_callback_gets_a_typed_summary_per_generation(tmp_path):
    seen: list[tuner.GenerationSummary] = []
    res = tuner.tune(dict(JOB), run_dir=tmp_path / "r", progress=False, callback=seen.append, report=False)
    assert [s.generation for s in seen] == [0, 1, 2, 3]
    assert [s.n_evals for s in seen] == [6, 12, 18, 24]
    hist = res.history
    for s in seen:  # each summary matches what the history holds for that generation
        rows = hist[hist["generation"] == s.generation]
        assert list(s.fitness) == rows["fitness"].tolist()
        assert [p["x0"] for p in s.params] == rows["x0"].tolist()
        assert s.best_fitness == hist["fitness"][: s.n_evals].min()
        assert s.generation_best == min(s.fitness)
    assert seen[-1].best_fitness == res.fitness and dict(seen[-1].best_params) == dict(res.params)
    with pytest.raises(dataclasses.FrozenInstanceError):
        seen[0].generation = 7


def test_callback_exception_stops_the_run_resumably(tmp_path, job_run):
    def stop(s):
        if s.generation == 1:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        tuner.tune(dict(JOB), run_dir=tmp_path / "r", progress=False, callback=stop, report=False)
    assert len(_history(tmp_path / "r")) == 12  # the generation the callback saw is on disk
    assert cli_main(["resume", str(tmp_path / "r"), "-q", "--no-report"]) == 0
    assert _history(tmp_path / "r") == _history(job_run.run_dir)  # as the run never stopped


def test_progress_lines(tmp_path, capsys):
    lines: list[str] = []
    tuner.tune(dict(JOB), run_dir=tmp_path / "a", progress=lines.append, report=False)
    assert any(line.startswith("gen 4/4") for line in lines), lines
    tuner.tune(dict(JOB), run_dir=tmp_path / "b", progress=True, report=False)
    assert "gen 4/4" in capsys.readouterr().err
    tuner.tune(dict(JOB), run_dir=tmp_path / "c", progress=False, report=False)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("override", ["optimizer.method=psoo", "optimizer.population=0", "parallel.backend=gpu",
                                      "objective.function=rosenbrok"])
def test_errors_carry_the_cli_error_line(tmp_path, capsys, override):
    path = _write_job(tmp_path)
    assert cli_main(["run", str(path), "--set", override, "-q"]) == 2
    line = capsys.readouterr().err.strip()
    with pytest.raises(tuner.ConfigError) as exc:
        tuner.tune(path, overrides=[override], run_dir=tmp_path / "r", progress=False)
    assert line == f"error: {exc.value}" and line.startswith(f"error: {path}: ")
    assert not (tmp_path / "r").exists()  # refused before anything is written


def test_errors_for_dicts_and_run_dirs(tmp_path):
    with pytest.raises(tuner.ConfigError, match=r"^<dict>: optimizer.method: unknown optimizer 'nope'"):
        tuner.tune({**JOB, "optimizer": {"method": "nope"}}, progress=False)
    with pytest.raises(tuner.ConfigError, match="is a sweep file"):
        tuner.tune(ROOT / "configs" / "demo.yaml", progress=False)
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "x.txt").write_text("x")
    with pytest.raises(tuner.RunError, match="exists and is not empty"):
        tuner.tune(dict(JOB), run_dir=tmp_path / "busy", progress=False)
    with pytest.raises(tuner.RunError, match="no such directory"):
        tuner.load(tmp_path / "nothing")
    with pytest.raises(TypeError, match="expected a path, a dict or a RunConfig"):
        tuner.tune(42, progress=False)


@pytest.mark.parametrize("kwargs, message", [
    ({"seed": "x"}, r"^tune\(\): seed: expected an int, got str 'x'"),
    ({"n_jobs": "two"}, r"^tune\(\): parallel.n_jobs: expected an int, got str 'two'"),
    ({"seed": 1.5}, r"^tune\(\): seed: expected an int, got float 1.5"),
    ({"overrides": [3]}, r"^tune\(\): overrides: expected a list of 'key.path=value' strings"),
    ({"report": "no"}, r"^tune\(\): report: expected True or False, got str 'no'"),
])
def test_bad_keyword_arguments_are_config_errors(tmp_path, kwargs, message):
    """seed/n_jobs/overrides of the wrong type: a ConfigError naming the argument, not a bare int() ValueError."""
    with pytest.raises(tuner.ConfigError, match=message):
        tuner.tune(dict(JOB), run_dir=tmp_path / "r", progress=False, **kwargs)
    assert not (tmp_path / "r").exists()


def test_one_override_string_is_one_override(tmp_path):
    """overrides="a.b=1" is that override (it was split into characters: "--set: ... got 'o'")."""
    res = tuner.tune(dict(JOB), overrides="optimizer.generations=2", run_dir=tmp_path / "r", progress=False,
                     report=False)
    assert set(res.history["generation"]) == {0, 1}


def test_filter_warmup_of_the_wrong_type_names_its_key():
    job = {"name": "w", "objective": {"kind": "filter", "filter": "madgwick", "warmup_s": "2s",
                                      "data": {"train": [{"synthetic": {"generator": "bench6dof", "duration_s": 5}}]}}}
    with pytest.raises(tuner.ConfigError, match=r"^<dict>: objective.warmup_s: expected a number of seconds >= 0, "
                                                r"got '2s'$"):
        tuner.tune(job, progress=False)


def test_function_objective_builds_its_point(job_run):
    from objectives.functions import FUNCTIONS

    res = job_run
    x = res.build()
    assert x.tolist() == [res.params[f"x{i}"] for i in range(3)]
    assert FUNCTIONS["rosenbrock"][0](x) == pytest.approx(res.fitness, rel=1e-12)


def _readme_python_api() -> str:
    text = (ROOT / "README.md").read_text()
    section = text.split("\n## Python API\n", 1)[1].split("\n## ", 1)[0]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_readme_example_runs_and_build_reproduces_the_score(tmp_path, monkeypatch, capsys):
    """The README's Python example, verbatim; its filter rebuilt from the run scores the run's fitness."""
    from objectives.attitude.metrics import euler_stats

    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(compile(_readme_python_api(), "README.md", "exec"), ns)
    res, rec, q = ns["result"], ns["rec"], ns["q"]
    assert res.status == "finished" and res.run_dir.parent == tmp_path / "runs"
    assert isinstance(res.history, pd.DataFrame) and len(res.history) == res.n_evals
    assert ns["same"].fitness == res.fitness
    # euler_rmse_mean of one recording: mean per-axis Euler RMSE (deg) after warmup_s, recomputed here from
    # the quaternions that Result.build().run(...) gives on the plain arrays of the training recording
    warmup = yaml.safe_load((res.run_dir / "config.yaml").read_text())["objective"]["warmup_s"]
    mask = rec.motion.copy()
    mask[: int(round(warmup / rec.dt))] = False
    score = float(np.mean(euler_stats(q, rec.quat, mask).rmse_deg))
    assert score == pytest.approx(res.fitness, rel=1e-12)
    assert "gen " in capsys.readouterr().out  # the example's callback printed each generation


def test_build_gives_the_tuned_controller(tmp_path):
    """Result.build() of a closed-loop run: the controller, simulated on the run's plant and profile, gives the
    run's cost (eq. 2.39); its values are the complete tuned configuration."""
    from objectives.control.plants.wmp.model import simulate_closed_loop
    from tuner.api import _objective_of
    from tuner.starter import starter_text

    job = yaml.safe_load(starter_text("pid"))
    job.update(optimizer={"method": "pso", "population": 4, "generations": 1}, parallel={"backend": "serial"})
    res = tuner.tune(job, run_dir=tmp_path / "pid", progress=False, report=False)
    ctl = res.build()
    assert type(ctl).__name__ == "PID" and dict(ctl.values) == res.best
    assert set(res.best) > set(res.params) and res.deployment.kind == "closed_loop"
    obj, _ = _objective_of(res.run_dir)
    obj({**obj.fixed, **res.params})  # sets the objective up (plant, profile, noise)
    loop = obj.loop
    sim = simulate_closed_loop(type(ctl).kind, ctl.param_array(), type(ctl).state_size, loop._ref, loop._noise,
                               loop.plant.params, loop.plant.sensors, None, loop.n_sub, loop.fall_limit_deg)
    ev = loop.evaluation({"t": sim["t"], "references": loop._ref, "outputs": sim["y"], "measurements": sim["meas"],
                          "voltages": sim["u"], "currents": sim["x"][:, 6:8], "state": sim["x"],
                          "status": sim["status"], "status_name": sim["status_name"], "n_done": sim["n_done"]})
    assert ev.status == "ok" and ev.fitness == res.fitness


def test_demo_runs_a_packaged_job_from_any_directory(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli_main(["demo", "rosenbrock", "-q"]) == 0
    (run_dir,) = (tmp_path / "runs").iterdir()
    res = tuner.load(run_dir)
    assert res.status == "finished" and res.n_evals == 30 * 100
    assert "tuner/data/configs/rosenbrock.yaml" in yaml.safe_load((run_dir / "config.yaml").read_text())["source"]
