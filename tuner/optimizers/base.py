"""The ask/tell interface shared by every optimiser, and the bookkeeping they have in common.

An optimiser works in the unit cube only: :meth:`Optimizer.ask` returns the next population
``(n, dim)``; the caller evaluates it however it likes (serially, on a cluster) and hands the
fitness back with :meth:`Optimizer.tell`. Optimisers never call the objective, never open a pool
and never touch a file, which is what makes serial, parallel and resumed runs give the same numbers.

Stopping
--------
``done`` becomes True when ``generations`` tells have happened, when ``max_evals`` evaluations have
been told, when the best fitness reaches ``target``, or when the best fitness has not improved by
more than ``tol`` (relative) for ``patience`` generations. ``stop_reason`` says which.

Options
-------
Every optimiser declares its options once, as the :class:`~tuner.params.ParamSet` ``options`` (name,
default, allowed values, unit, doc; :data:`COMMON` for the options every method shares). The config's
validation (:meth:`Optimizer.check_options`, without the dimension; with it when a run starts), the
constructor (the same call), ``tuner describe <method>`` and the docs read that declaration; the
rules that tie options together (``constriction`` needs ``c1 + c2 > 4``, ...) are the class's
:meth:`Optimizer._combination`. :meth:`Optimizer.population_for` is the one computation of the
population from the options and the dimension.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from typing import Any, ClassVar

import numpy as np

from tuner.params import NONNEG, Interval, Param, ParamSet

__all__ = ["Optimizer", "OptionError", "latin_hypercube", "COMMON", "declare"]


class OptionError(ValueError):
    """An optimiser option with a bad name or value; ``key`` names the option ("" when no single one)."""

    def __init__(self, message: str, key: str = ""):
        self.key, self.message = key, message
        super().__init__(f"{key} {message}" if key else message)


#: at least one
AT_LEAST_1 = Interval(1.0)

#: The options every optimiser shares (budget, stopping rules, warm start).
COMMON: tuple[Param, ...] = (
    Param("population", 20, unit="candidates", allowed=AT_LEAST_1, integer=True,
          doc="Candidates per generation (ask returns this many rows)."),
    Param("generations", 50, unit="generations", allowed=AT_LEAST_1, integer=True, nullable=True,
          doc="Budget in generations (null for no limit; then give max_evals, target or patience)."),
    Param("max_evals", None, unit="evaluations", allowed=AT_LEAST_1, integer=True, nullable=True, kind="number",
          doc="Budget in evaluations; the run stops after the generation that reaches it."),
    Param("target", None, unit="fitness", nullable=True, kind="number",
          doc="Stop as soon as the best fitness is <= target."),
    Param("patience", None, unit="generations", allowed=AT_LEAST_1, integer=True, nullable=True, kind="number",
          doc="Stop when the best fitness has not improved by more than tol (relative) for this many generations."),
    Param("tol", 1e-9, unit="1", allowed=NONNEG, doc="Relative improvement that counts for patience."),
    Param("x0", None, kind="any", nullable=True,
          doc="Warm start: a point of the unit cube, or a mapping of physical values (how each method uses it is "
              "documented there)."),
)


def declare(name: str, own: Iterable[Param] = (), common: Iterable[Param] = COMMON) -> ParamSet:
    """The option declaration of optimiser ``name``: its ``own`` options, then the ``common`` ones (an own
    option of the same name, e.g. a method's population default, replaces the common one)."""
    own = tuple(own)
    mine = {p.name for p in own}
    return ParamSet(name, own + tuple(p for p in common if p.name not in mine))


def latin_hypercube(rng: np.random.Generator, n: int, dim: int) -> np.ndarray:
    """``n`` points of a Latin hypercube in ``[0, 1]^dim`` (one point per stratum per axis)."""
    u = (rng.random((n, dim)) + np.arange(n)[:, None]) / n
    for j in range(dim):
        u[:, j] = u[rng.permutation(n), j]
    return u


class Optimizer:
    """Base class: budget, best-so-far, stopping rules, state round trip.

    Parameters
    ----------
    dim : int
        Number of free parameters (the unit cube's dimension).
    rng : numpy.random.Generator
        The only source of randomness; its state is part of :meth:`state`.
    population : int
        Candidates per generation (``ask`` returns this many rows).
    generations : int
        Budget in generations (``None`` for no limit; then give ``max_evals`` or a target).
    max_evals : int, optional
        Budget in evaluations; the run stops after the generation that reaches it.
    target : float, optional
        Stop as soon as the best fitness is ``<= target``.
    patience : int, optional
        Stop when the best fitness has not improved by more than ``tol`` (relative) for this many
        generations.
    tol : float
        Relative improvement that counts for ``patience`` (default 1e-9).
    x0 : array (dim,), optional
        Warm start in the unit cube (how each method uses it is documented there).
    """

    name: ClassVar[str] = ""
    options: ClassVar[ParamSet] = declare("optimizer")

    def __init__(
        self,
        dim: int,
        rng: np.random.Generator,
        *,
        population: int = 20,
        generations: int | None = 50,
        max_evals: int | None = None,
        target: float | None = None,
        patience: int | None = None,
        tol: float = 1e-9,
        x0: Any = None,
    ):
        Optimizer.check_options(dict(population=population, generations=generations, max_evals=max_evals,
                                     target=target, patience=patience, tol=tol), dim)
        self.dim = int(dim)
        self.rng = rng
        self.population = int(population)
        self.generations = None if generations is None else int(generations)
        self.max_evals = None if max_evals is None else int(max_evals)
        self.target = None if target is None else float(target)
        self.patience = None if patience is None else int(patience)
        self.tol = float(tol)
        self.x0 = None if x0 is None else self._check_point(x0, "x0")
        self.generation = 0
        self.n_evals = 0
        self.best_x = np.full(self.dim, np.nan)
        self.best_f = np.inf
        self._last_improvement = 0
        self.stop_reason = ""

    # --- options ------------------------------------------------------------------------------
    @classmethod
    def option_names(cls) -> list[str]:
        """Every option the method accepts (its declaration's names)."""
        return cls.options.names()

    @classmethod
    def check_options(cls, values: Mapping[str, Any], dim: int | None = None) -> dict[str, Any]:
        """``values`` (the options given) checked against the declaration, then the rules that combine
        them (:meth:`_combination`; those needing the dimension only when ``dim`` is given).

        Returns the checked values (numbers as float, integers as int); raises :class:`OptionError`
        naming the option."""
        decl, out = cls.options, {}
        for k, v in values.items():
            if k not in decl.names():
                raise OptionError(f"unknown option for {cls.name}; allowed: {sorted(decl.names())}", k)
            try:
                out[k] = decl[k].check(cls.name, v)
            except ValueError as exc:
                text, head = str(exc), f"{cls.name}: {k} "
                raise OptionError(text[len(head):] if text.startswith(head) else text, k) from None
        if dim is not None and int(dim) < 1:
            raise OptionError(f"dimension must be >= 1, got {dim} (is every parameter fixed?)")
        cls._combination({**decl.defaults(), **values}, dim, set(values))
        return out

    @classmethod
    def _combination(cls, v: dict[str, Any], dim: int | None, given: set[str]) -> None:
        """Rules between options (``v``: every option, defaults filled in; ``given``: the names set
        explicitly); raise :class:`OptionError`. Subclasses extend it."""
        if all(v[k] is None for k in ("generations", "max_evals", "target", "patience")):
            raise OptionError("give a budget: generations, max_evals, target or patience")

    @classmethod
    def population_for(cls, dim: int, options: Mapping[str, Any]) -> int:
        """The population the method runs with on ``dim`` free parameters for the given ``options``
        (the one computation: the constructor, the config and the worker rule use it)."""
        pop = options.get("population")
        return int(cls.options["population"].default if pop is None else pop)

    def _check_point(self, x: Any, what: str) -> np.ndarray:
        x = np.asarray(x, dtype=float).reshape(-1)
        if x.shape != (self.dim,) or not np.all(np.isfinite(x)):
            raise OptionError(f"{what} must be {self.dim} finite numbers in [0, 1], got {x}")
        return np.clip(x, 0.0, 1.0)

    # --- protocol -----------------------------------------------------------------------------
    def ask(self) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def tell(self, x: np.ndarray, f: np.ndarray) -> None:
        """Record the fitness ``f`` (n,) of the points ``x`` (n, dim) returned by :meth:`ask`."""
        x = np.asarray(x, dtype=float)
        f = np.asarray(f, dtype=float)
        if x.shape[0] != f.shape[0]:
            raise ValueError(f"tell: {x.shape[0]} points but {f.shape[0]} fitness values")
        f = np.where(np.isfinite(f), f, np.inf)
        self._tell(x, f)
        self.n_evals += len(f)
        self.generation += 1
        i = int(np.argmin(f)) if len(f) else 0
        if len(f) and f[i] < self.best_f:
            gain = self.best_f - f[i]
            if not np.isfinite(self.best_f) or gain > self.tol * max(abs(self.best_f), 1e-300):
                self._last_improvement = self.generation
            self.best_f = float(f[i])
            self.best_x = x[i].copy()

    def _tell(self, x: np.ndarray, f: np.ndarray) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def done(self) -> bool:
        if self.target is not None and self.best_f <= self.target:
            self.stop_reason = f"target {self.target:g} reached"
        elif self.generations is not None and self.generation >= self.generations:
            self.stop_reason = f"{self.generations} generations"
        elif self.max_evals is not None and self.n_evals >= self.max_evals:
            self.stop_reason = f"{self.max_evals} evaluations"
        elif self.patience is not None and self.generation - self._last_improvement >= self.patience:
            self.stop_reason = f"no improvement for {self.patience} generations"
        else:
            extra = self._method_done()
            if not extra:
                return False
            self.stop_reason = extra
        return True

    def _method_done(self) -> str:
        """Method-specific termination (e.g. CMA-ES); an empty string means go on."""
        return ""

    # --- state --------------------------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        """Everything needed to resume, RNG state included (a picklable dict)."""
        fields = {k: copy.deepcopy(v) for k, v in self.__dict__.items() if k != "rng"}
        return self._tagged(fields, rng=copy.deepcopy(self.rng.bit_generator.state),
                            rng_class=type(self.rng.bit_generator).__name__)

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> Optimizer:
        obj = cls._bare(state, without=("rng", "rng_class"))
        bitgen = getattr(np.random, state["rng_class"])()
        bitgen.state = state["rng"]
        obj.rng = np.random.Generator(bitgen)
        obj._restore()
        return obj

    def _tagged(self, fields: dict[str, Any], **extra: Any) -> dict[str, Any]:
        """``fields`` (the instance's own, as :meth:`state` keeps them), then ``extra``, then the class tag
        that :meth:`_bare` checks."""
        return {**fields, **extra, "class": type(self).__name__}

    @classmethod
    def _bare(cls, state: dict[str, Any], without: tuple[str, ...] = ()) -> Any:
        """An instance made without ``__init__`` whose fields are ``state``'s, less its class tag and the
        keys ``without``; ValueError when the tag names another class."""
        if state.get("class") != cls.__name__:
            raise ValueError(f"state is not of a {cls.__name__}")
        obj = cls.__new__(cls)
        obj.__dict__.update({k: v for k, v in state.items() if k != "class" and k not in without})
        return obj

    def _restore(self) -> None:
        """Hook for subclasses whose state needs rebuilding after :meth:`from_state`."""


class WrapperOptimizer(Optimizer):
    """An optimiser that drives another one (``self.inner``) and shares its RNG: its state is its own
    fields plus the inner optimiser's state; subclasses name the inner class of a state."""

    def state(self) -> dict[str, Any]:
        fields = {k: v for k, v in self.__dict__.items() if k not in ("rng", "inner")}
        return self._tagged(fields, inner=self.inner.state())

    @classmethod
    def _inner_class(cls, fields: dict[str, Any]) -> type:  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> WrapperOptimizer:
        obj = cls._bare(state)
        obj.inner = cls._inner_class(obj.__dict__).from_state(state["inner"])
        obj.rng = obj.inner.rng
        return obj
