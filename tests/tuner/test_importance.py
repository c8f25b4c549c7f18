"""Parameter importance (tuner.importance): the analytic functional-ANOVA split of a fitted quadratic,
checked against closed forms and against a Monte Carlo estimate of Sobol' indices (Saltelli 2010)."""

import numpy as np
import pytest

from tuner.importance import _ranks, importance_caption, quadratic_anova


def _model(u):
    x = u - 0.5
    return 3.0 * x[:, 0] + 2.0 * (x[:, 1] ** 2 - 1 / 12) + 4.0 * x[:, 0] * x[:, 2] + 0.0 * x[:, 3]


def test_closed_form_shares_of_an_exact_quadratic():
    rng = np.random.default_rng(1)
    u = rng.random((400, 4))
    imp = quadratic_anova(u, _model(u), ["a", "b", "c", "d"], rank=False)
    assert imp.terms == "quadratic with interactions" and imp.r2 == pytest.approx(1.0)
    main = np.array([9 / 12, 4 / 180, 0.0, 0.0])  # b^2/12 + a^2/180
    inter = 16 / 144  # a_ij^2 / 144 for (a, c)
    np.testing.assert_allclose(imp.main, main, atol=1e-10)
    assert imp.interaction[0, 2] == pytest.approx(inter) and imp.interaction[2, 0] == pytest.approx(inter)
    total = main.sum() + inter
    np.testing.assert_allclose(imp.share, [(main[0] + inter / 2) / total, main[1] / total, inter / 2 / total, 0.0],
                               atol=1e-10)
    assert imp.share.sum() == pytest.approx(1.0) and imp.order() == ["a", "c", "b", "d"]


def test_variance_split_matches_monte_carlo_sobol_indices():
    """First-order Sobol' index of each input of the fitted model = main effect / model variance."""
    rng = np.random.default_rng(2)
    u = rng.random((300, 4))
    imp = quadratic_anova(u, _model(u), rank=False)
    n = 200_000
    A, B = rng.random((n, 4)), rng.random((n, 4))
    fA, fB = _model(A), _model(B)
    var = np.var(np.concatenate([fA, fB]))
    total = imp.main.sum() + np.triu(imp.interaction, 1).sum()
    assert var == pytest.approx(total, rel=0.02)
    for i in range(4):
        ABi = A.copy()
        ABi[:, i] = B[:, i]
        s1 = np.mean(fB * (_model(ABi) - fA)) / var  # Saltelli 2010, eq. (b)
        assert s1 == pytest.approx(imp.main[i] / total, abs=0.01)


def test_few_points_drop_terms_and_too_few_give_none():
    rng = np.random.default_rng(3)
    u = rng.random((16, 3))
    y = u[:, 0]
    assert quadratic_anova(u, y).terms == "quadratic"  # 14 <= 16 < 2 * 10 coefficients with interactions
    assert quadratic_anova(u[:13], y[:13]).terms == "linear"
    assert quadratic_anova(u[:5], y[:5]) is None  # fewer than d + 3
    imp = quadratic_anova(u, y, ["x", "y", "z"])
    assert imp.order()[0] == "x" and imp.share[0] > 0.9


def test_ranks_make_it_robust_to_one_huge_value_and_nan_rows_are_dropped():
    rng = np.random.default_rng(4)
    u = rng.random((60, 2))
    y = (u[:, 1] - 0.3) ** 2
    y[0] = 1e12  # a penalty-like fitness
    y[1] = np.nan
    imp = quadratic_anova(u, y, ["flat", "steep"])
    assert imp.n == 59 and imp.order() == ["steep", "flat"] and imp.share[1] > 0.8
    assert "steep matters most" in importance_caption(imp) and "R^2" in importance_caption(imp)


def test_ties_share_their_mean_rank():
    np.testing.assert_allclose(_ranks(np.array([3.0, 1.0, 3.0, 2.0])), [2.5, 0.0, 2.5, 1.0])


def test_constant_fitness_has_zero_shares_and_bad_shapes_raise():
    u = np.random.default_rng(5).random((20, 2))
    imp = quadratic_anova(u, np.ones(20))
    assert imp.share.tolist() == [0.0, 0.0]
    with pytest.raises(ValueError, match="must be"):
        quadratic_anova(u, np.ones(19))
