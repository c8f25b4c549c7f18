"""Slow pure-Python fuzzy inference, written from the FAEKF paper's eqs. 28-31 for comparison with
``objectives.fuzzy``: memberships computed per rule, no shared scratch, no numba."""

from __future__ import annotations

import math


def mf(kind: int, p, x: float) -> float:
    if kind == 0:
        return math.exp(-((x - p[0]) ** 2) / (2.0 * p[1] ** 2))
    if kind == 1:
        a, b, c = p[0], p[1], p[2]
        left = 1.0 if x >= b and x >= a else ((x - a) / (b - a) if a <= x < b else 0.0)
        right = 1.0 if x <= b and x <= c else ((c - x) / (c - b) if b < x <= c else 0.0)
        return min(left, right)
    a, b, c, d = p[0], p[1], p[2], p[3]
    left = 1.0 if x >= b else ((x - a) / (b - a) if x >= a else 0.0)
    right = 1.0 if x <= c else ((d - x) / (d - c) if x <= d else 0.0)
    return min(left, right)


def sugeno_ref(x, mf_kind, mf_params, rules, consequents, and_op="min", default=None) -> float:
    """Eq. 30 with firing strengths by eq. 29 (min) or the product."""
    num = den = 0.0
    for r, kappa in zip(rules, consequents):
        grades = [mf(int(mf_kind[j][s]), mf_params[j][s], float(x[j])) for j, s in enumerate(r) if s >= 0]
        w = 1.0
        for g in grades:
            w = min(w, g) if and_op == "min" else w * g
        num += kappa * w
        den += w
    if den > 0:
        return num / den
    return default if default is not None else sum(consequents) / len(consequents)


def mamdani_ref(x, mf_kind, mf_params, rules, out_kind, out_params, rule_out, y_grid) -> float:
    """Min implication, max aggregation, discrete centroid."""
    ws = []
    for r in rules:
        grades = [mf(int(mf_kind[j][s]), mf_params[j][s], float(x[j])) for j, s in enumerate(r) if s >= 0]
        ws.append(min(grades or [1.0]))
    num = den = 0.0
    for y in y_grid:
        agg = max(min(w, mf(int(out_kind[o]), out_params[o], float(y))) for w, o in zip(ws, rule_out))
        num += agg * y
        den += agg
    return num / den
