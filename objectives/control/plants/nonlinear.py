"""Nonlinear plants from a Python function: ``plant: {python: "module:dynamics", x0, params}``.

YAML (``objective.plant``)::

    python: cartpole:dynamics   # module (found next to the config first) and function
    x0: [0.0, 0.0, 0.1, 0.0]    # initial state
    params: {M: 0.5, m: 0.2}    # passed to dynamics as a namedtuple: params.M, params.m
    n_inputs: 1                 # length of u
    outputs: [0, 2]             # y = x[outputs] (default: every state)
    output: 0                   # which y the loop controls (index into outputs)
    inner_output: 1             # the inner loop's y (cascaded PID)
    n_sub: 10                   # RK4 steps per controller period
    delay_s: 0.0                # input delay, a whole number of periods
    linearize_at: {x: [0, 0, 0, 0], u: [0]}   # operating point of a state-feedback design

``dynamics(x, u, t, params) -> dx`` gets float64 arrays ``x`` (n,) and ``u`` (m,), the time ``t`` (s)
and the namedtuple ``params``, and returns ``dx/dt`` as a float64 array (n,). The closed loop
integrates it with fixed-step RK4 (``n_sub`` steps per period, the input held). When numba can
compile the function (``numba.njit``: NumPy arithmetic, ``math``, no Python objects), the whole loop
is one compiled kernel; otherwise the same loop runs in Python (slower, identical results) and
:attr:`NonlinearPlant.compiled` says so.

Checked before any tuning: ``dx`` has the shape of ``x0`` and is finite at ``x0`` (and at the
operating point), and one RK4 sub-step is stable for every stable mode of the linearisation at
``x0`` (``|R(h lambda)| <= 1``, R the RK4 stability polynomial), so a too coarse ``n_sub`` is an error
rather than a diverging loop.
"""

from __future__ import annotations

import collections
import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from objectives.control.plants.base import PlantKind, SteppedPlant, rk4_stepper
from tuner.sizes import check_samples

__all__ = ["NonlinearPlant", "nonlinear_from_spec", "import_relative", "NL_KEYS", "PYTHON"]

NL_KEYS = {"python", "x0", "params", "n_inputs", "outputs", "output", "inner_output", "n_sub", "delay_s",
           "linearize_at"}


def import_relative(spec: str, base_dir: pathlib.Path | None, key: str = "objective.plant.python") -> Any:
    """``"module:attr"`` imported with ``base_dir`` (the config's folder) searched first, if the command may load
    it (:func:`tuner.trust.import_code`: never in a read-only command, never from a handed-over run directory)."""
    from tuner.trust import import_code

    return import_code(spec, base_dir, key)


def _rk4_amp(z: complex) -> float:
    return abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)


@dataclass
class NonlinearPlant(SteppedPlant):
    """A nonlinear plant ``dx/dt = f(x, u, t, params)`` (module docstring): the stepped variant of the
    ``Plant`` protocol (:class:`~objectives.control.plants.base.SteppedPlant`), advanced by RK4."""

    callable: str
    x0: np.ndarray
    params: Any
    period_s: float
    n_inputs: int = 1
    outputs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    output: int = 0
    inner_output: int = -1
    n_sub: int = 10
    delay_n: int = 0
    x_op: np.ndarray | None = None
    u_op: np.ndarray | None = None
    fn: Any = None
    compiled: bool = False
    model: str = "python"

    @property
    def n_states(self) -> int:
        return self.x0.size

    @property
    def n_outputs(self) -> int:
        return self.outputs.size

    def stepper(self):
        """The loop kernel and RK4 compiled with ``fn`` when numba compiles it, else both in Python."""
        return rk4_stepper(self.compiled)

    def named_parameters(self) -> dict[str, float]:
        """``params`` (the dynamics' named constants)."""
        return dict(self.params._asdict())

    def rhs(self, x: np.ndarray, u: np.ndarray, t: float = 0.0) -> np.ndarray:
        return np.asarray(self.fn(np.asarray(x, dtype=float), np.asarray(u, dtype=float), t, self.params))

    def jacobians(self, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Central-difference ``(df/dx, df/du)`` at ``(x, u)``."""
        n, m = x.size, u.size
        a, b = np.empty((n, n)), np.empty((n, m))
        for j in range(n):
            e = np.zeros(n)
            e[j] = 1e-6 * max(1.0, abs(x[j]))
            a[:, j] = (self.rhs(x + e, u) - self.rhs(x - e, u)) / (2 * e[j])
        for j in range(m):
            e = np.zeros(m)
            e[j] = 1e-6 * max(1.0, abs(u[j]))
            b[:, j] = (self.rhs(x, u + e) - self.rhs(x, u - e)) / (2 * e[j])
        return a, b

    def design_model(self) -> tuple[np.ndarray, np.ndarray]:
        """The ZOH discretisation at the period of the linearisation at ``linearize_at`` (computed once)."""
        import control

        if getattr(self, "_design", None) is None:
            a, b = self.jacobians(self.x_op, self.u_op)
            d = control.sample_system(control.ss(a, b, np.eye(a.shape[0]), np.zeros(b.shape)), self.period_s)
            self._design = (np.asarray(d.A, dtype=float), np.asarray(d.B, dtype=float))
        return self._design

    def tracked_row(self) -> np.ndarray:
        row = np.zeros(self.n_states)
        row[self.outputs[self.output]] = 1.0
        return row


def _namedtuple(params: Mapping[str, Any], key: str) -> Any:
    if not isinstance(params, Mapping):
        raise ValueError(f"{key}.params: expected a mapping of names to numbers, got {params!r}")
    for k, v in params.items():
        if not (isinstance(k, str) and k.isidentifier()):
            raise ValueError(f"{key}.params: names must be identifiers, got {k!r}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{key}.params.{k}: must be a finite number, got {v!r}")
    names = tuple(params)
    cls = _TUPLES.get(names)
    if cls is None:  # one class per field list: a model set's plants share the compiled loop
        cls = _TUPLES[names] = collections.namedtuple("PlantParams", list(names))
    return cls(*(float(v) for v in params.values()))


#: the params namedtuple class of each field list, and the numba dispatcher of each dynamics function:
#: reused, so the plants of a model set (the same dynamics, other values) compile the loop once
_TUPLES: dict[tuple[str, ...], Any] = {}
_JITTED: dict[Any, Any] = {}


def _vec(key: str, v: Any, n: int | None = None) -> np.ndarray:
    try:
        a = np.array(v, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: expected a list of numbers, got {v!r}") from None
    if a.size == 0 or not np.all(np.isfinite(a)) or (n is not None and a.size != n):
        want = f"{n} finite numbers" if n is not None else "a non-empty list of finite numbers"
        raise ValueError(f"{key}: expected {want}, got {v!r}")
    return a


def _int(spec: Mapping[str, Any], name: str, default: int, lo: int, hi: int, key: str) -> int:
    v = spec.get(name, default)
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise ValueError(f"{key}.{name}: must be an integer in {lo}..{hi}, got {v!r}")
    return v


def nonlinear_from_spec(spec: Mapping[str, Any], period_s: float, base_dir: pathlib.Path | None,
                        key: str = "objective.plant") -> NonlinearPlant:
    """Import, validate and (where numba can) compile the dynamics of ``spec`` (its keys among
    :data:`NL_KEYS`, checked by :func:`~objectives.control.plants.plant_kind`)."""
    target = spec["python"]
    if not isinstance(target, str) or ":" not in target:
        raise ValueError(f"{key}.python: expected 'module:function', got {target!r}")
    try:
        fn = import_relative(target, base_dir, f"{key}.python")
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"{key}.python: cannot import {target!r} ({exc}); modules are searched in the "
                         "config's folder first, then on sys.path") from None
    if not callable(fn):
        raise ValueError(f"{key}.python: {target!r} is not callable")
    if "x0" not in spec:
        raise ValueError(f"{key}.x0: missing; the initial state (one number per state)")
    x0 = _vec(f"{key}.x0", spec["x0"])
    n = x0.size
    params = _namedtuple(spec.get("params") or {}, key)
    m = _int(spec, "n_inputs", 1, 1, 64, key)
    outputs = np.array(spec.get("outputs", list(range(n))), dtype=np.int64).reshape(-1)
    if outputs.size == 0 or outputs.min() < 0 or outputs.max() >= n:
        raise ValueError(f"{key}.outputs: state indices in 0..{n - 1}, got {spec.get('outputs')!r}")
    output = _int(spec, "output", 0, 0, outputs.size - 1, key)
    inner = _int(spec, "inner_output", -1, -1, outputs.size - 1, key)
    n_sub = _int(spec, "n_sub", 10, 1, 10000, key)
    delay = spec.get("delay_s", 0.0)
    if not (isinstance(delay, (int, float)) and math.isfinite(delay) and delay >= 0) \
            or abs(delay / period_s - round(delay / period_s)) > 1e-6:
        raise ValueError(f"{key}.delay_s: a whole number of controller periods ({period_s} s) >= 0, got {delay!r}")
    check_samples(f"{key}.delay_s", round(delay / period_s), "the input delay line")
    lin = spec.get("linearize_at") or {}
    if not isinstance(lin, Mapping) or set(lin) - {"x", "u"}:
        raise ValueError(f"{key}.linearize_at: expected {{x: [...], u: [...]}}, got {lin!r}")
    x_op = _vec(f"{key}.linearize_at.x", lin["x"], n) if "x" in lin else x0.copy()
    u_op = _vec(f"{key}.linearize_at.u", lin["u"], m) if "u" in lin else np.zeros(m)
    plant = NonlinearPlant(target, x0, params, float(period_s), m, outputs, output, inner, n_sub,
                           int(round(delay / period_s)), x_op, u_op, fn)
    for where, x, u in (("x0", x0, np.zeros(m)), ("linearize_at", x_op, u_op)):
        try:
            dx = np.asarray(fn(x.copy(), u.copy(), 0.0, params))
        except Exception as exc:  # noqa: BLE001 - user code: any failure is a config error with its text
            raise ValueError(f"{key}.python: {target} raised at {where}: {type(exc).__name__}: {exc}") from None
        if dx.shape != (n,):
            raise ValueError(f"{key}.python: {target} returned shape {dx.shape} at {where}; it must return "
                             f"dx with the shape of x0 ({n},)")
        if not np.all(np.isfinite(dx.astype(float))):
            raise ValueError(f"{key}.python: {target} returned a non-finite dx {dx.tolist()} at {where}")
    a, _ = plant.jacobians(x0, np.zeros(m))
    h = period_s / n_sub
    for lam in np.linalg.eigvals(a):
        if lam.real < 0 and _rk4_amp(h * lam) > 1.0:
            need = math.ceil(n_sub * abs(h * lam) / 2.5)
            raise ValueError(f"{key}.n_sub: RK4 with step {h:.3g} s is unstable for the stable mode {lam:.4g} "
                             f"1/s of the linearisation at x0; use n_sub >= {max(need, n_sub + 1)}")
    plant.fn, plant.compiled = _compile(fn, x0, m, params)
    return plant


def _compile(fn: Any, x0: np.ndarray, m: int, params: Any) -> tuple[Any, bool]:
    """``numba.njit(fn)`` when it compiles and agrees with ``fn`` at x0, else ``fn``."""
    import numba

    try:
        jf = fn if isinstance(fn, numba.core.registry.CPUDispatcher) else _JITTED.get(fn)
        if jf is None:
            jf = _JITTED[fn] = numba.njit(fn)
        got = jf(x0.copy(), np.zeros(m), 0.0, params)
    except Exception:  # noqa: BLE001 - numba's typing errors have many classes: fall back to Python
        return fn, False
    if not np.allclose(got, fn(x0.copy(), np.zeros(m), 0.0, params) if not hasattr(fn, "py_func")
                       else fn.py_func(x0.copy(), np.zeros(m), 0.0, params), equal_nan=True):
        return fn, False
    return jf, True


def python_uncertain(spec: Mapping[str, Any]) -> dict[str, float]:
    """The parameters an ``uncertainty:`` block may perturb: ``params.<name>`` of the dynamics and ``delay_s``."""
    params = spec.get("params") or {}
    return {**{f"params.{k}": float(v) for k, v in params.items()}, "delay_s": float(spec.get("delay_s", 0.0))}


#: the registered kind (objectives.control.plants.PLANTS)
PYTHON = PlantKind("python", frozenset(NL_KEYS), nonlinear_from_spec, "siso",
                   "'module:dynamics' with dynamics(x, u, t, params) -> dx; x0, params, n_inputs, outputs, "
                   "n_sub (RK4 steps per period), linearize_at", uncertain=python_uncertain)
