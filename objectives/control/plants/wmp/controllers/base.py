"""What every WMP controller shares: named parameters, default search space, kernel parameter array.

A controller is a numba step function dispatched by an integer ``kind`` inside the closed-loop
kernel (see :mod:`objectives.control.plants.wmp.controllers.kernels`) plus a thin subclass of
:class:`Controller` that declares

- ``name``: the YAML name (``controller: pid``);
- ``kind``: the ``KIND_WMP_*`` constant (:mod:`objectives.control.kinds`) of its branch in
  ``kernels.controller_step``;
- ``decl``: the one :class:`objectives.params.ParamSet` of its parameters (default -- thesis Table 2.7
  where it gives them --, search bounds, scale, unit, allowed range, doc, equation); ``params`` (the
  default search space as :class:`tuner.space.Real`) and ``defaults`` derive from it, and
  :meth:`Controller.resolve` validates the values of every evaluation against it;
- ``state_size``: length of the zeroed float state array the step function uses;

and implements ``_build(values) -> np.ndarray``, the float parameter array of its step function.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from objectives.control.plants.wmp.model import SensorParams, WMPParams
from objectives.params import Declared, ParamSet
from tuner.space import Real, Space

__all__ = ["Controller"]


class Controller(Declared):
    """Base class; instances are cheap and picklable (plain dataclass-like attributes).

    Parameters
    ----------
    plant : plant parameters the design may depend on (LQR linearises the model).
    sensors : sampling period and sensor settings.
    """

    name: ClassVar[str] = ""
    kind: ClassVar[int] = -1
    #: the loop the controller runs in (objectives.control.controllers): the pendulum's own
    family: ClassVar[str] = "wmp"
    #: the one declaration of the parameters (``params`` and ``defaults`` derive from it)
    decl: ClassVar[ParamSet | None] = None
    params: ClassVar[tuple[Real, ...]] = ()
    defaults: ClassVar[dict[str, Any]] = {}
    state_size: ClassVar[int] = 0

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("decl") is not None:
            cls.params = cls.decl.reals()
            cls.defaults = cls.decl.defaults()

    def __init__(self, plant: WMPParams | None = None, sensors: SensorParams | None = None):
        self.plant = plant or WMPParams()
        self.sensors = sensors or SensorParams()
        #: the deployed controller's complete values (``build`` hook); None: ``param_array`` defaults
        self.values: dict[str, Any] | None = None

    @classmethod
    def declaration_for(cls, plant: Any = None) -> ParamSet:
        """The declaration on ``plant`` (the same for every pendulum: the protocol of
        :mod:`objectives.control.controllers`)."""
        return cls.decl

    @classmethod
    def default_space(cls) -> Space:
        return Space(cls.params)

    @classmethod
    def resolve(cls, values: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Defaults updated with ``values``, validated against ``decl``; unknown names are a
        ``ValueError`` listing the known ones, a bad value one naming the key and the allowed range."""
        values = dict(values or {})
        if cls.decl is not None:
            return cls.decl.validate(values)
        known = [p.name for p in cls.params]
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise ValueError(f"controller {cls.name!r}: unknown parameter(s) {unknown}; known: {known}")
        out = dict(cls.defaults)
        out.update(values)
        missing = [n for n in known if n not in out]
        if missing:
            raise ValueError(f"controller {cls.name!r}: no value for {missing}")
        return out

    def param_array(self, values: Mapping[str, Any] | None = None) -> np.ndarray:
        """The float64 parameter array of the kernel step for ``values`` (defaults filled in; without
        ``values``, the instance's own :attr:`values` when it has them)."""
        if values is None:
            values = self.values
        arr = np.ascontiguousarray(self._build(self.resolve(values)), dtype=float)
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"controller {self.name!r}: non-finite parameter array for {dict(values or {})}")
        return arr

    def _build(self, values: dict[str, Any]) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError
