"""objectives.fuzzy against closed forms and the slow reference in tests/reference/fuzzy_reference.py."""

import math

import numpy as np
import pytest
from numba import njit

from objectives import fuzzy as fz
from tests.reference.fuzzy_reference import mamdani_ref, mf, sugeno_ref


def test_membership_closed_forms():
    assert fz.gaussmf(2.0, 2.0, 0.3) == 1.0
    assert fz.gaussmf(2.3, 2.0, 0.3) == pytest.approx(math.exp(-0.5), rel=1e-14)
    assert fz.trimf(0.5, 0.0, 1.0, 3.0) == 0.5
    assert fz.trimf(2.0, 0.0, 1.0, 3.0) == pytest.approx(0.5)
    assert fz.trimf(-0.1, 0.0, 1.0, 3.0) == 0.0 and fz.trimf(3.1, 0.0, 1.0, 3.0) == 0.0
    assert fz.trapmf(1.5, 0.0, 1.0, 2.0, 4.0) == 1.0
    assert fz.trapmf(3.0, 0.0, 1.0, 2.0, 4.0) == 0.5
    # shoulders: vertical edges and open (infinite) shoulders
    assert fz.trimf(1.0, 1.0, 1.0, 2.0) == 1.0 and fz.trimf(1.5, 1.0, 1.0, 2.0) == 0.5
    assert fz.trapmf(-1e9, -np.inf, -np.inf, 0.0, 1.0) == 1.0
    assert fz.trapmf(0.25, -np.inf, -np.inf, 0.0, 1.0) == 0.75
    assert fz.trapmf(1e9, 0.0, 1.0, np.inf, np.inf) == 1.0
    assert fz.trapmf(2.0, 0.0, 0.0, 2.0, 2.0) == 1.0 and fz.trapmf(2.0001, 0.0, 0.0, 2.0, 2.0) == 0.0


def test_membership_matches_reference_on_random_points():
    rng = np.random.default_rng(1)
    for _ in range(300):
        p = np.sort(rng.uniform(-2, 2, 4))
        x = rng.uniform(-3, 3)
        assert fz.membership(1, p, x) == pytest.approx(mf(1, p, x), abs=1e-14)
        assert fz.membership(2, p, x) == pytest.approx(mf(2, p, x), abs=1e-14)
        g = np.array([p[0], abs(p[1]) + 0.1, 0, 0])
        assert fz.membership(0, g, x) == pytest.approx(mf(0, g, x), rel=1e-14)


def _random_system(rng, n_in=3, n_sets=4, n_rules=20):
    kind = rng.integers(0, 3, (n_in, n_sets))
    params = np.sort(rng.uniform(-1, 1, (n_in, n_sets, 4)), axis=2)
    params[kind == 0, 1] = rng.uniform(0.1, 0.8, int((kind == 0).sum()))
    rules = rng.integers(-1, n_sets, (n_rules, n_in))
    return kind, params, rules, rng.normal(size=n_rules)


@pytest.mark.parametrize("and_op", ["min", "prod"])
def test_sugeno_matches_reference(and_op):
    rng = np.random.default_rng(2)
    for _ in range(20):
        kind, params, rules, cons = _random_system(rng)
        fis = fz.SugenoFIS(kind, params, rules, cons, and_op=and_op)
        X = rng.uniform(-1.2, 1.2, (25, 3))
        got = fis(X)
        ref = [sugeno_ref(x, kind, params, rules, cons, and_op) for x in X]
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)
        # the allocating kernel form gives the same numbers
        assert fz.sugeno(X[0], *fis.kernel_args()) == pytest.approx(got[0], rel=1e-14, abs=1e-15)


def _faekf_like():
    """Three inputs with Z/S/B Gaussian sets and the FAEKF paper's Table 1 pattern K_{1+f+a+h}."""
    c = np.array([[0.0, 5.0, 10.0], [0.0, 0.5, 1.0], [0.0, 0.5, 1.0]])
    s = np.array([2.0, 0.2, 0.2])
    params = np.stack([c, np.repeat(s[:, None], 3, axis=1)], axis=2)
    rules = fz.grid_rules([3, 3, 3])
    kappa = np.array([1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0])
    return fz.SugenoFIS("gauss", params, rules, kappa[rules.sum(axis=1)]), kappa


def test_grid_rules_order_and_table1_pattern():
    rules = fz.grid_rules([3, 3, 3])
    assert rules.shape == (27, 3)
    np.testing.assert_array_equal(rules[0], [0, 0, 0])
    np.testing.assert_array_equal(rules[1], [0, 0, 1])  # last input varies fastest
    np.testing.assert_array_equal(rules[9], [1, 0, 0])
    fis, kappa = _faekf_like()
    # Table 1: f=Z, a=B, h=B -> K5; f=S, a=Z, h=Z -> K2
    assert fis.consequents[fis.rules.tolist().index([0, 2, 2])] == kappa[4]
    assert fis.consequents[fis.rules.tolist().index([1, 0, 0])] == kappa[1]


def test_sugeno_at_set_centres_and_monotone():
    fis, kappa = _faekf_like()
    # at the centre of (Z, Z, Z) every S set has grade e = exp(-2.5^2 / 2) and B ~ 4e-6; with the min
    # AND the 7 rules built of Z and S fire with 1 (ZZZ) or e: hand evaluation of eq. 30
    # the 19 rules with a B set fire with b = exp(-5^2 / 2)
    e, b = math.exp(-3.125), math.exp(-12.5)
    has_b = (fis.rules == 2).any(axis=1)
    kb = fis.consequents[has_b].sum()
    assert fis([0.0, 0.0, 0.0]) == pytest.approx(
        (1 + e * (3 * 2 + 3 * 4 + 8) + b * kb) / (1 + 7 * e + 19 * b), rel=1e-13)
    # the product AND weighs rules with two S sets by e^2: closer to K1
    prod = fz.SugenoFIS(fis.mf_kind, fis.mf_params, fis.rules, fis.consequents, and_op="prod")
    assert prod([0.0, 0.0, 0.0]) == pytest.approx(
        (1 + 3 * e * 2 + 3 * e**2 * 4 + e**3 * 8) / (1 + 3 * e + 3 * e**2 + e**3), rel=1e-3)
    # more disturbance never lowers the scaling factor on this table
    a = np.linspace(0, 1, 50)
    out = fis(np.stack([np.full(50, 5.0), a, np.full(50, 0.3)], axis=1))
    assert np.all(np.diff(out) >= -1e-12)


def test_single_rule_and_fallbacks():
    params = np.array([[[0.0, 1.0, 2.0, 0.0], [2.0, 3.0, 4.0, 0.0]]])
    fis = fz.SugenoFIS("tri", params, [[0], [1]], [7.0, 11.0])
    assert fis([0.5]) == 7.0  # only rule 0 fires
    assert fis([2.0]) == 9.0  # x = 2 is a foot of both triangles: no rule fires, the mean
    assert fis([10.0]) == 9.0  # nothing fires: mean of the consequents
    fis_d = fz.SugenoFIS("tri", params, [[0], [1]], [7.0, 11.0], default=-1.0)
    assert fis_d([10.0]) == -1.0
    assert fis_d([1.5]) == 7.0
    assert fis_d([2.5]) == 11.0
    # a rule of only don't-cares always fires with strength 1
    fis_dc = fz.SugenoFIS("tri", params, [[0], [-1]], [7.0, 11.0])
    assert fis_dc([0.5]) == pytest.approx((0.5 * 7 + 11) / 1.5)


def test_sugeno_usable_inside_another_kernel():
    fis, _ = _faekf_like()

    @njit
    def run(X, kind, params, rules, cons):
        mu = np.empty(kind.shape)
        out = np.empty(X.shape[0])
        for k in range(X.shape[0]):
            fz.fuzzify(X[k], kind, params, mu)
            out[k] = fz.sugeno_mu(mu, rules, cons, fz.AND_MIN, np.nan)
        return out

    X = np.random.default_rng(3).uniform(0, 1, (10, 3)) * [10, 1, 1]
    np.testing.assert_allclose(run(X, fis.mf_kind, fis.mf_params, fis.rules, fis.consequents), fis(X),
                               rtol=1e-15)


def test_mamdani_matches_reference_and_symmetry():
    params = np.array([[[-1.0, 0.0, 1.0, 0], [0.0, 1.0, 2.0, 0]], [[-1.0, 0.0, 1.0, 0], [0.0, 1.0, 2.0, 0]]])
    rules = fz.grid_rules([2, 2])
    out_params = np.array([[-1.0, 0.0, 1.0], [0.0, 1.0, 2.0], [1.0, 2.0, 3.0]])
    rule_out = rules.sum(axis=1)
    m = fz.MamdaniFIS("tri", params, rules, "tri", out_params, rule_out, (-1.0, 3.0), n_points=401)
    rng = np.random.default_rng(4)
    y = np.linspace(-1.0, 3.0, 401)
    for x in rng.uniform(0, 1, (10, 2)):
        ref = mamdani_ref(x, m.mf_kind, m.mf_params, m.rules, m.out_kind, m.out_params, m.rule_out, y)
        assert m(x) == pytest.approx(ref, rel=1e-12)
    # only the middle output set is active at x = (0.5, 0.5)? no: all four rules fire at 0.5 and
    # the aggregate is symmetric about y = 1
    assert m([0.5, 0.5]) == pytest.approx(1.0, abs=1e-12)
    assert m([0.0, 0.0]) == pytest.approx(0.0, abs=1e-9)  # only the set centred on 0 fires


def test_surface_and_lookup_table():
    fis, _ = _faekf_like()
    gx, gy = np.linspace(0, 10, 7), np.linspace(0, 1, 5)
    Z = fz.surface(fis, gx, gy, inputs=(0, 2), others=[0, 0.3, 0])
    assert Z.shape == (7, 5)
    for i, xv in enumerate(gx):
        for j, yv in enumerate(gy):
            assert Z[i, j] == pytest.approx(fis([xv, 0.3, yv]), rel=1e-14)
    # a plain callable gives the same surface
    Zc = fz.surface(lambda x: fis(x), gx, gy, inputs=(0, 2), others=[0, 0.3, 0])
    np.testing.assert_allclose(Zc, Z, rtol=1e-14)
    T = fz.lookup_table(fis, (0, 10), (0, 1), shape=(7, 5), inputs=(0, 2), others=[0, 0.3, 0])
    np.testing.assert_allclose(T, Z, rtol=1e-14)
    with pytest.raises(ValueError):
        fz.lookup_table(fis, (1, 0), (0, 1))
    with pytest.raises(ValueError):
        fz.surface(fis, gx, gy, inputs=(0, 0))


def test_lut_interp_exact_for_bilinear_and_clamps():
    xr, yr = (-1.0, 3.0), (0.0, 2.0)
    gx, gy = np.linspace(*xr, 9), np.linspace(*yr, 5)
    f = lambda x, y: 1.0 + 2.0 * x - 3.0 * y + 0.5 * x * y
    T = f(gx[:, None], gy[None, :])
    rng = np.random.default_rng(5)
    for x, y in zip(rng.uniform(*xr, 50), rng.uniform(*yr, 50)):
        assert fz.lut_interp(T, xr, yr, x, y) == pytest.approx(f(x, y), abs=1e-12)
    assert fz.lut_interp(T, xr, yr, gx[3], gy[2]) == pytest.approx(T[3, 2], abs=1e-13)
    assert fz.lut_interp(T, xr, yr, 100.0, -5.0) == pytest.approx(f(3.0, 0.0), abs=1e-12)
    assert fz.lut_interp(T, np.array(xr), np.array(yr), -9.0, 9.0) == pytest.approx(f(-1.0, 2.0), abs=1e-12)


def test_validation_errors():
    params = np.zeros((1, 2, 2))
    params[0, :, 1] = 1.0
    with pytest.raises(ValueError, match="sigma"):
        fz.SugenoFIS("gauss", np.zeros((1, 2, 2)), [[0], [1]], [1.0, 2.0])
    with pytest.raises(ValueError, match="kind"):
        fz.SugenoFIS("bell", params, [[0], [1]], [1.0, 2.0])
    with pytest.raises(ValueError, match="rule set indices"):
        fz.SugenoFIS("gauss", params, [[0], [2]], [1.0, 2.0])
    with pytest.raises(ValueError, match="consequents"):
        fz.SugenoFIS("gauss", params, [[0], [1]], [1.0])
    with pytest.raises(ValueError, match="non-decreasing"):
        fz.SugenoFIS("tri", [[[0.0, 2.0, 1.0]]], [[0]], [1.0])
    with pytest.raises(ValueError, match="columns"):
        fz.SugenoFIS("gauss", params, [[0], [1]], [1.0, 2.0])([1.0, 2.0])
    np.testing.assert_array_equal(fz.as_mf_kind(["gauss", 2], 2, 3), [[0, 0, 0], [2, 2, 2]])
