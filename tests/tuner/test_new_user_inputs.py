"""Bad inputs around the deployment, validation and CSV features, as a new user writes them: each is one
``error:`` line with exit 2 before any tuning (no run directory), and the notes of a deployment show."""


import pytest
import yaml

from tests.conftest import one_error_line
from tests.conftest import run_tuner as tuner
from tests.tuner.test_preflight import COLUMNS, filter_job, no_run_dir, write_csv


@pytest.mark.parametrize("over, expected", [
    # one value in two places: which one the run used was a guess (the searched one won, silently)
    ({"objective": {"fixed": {"use_mag": False, "beta": 0.1}}, "parameters": {"beta": {"low": 0.01, "high": 1.0}}},
     ["objective.fixed.beta", "0.1 is fixed here but parameters.beta searches it", "write it in one place"]),
    ({"objective": {"fixed": {"use_mag": False, "zeta": 0.1}},
      "parameters": {"beta": {"low": 0.01, "high": 1.0}, "zeta": {"fixed": 0.2}}},
     ["objective.fixed.zeta", "0.1 contradicts parameters.zeta: {fixed: 0.2}"]),
    # a misspelt start: was "could not convert string to float: 'up'"
    ({"objective": {"q0": "up"}}, ["objective.q0", "expected accmag, truth, broad or 4 finite numbers", "'up'"]),
    ({"objective": {"q0": [0, 0, 0, 0]}}, ["objective.q0", "not all 0"]),
])
def test_contradictions_and_bad_starts_are_errors_before_tuning(tmp_path, over, expected):
    write_csv(tmp_path / "rec.csv")
    one_error_line(tuner("run", str(filter_job(tmp_path, **over))), f"{tmp_path / 'job.yaml'}: ", *expected)
    assert no_run_dir(tmp_path)


def test_the_same_value_in_both_places_is_accepted(tmp_path):
    write_csv(tmp_path / "rec.csv")
    job = filter_job(tmp_path, objective={"fixed": {"use_mag": False, "zeta": 0.0}},
                     parameters={"beta": {"low": 0.01, "high": 1.0}, "zeta": {"fixed": 0.0}},
                     optimizer={"method": "random", "population": 2, "generations": 1})
    out = tuner("run", str(job), "--no-report")
    assert out.returncode == 0, out.stderr


def test_validation_folds_beyond_the_recordings_is_an_error_before_tuning(tmp_path):
    """Was: the whole tuning ran, then `warning: cross-validation not run` (k=5 with 2 recordings)."""
    for name in ("a", "b"):
        write_csv(tmp_path / f"{name}.csv")
    data = [{"csv": {"path": f"{n}.csv", "columns": COLUMNS}} for n in ("a", "b")]
    job = filter_job(tmp_path, objective={"data": data}, validation={"cv": "kfold", "folds": 5})
    one_error_line(tuner("run", str(job)), "validation.folds", "k=5", "cross-validation after the run needs it")
    assert no_run_dir(tmp_path)


def test_yaml_syntax_errors_are_one_line(tmp_path):
    """A broken column map file or job file: one line (PyYAML's message spans several)."""
    write_csv(tmp_path / "rec.csv")
    (tmp_path / "cols.yaml").write_text("columns: [a, b\n")
    job = filter_job(tmp_path, objective={"data": [{"csv": {"path": "rec.csv", "columns": "cols.yaml"}}]})
    one_error_line(tuner("run", str(job)), "cols.yaml: not valid YAML", "line 2")
    bad = tmp_path / "broken.yaml"
    bad.write_text("name: x\nobjective: {kind: [\n")
    one_error_line(tuner("run", str(bad)), "broken.yaml: not valid YAML", "line 3")


def test_time_going_back_names_plain_seconds(tmp_path):
    rec = write_csv(tmp_path / "rec.csv")
    lines = rec.read_text().splitlines()
    lines[2], lines[3] = lines[3], lines[2]
    rec.write_text("\n".join(lines) + "\n")
    # the row whose stamp goes back is dropped; the gap it leaves is the error, which says so
    line = one_error_line(tuner("run", str(filter_job(tmp_path))), "not uniformly sampled", "set resample_hz",
                          "dropped 1 of", "whose stamp is not after the one before them (first at row 3: 0.01 s "
                          "after 0.02 s)")
    assert "np.float64" not in line


def test_show_names_a_truth_start_replaced_in_the_deployment_and_prefix_only_for_c(tmp_path):
    write_csv(tmp_path / "rec.csv")
    job = filter_job(tmp_path, objective={"fixed": {"use_mag": False, "init": "truth"}},
                     parameters={"beta": {"low": 0.01, "high": 1.0}},
                     optimizer={"method": "random", "population": 2, "generations": 1})
    out = tuner("run", str(job), "--run-dir", str(tmp_path / "run"), "--no-report")
    assert out.returncode == 0, out.stderr
    dep = yaml.safe_load((tmp_path / "run" / "best.yaml").read_text())["deployment"]
    assert dep["values"]["init"] == "accmag" and dep["scoring"]["init"] == "truth"
    show = tuner("show", str(tmp_path / "run"))
    assert show.returncode == 0, show.stderr
    notes = [ln for ln in show.stdout.splitlines() if ln.startswith("note:")]
    assert len(notes) == 1 and "ground truth" in notes[0] and "init: accmag" in notes[0], show.stdout
    # tuner evaluate RUN scores with the run's scoring settings (the truth start) and says so under the
    # deployed values it prints (was: scores of the truth start above "deployed ... init='accmag'")
    ev = tuner("evaluate", str(tmp_path / "run"))
    assert ev.returncode == 0, ev.stderr
    assert ev.stdout.strip().splitlines()[-1].startswith("note: the scores above use the run's scoring settings; "
                                                         "the run was scored with the start orientation taken")
    # was: "--prefix 'MH': a C identifier ([A-Za-z_][A-Za-z0-9_]*) for --format c" for a valid identifier
    one_error_line(tuner("export", str(tmp_path / "run"), "--format", "yaml", "--prefix", "MH"),
                   "--prefix 'MH'", "only for --format c", "got --format yaml")
    one_error_line(tuner("export", str(tmp_path / "run"), "--format", "c", "--prefix", "1MH"),
                   "--prefix '1MH'", "a C identifier")
    assert tuner("export", str(tmp_path / "run"), "--format", "c", "--prefix", "MH").returncode == 0


@pytest.mark.parametrize("params, expected", [
    ("beta: abc\n", ["params:", "beta must be a number", "'abc'"]),  # was a 37-line traceback, exit 1
    ("betta: 0.1\n", ["params.betta: not a parameter of this objective", "allowed:", "beta"]),  # was "missing ['beta']"
])
def test_evaluate_with_bad_params_is_one_error_line(tmp_path, params, expected):
    write_csv(tmp_path / "rec.csv")
    (tmp_path / "p.yaml").write_text(params)
    job = filter_job(tmp_path, parameters={"beta": {"low": 0.01, "high": 1.0}})
    one_error_line(tuner("evaluate", str(job), "--params", str(tmp_path / "p.yaml")), "p.yaml: ", *expected)


def test_from_run_refuses_a_deployment_value_the_filter_does_not_know(tmp_path):
    """A hand-edited best.yaml (``mag_rejections: true``): was silently dropped, so the filter built was not
    the one the file records."""
    from objectives.attitude.filters.base import AttitudeFilter

    write_csv(tmp_path / "rec.csv")
    job = filter_job(tmp_path, parameters={"beta": {"low": 0.01, "high": 1.0}},
                     optimizer={"method": "random", "population": 2, "generations": 1})
    assert tuner("run", str(job), "--run-dir", str(tmp_path / "run"), "--no-report").returncode == 0
    assert AttitudeFilter.from_run(tmp_path / "run").values["use_mag"] is False
    best = yaml.safe_load((tmp_path / "run" / "best.yaml").read_text())
    best["deployment"]["values"]["mag_rejections"] = True
    (tmp_path / "run" / "best.yaml").write_text(yaml.safe_dump(best, sort_keys=False))
    with pytest.raises(ValueError, match="deployment.values.mag_rejections: not a parameter of madgwick; allowed: "):
        AttitudeFilter.from_run(tmp_path / "run")


@pytest.mark.parametrize("spec, expected", [
    # was: "'time' is not uniformly sampled ... (tolerance -1 dt)", blaming the recording
    ({"path": "rec.csv", "columns": COLUMNS, "jitter_tol": -1}, ["jitter_tol must be a number > 0", "got -1"]),
    # was: "csv.path: file not found: <the job's folder>"
    ({"columns": COLUMNS}, ["objective.data[0].csv.path: missing (required)"]),
    ({"path": ".", "columns": COLUMNS}, ["objective.data[0].csv.path: not a file"]),
])
def test_csv_spec_errors_name_what_is_wrong(tmp_path, spec, expected):
    write_csv(tmp_path / "rec.csv")
    one_error_line(tuner("run", str(filter_job(tmp_path, objective={"data": [{"csv": spec}]}))), *expected)
    assert no_run_dir(tmp_path)


def test_a_deployment_value_outside_its_choices_is_refused():
    """A hand-edited ``init: truth`` (scoring only, not a choice of the deployed filter): the C header left it
    out without a word; now every reader of the deployment (export, from_run, load_best) refuses it."""
    from tuner.deployment import Deployment

    doc = {"kind": "filter", "name": "mahony", "values": {"Kp": 0.5, "init": "accmag"},
           "choices": {"init": ["accmag", "broad"]}}
    assert Deployment.from_doc(doc).values["init"] == "accmag"
    doc["values"]["init"] = "truth"
    with pytest.raises(ValueError, match=r"values.init: 'truth' is not one of its choices \['accmag', 'broad'\]"):
        Deployment.from_doc(doc)
