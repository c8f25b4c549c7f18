"""The generic loop's statistics kernel against the slow NumPy reference, and the item runner's kernel
(candidates x models x scenarios, serial and on threads) against the plant's own loop one item at a time."""

import math

import numpy as np
import pytest

from objectives.control.objective import ClosedLoopObjective
from objectives.control.plants.metrics import _item_stats, row_metrics, stat_size, windows
from tests.reference import loop_metrics_reference as ref


def _obj(plant, controller="pid2dof", **kw):
    sec = {"kind": "closed_loop", "plant": plant, "controller": controller, "period_s": kw.pop("period_s", 0.01)}
    sec.update(kw)
    return ClosedLoopObjective.from_config(sec)


SCENARIOS = [
    {"name": "step", "duration_s": 4.0, "reference": [{"t": 0.3, "value": 1.5}, {"t": 3.0, "value": 0.5}],
     "load": [{"t": 2.0, "value": 0.4}]},
    {"name": "ramp", "duration_s": 3.0, "reference": [{"t": 0.5, "value": -1.0, "ramp_s": 0.4}]},
    {"name": "load", "duration_s": 3.0, "reference": [], "load": [{"t": 0.0, "value": 1.0}, {"t": 2.0, "value": 0.0}]},
    {"name": "noise", "duration_s": 2.0, "reference": [], "sensor": {"noise_std": 0.05, "seed": 3}},
]


def test_windows_are_the_first_step_and_the_first_load_step():
    t = np.arange(100) * 0.1
    r = np.where(t >= 1.0 - 1e-12, 2.0, 0.0)
    r[t >= 6.0 - 1e-12] = 1.0
    load = np.where(t >= 4.0 - 1e-12, 0.5, 0.0)
    k0, k1, r0, r1, l0, l1 = windows(r, load)
    assert (k0, k1, r0, r1) == (10, 40, 0.0, 2.0)  # cut at the load step
    assert (l0, l1) == (40, 60)  # cut at the next reference change
    assert windows(np.zeros(10), np.zeros(10)).tolist() == [-1, -1, 0, 0, -1, -1]


@pytest.mark.parametrize("aw", ["backcalc", "none"])
def test_statistics_kernel_equals_the_numpy_reference(aw):
    """Saturated, rate-limited, noisy PID loop in four scenarios: every statistic equals the reference's."""
    o = _obj({"tf": {"num": [1.0], "den": [0.5, 1.5, 1.0]}, "delay_s": 0.05},
             fixed={"K": 4.0, "Ti_s": 0.8, "Td_s": 0.1, "antiwindup": aw}, scenarios=SCENARIOS,
             actuator={"u_min": -2.0, "u_max": 2.5, "rate_limit": 30.0}, sensor={"noise_std": 0.01, "seed": 2})
    loop = o.loop
    h = loop.period
    for s, case in enumerate(loop.cases):
        tr = loop.simulate({}, 0, s)
        y, u, x, r = tr["y"], tr["u"], tr["x"], case.signals.r
        row = np.zeros(stat_size(y.shape[1], x.shape[1]))
        _item_stats(y, u, x, r, 0, h, case.win, r.size, 0.0, float(r.size), row)
        terms, means, q = row_metrics(row, y.shape[1], x.shape[1])
        e = r - y[:, 0]
        want = ref.cost_terms(case.signals.t, e, u[:, 0], h)
        assert terms == pytest.approx(want, rel=1e-12, abs=1e-15)
        assert means == pytest.approx(ref.signal_means(e, u[:, 0], y, x, h), rel=1e-12, abs=1e-15)
        assert {k: q[k] for k in ("peak_u", "u_std")} == pytest.approx(ref.signal_quantities(u), rel=1e-12)
        k0, k1, _, _, l0, l1 = case.win
        if k0 >= 0:
            assert {k: q[k] for k in ("overshoot_pct", "rise_time_s", "settling_time_s", "ss_error")} == \
                pytest.approx(ref.step_quantities(r, y[:, 0], h, int(k0), int(k1)), rel=1e-12, abs=1e-15)
        else:
            assert math.isnan(q["overshoot_pct"]) and math.isnan(q["ss_error"])
        if l0 >= 0:
            assert q["load_peak_error"] == pytest.approx(ref.load_peak(r, y[:, 0], int(l0), int(l1)), rel=1e-12)
        else:
            assert math.isnan(q["load_peak_error"])


def test_item_kernel_equals_each_item_run_alone_serial_and_on_threads():
    """The population kernel over candidates x models x scenarios gives, bit for bit, each item's statistics
    from the plant's own loop and the statistics kernel, on one thread and on two; the objective's serial calls
    equal its population batch."""
    o = _obj({"tf": {"num": [1.0], "den": [0.5, 1.5, 1.0]}, "delay_s": 0.05}, scenarios=SCENARIOS,
             fixed={"antiwindup": "clamp"}, actuator={"u_min": -2.0, "u_max": 2.5},
             uncertainty={"parameters": {"tf.num[0]": {"rel": 0.3}, "delay_s": [0.0, 0.1]},
                          "tune": {"corners": True, "samples": 2, "seed": 5}})
    loop = o.loop
    cands = [{"K": 1.0, "Ti_s": 1.0}, {"K": 3.0, "Ti_s": 0.5, "Td_s": 0.05}, {"K": 8.0, "Ti_s": 0.3}]
    cps = np.array([loop.coeffs(p) for p in cands])
    serial, threads = loop._runner.run(cps, 1), loop._runner.run(cps, 2)
    assert serial.shape == (3, 7, 4, stat_size(1, 2))
    assert np.array_equal(serial, threads, equal_nan=True)
    for c in range(3):
        for m in (0, 3, 6):
            for s, case in enumerate(loop.cases):
                tr = loop._runner.trace(cps[c], m, s)
                row = np.zeros(serial.shape[-1])
                n = case.sig.shape[0]
                _item_stats(tr["y"], tr["u"], tr["x"], case.signals.r, 0, loop.period, case.win, n, 0.0, float(n), row)
                assert np.array_equal(row, serial[c, m, s], equal_nan=True)
    one = [o(p) for p in cands]
    assert one == o.evaluate_batch(cands, 2)
    assert one[1].metrics["step.iae"] == pytest.approx(np.mean(
        [row_metrics(serial[1, m, 0], 1, 2)[0]["iae"] for m in range(7)]), rel=1e-12)


@pytest.mark.slow
def test_stepped_plants_run_item_by_item_with_the_same_statistics():
    """A Python plant (one model per params set) through the runner equals its own loop, and the linear
    dynamics equal the LTI plant's statistics."""
    kw = dict(fixed={"K": 2.0, "Ti_s": 1.0, "Td_s": 0.1}, scenarios=SCENARIOS[:2])
    nl = _obj({"python": "tests.control.loop_dynamics:linear", "x0": [0.0, 0.0], "outputs": [0], "n_sub": 50}, **kw)
    lti = _obj({"ss": {"A": [[0, 1], [-2, -0.5]], "B": [[0], [1]], "C": [[1, 0]]}}, **kw)
    a, b = nl.loop._runner.run(nl.coeffs({})), lti.loop._runner.run(lti.coeffs({}))
    assert a.shape == b.shape
    assert np.allclose(a, b, rtol=1e-7, atol=1e-9, equal_nan=True)
