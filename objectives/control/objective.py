"""The closed-loop objective: a controller (one registry) tuned on a plant (one registry) in its family's loop.

``objective: {kind: closed_loop, plant: ..., controller: ..., fixed: {...}, ...}``. The plant picks the
loop: ``plant: wmp`` (the default) is the thesis's wheeled mobile pendulum with its sensors and eq. 2.39
(:mod:`objectives.control.plants.wmp.loop`, whose docstring lists its keys); a mapping with one type key
(``tf``, ``zpk``, ``ss``, ``python``, ``fmu``) is any plant in the generic loop
(:mod:`objectives.control.plants.loop`, its keys there). The kinds are registered in
:data:`objectives.control.plants.PLANTS`, their loops in :data:`objectives.control.plants.LOOPS`, the
controllers in :data:`objectives.control.controllers.CONTROLLERS` (a controller runs on the plants of its
family).

This class is what the engine sees (``tuner.objectives`` entry point ``closed_loop``): the controller's
declaration, ``fixed`` values, default space, validation, deployment and the engine's catalog are
handled here once for every plant; simulating and scoring belong to the loop (:attr:`loop`), reporting
to the loop's report module. Calling it with a dict of controller parameters returns the loop's
:class:`tuner.objective.Evaluation`; a design that cannot be built (a Riccati equation without
solution) is a failed evaluation ``controller design failed: ...``.
"""

from __future__ import annotations

import pathlib
from collections.abc import Mapping
from typing import Any

import numpy as np

from objectives.control.controllers import get_controller
from objectives.control.design import evaluate_loop
from objectives.control.plants import loop_class, plant_kind
from tuner.deployment import Deployment
from tuner.objective import Evaluation
from tuner.space import Real, Space

__all__ = ["ClosedLoopObjective"]

#: the keys every closed-loop job may hold, whatever its plant (its loop adds its own)
COMMON_KEYS = frozenset({"kind", "plant", "controller", "fixed"})


class ClosedLoopObjective:
    """Picklable closed-loop objective (module docstring); derived state is rebuilt on unpickling.

    Parameters
    ----------
    plant : str or mapping
        ``"wmp"`` or a plant mapping (:func:`objectives.control.plants.plant_kind`).
    controller : str, optional
        A registered controller of the plant's family; the loop's default (``pid``, ``pid2dof``) if None.
    fixed : mapping, optional
        Controller values held fixed (override its defaults; never searched).
    base_dir : path, optional
        The config's folder (files the plant names are found there first).
    **settings
        The loop's own settings (``profile``, ``duration_s``, ... for the pendulum; ``period_s``,
        ``scenario``, ... for the generic loop).
    """

    def __init__(self, plant: Any = "wmp", controller: str | None = None, fixed: Mapping[str, Any] | None = None,
                 base_dir: str | pathlib.Path | None = None, **settings: Any) -> None:
        self.plant = plant
        self.controller = controller
        self.fixed = dict(fixed or {})
        self.base_dir = str(base_dir) if base_dir is not None else None
        self.settings = settings
        self._build()

    def _build(self) -> None:
        kind = plant_kind(self.plant)
        loop = loop_class(kind.family)
        self.controller = self.controller or loop.DEFAULT_CONTROLLER
        self._cls = get_controller(self.controller, kind.family,
                                   "objective.controller" if kind.family != "wmp" else None)
        #: the plant family's loop (simulation and scoring)
        self.loop = loop(kind, self.plant, self._cls, self.fixed, self.base_dir, **self.settings)

    # --- construction ---------------------------------------------------------------------------
    @classmethod
    def from_config(cls, section: Mapping[str, Any], base_dir: pathlib.Path | None = None) -> ClosedLoopObjective:
        """Build from the YAML ``objective:`` mapping; unknown keys and bad values are ``ValueError`` naming
        the key."""
        section = dict(section)
        spec = section.get("plant", "wmp")
        kind = plant_kind(spec)  # before the loop's keys: a typo'd plant is the cause
        loop = loop_class(kind.family)
        if section.get("kind", "closed_loop") != "closed_loop":
            raise ValueError(f"objective.kind must be 'closed_loop', got {section.get('kind')!r}")
        settings = loop.settings_from_config(section, base_dir)
        ctrl = section.get("controller", loop.DEFAULT_CONTROLLER)
        if not isinstance(ctrl, str):
            raise ValueError(f"objective.controller: expected a name, got {ctrl!r}")
        plant = dict(spec) if isinstance(spec, Mapping) else spec
        try:
            return cls(plant=plant, controller=ctrl, fixed=dict(section.get("fixed") or {}), base_dir=base_dir,
                       **settings)
        except ValueError as exc:
            raise ValueError(loop.error_key(str(exc))) from None

    # --- engine hooks (tuner.objective.TunableObjective) -----------------------------------------
    @property
    def decl(self) -> Any:
        """The controller's declaration on this plant."""
        return self.loop.decl

    @property
    def defaults(self) -> dict[str, Any]:
        """Initial parameter values (the declaration's defaults, thesis Table 2.7 for the pendulum; a tuning
        rule's PID with ``init:``) with ``fixed`` applied."""
        return self.decl.validate({**self.loop.start_values(), **self.fixed})

    def default_space(self) -> Space:
        """The controller's default space with the ``fixed`` values pinned."""
        return Space(Real(p.name, fixed=self.fixed[p.name], unit=p.unit, doc=p.doc) if p.name in self.fixed
                     else p.real() for p in self.decl)

    def default_params(self) -> dict[str, Any]:
        """:attr:`defaults` (the engine's name for the untuned values)."""
        return self.defaults

    def start_params(self) -> dict[str, Any] | None:
        """Where the search starts: the ``init:`` rule's PID (:mod:`objectives.control.plants.start`), or None
        (the optimiser's own start)."""
        return self.defaults if self.loop.start_values() else None

    def parameter_names(self) -> list[str]:
        """Every parameter of the controller (searched or fixed)."""
        return self.decl.names()

    def check_params(self, params: Mapping[str, Any]) -> None:
        """The controller declaration's validation of ``params`` (with ``fixed``); no design, no simulation."""
        self.decl.validate({**self.fixed, **params})

    def sample_rate(self) -> tuple[float | None, str]:
        """The controller's sampling rate (1 / its period)."""
        return 1.0 / float(self.loop.period_s), self.loop.rate_name

    def describe(self) -> dict[str, Any]:
        """Provenance for ``tuner export``: controller, plant and scenario."""
        return self.loop.describe()

    def values(self, params: Mapping[str, Any]) -> dict[str, Any]:
        """Every declared value of ``params`` with ``fixed`` and the defaults, validated."""
        return self.decl.validate({**self.fixed, **params})

    def deployment(self, params: Mapping[str, Any]) -> Deployment:
        """The complete tuned controller, scoring-only settings apart (:mod:`objectives.control.deployment`)."""
        from objectives.control.deployment import controller_deployment

        return controller_deployment(self, params)

    def build(self, params: Mapping[str, Any]) -> Any:
        """The deployed controller of ``params`` (``values``, ``param_array()``)."""
        return self.loop.build(self.values(params))

    def export_tables(self, params: Mapping[str, Any] | None = None) -> dict[str, Any] | None:
        """The controller's tables for ``tuner export``: the discrete coefficients (generic loop) or the fuzzy
        look-up tables (LUT1-3, thesis eq. 2.32); ``None`` for a controller without any."""
        return self.loop.export_tables({**self.fixed, **dict(params or {})})

    def export_c(self, params: Mapping[str, Any], precision: str, prefix: str, comment: str) -> dict[str, str]:
        """The deployed controller as C99 (``tuner export --format c-controller``): the generic loop's PID
        family and state feedback (:mod:`objectives.control.plants.cexport`); ValueError naming
        ``objective.controller`` for a controller without a C port."""
        return self._c_loop().export_c(self.values(params), precision, prefix, comment)

    def verify_c(self, params: Mapping[str, Any], precision: str, opt: tuple[str, ...]) -> dict[str, Any]:
        """The exported controller compiled and its loop closed next to the model (``tuner verify-c``)."""
        return self._c_loop().verify_c(self.values(params), precision, opt)

    def _c_loop(self) -> Any:
        from objectives.control.plants.cexport import c_controller_names

        if self.controller not in c_controller_names():  # the ports are the generic loop's
            where = f" (plant {self.loop.family})" if self.loop.family != "siso" else ""
            raise ValueError(f"objective.controller: {self.controller!r}{where} has no C port; the controllers with "
                             f"one: {', '.join(c_controller_names())}")
        return self.loop

    # --- evaluation -----------------------------------------------------------------------------
    def coeffs(self, params: Mapping[str, Any] | None = None) -> np.ndarray:
        """The kernel's coefficient array of ``params`` (``ValueError`` if the design cannot be built)."""
        return self.loop.coeffs(params or {})

    def simulate(self, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The closed loop of ``params`` (the loop's record of the run)."""
        return self.loop.simulate(params)

    def __call__(self, params: Mapping[str, Any]) -> Evaluation:
        return evaluate_loop(self.loop, params)  # a design that cannot be built: a failed evaluation

    def evaluate_batch(self, params_list: list[Mapping[str, Any]], n_threads: int) -> list[Any] | None:
        """A population in one kernel on ``n_threads`` threads, equal to ``[self(p) for p in params_list]``
        (``backend: threads``); None when the plant's loop has no population kernel."""
        return self.loop.evaluate_batch(params_list, n_threads)

    def traces(self, params: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
        """The responses of ``params`` against the references (the engine's method-comparison figure)."""
        return self.loop.traces(params)

    def finalize(self, run_dir: str | pathlib.Path, best: Mapping[str, Any]) -> dict[str, Any]:
        """After a run: the defaults' and the best parameters' scores and the loop's report figures."""
        return self.loop.finalize(pathlib.Path(run_dir), self.defaults, dict(best or {}))

    # --- engine catalog (tuner list / describe) -------------------------------------------------
    @classmethod
    def catalog(cls) -> dict[str, list[str]]:
        """Names ``objective.controller``, the eq. 2.39 cost, the pendulum's profiles and the generic loop's
        settings (``tuner list``)."""
        from objectives.control.controllers import CONTROLLERS
        from objectives.control.plants.wmp.profiles import PROFILES
        from objectives.control.settings_doc import SETTINGS

        return {"controllers": sorted(n for n in CONTROLLERS if n != "open_loop"),  # open_loop tunes nothing
                "metrics": ["mae_weighted_cost"], "data": sorted(PROFILES), "plants": ["plant"],
                "settings": list(SETTINGS)}

    @classmethod
    def explain(cls, name: str) -> dict[str, Any] | None:
        """``tuner describe NAME``: a controller, the plants, a setting of the generic loop, the eq. 2.39 cost or
        a profile, else None."""
        from objectives.control.describe import explain

        return explain(name)

    # --- pickling: rebuild derived state in the worker ------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        return {"plant": self.plant, "controller": self.controller, "fixed": self.fixed, "base_dir": self.base_dir,
                "settings": self.settings}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._build()
