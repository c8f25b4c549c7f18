"""LTI plants from YAML: ``tf``, ``zpk`` or ``ss``, continuous or discrete, with an input delay.

YAML (``objective.plant``)::

    {tf: {num: [2.0], den: [0.5, 1.0]}}                 # 2 / (0.5 s + 1)
    {zpk: {z: [], p: [-1, -2], k: 2.0}}
    {ss: {A: [[0, 1], [0, -2]], B: [[0], [1]], C: [[1, 0]], D: [[0]]}, x0: [0, 0]}
    # options of every LTI plant:
    dt: 0.01          # the model is discrete with this period (absent: continuous)
    delay_s: 0.2      # input delay (s), a whole number of controller periods
    method: zoh       # discretisation at the controller period: zoh | tustin
    output: 0         # the output the loop controls (index into y)
    inner_output: 1   # the inner loop's output (cascaded PID only)

The continuous model is discretised at the controller period with python-control
(``control.sample_system``); a discrete model must already have the controller period. The delay is
``d = delay_s / period`` samples of the plant input. The discrete model is what the closed-loop kernel
runs (``x[k+1] = Ad x[k] + Bd u[k-d]``, ``y[k] = Cd x[k] + Dd u[k-1-d]``: the output sampled before the
new input acts, so a feedthrough ``D`` never makes an algebraic loop).
"""

from __future__ import annotations

import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from objectives.control.plants.base import DiscreteLTI, PlantKind
from tuner.sizes import MAX_LOOP_STATES, MAX_MODEL_ORDER, check_count

__all__ = ["LTIPlant", "lti_from_spec", "LTI_KEYS", "TF", "ZPK", "SS"]

#: the model keys (exactly one is given)
MODELS = ("tf", "zpk", "ss")
#: every key an LTI plant spec may hold
LTI_KEYS = {*MODELS, "dt", "delay_s", "method", "output", "inner_output", "x0"}


@dataclass(frozen=True)
class LTIPlant(DiscreteLTI):
    """A discrete LTI plant at the controller period (the :class:`~objectives.control.plants.base.DiscreteLTI`
    variant of the ``Plant`` protocol).

    Attributes
    ----------
    Ad, Bd, Cd, Dd : (n, n), (n, m), (p, n), (p, m) float64
        Discrete state space at ``period_s``.
    period_s : float
        Controller period (s).
    delay_n : int
        Input delay in periods.
    x0 : (n,) float64
        Initial state.
    model : str
        What the YAML gave (``tf``, ``zpk``, ``ss``), with ``continuous`` telling whether it was.
    """

    Ad: np.ndarray
    Bd: np.ndarray
    Cd: np.ndarray
    Dd: np.ndarray
    period_s: float
    delay_n: int
    x0: np.ndarray
    model: str
    continuous: bool
    method: str
    output: int = 0
    inner_output: int = -1


def _matrix(key: str, value: Any, rows: int | None = None, cols: int | None = None) -> np.ndarray:
    """``value`` as a finite 2-D float array of the given shape; ValueError naming ``key`` otherwise."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected a matrix (list of rows of numbers), got {value!r}") from None
    if arr.ndim == 1 and arr.size and (rows == 1 or cols == 1):
        arr = arr.reshape((1, -1) if rows == 1 else (-1, 1))
    if arr.ndim != 2 or not np.all(np.isfinite(arr)):
        raise ValueError(f"{key}: expected a 2-D matrix of finite numbers, got {value!r}")
    want = (rows if rows is not None else arr.shape[0], cols if cols is not None else arr.shape[1])
    if arr.shape != want:
        raise ValueError(f"{key}: shape {arr.shape[0]}x{arr.shape[1]} does not fit; expected {want[0]}x{want[1]}")
    return arr


def _vector(key: str, value: Any, allow_empty: bool = False) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected a list of numbers, got {value!r}") from None
    if (arr.size == 0 and not allow_empty) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{key}: expected a non-empty list of finite numbers, got {value!r}")
    return arr


def _system(spec: Mapping[str, Any], key: str, dt: float | None):
    """The python-control system of the model ``spec`` (validated)."""
    import control

    kind = [m for m in MODELS if m in spec]
    if len(kind) != 1:
        raise ValueError(f"{key}: give exactly one model of {list(MODELS)}, got {sorted(spec)}")
    kind = kind[0]
    body = spec[kind]
    where = f"{key}.{kind}"
    if not isinstance(body, Mapping):
        raise ValueError(f"{where}: expected a mapping, got {body!r}")
    cdt = 0 if dt is None else dt
    if kind == "tf":
        if set(body) != {"num", "den"}:
            raise ValueError(f"{where}: needs exactly the keys num, den (highest power first), got {sorted(body)}")
        num, den = _vector(f"{where}.num", body["num"]), _vector(f"{where}.den", body["den"])
        num, den = np.trim_zeros(num, "f"), np.trim_zeros(den, "f")
        if den.size == 0:
            raise ValueError(f"{where}.den: the denominator is zero")
        if num.size > den.size:
            raise ValueError(f"{where}: not proper (numerator degree {num.size - 1} > denominator degree "
                             f"{den.size - 1}); a physical plant needs deg num <= deg den")
        if num.size == 0:
            raise ValueError(f"{where}.num: the numerator is zero (the plant has no effect)")
        check_count(f"{where}.den", den.size - 1, MAX_MODEL_ORDER, "the model's order")
        return kind, control.ss(control.tf(num, den, cdt))
    if kind == "zpk":
        if not {"p", "k"} <= set(body) <= {"z", "p", "k"}:
            raise ValueError(f"{where}: needs keys p, k and optionally z, got {sorted(body)}")
        zeros = _vector(f"{where}.z", body.get("z", []), allow_empty=True)
        poles = _vector(f"{where}.p", body["p"], allow_empty=True)
        if zeros.size > poles.size:
            raise ValueError(f"{where}: not proper ({zeros.size} zeros > {poles.size} poles)")
        check_count(f"{where}.p", poles.size, MAX_MODEL_ORDER, "the model's order (poles)")
        k = float(_vector(f"{where}.k", [body["k"]])[0])
        if k == 0:
            raise ValueError(f"{where}.k: the gain is zero (the plant has no effect)")
        num, den = k * np.poly(zeros), np.poly(poles)
        return kind, control.ss(control.tf(np.atleast_1d(num), np.atleast_1d(den), cdt))
    if not {"A", "B", "C"} <= set(body) <= {"A", "B", "C", "D"}:
        raise ValueError(f"{where}: needs keys A, B, C and optionally D, got {sorted(body)}")
    a = _matrix(f"{where}.A", body["A"])
    n = a.shape[0]
    check_count(f"{where}.A", n, MAX_MODEL_ORDER, "the model's order (rows of A)")
    if a.shape != (n, n) or n == 0:
        raise ValueError(f"{where}.A: must be square n x n with n >= 1, got {a.shape[0]}x{a.shape[1]}")
    b = _matrix(f"{where}.B", body["B"], rows=n)
    c = _matrix(f"{where}.C", body["C"], cols=n)
    d = _matrix(f"{where}.D", body.get("D", np.zeros((c.shape[0], b.shape[1]))), rows=c.shape[0], cols=b.shape[1])
    return kind, control.ss(a, b, c, d, cdt)


def lti_from_spec(spec: Mapping[str, Any], period_s: float, base_dir: pathlib.Path | None = None,
                  key: str = "objective.plant") -> LTIPlant:
    """Build and discretise the plant of ``spec`` (its keys among :data:`LTI_KEYS`, checked by
    :func:`~objectives.control.plants.plant_kind`) at ``period_s``; ``ValueError`` naming the key otherwise.
    ``base_dir`` is unused (a model given inline reads no file): the signature of every plant builder."""
    import control

    dt = spec.get("dt")
    if dt is not None and not (isinstance(dt, (int, float)) and dt > 0):
        raise ValueError(f"{key}.dt: the discrete model's period must be > 0 s, got {dt!r}")
    kind, sys = _system(spec, key, None if dt is None else float(dt))
    method = spec.get("method", "zoh")
    if method not in ("zoh", "tustin"):
        raise ValueError(f"{key}.method: must be zoh or tustin, got {method!r}")
    if dt is None:
        dsys = control.sample_system(sys, period_s, method=method)
    else:
        if not math.isclose(float(dt), period_s, rel_tol=1e-9):
            raise ValueError(f"{key}.dt: the discrete model's period {dt} s differs from the controller "
                             f"period {period_s} s; give the continuous model or set period_s: {dt}")
        dsys = sys
    ad, bd, cd, dd = (np.ascontiguousarray(np.asarray(m, dtype=float)) for m in (dsys.A, dsys.B, dsys.C, dsys.D))
    if not all(np.all(np.isfinite(m)) for m in (ad, bd, cd, dd)):
        raise ValueError(f"{key}: the discretisation at {period_s} s is not finite; check the model's scale")
    if dt is None and ad.size:
        # a stable continuous mode must stay stable once discretised (catches ill-conditioned models)
        lam_c = np.linalg.eigvals(np.asarray(sys.A, dtype=float))
        lam_d = np.linalg.eigvals(ad)
        if np.all(lam_c.real < 0) and np.max(np.abs(lam_d)) >= 1.0:
            raise ValueError(f"{key}: discretisation at {period_s} s is unstable (max |eig| "
                             f"{np.max(np.abs(lam_d)):.6g} >= 1 for a stable model); use a smaller period_s")
    delay = spec.get("delay_s", 0.0)
    if not (isinstance(delay, (int, float)) and delay >= 0 and math.isfinite(delay)):
        raise ValueError(f"{key}.delay_s: must be a number >= 0 s, got {delay!r}")
    d = delay / period_s
    if abs(d - round(d)) > 1e-6:
        raise ValueError(f"{key}.delay_s: {delay} s is not a whole number of controller periods "
                         f"({period_s} s); choose period_s dividing the delay")
    n = ad.shape[0]
    # the loop's linear analysis (poles at every evaluation) holds each delayed input sample as a state
    check_count(f"{key}.delay_s", n + (round(d) + 1) * bd.shape[1], MAX_LOOP_STATES,
                "the linear closed loop's size (plant states plus delayed input samples)",
                f"a delay of {delay} s is {round(d):,} periods of {period_s} s")
    x0 = _vector(f"{key}.x0", spec["x0"]) if "x0" in spec else np.zeros(n)
    if x0.shape != (n,):
        raise ValueError(f"{key}.x0: needs {n} values (one per state), got {x0.size}")
    output, inner = _index(spec, "output", 0, cd.shape[0], key), _index(spec, "inner_output", -1, cd.shape[0], key)
    return LTIPlant(ad, bd, cd, dd, float(period_s), int(round(d)), np.ascontiguousarray(x0), kind, dt is None,
                    method, output, inner)


def _index(spec: Mapping[str, Any], name: str, default: int, size: int, key: str) -> int:
    v = spec.get(name, default)
    if v == default:
        return default
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < size:
        raise ValueError(f"{key}.{name}: must be an output index in 0..{size - 1}, got {v!r}")
    return v


def lti_uncertain(spec: Mapping[str, Any]) -> dict[str, float]:
    """The parameters an ``uncertainty:`` block may perturb, with their nominal values: every coefficient
    of the model (``tf.num[i]``, ``tf.den[i]``, ``zpk.z[i]``, ``zpk.p[i]``, ``zpk.k``, ``ss.A[i][j]``,
    ``ss.B[i][j]``, ``ss.C[i][j]``, ``ss.D[i][j]``) and ``delay_s``."""
    from objectives.control.plants.uncertainty import spec_leaves

    model = next(m for m in MODELS if m in spec)
    body = spec[model]
    out: dict[str, float] = {}
    for part in {"tf": ("num", "den"), "zpk": ("z", "p", "k"), "ss": ("A", "B", "C", "D")}[model]:
        if part in body:
            out.update(spec_leaves(f"{model}.{part}", body[part]))
    out["delay_s"] = float(spec.get("delay_s", 0.0))
    return out


_LTI_DOC = ("{what}; options dt (discrete model's period), method (zoh | tustin), delay_s, x0, output, "
            "inner_output")
#: the registered kinds (objectives.control.plants.PLANTS): one builder for the three model forms
TF = PlantKind("tf", frozenset(LTI_KEYS), lti_from_spec, "siso",
               _LTI_DOC.format(what="{num, den}: transfer function, highest power first"), uncertain=lti_uncertain)
ZPK = PlantKind("zpk", frozenset(LTI_KEYS), lti_from_spec, "siso",
                _LTI_DOC.format(what="{z, p, k}: zeros, poles, gain"), uncertain=lti_uncertain)
SS = PlantKind("ss", frozenset(LTI_KEYS), lti_from_spec, "siso",
               _LTI_DOC.format(what="{A, B, C, D}: state space (MIMO for lqr_sf)"), uncertain=lti_uncertain)
