"""Fuzzy inference in numba: membership functions, zero-order Sugeno and Mamdani systems, look-up tables.

Used by the fuzzy-adaptive filters (AKF1D, FAEKF: noise covariance scaling factors) and by the fuzzy
controllers. Every ``@njit`` function here can be called from other ``@njit`` kernels.

Membership functions (scalar, ``@njit``)
----------------------------------------
``gaussmf(x, c, sigma) = exp(-(x - c)^2 / (2 sigma^2))`` (FAEKF paper eq. 28), ``trimf(x, a, b, c)``
and ``trapmf(x, a, b, c, d)`` (MATLAB's definitions). Shoulders are allowed: ``a == b`` gives a set
that is 1 from ``b`` on its left edge inclusive (a left shoulder when ``a`` is below the universe,
e.g. ``trapmf(x, -inf, -inf, c, d)`` is 1 for every ``x <= c``), ``c == d`` the mirror image.

Data layout of a system (a "rule table given as arrays")
--------------------------------------------------------
``n_in`` inputs, each with up to ``n_sets`` fuzzy sets (inputs with fewer sets leave the trailing
rows unused), ``n_rules`` rules:

``mf_kind`` : (n_in, n_sets) int64
    Kind of each set: ``GAUSS = 0`` (params ``c, sigma``), ``TRI = 1`` (``a, b, c``), ``TRAP = 2``
    (``a, b, c, d``). :func:`as_mf_kind` broadcasts one code, one code per input, or a full table.
``mf_params`` : (n_in, n_sets, 4) float64
    Parameters of each set; unused trailing entries are ignored.
``rules`` : (n_rules, n_in) int64
    Antecedent set index of each input in each rule; ``-1`` means "don't care" (the input does not
    take part in that rule). :func:`grid_rules` builds the full grid (first input varies slowest,
    the order of the FAEKF paper's Table 1 and of thesis Table 3.2).
``consequents`` : (n_rules,) float64
    Zero-order Sugeno singletons (``kappa^i`` of eq. 30).

Inference (FAEKF paper eqs. 28-31, thesis section 3.1.4)
--------------------------------------------------------
With crisp inputs (singleton fuzzification) eq. 28's sup-min ``max_chi min(X*(chi), X^i(chi))``
reduces to the membership value ``X^i(x)``. The firing strength of rule ``i`` is the AND over its
inputs, ``min`` (eq. 29; ``AND_MIN = 0``) or the product (``AND_PROD = 1``); the output is the weighted
average of the singletons (eq. 30). If no rule fires (total strength 0, e.g. an input far outside
every triangular set) the output is ``default`` when it is finite, otherwise the mean of the
consequents (a neutral value documented as the fallback).

Hot loops should fuzzify once into preallocated scratch (:func:`fuzzify`, ``mu`` of shape
(n_in, n_sets)) and call :func:`sugeno_mu`: each set's membership is then computed once per sample
instead of once per rule (9 instead of 81 Gaussians for the 27-rule FAEKF) and nothing is allocated.
:func:`sugeno` is the convenient form that allocates ``mu`` itself.

Mamdani
-------
:func:`mamdani_mu` / :func:`mamdani`: rule ``i`` points at an output set ``rule_out[i]``; implication
``min``, aggregation ``max``, defuzzification by the centroid over a discretised output universe
``y_grid`` (cost O(n_rules * len(y_grid)) per call).

Surfaces and look-up tables
---------------------------
:func:`surface` evaluates a system (a :class:`SugenoFIS`, a :class:`MamdaniFIS` or any callable
``f(x: (n_in,) array) -> float``) on a grid of two of its inputs (others held at given values):
``Z[i, j] = f(x = grid_x[i], y = grid_y[j])``, shape ``(len(grid_x), len(grid_y))`` (transpose for
``matplotlib.contourf(X, Y, Z.T)``). :func:`lookup_table` does the same on uniform grids over
``x_range`` x ``y_range``, and :func:`lut_interp` (``@njit``) interpolates such a table bilinearly,
clamping inputs to the table's ranges: the form a LUT controller runs on a microcontroller.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

__all__ = [
    "GAUSS", "TRI", "TRAP", "AND_MIN", "AND_PROD",
    "gaussmf", "trimf", "trapmf", "membership", "fuzzify", "firing", "sugeno_mu", "sugeno",
    "mamdani_mu", "mamdani", "lut_interp",
    "as_mf_kind", "grid_rules", "SugenoFIS", "MamdaniFIS", "surface", "lookup_table",
]

GAUSS = 0
TRI = 1
TRAP = 2
AND_MIN = 0
AND_PROD = 1

_KIND_NAMES = {"gauss": GAUSS, "gaussmf": GAUSS, "tri": TRI, "trimf": TRI, "trap": TRAP, "trapmf": TRAP}


# --- membership functions ---------------------------------------------------------------------
@njit(cache=True, inline="always")
def gaussmf(x, c, sigma):
    """Gaussian set ``exp(-(x - c)^2 / (2 sigma^2))`` (FAEKF paper eq. 28); ``sigma > 0``."""
    z = (x - c) / sigma
    return math.exp(-0.5 * z * z)


@njit(cache=True, inline="always")
def trapmf(x, a, b, c, d):
    """Trapezoid with feet ``a``, ``d`` and plateau ``[b, c]`` (``a <= b <= c <= d``).

    Shoulders: ``a == b`` makes the left edge vertical, ``c == d`` the right edge; with infinite
    ``a = b = -inf`` the set is 1 for every ``x <= c`` (an open left shoulder), likewise ``d = c = inf``.
    """
    if x < a or x > d:
        return 0.0
    if x < b:
        return (x - a) / (b - a)
    if x > c:
        return (d - x) / (d - c)
    return 1.0


@njit(cache=True, inline="always")
def trimf(x, a, b, c):
    """Triangle with feet ``a``, ``c`` and peak ``b`` (``a <= b <= c``); ``a == b`` or ``b == c`` give
    a right-angled triangle (value 1 at the peak)."""
    return trapmf(x, a, b, b, c)  # a trapezoid with a one-point plateau


@njit(cache=True, inline="always")
def membership(kind, p, x):
    """Membership of ``x`` in a set of ``kind`` (GAUSS/TRI/TRAP) with parameters ``p`` (4,)."""
    if kind == GAUSS:
        return gaussmf(x, p[0], p[1])
    if kind == TRI:
        return trimf(x, p[0], p[1], p[2])
    return trapmf(x, p[0], p[1], p[2], p[3])


# --- Sugeno ------------------------------------------------------------------------------------
@njit
def fuzzify(x, mf_kind, mf_params, mu):
    """Membership of every input in every set: ``mu[j, s]`` (writes into ``mu``, (n_in, n_sets))."""
    n_in, n_sets = mf_kind.shape
    for j in range(n_in):
        for s in range(n_sets):
            mu[j, s] = membership(mf_kind[j, s], mf_params[j, s], x[j])


@njit(cache=True, inline="always")
def firing(mu, rules, i, and_op):
    """Firing strength of rule ``i`` from memberships ``mu`` (eq. 29 for ``AND_MIN``).

    Inputs marked ``-1`` (don't care) are skipped; a rule of only don't-cares fires with 1.
    """
    w = 1.0
    for j in range(rules.shape[1]):
        s = rules[i, j]
        if s < 0:
            continue
        m = mu[j, s]
        if and_op == AND_PROD:
            w *= m
        elif m < w:
            w = m
    return w


@njit
def sugeno_mu(mu, rules, consequents, and_op=AND_MIN, default=np.nan):
    """Zero-order Sugeno output from precomputed memberships (FAEKF paper eqs. 29-30).

    Parameters
    ----------
    mu : (n_in, n_sets) float64, from :func:`fuzzify`.
    rules : (n_rules, n_in) int64, set indices, -1 = don't care.
    consequents : (n_rules,) float64 singletons.
    and_op : AND_MIN (0, eq. 29) or AND_PROD (1).
    default : output when no rule fires; NaN (the default) means the mean of ``consequents``.
    """
    num = 0.0
    den = 0.0
    for i in range(rules.shape[0]):
        w = firing(mu, rules, i, and_op)
        num += w * consequents[i]
        den += w
    if den > 0.0:
        return num / den
    if not math.isnan(default):
        return default
    return np.mean(consequents)


@njit(cache=True)
def sugeno(x, mf_kind, mf_params, rules, consequents, and_op=AND_MIN, default=np.nan):
    """Zero-order Sugeno system (FAEKF paper eqs. 28-31) at the crisp input ``x`` (n_in,).

    See the module docstring for the array layout. Allocates an (n_in, n_sets) scratch array per
    call; in per-sample loops use :func:`fuzzify` + :func:`sugeno_mu` with preallocated scratch.
    """
    mu = np.empty(mf_kind.shape)
    fuzzify(x, mf_kind, mf_params, mu)
    return sugeno_mu(mu, rules, consequents, and_op, default)


# --- Mamdani -----------------------------------------------------------------------------------
@njit
def mamdani_mu(mu, rules, out_kind, out_params, rule_out, y_grid, and_op=AND_MIN, default=np.nan):
    """Mamdani system (min implication, max aggregation, centroid) from memberships ``mu``.

    Parameters
    ----------
    mu : (n_in, n_sets) memberships from :func:`fuzzify`.
    rules : (n_rules, n_in) int64 antecedents (-1 = don't care).
    out_kind : (n_out,) int64 kinds of the output sets; out_params : (n_out, 4).
    rule_out : (n_rules,) int64 output set of each rule.
    y_grid : (M,) discretised output universe, increasing (uniform spacing assumed for the centroid).
    default : output when the aggregated set is empty; NaN means the middle of ``y_grid``.
    """
    num = 0.0
    den = 0.0
    n_rules = rules.shape[0]
    for k in range(y_grid.shape[0]):
        y = y_grid[k]
        agg = 0.0
        for i in range(n_rules):
            w = firing(mu, rules, i, and_op)
            if w <= agg:
                continue
            o = rule_out[i]
            m = membership(out_kind[o], out_params[o], y)
            if m < w:
                w = m
            if w > agg:
                agg = w
        num += agg * y
        den += agg
    if den > 0.0:
        return num / den
    if not math.isnan(default):
        return default
    return 0.5 * (y_grid[0] + y_grid[y_grid.shape[0] - 1])


@njit(cache=True)
def mamdani(x, mf_kind, mf_params, rules, out_kind, out_params, rule_out, y_grid, and_op=AND_MIN,
            default=np.nan):
    """Mamdani system at the crisp input ``x`` (allocates its scratch; see :func:`mamdani_mu`)."""
    mu = np.empty(mf_kind.shape)
    fuzzify(x, mf_kind, mf_params, mu)
    return mamdani_mu(mu, rules, out_kind, out_params, rule_out, y_grid, and_op, default)


# --- look-up tables ----------------------------------------------------------------------------
@njit
def lut_interp(table, x_range, y_range, x, y):
    """Bilinear interpolation in ``table`` (nx, ny) sampled uniformly on ``x_range`` x ``y_range``.

    ``table[i, j]`` is the value at ``x_range[0] + i * dx``, ``y_range[0] + j * dy``; inputs outside
    the ranges are clamped to the edges (a LUT controller saturates its inputs). ``x_range`` and
    ``y_range`` are ``(low, high)`` tuples or (2,) arrays. Needs ``nx, ny >= 2``.
    """
    nx, ny = table.shape
    x0 = x_range[0]
    y0 = y_range[0]
    fx = (x - x0) / (x_range[1] - x0) * (nx - 1)
    fy = (y - y0) / (y_range[1] - y0) * (ny - 1)
    if not fx > 0.0:  # also maps NaN to the edge rather than indexing with it
        fx = 0.0
    elif fx > nx - 1:
        fx = nx - 1.0
    if not fy > 0.0:
        fy = 0.0
    elif fy > ny - 1:
        fy = ny - 1.0
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    tx = fx - i
    ty = fy - j
    return ((1.0 - tx) * ((1.0 - ty) * table[i, j] + ty * table[i, j + 1])
            + tx * ((1.0 - ty) * table[i + 1, j] + ty * table[i + 1, j + 1]))


@njit(cache=True)
def _sugeno_grid(grid_x, grid_y, ix, iy, base, mf_kind, mf_params, rules, consequents, and_op, default,
                 out):
    x = base.copy()
    mu = np.empty(mf_kind.shape)
    for a in range(grid_x.shape[0]):
        x[ix] = grid_x[a]
        for b in range(grid_y.shape[0]):
            x[iy] = grid_y[b]
            fuzzify(x, mf_kind, mf_params, mu)
            out[a, b] = sugeno_mu(mu, rules, consequents, and_op, default)


@njit(cache=True)
def _sugeno_batch(X, mf_kind, mf_params, rules, consequents, and_op, default, out):
    mu = np.empty(mf_kind.shape)
    for k in range(X.shape[0]):
        fuzzify(X[k], mf_kind, mf_params, mu)
        out[k] = sugeno_mu(mu, rules, consequents, and_op, default)


# --- Python-side construction and validation ---------------------------------------------------
def as_mf_kind(kind: Any, n_in: int, n_sets: int) -> np.ndarray:
    """Broadcast set kinds to the (n_in, n_sets) int64 table the kernels take.

    ``kind`` may be one code or name (``0``/``"gauss"``, ``1``/``"tri"``, ``2``/``"trap"``), one per
    input (length ``n_in``), or a full (n_in, n_sets) table.
    """
    def code(k: Any) -> int:
        if isinstance(k, str):
            if k.lower() not in _KIND_NAMES:
                raise ValueError(f"unknown membership kind {k!r}; known: {sorted(_KIND_NAMES)}")
            return _KIND_NAMES[k.lower()]
        k = int(k)
        if k not in (GAUSS, TRI, TRAP):
            raise ValueError(f"membership kind code must be 0 (gauss), 1 (tri) or 2 (trap), got {k}")
        return k

    arr = np.asarray(kind, dtype=object)
    if arr.ndim == 0:
        return np.full((n_in, n_sets), code(arr.item()), dtype=np.int64)
    codes = np.vectorize(code, otypes=[np.int64])(arr)
    if codes.shape == (n_in,):
        return np.repeat(codes[:, None], n_sets, axis=1).astype(np.int64)
    if codes.shape == (n_in, n_sets):
        return np.ascontiguousarray(codes, dtype=np.int64)
    raise ValueError(f"mf_kind must be a scalar, ({n_in},) or ({n_in}, {n_sets}), got shape {codes.shape}")


def grid_rules(n_sets: Sequence[int]) -> np.ndarray:
    """All combinations of set indices, first input varying slowest: (prod(n_sets), len(n_sets)).

    ``grid_rules([3, 3, 3])`` is the antecedent table of the FAEKF paper's 27 rules in the order of
    its Table 1 read as ``(f, a_ext, h_ext)``.
    """
    grids = np.meshgrid(*[np.arange(int(n)) for n in n_sets], indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1).astype(np.int64)


def _check_sets(mf_kind: np.ndarray, mf_params: np.ndarray, rules: np.ndarray) -> None:
    n_in, n_sets = mf_kind.shape
    if mf_params.shape != (n_in, n_sets, 4):
        raise ValueError(f"mf_params must have shape ({n_in}, {n_sets}, 4), got {mf_params.shape}")
    if rules.ndim != 2 or rules.shape[1] != n_in:
        raise ValueError(f"rules must have shape (n_rules, {n_in}), got {rules.shape}")
    if rules.size and (rules.min() < -1 or rules.max() >= n_sets):
        raise ValueError(f"rule set indices must be in [-1, {n_sets - 1}], got {rules.min()}..{rules.max()}")
    for j in range(n_in):
        used = np.unique(rules[:, j][rules[:, j] >= 0])
        for s in used:
            k, p = mf_kind[j, s], mf_params[j, s]
            if k == GAUSS:
                if not (np.isfinite(p[0]) and np.isfinite(p[1]) and p[1] > 0):
                    raise ValueError(f"input {j} set {s}: Gaussian needs finite c and sigma > 0, got {p[:2]}")
            else:
                q = p[:3] if k == TRI else p
                if np.any(np.isnan(q)) or np.any(q[1:] < q[:-1]):
                    raise ValueError(f"input {j} set {s}: {'tri' if k == TRI else 'trap'} parameters must "
                                     f"be non-decreasing, got {q}")


@dataclass(frozen=True, eq=False)
class SugenoFIS:
    """A validated zero-order Sugeno system (arrays as in the module docstring).

    Parameters
    ----------
    mf_kind : scalar, (n_in,) or (n_in, n_sets) set kinds (see :func:`as_mf_kind`).
    mf_params : (n_in, n_sets, k<=4) set parameters (padded with zeros to 4).
    rules : (n_rules, n_in) int set indices (-1 = don't care).
    consequents : (n_rules,) singletons.
    and_op : "min" (FAEKF eq. 29) or "prod".
    default : output when no rule fires; None = the mean of the consequents.

    Call it with one input ``(n_in,)`` or a batch ``(M, n_in)``.
    """

    mf_kind: Any
    mf_params: Any
    rules: Any
    consequents: Any
    and_op: str = "min"
    default: float | None = None

    def __post_init__(self) -> None:
        p = np.asarray(self.mf_params, dtype=float)
        if p.ndim != 3 or p.shape[2] > 4:
            raise ValueError(f"mf_params must have shape (n_in, n_sets, <=4), got {p.shape}")
        p = np.ascontiguousarray(np.pad(p, ((0, 0), (0, 0), (0, 4 - p.shape[2]))))
        kind = as_mf_kind(self.mf_kind, p.shape[0], p.shape[1])
        rules = np.ascontiguousarray(np.asarray(self.rules, dtype=np.int64))
        cons = np.ascontiguousarray(np.asarray(self.consequents, dtype=float).reshape(-1))
        _check_sets(kind, p, rules)
        if cons.shape != (rules.shape[0],) or not np.all(np.isfinite(cons)):
            raise ValueError(f"consequents must be {rules.shape[0]} finite values, got {cons}")
        if self.and_op not in ("min", "prod"):
            raise ValueError(f"and_op must be 'min' or 'prod', got {self.and_op!r}")
        for name, val in (("mf_kind", kind), ("mf_params", p), ("rules", rules), ("consequents", cons)):
            object.__setattr__(self, name, val)

    @property
    def n_in(self) -> int:
        return self.mf_kind.shape[0]

    @property
    def and_code(self) -> int:
        return AND_MIN if self.and_op == "min" else AND_PROD

    @property
    def default_value(self) -> float:
        return np.nan if self.default is None else float(self.default)

    def kernel_args(self) -> tuple:
        """``(mf_kind, mf_params, rules, consequents, and_op, default)`` for :func:`sugeno`."""
        return (self.mf_kind, self.mf_params, self.rules, self.consequents, self.and_code,
                self.default_value)

    def __call__(self, x: Any) -> float | np.ndarray:
        X = np.asarray(x, dtype=float)
        single = X.ndim == 1
        X = np.ascontiguousarray(np.atleast_2d(X))
        if X.shape[1] != self.n_in:
            raise ValueError(f"input must have {self.n_in} columns, got shape {np.shape(x)}")
        out = np.empty(X.shape[0])
        _sugeno_batch(X, *self.kernel_args(), out)
        return float(out[0]) if single else out


@dataclass(frozen=True, eq=False)
class MamdaniFIS:
    """A validated Mamdani system: antecedents as :class:`SugenoFIS`, output sets and a y grid.

    Parameters
    ----------
    mf_kind, mf_params, rules : as :class:`SugenoFIS`.
    out_kind : scalar or (n_out,) output set kinds; out_params : (n_out, k<=4).
    rule_out : (n_rules,) int output set of each rule.
    y_range : (low, high) output universe, discretised into ``n_points`` for the centroid.
    """

    mf_kind: Any
    mf_params: Any
    rules: Any
    out_kind: Any
    out_params: Any
    rule_out: Any
    y_range: tuple[float, float]
    n_points: int = 201
    and_op: str = "min"
    default: float | None = None

    def __post_init__(self) -> None:
        ant = SugenoFIS(self.mf_kind, self.mf_params, self.rules, np.zeros(len(np.asarray(self.rules))))
        op = np.asarray(self.out_params, dtype=float)
        if op.ndim != 2 or op.shape[1] > 4:
            raise ValueError(f"out_params must have shape (n_out, <=4), got {op.shape}")
        op = np.ascontiguousarray(np.pad(op, ((0, 0), (0, 4 - op.shape[1]))))
        ok = as_mf_kind(self.out_kind, op.shape[0], 1)[:, 0].copy()
        ro = np.ascontiguousarray(np.asarray(self.rule_out, dtype=np.int64).reshape(-1))
        if ro.shape != (ant.rules.shape[0],) or ro.min() < 0 or ro.max() >= op.shape[0]:
            raise ValueError(f"rule_out must hold {ant.rules.shape[0]} indices in [0, {op.shape[0] - 1}]")
        lo, hi = map(float, self.y_range)
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi) or int(self.n_points) < 2:
            raise ValueError(f"need finite y_range low < high and n_points >= 2, got {self.y_range}, "
                             f"{self.n_points}")
        if self.and_op not in ("min", "prod"):
            raise ValueError(f"and_op must be 'min' or 'prod', got {self.and_op!r}")
        for name, val in (("mf_kind", ant.mf_kind), ("mf_params", ant.mf_params), ("rules", ant.rules),
                          ("out_kind", ok), ("out_params", op), ("rule_out", ro)):
            object.__setattr__(self, name, val)
        object.__setattr__(self, "_y", np.linspace(lo, hi, int(self.n_points)))

    @property
    def n_in(self) -> int:
        return self.mf_kind.shape[0]

    def kernel_args(self) -> tuple:
        """Arguments after ``x`` of :func:`mamdani`."""
        return (self.mf_kind, self.mf_params, self.rules, self.out_kind, self.out_params, self.rule_out,
                self._y, AND_MIN if self.and_op == "min" else AND_PROD,
                np.nan if self.default is None else float(self.default))

    def __call__(self, x: Any) -> float | np.ndarray:
        X = np.asarray(x, dtype=float)
        single = X.ndim == 1
        X = np.atleast_2d(X)
        if X.shape[1] != self.n_in:
            raise ValueError(f"input must have {self.n_in} columns, got shape {np.shape(x)}")
        args = self.kernel_args()
        out = np.array([mamdani(np.ascontiguousarray(r), *args) for r in X])
        return float(out[0]) if single else out


def surface(fis: SugenoFIS | MamdaniFIS | Callable[[np.ndarray], float], grid_x: Any, grid_y: Any,
            inputs: tuple[int, int] = (0, 1), others: Any = None) -> np.ndarray:
    """Evaluate a system over a grid of two of its inputs.

    Parameters
    ----------
    fis : SugenoFIS, MamdaniFIS, or a callable ``f(x: (n_in,) ndarray) -> float``.
    grid_x, grid_y : (nx,), (ny,) values of the inputs ``inputs[0]`` and ``inputs[1]``.
    inputs : which two inputs vary.
    others : (n_in,) values of all inputs; the varying entries are overwritten. Default zeros
        (n_in = 2 for a plain callable unless ``others`` says otherwise).

    Returns
    -------
    Z : (nx, ny), ``Z[i, j] = f(x=grid_x[i], y=grid_y[j])``.
    """
    gx = np.ascontiguousarray(np.asarray(grid_x, dtype=float).reshape(-1))
    gy = np.ascontiguousarray(np.asarray(grid_y, dtype=float).reshape(-1))
    n_in = getattr(fis, "n_in", None) or (len(others) if others is not None else 2)
    base = np.zeros(n_in) if others is None else np.array(others, dtype=float).reshape(-1)
    ix, iy = (int(i) for i in inputs)
    if base.shape != (n_in,) or not (0 <= ix < n_in and 0 <= iy < n_in) or ix == iy:
        raise ValueError(f"need two distinct inputs in [0, {n_in}) and others of length {n_in}, "
                         f"got inputs={inputs}, others shape {base.shape}")
    out = np.empty((gx.size, gy.size))
    if isinstance(fis, SugenoFIS):
        _sugeno_grid(gx, gy, ix, iy, base, *fis.kernel_args(), out)
        return out
    x = base.copy()
    for a, xv in enumerate(gx):
        x[ix] = xv
        for b, yv in enumerate(gy):
            x[iy] = yv
            out[a, b] = fis(x.copy())
    return out


def lookup_table(fis: SugenoFIS | MamdaniFIS | Callable[[np.ndarray], float], x_range: tuple[float, float],
                 y_range: tuple[float, float], shape: tuple[int, int] = (21, 21),
                 inputs: tuple[int, int] = (0, 1), others: Any = None) -> np.ndarray:
    """A (nx, ny) table of ``fis`` on uniform grids over ``x_range`` x ``y_range`` for :func:`lut_interp`."""
    nx, ny = (int(s) for s in shape)
    for name, (lo, hi), n in (("x_range", x_range, nx), ("y_range", y_range, ny)):
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi) or n < 2:
            raise ValueError(f"{name} must be finite (low, high) with low < high and >= 2 points, "
                             f"got {(lo, hi)} with {n} points")
    return surface(fis, np.linspace(*x_range, nx), np.linspace(*y_range, ny), inputs, others)
