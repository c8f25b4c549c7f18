"""The filter objective's reporting half: what it tells about itself and about a result
(:class:`FilterReporting`, a base of :class:`objectives.attitude.objective.FilterObjective`).

The names it accepts and their descriptions (``tuner list``, ``tuner describe``), its provenance for exports
(``describe``), the complete tuned filter (``deployment``, ``build``: :mod:`objectives.attitude.deployment`) and
the report at the end of a run (``finalize``: :mod:`objectives.attitude.report`). The C hooks are the
objective's own lines (:mod:`objectives.attitude.cexport.hooks`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from objectives.attitude import deployment as _deployment
from objectives.attitude.catalog import METRICS
from tuner.deployment import Deployment

__all__ = ["FilterReporting"]


class FilterReporting:
    """The reporting hooks of a filter objective (module docstring)."""

    @classmethod
    def catalog(cls) -> dict[str, list[str]]:
        """Names ``objective.filter``, ``objective.metric`` and data specs accept (``tuner list``)."""
        from objectives.attitude.catalog import data_sources
        from objectives.attitude.filters import filter_names

        return {"filters": filter_names(), "metrics": list(METRICS), "data": list(data_sources())}

    @classmethod
    def explain(cls, name: str) -> dict[str, Any] | None:
        """``tuner describe NAME``: a filter, metric or data source (see :mod:`objectives.attitude.catalog`)."""
        from objectives.attitude.catalog import explain

        return explain(name)

    def describe(self) -> dict[str, Any]:
        """Provenance for ``tuner export``: filter, metric and the data specs."""
        def specs(lst):
            out = []
            for spec in lst:
                if isinstance(spec, tuple) and spec[0] == "subset":  # a CV fold or a held-out selection part
                    return {"all": specs(list(spec[1])), "subset": sorted(spec[2])}
                if isinstance(spec, tuple):
                    return {"all": spec[1], "kfold": {"k": spec[2], "fold": spec[3]}}
                out.append(spec)
            return out

        data = specs(self.train_specs)
        if self.test_specs and not isinstance(data, dict):
            data = {"train": data, "test": specs(self.test_specs)}
        return {"objective": {"kind": "filter", "filter": self.filter, "metric": self.metric}, "data": data}

    def deployment(self, params: Mapping[str, Any]) -> Deployment:
        """The complete tuned filter: every value, scoring-only settings apart (objectives.attitude.deployment)."""
        return _deployment.filter_deployment(self, params)

    def build(self, params: Mapping[str, Any]):
        """The deployed filter instance of ``params`` (``.run(gyr, acc, mag, rate_hz=...)``, ``.stream()``)."""
        return _deployment.filter_build(self, params)

    # --- after the run ------------------------------------------------------------------------
    def finalize(self, run_dir: Path, best: Mapping[str, Any]) -> dict[str, Any]:
        """Train and test scores of the best parameters, a summary table and report figures."""
        from objectives.attitude.report import filter_report

        return filter_report(self, Path(run_dir), dict(best))
