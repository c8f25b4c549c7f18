"""Warnings a run's result deserves: parameters that ended at a search bound, failed evaluations.

A best value within ``tol`` (default 2 %) of a bound, measured in the coordinate the optimiser
searched (``log10`` for log-scaled parameters, the value itself for linear ones), suggests the
optimum lies outside the bounds: widen them and run again. Failed evaluations are counted with
their most frequent reasons. The run report, the sweep report and ``tuner show`` print the same
:class:`ReportWarning` objects.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from tuner.failures import failure_groups
from tuner.records import RunError
from tuner.rundir import RunDir
from tuner.space import Real, Space, SpaceError
from tuner.verdict import defaults_verdict

__all__ = ["ReportWarning", "bound_warnings", "failure_warnings", "run_warnings", "run_space", "BOUND_TOL"]

#: default distance to a bound (fraction of the searched range) that triggers a warning
BOUND_TOL = 0.02


@dataclass(frozen=True)
class ReportWarning:
    """One warning about a run's result.

    Attributes
    ----------
    kind : {"bound", "failed", "defaults"}
        ``bound``: a parameter ended near a search bound; ``failed``: evaluations failed; ``defaults``:
        held-out or CV scores say the tuned values are worse than the defaults (:mod:`tuner.verdict`).
    message : str
        One line for people (plain text).
    param : str
        Parameter name (``bound`` warnings), else empty.
    value : float
        The best value of ``param``; for ``failed`` the number of failed evaluations.
    bound : float
        The bound it is near (``bound`` warnings), else nan.
    side : {"low", "high", ""}
        Which bound.
    distance : float
        Distance to the bound as a fraction of the searched range (log range for log parameters);
        for ``failed`` the failed fraction of all evaluations.
    """

    kind: Literal["bound", "failed", "defaults"]
    message: str
    param: str = ""
    value: float = math.nan
    bound: float = math.nan
    side: Literal["low", "high", ""] = ""
    distance: float = math.nan


def _unit(p: Real, v: float) -> float:
    """Position of ``v`` in the searched coordinate of ``p``, not clipped (0 = low, 1 = high)."""
    if p.scale == "log":
        return (math.log10(v) - math.log10(p.low)) / (math.log10(p.high) - math.log10(p.low))
    return (v - p.low) / (p.high - p.low)


def bound_warnings(params: Mapping[str, Any], space: Space, tol: float = BOUND_TOL) -> list[ReportWarning]:
    """A warning for every free parameter of ``space`` whose value in ``params`` is within ``tol`` of a bound.

    Parameters
    ----------
    params : mapping
        Physical values (a ``best.yaml`` ``params`` block); names missing from it are skipped.
    space : Space
        The search space of the run (stage-0 bounds).
    tol : float
        Fraction of the searched range, in ``[0, 0.5)``.
    """
    if not 0 <= tol < 0.5:
        raise ValueError(f"tol: expected a fraction in [0, 0.5), got {tol!r}")
    out = []
    for p in space.free:
        if p.name not in params:
            continue
        try:
            v = float(params[p.name])
        except (TypeError, ValueError):
            continue
        if not math.isfinite(v) or (p.scale == "log" and v <= 0):
            continue
        u = _unit(p, v)
        side, bound, dist = ("low", p.low, u) if u <= 0.5 else ("high", p.high, 1.0 - u)
        if dist <= tol + 1e-12:  # 2 % means 2 % despite rounding (1 - 0.98 > 0.02 in binary)
            where = "log10 range" if p.scale == "log" else "range"
            out.append(ReportWarning(
                "bound", f"{p.name} = {v:.4g} is {max(dist, 0.0):.1%} of its {where} from the {side} bound "
                         f"{bound:.4g}: the optimum may lie outside [{p.low:.4g}, {p.high:.4g}]; widen the bounds",
                param=p.name, value=v, bound=bound, side=side, distance=max(dist, 0.0)))
    return out


def failure_warnings(n_failed: int, n_evals: int, errors: list[str] | None = None,
                     top: int = 3) -> list[ReportWarning]:
    """One warning when ``n_failed > 0``, naming the ``top`` most frequent reasons (grouped by
    :func:`tuner.failures.failure_groups`: the same reason with other numbers counts once per evaluation)."""
    if n_failed <= 0:
        return []
    frac = n_failed / n_evals if n_evals else math.nan
    msg = f"{n_failed} of {n_evals} evaluations failed ({frac:.1%})"
    common = failure_groups(errors or [])[:top]
    if common:
        msg += "; most frequent reasons: " + "; ".join(f"{g.example[:120]} (x{g.count})" for g in common)
    return [ReportWarning("failed", msg, value=float(n_failed), distance=frac)]


def run_space(run_dir: Path) -> Space | None:
    """The search space of a run directory's config, or None when it has none or it does not build."""
    rd = RunDir(run_dir)
    if not rd.file("config.yaml").exists():
        return None
    try:
        return Space.from_dict(rd.config().get("parameters") or {})
    except (RunError, SpaceError, AttributeError, TypeError):
        return None


def run_warnings(run_dir: str | Path, tol: float = BOUND_TOL) -> list[ReportWarning]:
    """Bound and failure warnings of a run directory (``config.yaml``, ``best.yaml``, ``meta.json``,
    ``history.csv``); files that do not exist yet (a run that just started) give no warning."""
    rd = RunDir(run_dir)
    out: list[ReportWarning] = []
    space = run_space(rd.path)
    if space is not None and rd.has_best():
        out += bound_warnings(dict(rd.best().params), space, tol)
    verdict = defaults_verdict(rd.best().evaluation) if rd.has_best() else None
    if verdict:  # held-out or CV scores say tuning made it worse (tuner.verdict)
        out.append(ReportWarning("defaults", verdict))
    rows = rd.history_rows()
    if rows:
        failed = [r for r in rows if r.get("status") not in ("ok", None)]
        return out + failure_warnings(len(failed), len(rows), [r.get("error") or "" for r in failed])
    if rd.file("meta.json").exists():
        meta = rd.meta()
        return out + failure_warnings(int(meta.n_failed or 0), int(meta.n_evals or 0), [])
    return out + failure_warnings(0, 0, [])
