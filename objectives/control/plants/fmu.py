"""FMU plants (FMI 2.0 co-simulation) through fmpy: ``plant: {fmu: path.fmu, inputs, outputs, parameters}``.

YAML (``objective.plant``)::

    fmu: first_order.fmu        # relative to the config's folder
    inputs: [u]                 # the FMU's input variables the controller drives (u[0] first)
    outputs: [y]                # the FMU's output variables measured (y[0] first)
    parameters: {K: 2.0}        # start values of FMU parameters
    output: 0                   # which output the loop controls
    inner_output: -1            # the inner loop's output (cascaded PID)
    delay_s: 0.0                # input delay, a whole number of periods

Each evaluation resets the FMU (``fmi2Reset``), sets the parameters, initialises it and then, each
controller period, sets the inputs, calls ``fmi2DoStep`` over the period and reads the outputs. The
loop around it (measurement, controller, actuator, delay) is the same as for Python dynamics; the FMU's
state is what it outputs (state feedback on an FMU feeds back its outputs). The FMU is driven from Python
(one library call per period), so it is slower than the compiled plants. fmpy is an optional extra
(``pip install -e '.[fmu]'``). Checked before any tuning: the file opens and validates, it is FMI 2.0
co-simulation, every named input, output and parameter exists with that causality, and one step runs.

An FMU is code (its native library runs in this process): it is loaded only by the commands that run code,
never from inside a handed-over run directory (:func:`tuner.trust.check_code`), and the file is opened as
untrusted data first (:mod:`.fmu_archive`: a zip of bounded size and entries, ``modelDescription.xml`` without
entities, an extraction folder removed with the plant, at exit and on Ctrl-C).
"""

from __future__ import annotations

import math
import pathlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from objectives.control.plants.base import PlantKind, SteppedPlant
from objectives.control.plants.kernels import _loop_nl

__all__ = ["FMUPlant", "fmu_from_spec", "FMU_KEYS", "FMU"]

FMU_KEYS = {"fmu", "inputs", "outputs", "parameters", "output", "inner_output", "delay_s"}


@dataclass
class FMUPlant(SteppedPlant):
    """An instantiated co-simulation FMU (module docstring): the stepped variant of the ``Plant`` protocol,
    advanced by ``fmi2DoStep``; not picklable (the objective rebuilds it)."""

    path: str
    inputs: list[str]
    outputs_names: list[str]
    parameters: dict[str, float]
    period_s: float
    output: int = 0
    inner_output: int = -1
    delay_n: int = 0
    x0: np.ndarray = field(default_factory=lambda: np.zeros(0))
    model: str = "fmu"
    compiled: bool = False
    params: Any = None
    fn: Any = None
    n_sub: int = 1

    def __post_init__(self) -> None:
        from fmpy.fmi2 import FMU2Slave

        from objectives.control.plants.fmu_archive import attach_cleanup, extract, read_description

        self._md = read_description(self.path, "objective.plant.fmu")
        byname = {v.name: v for v in self._md.modelVariables}
        self._vr_in = [byname[n].valueReference for n in self.inputs]
        self._vr_out = [byname[n].valueReference for n in self.outputs_names]
        self._vr_par = [byname[n].valueReference for n in self.parameters]
        self._dir = extract(self.path, "objective.plant.fmu")
        attach_cleanup(self, self._dir)  # the folder goes with this plant (and at exit, also after a Ctrl-C)
        self._fmu = FMU2Slave(guid=self._md.guid, unzipDirectory=str(self._dir),
                              modelIdentifier=self._md.coSimulation.modelIdentifier, instanceName="plant")
        self._fmu.instantiate()
        self._started = False
        self.outputs = np.arange(len(self.outputs_names), dtype=np.int64)
        self.reset()

    @property
    def n_states(self) -> int:
        return len(self.outputs_names)

    @property
    def n_inputs(self) -> int:
        return len(self.inputs)

    @property
    def n_outputs(self) -> int:
        return len(self.outputs_names)

    def reset(self) -> None:
        """Back to the start: reset, parameters, initialisation; ``x0`` = the initial outputs."""
        f = self._fmu
        if self._started:
            f.reset()
        self._started = True
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
        if self._vr_par:
            f.setReal(self._vr_par, [float(v) for v in self.parameters.values()])
        f.exitInitializationMode()
        self.x0 = np.array(f.getReal(self._vr_out), dtype=float)

    def advance(self, _f: Any, x: np.ndarray, u: np.ndarray, t: float, _params: Any, h: float,
                n_sub: int) -> np.ndarray:
        """One controller period: inputs ``u`` held, ``fmi2DoStep(t, h n_sub)``; returns the outputs (the
        signature of the RK4 step it replaces in the loop)."""
        self._fmu.setReal(self._vr_in, [float(v) for v in u])
        self._fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h * n_sub)
        return np.array(self._fmu.getReal(self._vr_out), dtype=float)

    def stepper(self):
        """The loop in Python (one library call per period) with :meth:`advance` as the step."""
        return _loop_nl.py_func, self.advance

    def named_parameters(self) -> dict[str, float]:
        """The FMU parameters the spec sets."""
        return dict(self.parameters)

    def tracked_row(self) -> np.ndarray:
        row = np.zeros(self.n_states)
        row[self.output] = 1.0
        return row

    def design_model(self) -> tuple[np.ndarray, np.ndarray]:
        raise ValueError("state feedback needs a model: an FMU plant has none (use a PID)")


def _names(key: str, v: Any) -> list[str]:
    if not isinstance(v, list) or not v or not all(isinstance(s, str) for s in v):
        raise ValueError(f"{key}: expected a non-empty list of variable names, got {v!r}")
    return v


def fmu_from_spec(spec: Mapping[str, Any], period_s: float, base_dir: pathlib.Path | None,
                  key: str = "objective.plant") -> FMUPlant:
    """Open, validate and instantiate the FMU of ``spec`` (its keys among :data:`FMU_KEYS`, checked by
    :func:`~objectives.control.plants.plant_kind`); ``ValueError`` naming the key otherwise."""
    from objectives.control.plants.fmu_archive import read_description
    from tuner.sizes import check_samples
    from tuner.trust import check_code

    try:
        import fmpy  # noqa: F401
    except ImportError:
        raise ValueError(f"{key}.fmu: FMU plants need fmpy (pip install -e '.[fmu]')") from None
    if not isinstance(spec["fmu"], str) or not spec["fmu"] or "\x00" in spec["fmu"]:
        raise ValueError(f"{key}.fmu: expected the path of an .fmu file, got {spec['fmu']!r}")
    path = pathlib.Path(spec["fmu"])
    if not path.is_absolute() and base_dir is not None:
        path = pathlib.Path(base_dir) / path
    check_code(path, f"{key}.fmu", "the FMU")  # a native library: only where this command may load code
    if not path.is_file():
        raise ValueError(f"{key}.fmu: no such file {str(path)!r}")
    md = read_description(path, f"{key}.fmu")
    if md.fmiVersion != "2.0" or md.coSimulation is None:
        raise ValueError(f"{key}.fmu: {path.name} must be FMI 2.0 co-simulation, got FMI {md.fmiVersion}"
                         f"{'' if md.coSimulation else ' without co-simulation'}")
    by = {v.name: v for v in md.modelVariables}
    inputs = _names(f"{key}.inputs", spec.get("inputs"))
    outputs = _names(f"{key}.outputs", spec.get("outputs"))
    params = spec.get("parameters") or {}
    if not isinstance(params, Mapping):
        raise ValueError(f"{key}.parameters: expected a mapping of name: value, got {params!r}")
    for what, names, causality in (("inputs", inputs, "input"), ("outputs", outputs, "output"),
                                   ("parameters", list(params), "parameter")):
        have = sorted(n for n, v in by.items() if v.causality == causality)
        for n in names:
            if n not in by or by[n].causality != causality or by[n].type != "Real":
                raise ValueError(f"{key}.{what}: {n!r} is not a Real {causality} of {path.name}; its {what}: {have}")
    for n, v in params.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{key}.parameters.{n}: must be a finite number, got {v!r}")
    delay = spec.get("delay_s", 0.0)
    if not (isinstance(delay, (int, float)) and math.isfinite(delay) and delay >= 0) \
            or abs(delay / period_s - round(delay / period_s)) > 1e-6:
        raise ValueError(f"{key}.delay_s: a whole number of controller periods ({period_s} s) >= 0, got {delay!r}")
    check_samples(f"{key}.delay_s", round(delay / period_s), "the input delay line")
    out_i, inner = spec.get("output", 0), spec.get("inner_output", -1)
    for name, v, lo in (("output", out_i, 0), ("inner_output", inner, -1)):
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v < len(outputs):
            raise ValueError(f"{key}.{name}: an index into outputs (0..{len(outputs) - 1}), got {v!r}")
    try:
        plant = FMUPlant(str(path), inputs, outputs, {k: float(v) for k, v in params.items()}, float(period_s),
                         out_i, inner, int(round(delay / period_s)))
        y1 = plant.advance(None, plant.x0, np.zeros(len(inputs)), 0.0, None, float(period_s), 1)
    except Exception as exc:  # noqa: BLE001 - a native library: any failure is a config error with its text
        raise ValueError(f"{key}.fmu: {path.name} does not run: {type(exc).__name__}: {exc}") from None
    if not np.all(np.isfinite(y1)):
        raise ValueError(f"{key}.fmu: {path.name} returned non-finite outputs {y1.tolist()} after one step")
    plant.reset()
    return plant


def fmu_uncertain(spec: Mapping[str, Any]) -> dict[str, float]:
    """The parameters an ``uncertainty:`` block may perturb: the ``parameters.<name>`` the spec sets and
    ``delay_s``."""
    params = spec.get("parameters") or {}
    return {**{f"parameters.{k}": float(v) for k, v in params.items()}, "delay_s": float(spec.get("delay_s", 0.0))}


#: the registered kind (objectives.control.plants.PLANTS)
FMU = PlantKind("fmu", frozenset(FMU_KEYS), fmu_from_spec, "siso",
                "path.fmu (FMI 2.0 co-simulation, extra fmu); inputs, outputs, parameters", uncertain=fmu_uncertain)
