"""Export formats: inf/NaN survive every format, strict JSON, importable Python, C headers that compile
together, the sample rate and units in the header, and ``tuner compare`` with significant digits."""

import importlib.util
import json
import math
import shutil
import subprocess
import sys

import pytest
import yaml

from tests.conftest import run_tuner
from tuner.config import config_from_dict
from tuner.export import export
from tuner.export_formats import c_prefix, json_load, to_c, to_json, to_python, to_yaml
from tuner.run import run

INF = math.inf
DOC = {"run": "r1", "fitness": 0.125, "objective": {"kind": "filter", "filter": "ekf"}, "optimizer": "pso",
       "seed": 3, "n_evals": 8, "git_commit": "", "exported": "2026-01-01T00:00:00Z",
       "params": {"q_q": 4.5e-9, "acc_gate": INF, "low": -INF, "off": math.nan, "n": 7, "flag": True,
                  "variant": "inf", "name": 'a "quoted" */ name', "vec": [1.0, INF, -2.5]},
       "units": {"q_q": "1 per sample", "acc_gate": "g"}, "sample_rate_hz": 1000.0,
       "sample_rate_note": "rate of the training recordings"}


def _same(a, b):
    """Equality with nan == nan, recursively."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and math.isnan(a):
        return isinstance(b, float) and math.isnan(b)
    return a == b and type(a) is type(b)


def _strict(text):
    def refuse(tok):
        raise ValueError(f"non-standard JSON token {tok}")

    return json.loads(text, parse_constant=refuse)


def test_yaml_round_trip_keeps_nonfinite():
    assert _same(yaml.safe_load(to_yaml(DOC)), DOC)


def test_json_is_strict_and_round_trips():
    text = to_json(DOC)
    raw = _strict(text)  # RFC 8259: no Infinity / NaN tokens
    assert raw["params"]["acc_gate"] == "inf" and raw["params"]["low"] == "-inf" and raw["params"]["off"] == "nan"
    assert raw["params"]["variant"] == "inf"  # a string stays a string
    assert "nonfinite" in raw and sorted(raw["nonfinite_paths"]) == sorted(
        ["/params/acc_gate", "/params/low", "/params/off", "/params/vec/1"])
    assert _same(json_load(text), DOC)
    finite = {**DOC, "params": {"a": 1.0}}
    assert "nonfinite" not in json.loads(to_json(finite))


def test_python_module_imports_from_another_directory(tmp_path):
    p = tmp_path / "elsewhere" / "tuned_params.py"
    p.parent.mkdir()
    p.write_text(to_python(DOC))
    spec = importlib.util.spec_from_file_location("tuned_params", p)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert _same(mod.PARAMS, DOC["params"])
    assert mod.UNITS == DOC["units"] and mod.PROVENANCE["sample_rate_hz"] == 1000.0
    out = subprocess.run([sys.executable, "-c", "import tuned_params as t, math; print(t.PARAMS['acc_gate'])"],
                         cwd=p.parent, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip() == "inf", out.stderr


@pytest.mark.parametrize("name, prefix", [("20261122T101500Z-ekf-bench6dof-a1b2c3", "EKF_BENCH6DOF"),
                                          ("my run.v2", "MY_RUN_V2"), ("1st", "P_1ST"), ("--", "TUNER"),
                                          ("EKF1", "EKF1")])
def test_c_prefix_is_a_sanitised_identifier(name, prefix):
    assert c_prefix(name) == prefix


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_two_c_headers_compile_in_one_translation_unit(tmp_path):
    other = {**DOC, "params": {**DOC["params"], "q_q": 1.5e-9}}
    (tmp_path / "ekf1.h").write_text(to_c(DOC, prefix="EKF1"))
    (tmp_path / "ekf2.h").write_text(to_c(other, prefix="EKF2"))
    text = (tmp_path / "ekf1.h").read_text()
    assert "1000 Hz" in text and "EKF1_Q_Q: 1 per sample" in text and "EKF1_N: unit not declared" in text
    assert text.split("#ifndef")[0].count("*/") == 1  # a name holding "*/" does not close the comment early
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "ekf1.h"\n#include "ekf2.h"\n#include "ekf1.h"\n'
        "int main(void) {\n"
        '  printf("%.17g %.17g %d %d %d\\n", EKF1_Q_Q, EKF2_Q_Q, isinf(EKF1_ACC_GATE) && EKF1_ACC_GATE > 0,\n'
        "         isinf(EKF2_LOW) && EKF2_LOW < 0, isnan(EKF1_OFF));\n"
        '  printf("%d|%d|%.17g\\n", EKF1_N, EKF1_FLAG, EKF1_VEC[2]);\n'
        "  return isinf(EKF1_VEC[1]) ? 0 : 3;\n}\n")
    body = text.split("#ifndef")[1]
    assert "char" not in body and "EKF1_VARIANT " not in body and "EKF1_NAME " not in body  # comments only
    cc = subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-o", "main", "main.c",
                         "-lm"],
                        cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert cc.returncode == 0, cc.stderr
    out = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0
    line1, line2 = out.stdout.splitlines()
    a, b, pinf, ninf, nan = line1.split()
    assert float(a) == 4.5e-9 and float(b) == 1.5e-9 and (pinf, ninf, nan) == ("1", "1", "1")
    assert line2 == "7|1|-2.5"  # strings without declared choices are comments, never C strings


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_choices_are_defines_and_booleans_0_1(tmp_path):
    doc = {**DOC, "params": {"variant": "original_c", "init": "broad", "use_mag": False, "rest_bias": True},
           "deployment": {"kind": "filter", "name": "madgwick", "choices": {"variant": ["paper", "original_c"],
                                                                           "init": ["accmag", "broad"]},
                          "scoring": {"init": "truth", "warmup_s": 2.0}, "notes": ["starts from accmag"]}}
    (tmp_path / "t.h").write_text(to_c(doc, prefix="M"))
    text = (tmp_path / "t.h").read_text()
    assert "#define M_VARIANT_PAPER 0" in text and "#define M_INIT_BROAD 1" in text
    assert "Scoring only" in text and "M_WARMUP_S" not in text  # scoring settings are never values
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "t.h"\nint main(void) {\n'
        '  printf("%d %d %d %d\\n", M_VARIANT == M_VARIANT_ORIGINAL_C, M_INIT == M_INIT_BROAD,'
        ' M_USE_MAG, M_REST_BIAS);\n'
        "  return 0;\n}\n")
    cc = subprocess.run(["cc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-o", "main", "main.c"],
                        cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert cc.returncode == 0, cc.stderr
    out = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, timeout=30)
    assert out.stdout.split() == ["1", "1", "0", "1"]


def test_bad_prefix_is_refused():
    with pytest.raises(ValueError, match="prefix"):
        to_c(DOC, prefix="1-bad")


# --- a real run with an inf parameter ----------------------------------------------------------
@pytest.fixture(scope="module")
def ekf_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ekfrun")
    raw = {"name": "ekf-inf", "seed": 2,
           "objective": {"kind": "filter", "filter": "ekf",
                         "data": [{"synthetic": {"generator": "bench6dof", "duration_s": 4, "rate_hz": 500,
                                                 "seed": 1}}]},
           "parameters": {"q_q": {"low": 1e-9, "high": 1e-3, "scale": "log"}, "rho": {"low": 1e-3, "high": 1e3,
                                                                                     "scale": "log"},
                          "acc_gate": {"fixed": INF}, "use_mag": True},
           "optimizer": {"method": "pso", "population": 4, "generations": 2}, "parallel": {"backend": "serial"}}
    return run(config_from_dict(raw, base_dir=tmp), run_dir=tmp / "r", quiet=True, report=False).run_dir


def _compile_and_run(tmp_path):
    """Compile ``tmp_path/m.c`` (C99, warnings are errors) and assert that it runs with exit 0."""
    cc = subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-o", "m", "m.c"], cwd=tmp_path, capture_output=True,
                        text=True, timeout=120)
    assert cc.returncode == 0, cc.stderr
    assert subprocess.run([str(tmp_path / "m")], timeout=30).returncode == 0


def _tuner(*args):
    return run_tuner(*args)


@pytest.mark.slow
def test_exports_of_a_run_with_inf_round_trip_to_the_same_score(ekf_run, tmp_path):
    from objectives.registry import build_objective

    best = yaml.safe_load((ekf_run / "best.yaml").read_text())
    assert best["params"]["acc_gate"] == INF
    loaded = {"yaml": yaml.safe_load(export(ekf_run, "yaml"))["params"],
              "json": json_load(export(ekf_run, "json"))["params"]}
    _strict(export(ekf_run, "json"))
    p = tmp_path / "tuned.py"
    p.write_text(export(ekf_run, "python"))
    spec = importlib.util.spec_from_file_location("tuned", p)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    loaded["python"] = mod.PARAMS
    cfg = yaml.safe_load((ekf_run / "config.yaml").read_text())
    obj = build_objective(dict(cfg["objective"]), ekf_run)
    for fmt, params in loaded.items():  # every value of the deployed filter: the run's point and the rest
        assert _same({k: params[k] for k in best["params"]}, best["params"]), fmt
        assert len(params) > len(best["params"]) and params["q_w"] == 9.71e-10, fmt  # a default, now exported
        assert obj(params).fitness == best["fitness"], fmt


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.slow
def test_cli_export_c_with_prefix_states_rate_and_units(ekf_run, tmp_path):
    out = _tuner("export", str(ekf_run), "--format", "c", "--prefix", "EKF1", "-o", str(tmp_path / "a.h"))
    assert out.returncode == 0, out.stderr
    default = _tuner("export", str(ekf_run), "--format", "c")
    assert default.returncode == 0 and "EKF_INF_Q_Q" in default.stdout  # prefix from the run's name
    (tmp_path / "b.h").write_text(default.stdout)
    text = (tmp_path / "a.h").read_text()
    assert "Sample rate the values assume: 500 Hz" in text and "EKF1_Q_Q: 1 per sample" in text
    assert "static const double EKF1_ACC_GATE = INFINITY;" in text
    (tmp_path / "m.c").write_text('#include "a.h"\n#include "b.h"\nint main(void) { return EKF1_Q_Q == EKF_INF_Q_Q '
                                  "&& EKF1_ACC_GATE > 1e308 ? 0 : 1; }\n")
    _compile_and_run(tmp_path)
    bad = _tuner("export", str(ekf_run), "--format", "c", "--prefix", "no-dash")
    assert bad.returncode == 2 and bad.stderr.startswith("error: --prefix")


def test_compare_prints_significant_digits(ekf_run):
    best = yaml.safe_load((ekf_run / "best.yaml").read_text())
    out = _tuner("compare", str(ekf_run))
    assert out.returncode == 0, out.stderr
    line = next(ln for ln in out.stdout.splitlines() if ln.startswith("param.q_q"))
    assert line.split()[1] == f"{best['params']['q_q']:.6g}" and "e-0" in line.split()[1]


def test_sample_rate_from_the_config_or_from_the_loaded_recordings():
    from objectives.attitude.objective import FilterObjective
    from tuner.export import _sample_rate

    stated = FilterObjective("madgwick", [{"synthetic": {"generator": "tilt1d", "duration_s": 2, "rate_hz": 250}}])
    assert _sample_rate(stated)["sample_rate_hz"] == 250.0
    loaded = FilterObjective("madgwick", [{"synthetic": {"generator": "tilt1d", "duration_s": 2, "seed": 1}}])
    assert _sample_rate(loaded)["sample_rate_hz"] == 800.0  # tilt1d's default rate, read from the recording
    mixed = FilterObjective("madgwick", [{"synthetic": {"generator": "tilt1d", "duration_s": 2, "rate_hz": 250}},
                                         {"synthetic": {"generator": "tilt1d", "duration_s": 2}}])
    out = _sample_rate(mixed)
    assert out["sample_rate_hz"] is None and "250 Hz, 800 Hz" in out["sample_rate_note"]
    assert _sample_rate(None)["sample_rate_hz"] is None


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler")
def test_c_names_differing_only_in_case_get_distinct_constants(tmp_path):
    doc = {**DOC, "params": {"k": 1.5, "K": 2.5, "a-b": 3.5, "a_b": 4.5}}
    text = to_c(doc, prefix="P")
    assert "P_K = 1.5" in text and "P_K_2 = 2.5" in text and "P_A_B_2 = 4.5" in text
    assert "P_K_2 (parameter K)" in text
    (tmp_path / "p.h").write_text(text)
    (tmp_path / "m.c").write_text('#include "p.h"\nint main(void) { return (P_K + P_K_2 + P_A_B + P_A_B_2) == 12.0 '
                                  "? 0 : 1; }\n")
    _compile_and_run(tmp_path)
