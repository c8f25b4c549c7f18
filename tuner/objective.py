"""The contract between the engine and any objective.

An objective is a picklable callable ``objective(params: dict) -> Evaluation`` (a bare float, or a
``(float, dict)`` pair, is accepted too and normalised by :func:`as_evaluation`). Lower fitness is
better. The engine never looks inside: it decodes candidates, calls the objective (in this process
or in workers), and records what comes back. A bare function is a complete objective.

Objectives that are expensive to set up (data loading, compilation) do it lazily on the first call,
so pickling them to workers stays cheap and each worker builds its state once.

Every other hook is optional and declared in :class:`TunableObjective`; the engine reaches them only
through :func:`hook`, so an objective without one simply does not get that service (no default
space: the config must list ``parameters``; no ``finalize``: the report has no extra section...).
Objective *kinds* that can be named in YAML (``objective.kind``) are registered in
:mod:`tuner.registry`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

if TYPE_CHECKING:  # pragma: no cover
    from tuner.space import Space

__all__ = ["Evaluation", "EvalRecord", "SeededCall", "Score", "Objective", "TunableObjective", "HOOKS", "hook",
           "as_evaluation", "PENALTY", "ToolError"]

#: fitness given to failed evaluations (exception, NaN, inf); finite so every optimiser copes.
PENALTY = 1.0e12


class ToolError(RuntimeError):
    """A program a hook runs (the C compiler of ``verify_c``) is missing or failed: its message is one line
    saying which program and why (``tuner verify-c`` prints it as its ``error:`` line, exit 2)."""


@dataclass(frozen=True)
class Evaluation:
    """Result of one evaluation.

    Attributes
    ----------
    fitness : float
        Value to minimise; finite when ``status == "ok"``.
    metrics : dict[str, float]
        Named breakdown (per recording, per axis...), written to ``history.csv`` and reports.
    status : {"ok", "failed"}
        ``failed`` when the candidate could not be scored (diverged filter, fallen robot, exception).
    error : str
        Why it failed; empty when ok.
    """

    fitness: float
    metrics: dict[str, float] = field(default_factory=dict)
    status: Literal["ok", "failed"] = "ok"
    error: str = ""

    @classmethod
    def failed(cls, error: str, metrics: dict[str, float] | None = None) -> Evaluation:
        return cls(PENALTY, dict(metrics or {}), "failed", error)


@dataclass(frozen=True)
class Score:
    """Detailed score of one parameter set on one split of an objective's data (``score`` hook).

    Attributes
    ----------
    fitness : float
        The objective's value (the same number ``__call__`` returns as fitness); NaN when the split
        holds no data.
    recordings : Mapping[str, Mapping[str, float]]
        Metrics per recording (or per scenario), keyed by its name.
    failed : str
        Why the parameters could not be scored (diverged filter...); empty when they could.
    outputs : Mapping[str, Any]
        Optional domain outputs per recording (filter traces...), for the objective's own report.
    """

    fitness: float
    recordings: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    failed: str = ""
    outputs: Mapping[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.failed


@runtime_checkable
class Objective(Protocol):
    """The whole required contract: a picklable callable from parameters to a result."""

    def __call__(self, params: dict[str, Any]) -> Evaluation | float | tuple[float, dict]: ...


class TunableObjective(Objective, Protocol):
    """Every hook the engine calls. All but ``__call__`` are optional (see :func:`hook`)."""

    def default_space(self) -> Space:
        """Parameters to search when the config gives no ``parameters:`` section."""

    def default_params(self) -> dict[str, Any]:
        """Initial (untuned) values of the parameters, e.g. a paper's; preflight evaluates them once
        and ``tuner evaluate`` of a config scores them."""

    def start_params(self) -> Mapping[str, Any] | None:
        """Where the search starts when the config gives no ``optimizer.x0`` (e.g. a tuning rule's
        controller), physical values by name; None for the optimiser's own start."""

    def parameter_names(self) -> Collection[str]:
        """Every name the objective accepts in a parameter dict; others are rejected at preflight."""

    def check_params(self, params: Mapping[str, Any]) -> None:
        """Raise ``ValueError`` (naming the parameter and what it allows) when ``params`` can never be
        evaluated, e.g. a negative gain; cheap, no data touched. Preflight calls it at both bounds of
        every searched parameter, so a search range reaching outside what the objective accepts is a
        config error instead of a run whose candidates there all fail."""

    def preflight(self) -> list[str]:
        """Load and validate all data once, before the first generation. Raise ``ValueError`` whose
        message starts with the config key (``objective.data[0]: ...``) on bad data; return warnings
        (e.g. implausible units) as strings."""

    def score(self, params: Mapping[str, Any], split: str = "train") -> Score:
        """Detailed :class:`Score` of ``params`` on the ``"train"`` or ``"test"`` data."""

    @property
    def has_test_data(self) -> bool:
        """True when there is held-out data (``score(params, "test")`` is meaningful)."""

    def with_data(self, data: Any) -> TunableObjective:
        """The same objective on other data (``tuner evaluate --data``); ``ValueError`` on bad data."""

    def export_tables(self, params: Mapping[str, Any]) -> Mapping[str, Mapping[str, Any]] | None:
        """Tables firmware needs, written by ``tuner export`` in every format: look-up tables
        ``{name: {"table": 2-D array, "x_range": (lo, hi), "y_range": (lo, hi)}}`` (rows follow y,
        columns follow x) or matrices without ranges (e.g. an LQR gain); optional ``doc`` and
        ``unit`` texts go into the C comment."""

    def describe(self) -> Mapping[str, Any]:
        """Provenance written by ``tuner export``: ``{"objective": {...}, "data": ...}``."""

    def traces(self, params: Mapping[str, Any]) -> Mapping[str, Mapping[str, Any]]:
        """Time responses of ``params`` for figures comparing methods: ``{panel label: {"t": (N,),
        "y": (N,), "ref": (N,) or None}}`` (same labels for every parameter set)."""

    def sample_rate(self) -> tuple[float | None, str]:
        """``(rate in Hz, note)`` that per-sample parameters assume (``None`` with the reason if unknown);
        ``tuner export`` writes it into every format."""

    def cv_folds(self, k: int | None = None, by: str | None = None) -> list[tuple[str, Any, Any]]:
        """Cross-validation folds for ``tuner cv``: ``[(name, train_objective, test_objective)]``, each
        objective on part of the data (e.g. leave one recording group out; ``k`` folds if given). ``by``
        is passed only when the config asks for it (``validation: {cv: {by: dataset}}``): leave one dataset
        out, a ``ValueError`` naming what is missing when the data has fewer than two datasets."""

    def evaluate_batch(self, params_list: Sequence[Mapping[str, Any]], n_threads: int,
                       seeds: Sequence[int] | None = None) -> list[Any] | None:
        """Evaluate a whole population in this process on ``n_threads`` threads (``backend: threads``).

        Returns one item per candidate, in order: what ``__call__`` would return (each must equal
        the serial call's result exactly), or the exception that candidate raised (recorded as a failed
        evaluation with its message, as the serial backend records it). Returns None when this
        configuration cannot be batched (the engine then evaluates serially). ``seeds`` is given only to
        objectives with ``takes_seed = True``: the seed of each candidate. An empty ``params_list``
        prepares (loads data, compiles kernels) and returns ``[]``."""

    def deployment(self, params: Mapping[str, Any]) -> Mapping[str, Any]:
        """The complete configuration that ``params`` deploy (:class:`tuner.deployment.Deployment` or its
        ``to_doc()`` dict): ``kind``, ``name``, ``values`` (searched, fixed and default values: every value
        that defines the deployed filter or controller), ``units``, ``docs``, ``sources``, ``choices``,
        ``scoring`` (settings that only serve scoring, never exported as part of the system),
        ``sample_rate_hz``, ``notes``. Written into ``best.yaml`` and every export."""

    def build(self, params: Mapping[str, Any]) -> Any:
        """The ready deployed object for ``params`` (e.g. the filter instance with its complete
        configuration, whose ``run(gyr, acc, mag, rate_hz=...)`` and ``stream()`` work on live data)."""

    def export_c(self, params: Mapping[str, Any], precision: str, prefix: str, comment: str) -> Mapping[str, str]:
        """``{filename: text}``: C source of the deployed system (a filter, a controller) with ``params`` baked
        in (``tuner export --format c-source``); ``comment`` is the run's provenance for the header."""

    def verify_c(self, params: Mapping[str, Any], precision: str, opt: tuple[str, ...]) -> Mapping[str, Any]:
        """The exported C compiled with the local compiler (flags ``opt``) and scored next to the model
        (``tuner verify-c``): ``{"python": Score, "c": Score, "precision": str, "flags": [str], "seconds":
        {"python": s, "c": s}}``, optionally ``"max_angle_rad": {recording: float}`` (the largest angle between
        the two outputs), and ``"compiler"``: the command line of the compiler that ran. :class:`ToolError`
        when the compiler is missing or fails."""

    def export_formats(self) -> Mapping[str, str]:
        """``{format: help}``: export formats of the objective's own (``tuner export --format NAME``), e.g. the
        parameter file of the program that runs the deployed system; names the engine's formats do not take."""

    def export_as(self, fmt: str, params: Mapping[str, Any], comment: str) -> str:
        """The text of the objective's own format ``fmt`` (one of :meth:`export_formats`) for the deployed
        ``params``; ``comment`` is the run's provenance and scores. ``ValueError`` naming every value the format
        cannot express."""

    def fingerprint(self) -> Mapping[str, Any]:
        """Statistics of the tuning data (e.g. a sensor's rate and noise), stored in the run directory at the
        run's start (``fingerprint.json``); an optional ``"summary"`` list of lines is printed then."""

    def compare_fingerprint(self, stored: Mapping[str, Any] | None) -> str | None:
        """One warning line when this objective's data differs from a run's stored :meth:`fingerprint` beyond
        the objective's thresholds (``tuner evaluate --data``, ``tuner verify-c --data``), else ``None``."""

    def finalize(self, run_dir: Path, params: Mapping[str, Any]) -> Mapping[str, Any]:
        """After a finished run: extra scores (held-out data) and figures; the returned metrics go
        into ``best.yaml`` and the report."""


#: names of the optional hooks (everything in :class:`TunableObjective` except ``__call__``)
HOOKS = ("default_space", "default_params", "start_params", "parameter_names", "check_params", "preflight", "score",
         "has_test_data", "with_data", "export_tables", "describe", "sample_rate", "traces", "cv_folds",
         "evaluate_batch", "finalize", "deployment", "build", "export_c", "verify_c", "fingerprint",
         "compare_fingerprint", "export_formats", "export_as")


def hook(objective: Any, name: str) -> Callable[..., Any] | None:
    """The objective's hook ``name`` (bound method), or None when it does not provide it.

    ``has_test_data`` is a property: it comes back as a callable returning its value.
    """
    if name not in HOOKS:
        raise ValueError(f"unknown objective hook {name!r}; known: {list(HOOKS)}")
    if name == "has_test_data":
        if not hasattr(objective, name):
            return None
        value = bool(getattr(objective, name))
        return lambda: value
    fn = getattr(objective, name, None)
    return fn if callable(fn) else None


def as_evaluation(value: Any) -> Evaluation:
    """Normalise what an objective returned; non-finite fitness becomes a failed evaluation."""
    if isinstance(value, Evaluation):
        ev = value
    elif isinstance(value, tuple) and len(value) == 2:
        ev = Evaluation(float(value[0]), dict(value[1]))
    else:
        try:
            ev = Evaluation(float(value))
        except (TypeError, ValueError):
            return Evaluation.failed(f"objective returned {type(value).__name__}, expected a number")
    if ev.status == "ok" and not math.isfinite(ev.fitness):
        return Evaluation(PENALTY, ev.metrics, "failed", f"non-finite fitness {ev.fitness}")
    if ev.status == "failed" and not math.isfinite(ev.fitness):
        return Evaluation(PENALTY, ev.metrics, "failed", ev.error)
    return ev


# The evaluation contract: how the loop calls an objective and what an evaluator hands back.


@dataclass(frozen=True)
class SeededCall:
    """Picklable adapter: called with ``(params, seed)``, passes the seed on if the objective takes one."""

    objective: Any

    def __call__(self, item: tuple[dict[str, Any], int]) -> Any:
        params, seed = item
        if getattr(self.objective, "takes_seed", False):
            return self.objective(params, seed=seed)
        return self.objective(params)


@dataclass(frozen=True)
class EvalRecord:
    """One evaluation as the run records it.

    ``raised`` is True when the objective raised (or timed out) rather than returning a result.
    """

    evaluation: Evaluation
    seconds: float
    worker: str = field(default="")
    raised: bool = False
