"""The PID benchmark's robust part (benchmarks/pid_robust.py): the plants' zero-pole-gain forms are the benchmark's
transfer functions, the uncertainty moves each time constant, the gain and the delay by +-30 %, and a smoke run
scores both tunings on the held-out plants."""

from __future__ import annotations

import control
import numpy as np
import pytest

from benchmarks import pid_robust as pr
from benchmarks.pid_plants import PLANTS


@pytest.mark.parametrize("name", list(PLANTS))
def test_the_zpk_form_is_the_benchmark_plant(name):
    spec, unc = pr.zpk_plant(name)
    num, den, delay, hr = PLANTS[name]
    w = np.logspace(-2, 2, 60)
    mine = control.zpk(spec["zpk"]["z"], spec["zpk"]["p"], spec["zpk"]["k"]) if "zpk" in spec \
        else control.tf(spec["tf"]["num"], spec["tf"]["den"])
    assert np.max(np.abs(mine(1j * w) - control.tf(num, den)(1j * w))) < 1e-12
    assert spec["delay_s"] == delay
    if hr is None:
        assert unc == {"tf.num[0]": {"rel": 0.3}}
        return
    for i, t in enumerate(hr[1]):  # each pole -1/T with T in [0.7 T, 1.3 T]
        lo, hi = unc[f"zpk.p[{i}]"]
        assert sorted([-1 / lo, -1 / hi]) == pytest.approx([0.7 * t, 1.3 * t])
    assert unc["zpk.k"] == {"rel": 0.3}
    assert ("delay_s" in unc) == (delay > 0)


@pytest.mark.slow
def test_smoke_run_scores_both_tunings_on_held_out_plants():
    out = pr.run(smoke=True)
    res = out["results"]["P1 n=3"]
    for mode in ("nominal", "robust"):
        assert 0.0 <= res[mode]["pass_rate"] <= 1.0 and np.isfinite(res[mode]["iae_p95"])
    assert "| P1 n=3 |" in out["markdown"]
