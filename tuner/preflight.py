"""Checks before the first generation: a run that cannot work stops here with one ``error:`` line.

:func:`preflight` runs in ``tuner run``, ``tuner resume`` and every sweep job (through
``tuner.run._build``), after the objective is built and before anything is written:

1. every name under ``parameters:`` and ``objective.fixed:`` is one the objective knows
   (``parameter_names`` hook; a misspelled ``betta:`` names the key, the allowed names and the
   closest one); a name under ``objective.fixed:`` that ``parameters:`` also searches, or fixes to
   another value, is an error (one value, one place);
   and each searched parameter's ``low`` and ``high`` is a value the objective accepts
   (``check_params`` hook, at the default point with one parameter moved to its bound);
2. the objective's ``preflight`` hook loads and validates all its data once (bad files, missing
   columns, NaN rows, ``warmup_s`` longer than a recording...) and returns warnings (units);
   then ``validation.cv`` must give folds (``cv_folds`` hook: e.g. ``folds`` at most the tuning
   recordings), so a CV that cannot run is found before the tuning, not after it;
3. with ``parallel.backend: dask`` and a scheduler ``address``, the same hook runs on every worker
   (a ``kind: python`` callable or a data file missing there is found now);
4. the default parameters (``default_params`` hook, else the centre of the space) are evaluated
   once: an objective that raises or exceeds ``objective.timeout_s`` there is an error saying why;
   one that scores them as failed (a fallen robot) is only a warning, since tuning may fix that.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Callable
from typing import Any

import numpy as np

from tuner.config import ConfigError, RunConfig
from tuner.objective import hook
from tuner.space import Space

__all__ = ["preflight", "check_names", "check_bounds", "check_cv_folds", "reference_point"]


def _key_error(cfg: RunConfig, exc: ValueError, default_key: str = "objective") -> ConfigError:
    msg = str(exc)
    key, _, rest = msg.partition(": ")
    if key.startswith("objective") and rest:
        return ConfigError(cfg.source, key, rest)
    return ConfigError(cfg.source, default_key, msg)


def check_names(cfg: RunConfig, objective: Any, space: Space) -> None:
    """Names under ``parameters:`` and ``objective.fixed:`` must be the objective's parameters."""
    names_fn = hook(objective, "parameter_names")
    if names_fn is None:
        return
    known = sorted(names_fn())
    fixed = cfg.objective.get("fixed") if isinstance(cfg.objective, dict) else None
    sections = [("objective.fixed", list(fixed or {}) if isinstance(fixed, dict) else [])]
    if cfg.parameters is not None:
        sections.insert(0, ("parameters", list(space.names)))
    for where, names in sections:
        for name in names:
            if name not in known:
                close = difflib.get_close_matches(name, known, n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ConfigError(cfg.source, f"{where}.{name}",
                                  f"not a parameter of this objective{hint}; allowed: {', '.join(known)}")
    if cfg.parameters is None or not isinstance(fixed, dict):
        return
    for name, value in fixed.items():  # one value in two places: which one the run used would be a guess
        if name in space.free_names:
            raise ConfigError(cfg.source, f"objective.fixed.{name}",
                              f"{value!r} is fixed here but parameters.{name} searches it; write it in one "
                              f"place (objective.fixed, or parameters.{name} with low/high or fixed)")
        if name in space.fixed and space.fixed[name] != value:
            raise ConfigError(cfg.source, f"objective.fixed.{name}",
                              f"{value!r} contradicts parameters.{name}: {{fixed: {space.fixed[name]!r}}}; "
                              f"write it in one place")


def check_bounds(cfg: RunConfig, objective: Any, space: Space) -> None:
    """Both bounds of every searched parameter must be values the objective accepts (``check_params``)."""
    check = hook(objective, "check_params")
    if check is None:
        return
    point = reference_point(objective, space)
    try:  # the point itself first: a bad fixed value is not the bounds' fault
        check(point)
    except ValueError as exc:
        bad = [n for n in space.fixed if f"{n} " in str(exc)]
        raise ConfigError(cfg.source, f"parameters.{bad[0]}.fixed" if bad else "objective",
                          f"the objective refuses its parameters before any search: {exc}") from None
    for p in space.free:
        for side in ("low", "high"):
            value = p.from_unit(0.0 if side == "low" else 1.0)
            try:
                check({**point, p.name: value})
            except ValueError as exc:
                raise ConfigError(cfg.source, f"parameters.{p.name}.{side}",
                                  f"{value!r} is outside what the objective accepts ({exc})") from None


def reference_point(objective: Any, space: Space) -> dict[str, Any]:
    """Default parameters restricted to the space (fixed values applied); the centre where none."""
    defaults_fn = hook(objective, "default_params")
    defaults = dict(defaults_fn()) if defaults_fn else {}
    centre = space.decode(np.full(space.dim, 0.5))
    return {n: (space.fixed[n] if n in space.fixed else defaults.get(n, centre[n])) for n in space.names}


def _worker_preflight(objective: Any) -> str:
    """On a Dask worker: run the objective's preflight hook there; '' when it passes."""
    fn = hook(objective, "preflight")
    try:
        if fn is not None:
            fn()
    except Exception as exc:  # reported back to the driver as text, with the worker's address
        return f"{type(exc).__name__}: {exc}"
    return ""


def _connect(cfg: RunConfig, client_cls: Any) -> Any:
    """A Dask client of ``parallel.address`` within ``parallel.connect_timeout_s``, or a :class:`ConfigError`.

    The connection is made in a helper thread with a hard deadline: a server that accepts but is not a
    scheduler can leave the client's handshake waiting forever, or answer bytes it reads as a huge frame.
    """
    import threading

    t = cfg.parallel.connect_timeout_s
    box: dict[str, Any] = {}

    def connect() -> None:
        try:
            box["client"] = client_cls(cfg.parallel.address, timeout=f"{t:g}s")
        except BaseException as exc:  # noqa: BLE001 - reported as the error line below
            box["error"] = exc

    th = threading.Thread(target=connect, daemon=True, name="tuner-dask-connect")
    th.start()
    th.join(t + 5.0)
    if "client" in box:
        return box["client"]
    why = (f"no Dask scheduler answered within {t:g} s (parallel.connect_timeout_s)" if th.is_alive() else
           f"cannot reach the scheduler: {type(box['error']).__name__}: {str(box['error'])[:300]}")
    raise ConfigError(cfg.source, "parallel.address", f"{cfg.parallel.address}: {why}")


def _dask_check(cfg: RunConfig, objective: Any) -> None:
    try:
        from distributed import Client
    except ImportError:
        raise ConfigError(cfg.source, "parallel.backend",
                          "dask needs the 'distributed' package: pip install -e '.[cluster]' (in a clone)") from None
    client = _connect(cfg, Client)
    try:
        results = client.run(_worker_preflight, objective)
    finally:
        client.close()
    bad = {w: r for w, r in results.items() if r}
    if bad:
        worker, why = next(iter(sorted(bad.items())))
        raise ConfigError(cfg.source, "objective", f"fails on Dask worker {worker} ({len(bad)} of {len(results)} "
                                                   f"workers): {why}")


def check_cv_folds(cfg: RunConfig, objective: Any) -> None:
    """With ``validation.cv``, the objective must give at least two folds (``cv_folds`` hook) for the
    configured ``folds`` (``kfold``) or its own grouping (``logo``); else a :class:`ConfigError` before tuning."""
    v = cfg.validation
    if v.cv is None:
        return
    fn = hook(objective, "cv_folds")
    if fn is None:
        raise ConfigError(cfg.source, "validation.cv", f"{type(objective).__name__} has no held-out folds (no "
                                                       "cv_folds hook): it cannot be cross-validated; remove it")
    try:
        k = v.folds if v.cv == "kfold" else None
        n = len(list(fn(k, by="dataset") if v.cv == "dataset" else fn(k)))
    except ValueError as exc:
        key = {"kfold": "validation.folds", "dataset": "validation.cv.by"}.get(v.cv, "validation.cv")
        raise ConfigError(cfg.source, key,
                          f"{exc}; the cross-validation after the run needs it") from None
    if n < 2:
        raise ConfigError(cfg.source, "validation", f"the objective gives {n} fold(s) here; cross-validation "
                                                    "needs at least 2")


def _child_eval(objective: Any, point: dict[str, Any], send: Any) -> None:
    from tuner.evaluate import evaluate_one

    code = 0
    try:
        send.send(evaluate_one(objective, point))
    except BaseException:  # pragma: no cover - evaluate_one records everything but a stop signal
        code = 1
    finally:
        os._exit(code)


def _evaluate_in_child(cfg: RunConfig, objective: Any, point: dict[str, Any]) -> Any:
    """The default point evaluated in a forked child, so that an objective that calls ``os._exit`` or
    crashes the interpreter there is one :class:`ConfigError` naming the exit status or signal."""
    import signal as _signal

    from tuner.evaluate import fork_child

    child, recv = fork_child(_child_eval, objective, point)
    try:
        try:
            rec = recv.recv()
        except EOFError:
            rec = None
        child.join()
    finally:
        if child.is_alive():
            child.kill()
            child.join()
        recv.close()
    if rec is not None:
        return rec
    code = child.exitcode
    how = f"exited with status {code}"
    if code is not None and code < 0:
        try:
            how = f"killed by signal {_signal.Signals(-code).name}"
        except ValueError:
            how = f"killed by signal {-code}"
    raise ConfigError(cfg.source, "objective", f"evaluating the default parameters crashed the process ({how}); "
                                               "an objective must return or raise, not end the process")


def preflight(cfg: RunConfig, objective: Any, space: Space,
              warn: Callable[[str], None] | None = None, evaluate: bool = True) -> list[str]:
    """Run the checks of the module docstring; raise :class:`ConfigError`, return the warnings.

    ``evaluate=False`` skips step 4 (used where the defaults were already scored).
    """
    from tuner.evaluate import evaluate_one

    check_names(cfg, objective, space)
    check_bounds(cfg, objective, space)
    warnings: list[str] = []
    fn = hook(objective, "preflight")
    if fn is not None:
        try:
            warnings += list(fn() or [])
        except ValueError as exc:
            raise _key_error(cfg, exc, "objective.data") from None
        except OSError as exc:
            raise ConfigError(cfg.source, "objective.data", f"{exc.filename or ''} {exc.strerror or exc}") from None
    if cfg.parallel.backend == "dask" and cfg.parallel.address:
        _dask_check(cfg, objective)
    if evaluate:
        point = reference_point(objective, space)
        # a crash at the defaults is one error line: evaluate them in a child (with `timeout_s` the evaluation
        # already runs in a forked child, which a daemonic preflight child could not start)
        in_child = ((cfg.objective.get("kind") == "python" or cfg.parallel.backend in ("loky", "dask"))
                    and not cfg.objective.get("timeout_s"))
        rec = _evaluate_in_child(cfg, objective, point) if in_child else evaluate_one(objective, point)
        if rec.raised:
            raise ConfigError(cfg.source, "objective", f"evaluating the default parameters failed: "
                                                       f"{rec.evaluation.error}")
        if rec.evaluation.status != "ok":
            warnings.append(f"the default parameters score as failed ({rec.evaluation.error})")
    for w in warnings:
        if warn:
            warn(f"warning: {w}")
    return warnings
