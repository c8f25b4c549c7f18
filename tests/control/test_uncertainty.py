"""Plant uncertainty: the block's checks, the seeded model sets, perturbed models against plants built
directly and python-control's frequency responses and margins, and the held-out assessment against an
independent per-model computation."""

import math
from pathlib import Path

import control
import numpy as np
import pytest
from scipy import stats

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants import register_plant, unregister_plant
from objectives.control.plants.base import PlantKind
from objectives.control.plants.lti import lti_from_spec
from objectives.control.plants.robustness import assess
from objectives.control.plants.tables import heldout_summary
from objectives.control.plants.uncertainty import draw_models, uncertainty_from_spec

TF = {"tf": {"num": [2.0], "den": [0.5, 1.5, 1.0]}, "delay_s": 0.1}
EXAMPLES = Path(__file__).resolve().parents[2] / "configs" / "examples"


def _obj(plant=None, controller="pid2dof", **kw):
    sec = {"kind": "closed_loop", "plant": plant or TF, "controller": controller, "period_s": kw.pop("period_s", 0.05),
           "scenario": kw.pop("scenario", {"duration_s": 10.0, "reference": [{"t": 0.1, "value": 1.0}]})}
    sec.update(kw)
    return ClosedLoopObjective.from_config(sec)


BAD = {
    "unknown name": ({"parameters": {"tf.den[5]": [0, 1]}},
                     "objective.uncertainty.parameters.tf.den[5]: not a parameter of this plant (did you mean"),
    "lists what it has": ({"parameters": {"mass": [0, 1]}},
                          "it has tf.num[0], tf.den[0], tf.den[1], tf.den[2], delay_s"),
    "nominal outside": ({"parameters": {"tf.num[0]": [2.5, 3.0]}},
                        "objective.uncertainty.parameters.tf.num[0]: the nominal value 2 is outside [2.5, 3]"),
    "rel of one": ({"parameters": {"tf.num[0]": {"rel": 1.0}}},
                   "objective.uncertainty.parameters.tf.num[0].rel: a relative range in (0, 1)"),
    "normal std": ({"parameters": {"tf.num[0]": {"normal": {"std": 0}}}},
                   "objective.uncertainty.parameters.tf.num[0].normal.std: must be > 0"),
    "negative delay": ({"parameters": {"delay_s": {"normal": {"std": 0.1}}}},
                       "objective.uncertainty.parameters.delay_s: a delay is >= 0 s"),
    "unknown form": ({"parameters": {"tf.num[0]": 0.3}}, "objective.uncertainty.parameters.tf.num[0]: [low, high]"),
    "empty": ({"parameters": {}}, "objective.uncertainty.parameters: a non-empty mapping"),
    "nothing to tune on": ({"parameters": {"tf.num[0]": {"rel": 0.1}}, "tune": {"corners": False, "samples": 0}},
                           "objective.uncertainty.tune: without corners and samples"),
    "tune key": ({"parameters": {"tf.num[0]": {"rel": 0.1}}, "tune": {"size": 3}},
                 "objective.uncertainty.tune: a mapping of corners, samples, seed"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_uncertainty_is_one_line_naming_the_key(case):
    spec, msg = BAD[case]
    with pytest.raises(ValueError) as exc:
        _obj(uncertainty=spec)
    assert msg in str(exc.value) and "\n" not in str(exc.value)


def test_too_many_corners_and_a_kind_without_perturbable_parameters():
    ss = {"ss": {"A": [[0.0, 1.0, 0.0, 0.0], [-1.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -1.0, -1.0]],
                 "B": [[0.0], [1.0], [0.0], [1.0]], "C": [[1.0, 0.0, 1.0, 0.0]]}}
    many = {f"ss.A[{i}][{j}]": {"rel": 0.1} for i, j in ((1, 0), (1, 1), (3, 2), (3, 3), (0, 1), (2, 3))}
    many["ss.B[1][0]"] = {"rel": 0.1}
    with pytest.raises(ValueError, match=r"tune.corners: 7 parameters have 128 corners \(at most 64\); set corners: "):
        _obj(ss, uncertainty={"parameters": many})
    register_plant(PlantKind("rigid", frozenset({"rigid", "delay_s"}), lambda spec, h, d, key: lti_from_spec(
        {"tf": {"num": [1.0], "den": [1.0, 0.0]}}, h, d, key), "siso"))
    try:
        with pytest.raises(ValueError, match="plant kind 'rigid' declares no parameter an uncertainty block may"):
            _obj({"rigid": {}}, uncertainty={"parameters": {"delay_s": [0, 0.1]}})
    finally:
        unregister_plant("rigid")


def test_model_sets_nominal_corners_samples_seeded_and_held_out_apart():
    o = _obj(uncertainty={"parameters": {"tf.num[0]": {"rel": 0.3}, "tf.den[0]": [0.4, 0.7], "delay_s": [0.05, 0.2]},
                          "tune": {"samples": 5, "seed": 3}, "validate": {"samples": 40, "seed": 9}})
    u = o.loop.uncertainty_block
    tune = draw_models(u, "tuning", 0.05)
    assert tune.labels[0] == "nominal" and tune.values[0] == {"tf.num[0]": 2.0, "tf.den[0]": 0.5, "delay_s": 0.1}
    assert [lab for lab in tune.labels if lab.startswith("corner")] == [f"corner {a}{b}{c}" for a in "-+" for b in "-+"
                                                                       for c in "-+"]
    assert tune.values[1] == pytest.approx({"tf.num[0]": 1.4, "tf.den[0]": 0.4, "delay_s": 0.05})
    assert tune.values[8] == pytest.approx({"tf.num[0]": 2.6, "tf.den[0]": 0.7, "delay_s": 0.2})
    assert len(tune.labels) == 1 + 8 + 5 == len(o.loop.models) == u.tuning_size()
    # samples: inside the ranges, the delay on the period grid, the same for the same seed, not for another
    samples = np.array([[v["tf.num[0]"], v["tf.den[0]"], v["delay_s"]] for v in tune.values[9:]])
    assert np.all((samples[:, 0] >= 1.4) & (samples[:, 0] <= 2.6) & (samples[:, 1] >= 0.4) & (samples[:, 1] <= 0.7))
    assert np.allclose(samples[:, 2] / 0.05, np.round(samples[:, 2] / 0.05), atol=1e-9)
    assert draw_models(u, "tuning", 0.05) == tune
    held = draw_models(u, "held-out", 0.05)
    assert len(held.labels) == 40 and "nominal" not in held.labels
    assert not any(v in tune.values for v in held.values)
    assert o.loop.heldout().describe() == "40 models (40 samples, seed 9)"
    assert o.loop.models.describe() == "14 models (1 nominal, 8 corners, 5 samples, seed 3)"


def test_normal_draws_are_the_truncated_normal():
    """Kolmogorov-Smirnov against scipy's truncated normal (3 std): the inverse-CDF draws are that distribution."""
    u = uncertainty_from_spec({"parameters": {"tf.num[0]": {"normal": {"std": 0.2, "mean": 2.1}}},
                               "validate": {"samples": 3000, "seed": 4}}, _obj().loop.kind, TF, 0.05)
    x = np.array([v["tf.num[0]"] for v in draw_models(u, "held-out", 0.05).values])
    assert stats.kstest(x, stats.truncnorm(-3, 3, loc=2.1, scale=0.2).cdf).pvalue > 0.01
    assert draw_models(u, "tuning", 0.05).values[1:3] == ({"tf.num[0]": pytest.approx(1.7)},
                                                          {"tf.num[0]": pytest.approx(2.5)})


def test_perturbed_models_are_the_plants_built_with_those_values():
    """Each tuning model's frequency response is python-control's of the perturbed transfer function with its
    delay; its margins agree with python-control's stability margins."""
    o = _obj(fixed={"K": 1.2, "Ti_s": 1.5, "Td_s": 0.2},
             uncertainty={"parameters": {"tf.num[0]": {"rel": 0.3}, "tf.den[1]": {"rel": 0.2}, "delay_s": [0.0, 0.3]},
                          "tune": {"samples": 2}})
    ms = o.loop.models
    w = np.logspace(-2, math.log10(math.pi / 0.05 * 0.99), 50)
    for m in (1, 6, 9):
        v = ms.values[m]
        P = control.sample_system(control.tf([v["tf.num[0]"]], [0.5, v["tf.den[1]"], 1.0]), 0.05)
        d = int(round(v["delay_s"] / 0.05))
        z = np.exp(1j * w * 0.05)
        assert np.allclose(ms.plants[m].frequency_response(w)[:, 0], P(z) * z ** (-d), rtol=1e-9)
    cp = o.coeffs({})
    mg = ms.margins(o.loop.ctrl, cp)
    h, K, Ti, Td, N = 0.05, 1.2, 1.5, 0.2, 10.0
    ad, bd, ki = Td / (Td + N * h), K * Td * N / (Td + N * h), K * h / Ti
    zt = control.tf([1, 0], [1], h)
    C = K + ki / (zt - 1) + bd * (zt - 1) / (zt - ad)
    for m in (0, 8):
        v = ms.values[m]
        P = control.sample_system(control.tf([v["tf.num[0]"]], [0.5, v["tf.den[1]"], 1.0]), h) * \
            control.tf([1], [1, 0], h) ** int(round(v["delay_s"] / h))
        wd = np.logspace(-3, math.log10(math.pi / h * 0.999), 40000)
        ref_ms = np.max(np.abs(1 / (1 + (C * P)(np.exp(1j * wd * h)))))
        assert mg[m]["ms"] == pytest.approx(ref_ms, rel=2e-3)


def test_heldout_assessment_against_an_independent_per_model_computation():
    """Ms of every held-out model from python-control on a dense grid; the pass rate and the worst Ms of the
    assessment are those (models within 0.3 % of the limit may fall either way on the coarser grid)."""
    lim = 1.5
    o = _obj(fixed={"K": 1.0, "Ti_s": 1.2, "Td_s": 0.2}, requirements={"max_ms": lim},
             uncertainty={"parameters": {"tf.num[0]": {"rel": 0.4}, "delay_s": [0.0, 0.3]},
                          "validate": {"samples": 30, "seed": 5}})
    a = assess(o.loop, "tuned", {})
    hs = o.loop.heldout()
    h, K, Ti, Td, N = 0.05, 1.0, 1.2, 0.2, 10.0
    ad, bd, ki = Td / (Td + N * h), K * Td * N / (Td + N * h), K * h / Ti
    zt = control.tf([1, 0], [1], h)
    C = K + ki / (zt - 1) + bd * (zt - 1) / (zt - ad)
    wd = np.logspace(-3, math.log10(math.pi / h * 0.999), 20000)
    ref = []
    for v in hs.values:
        P = control.sample_system(control.tf([v["tf.num[0]"]], [0.5, 1.5, 1.0]), h) * \
            control.tf([1], [1, 0], h) ** int(round(v["delay_s"] / h))
        ref.append(np.max(np.abs(1 / (1 + (C * P)(np.exp(1j * wd * h))))))
    ref = np.array(ref)
    mine = a.heldout.check("max_ms", None)["values"]
    assert np.allclose(mine, ref, rtol=2e-3)
    border = np.abs(ref / lim - 1) < 3e-3
    rate = heldout_summary(a.heldout)["pass_rate"]
    assert abs(rate - np.mean(ref <= lim)) <= border.mean() + 1e-12
    assert 0.0 < rate < 1.0  # the set straddles the limit: the check can fail both ways
    assert heldout_summary(a.heldout)["ms_max"] == pytest.approx(ref.max(), rel=2e-3)


@pytest.mark.slow
def test_python_plant_parameters_share_one_compiled_loop():
    """params.<name> of a Python plant: each model is the plant built with that value (equal responses), and the
    models share the dynamics' dispatcher and params class, so the loop compiles once."""
    from objectives.control.plants.nonlinear import _JITTED

    spec = {"python": "tests.control.loop_dynamics:stiff", "x0": [0.0], "params": {"lam": 2.0}, "n_sub": 4}
    o = _obj(spec, period_s=0.05, fixed={"K": 1.0, "Ti_s": 0.5},
             uncertainty={"parameters": {"params.lam": [1.0, 3.0]}, "tune": {"samples": 1}})
    ms = o.loop.models
    assert [p.params.lam for p in ms.plants[:3]] == [2.0, 1.0, 3.0]
    assert len({type(p.params) for p in ms.plants}) == 1 and len({id(p.fn) for p in ms.plants}) == 1
    assert sum(1 for f in _JITTED if getattr(f, "__name__", "") == "stiff") == 1
    direct = _obj({**spec, "params": {"lam": 3.0}}, period_s=0.05, fixed={"K": 1.0, "Ti_s": 0.5})
    assert np.array_equal(o.loop.simulate({}, 2)["y"], direct.simulate({})["y"])


@pytest.mark.slow
def test_robust_run_on_threads_equals_the_serial_run(tmp_path):
    """A short robust tuning (13 models x 2 scenarios per candidate): backend threads (the population kernel)
    writes the history the serial backend writes, row for row."""
    import yaml

    from tuner.api import tune

    raw = yaml.safe_load((EXAMPLES / "dc_motor_robust.yaml").read_text())
    raw["optimizer"] = {"method": "pso", "population": 8, "generations": 3, "init_spread": 0.2,
                        "x0": {"K": 185.0, "Ti_s": 1.7, "Td_s": 0.06}}  # near the robust optimum: some feasible
    hist = {}
    for backend in ("serial", "threads"):
        raw["parallel"] = {"backend": backend, "n_jobs": 2}
        raw["output"] = str(tmp_path / backend)
        hist[backend] = tune(raw, report=False).history.drop(columns=["seconds"])
    assert hist["serial"].equals(hist["threads"])
    assert (hist["serial"]["status"] == "failed").any() and (hist["serial"]["status"] == "ok").any()


def test_describe_answers_for_every_setting_of_the_generic_loop():
    from tests.conftest import run_tuner

    for name, words in (("requirements", "max_load_peak_error"), ("scenario", "duration_s"),
                        ("scenarios", "weight"), ("actuator", "rate_limit"), ("sensor", "noise_std"),
                        ("cost", "itae"), ("aggregate", "cvar"), ("uncertainty", "validate.samples")):
        res = run_tuner("describe", name)
        assert res.returncode == 0 and words in res.stdout, (name, res.stdout, res.stderr)
    res = run_tuner("describe", "requirements")
    line = next(x for x in res.stdout.splitlines() if x.strip().startswith("max_ms"))
    assert " 1 " in line and "every model" in line  # unit and where it is measured
    assert "settings" in run_tuner("list", "settings").stdout
