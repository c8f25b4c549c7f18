"""VQF (Laidig & Seel 2023) as an external reference filter, through the optional ``vqf`` package.

VQF is today's state of the art on the BROAD benchmark (about 2 deg mean total RMSE over the training
trials with its default parameters) and the reference users compare tuned filters with. This module
does not re-implement it: it calls the package's compiled core (``vqf.VQF.updateBatch``, causal, the
default; or ``vqf.offlineVQF``, acausal, with ``offline: true``) and exposes its documented parameters.
Having no kernel of its own, it stays outside the filter contract of
:meth:`~objectives.attitude.filters.base.AttitudeFilter.kernel_setup` (serial only, never batched; its stream
calls the package's own per-sample update).

Install with ``pip install vqf`` (or ``pip install -e '.[vqf]'`` in a clone of this repository).

Frames
------
VQF's 9-D quaternion is sensor-to-earth ``(w, x, y, z)`` in ENU (x east, y north, z up, heading from
magnetic north), which is the project's convention; ``working_frame = "ENU"`` and the base class
converts to the recording's frame. The 6-D quaternion (``use_mag: false``) has an arbitrary heading.

Initialisation
--------------
VQF initialises itself (its accelerometer low-pass starts from the first sample and the first
magnetometer samples set the heading within ``magNewFirstTime``); the common ``q0`` is not used.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from objectives.attitude.data.recording import Recording
from objectives.attitude.filters.base import AttitudeFilter, FilterResult
from objectives.attitude.filters.stream import StreamBase
from objectives.params import POSITIVE, Param, ParamSet

__all__ = ["VQF", "VQF_PARAMS", "INSTALL_HINT"]

INSTALL_HINT = "the VQF filter needs the 'vqf' package: pip install vqf"

#: VQF's documented parameters (``vqf.VQF(...).params`` of vqf 2.x) and their defaults.
#: Units as VQF documents them: taus and times in s, bias values in deg/s, restThAcc in m/s^2,
#: magNormTh relative to the reference norm, magDipTh in deg, magNewMinGyr in deg/s.
VQF_PARAMS: dict[str, Any] = {
    "tauAcc": 3.0, "tauMag": 9.0,
    "motionBiasEstEnabled": True, "restBiasEstEnabled": True, "magDistRejectionEnabled": True,
    "biasSigmaInit": 0.5, "biasForgettingTime": 100.0, "biasClip": 2.0, "biasSigmaMotion": 0.1,
    "biasVerticalForgettingFactor": 0.0001, "biasSigmaRest": 0.03,
    "restMinT": 1.5, "restFilterTau": 0.5, "restThGyr": 2.0, "restThAcc": 0.5,
    "magCurrentTau": 0.05, "magRefTau": 20.0, "magNormTh": 0.1, "magDipTh": 10.0,
    "magNewTime": 20.0, "magNewFirstTime": 5.0, "magNewMinGyr": 20.0,
    "magMinUndisturbedTime": 0.5, "magMaxRejectionTime": 60.0, "magRejectionFactor": 2.0,
}
_BOOL_PARAMS = ("motionBiasEstEnabled", "restBiasEstEnabled", "magDistRejectionEnabled")
#: units of the numeric parameters as VQF documents them
_UNITS = {
    "tauAcc": "s", "tauMag": "s", "biasSigmaInit": "deg/s", "biasForgettingTime": "s", "biasClip": "deg/s",
    "biasSigmaMotion": "deg/s", "biasVerticalForgettingFactor": "1", "biasSigmaRest": "deg/s", "restMinT": "s",
    "restFilterTau": "s", "restThGyr": "deg/s", "restThAcc": "m/s^2", "magCurrentTau": "s", "magRefTau": "s",
    "magNormTh": "1", "magDipTh": "deg", "magNewTime": "s", "magNewFirstTime": "s", "magNewMinGyr": "deg/s",
    "magMinUndisturbedTime": "s", "magMaxRejectionTime": "s", "magRejectionFactor": "1",
}
# VQF treats tau <= 0 as "no filtering" (immediate correction), which is allowed but not what a tuner
# should wander into by accident: the time constants must be positive.
_SEARCHED = {p.name: p for p in (
    Param("tauAcc", 3.0, (0.1, 30.0), "log", "s", "time constant of the accelerometer correction",
          allowed=POSITIVE),
    Param("tauMag", 9.0, (0.3, 100.0), "log", "s", "time constant of the magnetometer correction",
          allowed=POSITIVE),
    Param("biasSigmaMotion", 0.1, (0.01, 1.0), "log", "deg/s", "std of the bias random walk during motion"),
    Param("biasForgettingTime", 100.0, (10.0, 1000.0), "log", "s",
          "time in which the bias uncertainty grows back to biasClip"),
    Param("magRejectionFactor", 2.0, (1.0, 10.0), "log", "1",
          "factor by which tauMag is raised after a magnetic disturbance"),
)}


def _import_vqf():
    try:
        import vqf
    except ImportError as exc:
        raise ImportError(INSTALL_HINT) from exc
    return vqf


class VQF(AttitudeFilter):
    """VQF orientation filter (Laidig & Seel, Information Fusion 91:187-204, 2023), wrapped.

    Searched by default (log scale): ``tauAcc`` [0.1, 30] s and ``tauMag`` [0.3, 100] s (the time
    constants of the accelerometer and magnetometer corrections), ``biasSigmaMotion`` [0.01, 1] deg/s,
    ``biasForgettingTime`` [10, 1000] s, ``magRejectionFactor`` [1, 10]. Every other documented VQF
    parameter (see :data:`VQF_PARAMS`) is a fixed option at VQF's default and may be set by name; the
    booleans ``motionBiasEstEnabled``, ``restBiasEstEnabled``, ``magDistRejectionEnabled`` are fixed
    options. Further options: ``use_mag`` (9-D if true and the recording has a magnetometer, else
    6-D) and ``offline`` (acausal ``offlineVQF`` instead of the causal ``VQF.updateBatch``).

    Output: sensor-to-earth ``(w, x, y, z)``, working frame ENU (converted to the recording's frame).
    Diagnostics: ``bias`` (N, 3) rad/s, ``rest`` (N,), and with magnetometer ``mag_dist`` (N,) and
    ``delta`` (N,) rad.

    Degenerate input: VQF skips the accelerometer update when the acc vector is zero and the
    magnetometer update when the mag vector is zero (documented behaviour of its C++ core); NaN
    samples cannot reach it because :class:`Recording` rejects them.

    Raises
    ------
    ImportError
        At construction when the ``vqf`` package is not installed (with the install hint).
    """

    name = "vqf"
    working_frame = "ENU"
    needs_mag = True
    decl = ParamSet("vqf", (
        *_SEARCHED.values(),  # first, in this order: the unit-cube encoding of recorded runs
        *(Param(k, v, unit=_UNITS.get(k, ""), doc="VQF parameter (see vqf.VQF's documentation)")
          for k, v in VQF_PARAMS.items() if k not in _SEARCHED),
        Param("use_mag", True, doc="9-D (true) or 6-D (false) fusion"),
        Param("offline", False, doc="acausal offlineVQF instead of the causal VQF"),
    ))

    def __init__(self, **values: Any):
        _import_vqf()
        super().__init__(**values)

    def _check(self) -> None:
        vqf = _import_vqf()
        known = set(vqf.VQF(0.01).params)
        unknown = sorted(set(VQF_PARAMS) - known)
        if unknown:  # a vqf release renamed a parameter: fail loudly rather than silently ignore it
            raise ValueError(f"vqf: installed vqf does not know parameter(s) {unknown}")

    def vqf_params(self) -> dict[str, Any]:
        """The VQF parameter dict passed to the package (camelCase names, VQF's units)."""
        out = {}
        for k in VQF_PARAMS:
            v = self.values[k]
            out[k] = bool(v) if k in _BOOL_PARAMS else float(v)
        return out

    def _run(self, rec: Recording, q0: np.ndarray) -> FilterResult:
        vqf = _import_vqf()
        gyr = np.ascontiguousarray(rec.gyr, dtype=np.float64)
        acc = np.ascontiguousarray(rec.acc, dtype=np.float64)
        use_mag = bool(self.values["use_mag"]) and rec.mag is not None
        mag = np.ascontiguousarray(rec.mag, dtype=np.float64) if use_mag else None
        params = self.vqf_params()
        if self.values["offline"]:
            out = vqf.offlineVQF(gyr, acc, mag, rec.dt, params)
        else:
            out = vqf.VQF(rec.dt, **params).updateBatch(gyr, acc, mag)
        quat = np.asarray(out["quat9D"] if use_mag else out["quat6D"], dtype=np.float64)
        diag = {"bias": np.asarray(out["bias"]), "rest": np.asarray(out["restDetected"])}
        if use_mag:
            diag["mag_dist"] = np.asarray(out["magDistDetected"])
            diag["delta"] = np.asarray(out["delta"])
        return FilterResult(quat, "ENU", diag)

    def stream(self, rate_hz: float | None = None, dt: float | None = None, q0: Any = None, frame: str = "ENU"):
        """Per-sample VQF through the package's own ``VQF.update`` (O(1)); ``q0`` is ignored as in
        :meth:`run`. Not available with ``offline: true`` (the offline filter is acausal)."""
        if self.values["offline"]:
            raise ValueError("vqf: offline=True is acausal and has no per-sample stream; use offline=False")
        return _VQFStream(self, rate_hz, dt, q0, frame)


class _VQFStream(StreamBase):
    def update(self, gyr: Any, acc: Any, mag: Any = None) -> np.ndarray:
        """Feed one sample (rad/s, m/s^2, any unit); the estimate after it, (4,) in ``frame``."""
        from objectives.attitude.quaternion import to_frame

        g, a, m = self._read(gyr, acc, mag)
        if self.n == 0:
            self._vqf = _import_vqf().VQF(self.dt, **self.filter.vqf_params())
        self._vqf.update(np.ascontiguousarray(g), np.ascontiguousarray(a),
                         None if m is None else np.ascontiguousarray(m))
        self.n += 1
        q = np.asarray(self._vqf.getQuat9D() if self.use_mag else self._vqf.getQuat6D(), dtype=np.float64)
        return to_frame(q[None, :], "ENU", self.frame)[0]

