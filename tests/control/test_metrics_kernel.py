"""The numba scorer of the closed loop equals the NumPy measures bit for bit (objectives/control/metrics.py)."""

import numpy as np
import pytest

from objectives.batch_threads import _pairwise_sum
from objectives.control.plants.wmp import metrics as M


@pytest.mark.parametrize("n", [1, 7, 8, 9, 127, 128, 129, 255, 256, 1000, 1001, 4097, 100_003])
def test_pairwise_sum_is_numpys_sum(n):
    rng = np.random.default_rng(n)
    for _ in range(20):
        a = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 8, n)  # wide range: order changes the bits
        assert _pairwise_sum(a, 0, n) == np.sum(a)
        lo = int(rng.integers(0, n))
        assert _pairwise_sum(a, lo, n - lo) == np.sum(a[lo:])


def test_a_plain_left_to_right_sum_would_differ():
    a = np.random.default_rng(0).standard_normal(1000) * 10.0 ** np.random.default_rng(1).uniform(-8, 8, 1000)
    plain = 0.0
    for v in a:
        plain += v
    assert plain != np.sum(a)  # so the equality above checks the order, not only the value


def test_measures_and_cost_equal_the_numpy_functions():
    rng = np.random.default_rng(7)
    for _ in range(300):
        n = int(rng.integers(1, 3000))
        ts = float(rng.choice([0.01, 0.005, 1.0 / 300.0]))
        e = rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 3)
        out = np.empty(4)
        M._measures_kernel(e, ts, np.empty(n), out)
        assert out.tolist() == [M.sae(e), M.sse(e), M.stae(e, ts), M.stse(e, ts)]
        sig = [rng.standard_normal(n) * 10.0 ** rng.uniform(-4, 1) for _ in range(4)]
        w = {"alpha1": rng.uniform(0.1, 3.0), "beta": rng.uniform(0.1, 3.0)}
        terms = np.array([np.mean(np.abs(sig[0])), np.mean(np.abs(sig[1])), np.mean(np.abs(sig[2])),
                          np.mean(sig[3] ** 2)])
        assert M._weighted_cost_kernel(terms, M.cost_exponents(w)) == M.mae_weighted_cost(*sig, w)


def test_cost_exponents_defaults_overrides_and_unknown_keys():
    assert M.cost_exponents().tolist() == [1.4, 0.85, 1.6, 0.4]
    assert M.cost_exponents({"gamma": 1}).tolist() == [1.4, 0.85, 1.6, 1.0]
    with pytest.raises(ValueError, match="unknown cost weight"):
        M.cost_exponents({"delta": 1.0})
