"""The Python API: ``tuner.tune(config)`` and ``tuner.load(run_dir)``, the command line's ``run`` from code.

``tune`` takes what ``tuner run`` takes (a job file, or the same job as a dict or a
:class:`tuner.config.RunConfig`, with ``seed``, ``n_jobs``, ``run_dir`` and ``--set``-style
``overrides``), runs it through the same :func:`tuner.run.run`, and returns a :class:`Result` read
back from the run directory, so a run made from code and one made by ``tuner run`` with the same
config and seed have the same files and the same ``history.csv`` (but for its ``seconds`` column).
``load`` gives the same :class:`Result` for a run that is already on disk.

Bad input raises :class:`tuner.config.ConfigError` (or :class:`tuner.records.RunError` for a run
directory) whose text is the command line's ``error:`` line without the ``error:``, before anything
is written.
"""

from __future__ import annotations

import dataclasses
import io
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tuner.config import ConfigError, RunConfig, apply_overrides, config_from_dict, load_config
from tuner.records import RunError
from tuner.rundir import RunDir
from tuner.safe_io import read_text, regular

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from tuner.loop import Generation

__all__ = ["GenerationSummary", "Result", "tune", "load", "ConfigError", "RunError"]


@dataclass(frozen=True)
class GenerationSummary:
    """What ``tune(..., callback=f)`` hands ``f`` after each generation (already written to the run directory).

    Attributes
    ----------
    stage : int
        Refinement stage (0-based; ``optimizer.refine.stages``).
    generation : int
        Generation within the stage (0-based, as in ``history.csv``).
    n_evals : int
        Evaluations so far, all stages.
    n_failed : int
        Failed evaluations so far.
    best_fitness : float
        Best fitness so far (inf while none succeeded).
    best_params : Mapping[str, Any]
        Its parameter values (empty while none succeeded).
    generation_best, generation_median : float
        Best and median fitness of this generation's successful candidates (NaN when none succeeded).
    params : tuple[Mapping[str, Any], ...]
        This generation's candidates in the order they were asked.
    fitness : tuple[float, ...]
        Their fitness (failed candidates carry the penalty, :data:`tuner.objective.PENALTY`).
    """

    stage: int
    generation: int
    n_evals: int
    n_failed: int
    best_fitness: float
    best_params: Mapping[str, Any]
    generation_best: float
    generation_median: float
    params: tuple[Mapping[str, Any], ...] = ()
    fitness: tuple[float, ...] = ()

    @classmethod
    def from_generation(cls, g: Generation) -> GenerationSummary:
        best = g.best
        return cls(g.stage, g.generation, g.stats.n_evals, g.n_failed, best.fitness if best else math.inf,
                   dict(best.params) if best else {}, g.stats.gen_best, g.stats.gen_median,
                   tuple(dict(p) for p in g.params), tuple(float(r.evaluation.fitness) for r in g.records))


@dataclass(frozen=True, eq=False)
class Result:
    """A run, read from its directory (:func:`tune` and :func:`load` return it).

    Attributes
    ----------
    run_dir : Path
        The run directory (``tuner show``, ``tuner export`` and ``tuner resume`` take it too).
    status : str
        ``finished``, ``interrupted``, ``running`` (a run still going, or killed) ...
    fitness : float
        The best fitness (``best.yaml``); inf when no evaluation succeeded.
    params : Mapping[str, Any]
        The searched values of the best point.
    best : Mapping[str, Any]
        The complete tuned configuration: every value that defines the deployed filter or controller
        (searched, fixed and default values; :attr:`deployment` says which is which).
    deployment : Any
        The typed record behind ``best`` (:class:`tuner.deployment.Deployment`: units, docs, sources and
        the settings that only served scoring); None when the run has no best point.
    metrics : Mapping[str, Any]
        The best point's metrics, plus what the objective's report step added (held-out scores ...).
    history : pandas.DataFrame
        ``history.csv``: one row per evaluation (``eval``, ``stage``, ``generation``, ``index``, the
        parameters, ``fitness``, ``status``, ``error``, ``seconds``, the metrics).
    validation : Mapping[str, Any] or None
        ``validation.json`` (CV score, gap, folds) when the run had a ``validation:`` section.
    n_evals, n_failed : int
        Evaluations made, failures among them.
    stop_reason : str
        Why the optimiser stopped.
    repeats : tuner.records.Repeats or None
        A repeated run's spread over its seeds (``repeats.json``); ``params``, ``best`` and ``history`` are
        then the deployed repeat's. None for a single run.
    """

    run_dir: Path
    status: str
    fitness: float
    params: Mapping[str, Any]
    best: Mapping[str, Any]
    deployment: Any
    metrics: Mapping[str, Any]
    history: pd.DataFrame = field(repr=False)
    validation: Mapping[str, Any] | None
    n_evals: int
    n_failed: int
    stop_reason: str
    repeats: Any = None

    def report(self) -> Path:
        """(Re)write ``report.md``, ``report.html`` and ``figures/`` of the run; returns ``report.html``."""
        from tuner.report import write_run_report

        write_run_report(self.run_dir)
        return self.run_dir / "report.html"

    def build(self) -> Any:
        """The tuned filter or controller, ready for ``.run(...)`` / ``.stream(...)`` on new data.

        Built by the objective's ``build`` hook from :attr:`best` (the run's objective is re-created
        from its ``config.yaml``; no data is loaded). This runs the code the config names (a plant module,
        an FMU), but none from inside the run directory (:mod:`tuner.trust`: ``ConfigError`` naming it).
        ``ValueError`` when the run has no best point or its objective kind builds nothing (e.g.
        ``function``, ``python``).
        """
        from tuner.objective import hook

        if not self.params:
            raise ValueError(f"{self.run_dir}: no successful evaluation, nothing to build")
        objective, space = _objective_of(self.run_dir)
        build = hook(objective, "build")
        if build is None:
            raise ValueError(f"{self.run_dir}: objective kind {type(objective).__name__} builds no filter or "
                             "controller (no `build` hook); use Result.best")
        return build({**space.fixed, **self.params})


def _objective_of(run_dir: Path) -> tuple[Any, Any]:
    """The objective and search space of a run, re-created from its ``config.yaml`` (no data loaded)."""
    from tuner.setup import run_objective

    _, objective, space = run_objective(RunDir(run_dir))
    return objective, space


def _config(config: str | Path | Mapping[str, Any] | RunConfig, overrides: list[str] | None, seed: int | None,
            n_jobs: int | None) -> RunConfig:
    """``config`` as a validated :class:`RunConfig` with ``overrides``, ``seed`` and ``n_jobs`` applied."""
    overrides = _check_kwargs(overrides, seed, n_jobs)
    if isinstance(config, (str, Path)):
        from tuner.sweep import is_sweep_file

        if is_sweep_file(config):
            raise ConfigError(config, "sweep", "is a sweep file; tune() runs one job (use `tuner sweep` for "
                                               "sweeps)")
        return load_config(config, overrides, seed=seed, n_jobs=n_jobs)
    if isinstance(config, RunConfig):
        raw, source, base_dir = dict(config.raw), config.source, config.base_dir
    elif isinstance(config, Mapping):
        raw, source, base_dir = dict(config), "<dict>", Path.cwd()
        raw.setdefault("name", "job")
    else:
        raise TypeError(f"config: expected a path, a dict or a RunConfig, got {type(config).__name__}")
    raw = apply_overrides(raw, overrides, source)
    if seed is not None:
        raw["seed"] = seed
    if n_jobs is not None:
        raw["parallel"] = {**(raw.get("parallel") or {}), "n_jobs": n_jobs}
    return config_from_dict(raw, source=source, base_dir=base_dir)


def _check_kwargs(overrides: Any, seed: Any, n_jobs: Any) -> list[str]:
    """``overrides`` as a list of strings; ``seed`` and ``n_jobs`` integers (or None): else a ConfigError."""
    for key, value in (("seed", seed), ("parallel.n_jobs", n_jobs)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
            raise ConfigError("tune()", key, f"expected an int, got {type(value).__name__} {value!r}")
    if overrides is None:
        return []
    if isinstance(overrides, str):
        overrides = [overrides]
    if not isinstance(overrides, (list, tuple)) or not all(isinstance(o, str) for o in overrides):
        raise ConfigError("tune()", "overrides", f"expected a list of 'key.path=value' strings, got {overrides!r}")
    return list(overrides)


def tune(config: str | Path | Mapping[str, Any] | RunConfig, *, seed: int | None = None, n_jobs: int | None = None,
         run_dir: str | Path | None = None, progress: bool | Callable[[str], None] = True,
         callback: Callable[[GenerationSummary], None] | None = None,
         overrides: list[str] | None = None, report: bool = True, repeats: int | None = None) -> Result:
    """Tune a job, as ``tuner run`` does, and return its :class:`Result`.

    Parameters
    ----------
    config : path, dict or RunConfig
        A job file (as for ``tuner run``), the same job as a mapping (relative paths in it are taken
        from the current directory; ``name`` defaults to ``job``) or a :class:`tuner.config.RunConfig`.
    seed, n_jobs : int, optional
        Override ``seed`` and ``parallel.n_jobs`` (``--seed``, ``--n-jobs``).
    run_dir : path, optional
        The run directory (``--run-dir``); default ``<output>/<UTC time>-<name>-<6 hex>``.
    progress : bool or callable
        True: progress lines on standard error, as ``tuner run`` prints them; False: none; a callable
        gets each line instead.
    callback : callable, optional
        ``callback(summary)`` with a :class:`GenerationSummary` after each generation, once it is written
        to the run directory. An exception it raises stops the run there (status ``running`` on disk;
        ``tuner resume`` continues it) and propagates.
    overrides : list of str, optional
        ``key.path=value`` strings, as ``--set`` (one string is one override).
    report : bool
        False: no report, live or final (``--no-report``; ``tuner report RUN_DIR`` writes it later).
    repeats : int, optional
        Override ``repeats`` (``--repeats``): run the job with seeds ``seed .. seed + repeats - 1`` and deploy
        one of them (:mod:`tuner.repeats`); the :class:`Result` carries the spread in ``repeats``.

    Raises
    ------
    ConfigError
        A bad config, option, parameter or data file (the text of the command line's ``error:`` line);
        nothing is written.
    RunError
        ``run_dir`` exists and is not empty, or is in use.
    KeyboardInterrupt
        Ctrl-C, SIGTERM or SIGHUP stopped the run: it is saved first (status ``interrupted``; :func:`load`
        reads it, ``tuner resume`` continues it), then the interrupt goes on to the caller, so a script
        looping over ``tune()`` stops too.
    """
    from tuner.repeats import run

    if not isinstance(report, bool):  # report="no" would be true: a report the caller asked to leave out
        raise ConfigError("tune()", "report", f"expected True or False, got {type(report).__name__} {report!r}")
    cfg = _config(config, overrides, seed, n_jobs)
    if repeats is not None:
        if isinstance(repeats, bool) or not isinstance(repeats, int):
            raise ConfigError("tune()", "repeats", f"expected an integer, got {type(repeats).__name__} {repeats!r}")
        checked = config_from_dict({**cfg.raw, "repeats": repeats}, source=cfg.source, base_dir=cfg.base_dir)
        cfg = dataclasses.replace(cfg, repeats=checked.repeats, raw=checked.raw)
    printer = progress if callable(progress) else None
    on_generation = (lambda g: callback(GenerationSummary.from_generation(g))) if callback is not None else None
    res = run(cfg, run_dir=run_dir, quiet=not progress, progress=printer, on_generation=on_generation,
              report=report)
    if res.status == "interrupted":  # saved; a script looping over tune() must stop as on any Ctrl-C
        raise KeyboardInterrupt(f"interrupted; the run is saved: tuner.load({str(res.run_dir)!r}) reads it, "
                                f"`tuner resume {res.run_dir}` continues it")
    return load(res.run_dir)


def load(run_dir: str | Path) -> Result:
    """The :class:`Result` of a run directory (finished, or interrupted: then of what was done).

    Raises :class:`RunError` naming the file when ``meta.json`` or ``best.yaml`` is missing or corrupt.
    """
    import pandas as pd

    rd = RunDir(run_dir)
    if not rd.path.is_dir():
        raise RunError(f"{rd.path}: not a run directory (no such directory)")
    meta = rd.meta()
    repeats = rd.repeats()
    src = RunDir(rd.chosen_repeat() or rd.path)  # a repeated run's history is its deployed repeat's
    try:
        text = read_text(src.file("history.csv")) if regular(src.file("history.csv")) else ""
        history = pd.read_csv(io.StringIO(text)) if text else pd.DataFrame()
    except (UnicodeDecodeError, ValueError, pd.errors.ParserError) as exc:  # EmptyDataError is a ValueError
        raise RunError(f"{src.file('history.csv')}: unreadable ({str(exc).strip().splitlines()[0][:200]})") from None
    params: dict[str, Any] = {}
    best: dict[str, Any] = {}
    metrics: dict[str, Any] = {}
    deployment, fitness = None, math.inf
    if rd.has_best():
        from tuner.deployment import load_deployment
        from tuner.trust import data_only

        b = rd.best()
        params, fitness = dict(b.params), float(b.fitness)
        metrics = {**dict(b.metrics), **dict(b.evaluation or {})}
        with data_only("tuner.load"):  # reading a run loads no code its config names (tuner.trust)
            deployment = load_deployment(rd.path)
        best = dict(deployment.values)
    return Result(rd.path.resolve(), meta.status, fitness, params, best, deployment, metrics, history,
                  src.validation(), int(meta.n_evals), int(meta.n_failed), meta.stop_reason or "", repeats)
