"""The ``Plant`` protocol, its two typed variants and the record that registers a plant kind.

python-control's ``InputOutputSystem`` -> ``LTI`` / ``NonlinearIOSystem`` split is the model: every plant
gives the same small face (:class:`Plant`), and a plant is one of two typed variants that say how the
loop advances it:

- :class:`DiscreteLTI`: a discrete state space at the controller period (``Ad, Bd, Cd, Dd``, an input
  delay); the loop kernel runs the recursion itself, and the linear loop has an exact frequency
  response, so margins, Ms and the closed-loop poles are defined (``linear = True``);
- :class:`SteppedPlant`: anything advanced one controller period at a time by its own step
  (``advance``): Python dynamics integrated with RK4 (compiled with the loop when numba can), an FMU's
  ``fmi2DoStep``; no frequency response (``linear = False``).

What a plant must provide (the objective, the loop and the reports read nothing else):

- sizes: ``n_states``, ``n_inputs``, ``n_outputs``; ``period_s`` (the controller period it was built at),
  ``delay_n`` (input delay in periods), ``output`` / ``inner_output`` (indices of the controlled and the
  inner loop's output, -1 for none), ``x0`` (initial state), ``model`` (the type key it came from);
- ``reset()``: back to the initial state before every simulation (a plant with internal state of its own,
  such as an FMU instance, re-initialises it; the others do nothing);
- ``run_loop(sig, cp, opt, y, u, x)``: the whole closed loop of the generic kernels
  (:mod:`objectives.control.plants.kernels`) on this plant, writing outputs, inputs and states per period
  and returning ``(status, periods done)``; the two variants implement it once each;
- ``design_model()``: ``(Ad, Bd)`` of the linearisation at the operating point, discretised at the
  period, for model-based designs (state feedback); ``ValueError`` when the plant has none;
  ``tracked_row()``: the state combination the controlled output is (a state feedback's pre-filter);
- ``named_parameters()``: the plant's named physical parameters (``{name: value}``). What an
  ``uncertainty:`` block may perturb is the kind's to declare (:attr:`PlantKind.uncertain`, by name, with
  the nominal values of a spec); a model set is built by calling the kind's builder again on each
  perturbed spec (:attr:`PlantKind.perturb`), one plant per model, and the loop aggregates per model;
- linear plants only: ``frequency_response(w)`` / ``state_frequency_response(w)`` for the loop's
  margins (:mod:`objectives.control.plants.analysis`).

A new plant kind is one module with a class implementing one variant and a :class:`PlantKind`
(its YAML type key, its allowed keys, its builder, the loop family it runs in), plus one line in
:data:`objectives.control.plants.PLANTS` (or :func:`objectives.control.plants.register_plant`). A
physics engine with its own timestep (a MuJoCo model) is a :class:`SteppedPlant` whose ``advance`` runs
``period_s / timestep`` engine steps with the input held, names its actuators and sensors in its spec,
reads the initial state from a keyframe in ``reset``, and gives ``design_model`` from the engine's own
linearisation at an operating point. A plant whose loop cannot be the generic kernel (the pendulum, with
its sensor suite and Kalman filter inside the loop) gives its kind a family of its own and the objective
runs that family's loop (:mod:`objectives.control.plants.wmp`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from objectives.control.plants.kernels import _loop_lti, _loop_nl, _rk4

__all__ = ["Plant", "DiscreteLTI", "SteppedPlant", "PlantKind"]


@runtime_checkable
class Plant(Protocol):
    """The face every plant gives (module docstring)."""

    linear: ClassVar[bool]
    model: str
    period_s: float
    delay_n: int
    output: int
    inner_output: int
    x0: np.ndarray

    @property
    def n_states(self) -> int: ...

    @property
    def n_inputs(self) -> int: ...

    @property
    def n_outputs(self) -> int: ...

    def reset(self) -> None: ...

    def run_loop(self, sig: np.ndarray, cp: np.ndarray, opt: np.ndarray, y: np.ndarray, u: np.ndarray,
                 x: np.ndarray) -> tuple[int, int]: ...

    def design_model(self) -> tuple[np.ndarray, np.ndarray]: ...

    def tracked_row(self) -> np.ndarray: ...

    def named_parameters(self) -> dict[str, float]: ...


class DiscreteLTI:
    """The linear variant: ``x[k+1] = Ad x[k] + Bd u[k-d]``, ``y[k] = Cd x[k] + Dd u[k-1-d]`` at ``period_s``.

    A subclass holds the attributes ``Ad, Bd, Cd, Dd`` (float64, contiguous), ``period_s``, ``delay_n``,
    ``x0``, ``output``, ``inner_output`` and ``model``."""

    linear: ClassVar[bool] = True
    Ad: np.ndarray
    Bd: np.ndarray
    Cd: np.ndarray
    Dd: np.ndarray
    period_s: float
    delay_n: int
    x0: np.ndarray
    output: int

    @property
    def n_states(self) -> int:
        return self.Ad.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.Bd.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.Cd.shape[0]

    def reset(self) -> None:
        """Nothing to reset: the recursion starts from ``x0`` in every run."""

    def run_loop(self, sig, cp, opt, y, u, x):
        """The loop kernel with the discrete recursion (:func:`~objectives.control.plants.kernels._loop_lti`)."""
        return _loop_lti(self.Ad, self.Bd, self.Cd, self.Dd, self.x0, sig, cp, opt, y, u, x)

    def design_model(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Ad, Bd)``: the model a state-feedback design uses (the delay is left out)."""
        return self.Ad, self.Bd

    def tracked_row(self) -> np.ndarray:
        """The row of ``Cd`` of the controlled output (the state-feedback pre-filter's target)."""
        return self.Cd[self.output]

    def named_parameters(self) -> dict[str, float]:
        """None by name: an LTI model is perturbed in its spec (coefficients, matrix entries, delay)."""
        return {}

    def _resolvent_b(self, omega_rad_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``z = e^{j w h}`` and ``(zI - Ad)^-1 Bd[:, 0]`` at every ``w``, shape (len(w), n) (one batched solve)."""
        z = np.exp(1j * np.asarray(omega_rad_s, dtype=float).reshape(-1) * self.period_s)
        n = self.n_states
        if n == 0:
            return z, np.zeros((z.size, 0), dtype=complex)
        m = z[:, None, None] * np.eye(n)[None] - self.Ad[None]
        rhs = np.broadcast_to(self.Bd[:, 0].astype(complex), (z.size, n))[..., None]
        return z, np.linalg.solve(m, rhs)[..., 0]

    def frequency_response(self, omega_rad_s: np.ndarray) -> np.ndarray:
        """``P(e^{j w h})`` of every output to input 0 with the delay, shape (len(w), p) complex.

        The feedthrough is delayed by one period as in the kernel."""
        z, xb = self._resolvent_b(omega_rad_s)
        g = xb @ self.Cd.T.astype(complex)
        return (g + self.Dd[:, 0][None, :] / z[:, None]) * (z ** (-self.delay_n))[:, None]

    def state_frequency_response(self, omega_rad_s: np.ndarray) -> np.ndarray:
        """``(zI - Ad)^-1 Bd[:, 0] z^-d`` at ``z = e^{j w h}``, shape (len(w), n) complex."""
        z, xb = self._resolvent_b(omega_rad_s)
        return xb * (z ** (-self.delay_n))[:, None]


class SteppedPlant:
    """The stepped variant: the loop advances the plant one period at a time by :meth:`stepper`'s step.

    A subclass holds ``x0``, ``period_s``, ``n_sub``, ``outputs`` (the state indices measured), ``fn`` and
    ``params`` (what the step gets), and gives :meth:`stepper`."""

    linear: ClassVar[bool] = False
    x0: np.ndarray
    period_s: float
    n_sub: int
    outputs: np.ndarray
    fn: Any
    params: Any

    @property
    def n_outputs(self) -> int:
        return int(np.asarray(self.outputs).size)

    def reset(self) -> None:
        """Nothing to reset by default: each run starts from ``x0``."""

    def stepper(self) -> tuple[Callable[..., Any], Callable[..., Any]]:
        """``(loop, step)``: the loop kernel (compiled, or its ``py_func``) and the step with the signature
        of :func:`~objectives.control.plants.kernels._rk4` ``(f, x, u, t, params, h, n_sub) -> x_next``."""
        raise NotImplementedError

    def run_loop(self, sig, cp, opt, y, u, x):
        """:meth:`reset`, then the loop kernel of :func:`~objectives.control.plants.kernels._loop_nl` with
        this plant's step."""
        self.reset()
        loop, step = self.stepper()
        return loop(self.fn, step, self.params, self.x0, sig, cp, opt, self.period_s, self.n_sub,
                    self.outputs, self.n_inputs, y, u, x)


def rk4_stepper(compiled: bool) -> tuple[Callable[..., Any], Callable[..., Any]]:
    """The loop and RK4 step of Python dynamics: compiled together, or both in Python."""
    return (_loop_nl, _rk4) if compiled else (_loop_nl.py_func, _rk4.py_func)


@dataclass(frozen=True)
class PlantKind:
    """A registered plant kind.

    Attributes
    ----------
    key : str
        The YAML type key (``plant: {tf: ...}``), or the bare name (``plant: wmp``) when ``named``.
    keys : frozenset of str
        Every key a plant mapping of this kind may hold (its own key included); checked before building.
    build : callable
        The builder the family's loop calls; for the ``siso`` family
        ``build(spec, period_s, base_dir, key) -> Plant``, ``ValueError`` starting with ``key`` for bad input.
    family : str
        The loop it runs in (:data:`objectives.control.plants.LOOPS`), and so the controllers it accepts.
    doc : str
        One line for ``tuner describe plant``.
    named : bool
        Given by name alone (``plant: wmp``), its settings at the objective's top level.
    uncertain : callable, optional
        ``uncertain(spec) -> {name: nominal value}``: the parameters of a plant spec an ``uncertainty:``
        block may perturb (:mod:`objectives.control.plants.uncertainty`), by the names the block uses
        (``tf.den[1]``, ``params.m``, ``delay_s``, or any name the kind chooses); None: none.
    perturb : callable, optional
        ``perturb(spec, {name: value}) -> spec``: a copy of ``spec`` with those parameters set, which
        ``build`` then builds; None: the names are paths into the spec (``a.b[i][j]``) and are set there.
    """

    key: str
    keys: frozenset[str]
    build: Any
    family: str = "siso"
    doc: str = ""
    named: bool = False
    uncertain: Any = None
    perturb: Any = None
