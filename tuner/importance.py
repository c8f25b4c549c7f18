"""Parameter importance from a run's history: functional ANOVA of a fitted quadratic response surface.

Method. The searched parameters are taken in the optimiser's coordinates (the unit cube, log scale
already applied by :class:`tuner.space.Space`), centred, ``x = u - 1/2``. A quadratic model is fitted by
least squares to the ranks of the fitness of the successful evaluations (ranks, so that one huge
fitness or a penalty-like value does not decide the fit)::

    r(x) ~ c + sum_i b_i x_i + sum_i a_ii (x_i^2 - 1/12) + sum_{i<j} a_ij x_i x_j

Under the uniform distribution on the cube these basis functions are mutually orthogonal with zero
mean, so the model's variance splits exactly (functional ANOVA, Sobol 1993; Hutter et al. 2014 apply
the same split to a random forest in fANOVA):

- main effect of ``i``: ``b_i^2 / 12 + a_ii^2 / 180`` (``Var x = 1/12``, ``Var x^2 = 1/80 - 1/144``),
- interaction of ``i`` and ``j``: ``a_ij^2 / 144``.

A parameter's importance is its main effect plus half of each of its interactions, as a share of the
model's variance (the shares sum to 1). ``r2`` says how much of the ranks' variance the model explains:
a low ``r2`` means the ranking of parameters is a rough guide only. With few evaluations the model
drops the interactions (fewer than 2 evaluations per coefficient), then the squares; with fewer
evaluations than ``d + 3`` no importance is computed.

Why not a random forest: it needs scikit-learn (not a dependency) and a seed of its own; the quadratic
surface is cheap, deterministic and its decomposition is exact, at the price of missing effects a
quadratic cannot express (several valleys).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Importance", "quadratic_anova", "importance_caption"]


@dataclass(frozen=True)
class Importance:
    """Variance shares of a fitted quadratic model.

    Attributes
    ----------
    names : tuple of str
        The parameters, in input order.
    share : ndarray, shape (d,)
        Main effect plus half of each interaction, divided by the model's variance; sums to 1
        (all zeros when the model is constant).
    main : ndarray, shape (d,)
        Main-effect variances (model units squared).
    interaction : ndarray, shape (d, d)
        Symmetric interaction variances, zero diagonal.
    r2 : float
        Coefficient of determination of the fit (1 = the model reproduces the data).
    terms : str
        ``"quadratic with interactions"``, ``"quadratic"`` or ``"linear"``: the model that was fitted.
    n : int
        Evaluations used.
    """

    names: tuple[str, ...]
    share: np.ndarray
    main: np.ndarray
    interaction: np.ndarray
    r2: float
    terms: str
    n: int

    def order(self) -> list[str]:
        """Parameter names from the most to the least important (ties keep input order)."""
        idx = sorted(range(len(self.names)), key=lambda i: (-self.share[i], i))
        return [self.names[i] for i in idx]


def _ranks(y: np.ndarray) -> np.ndarray:
    """Average ranks (ties share their mean rank), 0-based."""
    order = np.argsort(y, kind="stable")
    r = np.empty(len(y))
    r[order] = np.arange(len(y), dtype=float)
    ys = y[order]
    i = 0
    while i < len(ys):  # ties: a few, in a short array; plain loop on the sorted values is fine
        j = i
        while j + 1 < len(ys) and ys[j + 1] == ys[i]:
            j += 1
        if j > i:
            r[order[i:j + 1]] = (i + j) / 2.0
        i = j + 1
    return r


def quadratic_anova(u: np.ndarray, y: np.ndarray, names: list[str] | tuple[str, ...] | None = None,
                    rank: bool = True) -> Importance | None:
    """Importance of each column of ``u`` for ``y`` (see the module docstring).

    Parameters
    ----------
    u : array, shape (n, d)
        Points in the unit cube (``Space.to_unit`` coordinates); rows with a non-finite value are dropped.
    y : array, shape (n,)
        Fitness of each point; non-finite values are dropped.
    names : sequence of str, optional
        Parameter names (default ``x0, x1, ...``).
    rank : bool
        Fit the ranks of ``y`` (default) instead of ``y`` itself.

    Returns
    -------
    Importance or None
        ``None`` with fewer than ``d + 3`` usable points or no parameter.
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if u.ndim != 2 or y.shape != (u.shape[0],):
        raise ValueError(f"u must be (n, d) and y (n,), got {u.shape} and {y.shape}")
    d = u.shape[1]
    names = tuple(names) if names is not None else tuple(f"x{i}" for i in range(d))
    if len(names) != d:
        raise ValueError(f"{len(names)} names for {d} columns")
    ok = np.isfinite(y) & np.isfinite(u).all(axis=1)
    u, y = u[ok], y[ok]
    n = len(y)
    if d == 0 or n < d + 3:
        return None
    t = _ranks(y) if rank else y
    x = u - 0.5
    pairs = [(i, j) for i in range(d) for j in range(i + 1, d)]
    n_full = 1 + 2 * d + len(pairs)
    if pairs and n >= 2 * n_full:
        terms = "quadratic with interactions"
    elif n >= 2 * (1 + 2 * d):
        terms, pairs = "quadratic", []
    else:
        terms, pairs = "linear", []
    cols = [np.ones(n)] + [x[:, i] for i in range(d)]
    if terms != "linear":
        cols += [x[:, i] ** 2 - 1.0 / 12.0 for i in range(d)]
    cols += [x[:, i] * x[:, j] for i, j in pairs]
    A = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(A, t, rcond=None)
    resid = t - A @ coef
    ss = float(np.sum((t - t.mean()) ** 2))
    r2 = 1.0 - float(resid @ resid) / ss if ss > 0 else 0.0
    b = coef[1:1 + d]
    a = coef[1 + d:1 + 2 * d] if terms != "linear" else np.zeros(d)
    main = b ** 2 / 12.0 + a ** 2 / 180.0
    inter = np.zeros((d, d))
    for k, (i, j) in enumerate(pairs):
        inter[i, j] = inter[j, i] = coef[1 + 2 * d + k] ** 2 / 144.0
    total = float(main.sum() + np.triu(inter, 1).sum())
    # a constant fitness has nothing to explain (its fitted coefficients are rounding noise)
    share = (main + 0.5 * inter.sum(axis=1)) / total if total > 0 and ss > 0 else np.zeros(d)
    return Importance(names, share, main, inter, r2, terms, n)


def importance_caption(imp: Importance) -> str:
    """What the importance numbers mean, in plain words (shown under the figure)."""
    top = imp.order()[0]
    fit = ("closely" if imp.r2 >= 0.8 else "roughly" if imp.r2 >= 0.4 else "poorly")
    return (f"How much of the change in fitness rank over the searched region each parameter explains. A "
            f"model ({imp.terms} terms) was fitted to the ranks of {imp.n} successful evaluations in the optimiser's "
            f"coordinates (log scale for log parameters), and its variance split into each parameter's own "
            f"effect plus half of its joint effects with others (functional ANOVA). The model follows the "
            f"data {fit} (R^2 = {imp.r2:.2f}). Here {top} matters most: changing it moves the fitness most. "
            f"A parameter with a small share can still matter near the optimum; the share describes the "
            f"searched region as the optimiser sampled it, not a causal effect.")
