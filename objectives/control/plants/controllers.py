"""Controllers of the generic loop (any plant of the ``siso`` family), declared like the filters.

YAML ``objective.controller`` names, registered in :data:`objectives.control.controllers.CONTROLLERS`
with the pendulum's own (``pid``, ``lqr``... of :mod:`objectives.control.plants.wmp.controllers`, family
``wmp``):

- ``pid2dof``: PID in ideal (standard) form ``K (b r - y) + K/Ti int e + K Td d/dt (c r - y)``;
- ``pid2dof_par``: the same PID in parallel form with gains ``Kp, Ki, Kd`` (``K = Kp``, ``Ti = Kp / Ki``,
  ``Td = Kd / Kp``);
- ``pid_cascade``: two ideal-form PIDs, the outer one's output the inner one's set point;
- ``lqr_sf``: state feedback ``u = -K x + Nbar r`` with ``K`` from ``control.dlqr`` of the discrete
  plant and ``Q = diag(q1..qn)``, ``R = diag(r1..rm)`` tuned; ``Nbar`` makes the controlled output's
  steady state equal ``r`` (Franklin, Powell & Emami-Naeini's reference pre-filter); nonlinear plants
  are linearised numerically at ``linearize_at``.

Each PID is discretised at the period ``h`` as in Åström & Murray, Feedback Systems (2nd ed.,
section 11.5): forward-Euler integral, backward-difference derivative filtered with ``Td / N``,
anti-windup by back-calculation (tracking time ``Tt``, default ``sqrt(Ti Td)`` or ``Ti / 2`` without
derivative) or clamping. Every class gives the kernel coefficients (:meth:`coeffs`), the feedback
transfer function from each plant output (:meth:`feedback`, for margins and Ms) and the export tables.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from objectives.control.kinds import KIND_CASCADE, KIND_OPEN, KIND_PID, KIND_SF
from objectives.params import NONNEG, POSITIVE, Declared, Interval, Param, ParamSet

__all__ = ["LoopController", "PID2DOF", "PID2DOFParallel", "PIDCascade", "LQRStateFeedback", "OpenLoop",
           "pid_coeffs", "pid_tf"]

_EXT = Interval(allow_inf=True)
_AW = ("backcalc", "clamp", "none")


def _common(owner: str) -> tuple[Param, ...]:
    return (
        Param("b", 1.0, unit="1", allowed=NONNEG, doc="set-point weight of the proportional term (2-DOF)"),
        Param("c", 0.0, unit="1", allowed=NONNEG, doc="set-point weight of the derivative term (2-DOF)"),
        Param("N", 10.0, unit="1", allowed=POSITIVE, doc="derivative filter: time constant Td / N"),
        Param("antiwindup", "backcalc", choices=_AW, doc="integrator anti-windup: back-calculation, clamping, none"),
        Param("Tt_s", 0.0, unit="s", allowed=NONNEG, doc="back-calculation tracking time (0: sqrt(Ti Td), or Ti/2)"),
        Param("u_min", -math.inf, unit="u", allowed=_EXT, doc="controller output lower limit (unset: the actuator's)"),
        Param("u_max", math.inf, unit="u", allowed=_EXT, doc="controller output upper limit (unset: the actuator's)"),
    )


def pid_coeffs(K: float, Ti: float, Td: float, h: float, v: Mapping[str, Any]) -> np.ndarray:
    """Kernel coefficients ``[K, b, c, ki, ad, bd, aw, kt, u_min, u_max]`` of one PID block
    (``Ti = inf``: no integral action)."""
    n = float(v["N"])
    ki = 0.0 if math.isinf(Ti) else K * h / Ti
    ad = Td / (Td + n * h) if Td > 0 else 0.0
    bd = K * Td * n / (Td + n * h) if Td > 0 else 0.0
    tt = float(v["Tt_s"]) or (math.sqrt(Ti * Td) if Td > 0 else 0.5 * Ti)
    kt = 0.0 if math.isinf(tt) else h / tt
    aw = {"none": 0.0, "backcalc": 1.0, "clamp": 2.0}[v["antiwindup"]]
    if float(v["u_min"]) >= float(v["u_max"]):
        raise ValueError(f"u_min {v['u_min']} must be below u_max {v['u_max']}")
    return np.array([K, v["b"], v["c"], ki, ad, bd, aw, kt, v["u_min"], v["u_max"]], dtype=float)


def pid_tf(cp: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Feedback transfer function ``-u/y`` of a PID block at ``z`` (no limits):
    ``K + ki / (z - 1) + bd (z - 1) / (z - ad)``."""
    k, ki, ad, bd = cp[0], cp[3], cp[4], cp[5]
    return k + ki / (z - 1.0) + bd * (z - 1.0) / (z - ad)


class LoopController(Declared):
    """Base: ``name``, ``decl`` and the methods the loop objective calls."""

    name: ClassVar[str] = ""
    kind: ClassVar[int] = KIND_OPEN
    #: the loop these controllers run in (objectives.control.controllers)
    family: ClassVar[str] = "siso"
    needs_inner: ClassVar[bool] = False
    #: its PID blocks in the C export (:mod:`.cexport`), in the kernel's order: per block the C expressions of
    #: its ideal form ``K, Ti, Td`` and its output limits over the declared values (``p->NAME``); the common
    #: values (``b``, ``c``, ``N``, ``antiwindup``, ``Tt_s``) are read as :func:`pid_coeffs` reads them
    C_BLOCKS: ClassVar[tuple[tuple[str, str, str, str, str], ...]] = ()

    @classmethod
    def declaration_for(cls, plant: Any) -> ParamSet:
        """The declaration for ``plant`` (state feedback has one weight per state and input)."""
        return cls.declaration()

    @classmethod
    def coeffs(cls, v: Mapping[str, Any], plant: Any) -> np.ndarray:
        raise NotImplementedError

    @classmethod
    def feedback(cls, cp: np.ndarray, plant: Any, z: np.ndarray) -> dict[str, np.ndarray]:
        """``{"outputs": (len(z), p) or "states": (len(z), n)}``: ``-du/dsignal`` of input 0."""
        raise NotImplementedError

    @classmethod
    def tables(cls, cp: np.ndarray, plant: Any) -> dict[str, dict[str, Any]]:
        raise NotImplementedError

    @classmethod
    def from_ideal(cls, K: float, Ti: float, Td: float) -> dict[str, float] | None:
        """The controller's values of the ideal-form PID ``(K, Ti, Td)`` (a tuning rule's result, ``init:``);
        None for a controller that is not one PID."""
        return None


def _pid_tables(cp: np.ndarray, h: float, prefix: str = "") -> dict[str, dict[str, Any]]:
    """A PID block's gains and difference-equation coefficients, for ``tuner export``."""
    return {
        f"{prefix}gains": {"table": np.asarray(cp[:10], dtype=float)[None, :],
                           "doc": f"[K, b, c, ki, ad, bd, aw, kt, u_min, u_max] at h = {h} s: v = K (b r - y) + I + D; "
                                  "D = ad D + bd ((c r - y) - (c r - y)_prev); u = clip(v, u_min, u_max); "
                                  "I += ki (r - y) + (aw == 1: kt (u - v); aw == 2: no update while saturated "
                                  "towards the error)",
                           "unit": "u per unit of y (K, ki, bd); 1 (b, c, ad, aw, kt); u (limits)"},
        f"{prefix}C_num": {"table": np.atleast_2d(_pid_poly(cp)[0]),
                           "doc": "feedback part C(z) = U/E numerator, powers of z descending",
                           "unit": "u per unit of y"},
        f"{prefix}C_den": {"table": np.atleast_2d(_pid_poly(cp)[1]),
                           "doc": "feedback part C(z) denominator, powers of z descending (leading 1)", "unit": "1"},
    }


def _pid_poly(cp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator (z, descending) of :func:`pid_tf`."""
    k, ki, ad, bd = cp[0], cp[3], cp[4], cp[5]
    den = np.polymul([1.0, -1.0], [1.0, -ad])
    num = np.polyadd(np.polyadd(k * den, ki * np.array([1.0, -ad])), bd * np.polymul([1.0, -1.0], [1.0, -1.0]))
    return num, den


class PID2DOF(LoopController):
    """Two-degree-of-freedom PID in ideal form for any SISO loop (discrete, anti-windup, limits)."""

    name = "pid2dof"
    kind = KIND_PID
    C_BLOCKS = (("p->K", "p->Ti_s", "p->Td_s", "p->u_min", "p->u_max"),)
    decl = ParamSet("controller 'pid2dof'", (
        Param("K", 1.0, (1e-3, 1e3), "log", unit="u/y", allowed=POSITIVE, doc="proportional gain"),
        Param("Ti_s", 1.0, (1e-3, 1e3), "log", unit="s", allowed=Interval(0.0, low_open=True, allow_inf=True),
              doc="integral time (inf: no integral action)"),
        Param("Td_s", 0.0, unit="s", allowed=NONNEG, doc="derivative time (searched when given bounds)"),
        *_common("pid2dof"),
    ))

    @classmethod
    def coeffs(cls, v, plant):
        return pid_coeffs(float(v["K"]), float(v["Ti_s"]), float(v["Td_s"]), plant.period_s, v)

    @classmethod
    def feedback(cls, cp, plant, z):
        out = np.zeros((z.size, plant.n_outputs), dtype=complex)
        out[:, plant.output] = pid_tf(cp, z)
        return {"outputs": out}

    @classmethod
    def tables(cls, cp, plant):
        return _pid_tables(cp, plant.period_s)

    @classmethod
    def from_ideal(cls, K, Ti, Td):
        return {"K": float(K), "Ti_s": float(Ti), "Td_s": float(Td)}


class PID2DOFParallel(PID2DOF):
    """Two-degree-of-freedom PID in parallel form ``Kp, Ki, Kd`` (converted to the ideal form)."""

    name = "pid2dof_par"
    C_BLOCKS = (("p->Kp", "(p->Ki == 0 ? (PFX_real)INFINITY : p->Kp / p->Ki)", "p->Kd / p->Kp", "p->u_min",
                 "p->u_max"),)
    decl = ParamSet("controller 'pid2dof_par'", (
        Param("Kp", 1.0, (1e-3, 1e3), "log", unit="u/y", allowed=POSITIVE, doc="proportional gain"),
        Param("Ki", 1.0, (1e-3, 1e3), "log", unit="u/(y s)", allowed=NONNEG, doc="integral gain (0: none)"),
        Param("Kd", 0.0, unit="u s/y", allowed=NONNEG, doc="derivative gain (searched when given bounds)"),
        *_common("pid2dof_par"),
    ))

    @classmethod
    def coeffs(cls, v, plant):
        kp = float(v["Kp"])
        ti = math.inf if float(v["Ki"]) == 0 else kp / float(v["Ki"])
        return pid_coeffs(kp, ti, float(v["Kd"]) / kp, plant.period_s, v)

    @classmethod
    def from_ideal(cls, K, Ti, Td):
        return {"Kp": float(K), "Ki": 0.0 if math.isinf(Ti) else float(K) / float(Ti), "Kd": float(K) * float(Td)}


class PIDCascade(LoopController):
    """Cascaded PIDs: the outer loop on ``output`` sets the inner loop's reference on ``inner_output``."""

    name = "pid_cascade"
    kind = KIND_CASCADE
    needs_inner = True
    C_BLOCKS = (("p->K_o", "p->Ti_o_s", "p->Td_o_s", "p->r_i_min", "p->r_i_max"),
                ("p->K_i", "p->Ti_i_s", "p->Td_i_s", "p->u_min", "p->u_max"))
    decl = ParamSet("controller 'pid_cascade'", (
        Param("K_o", 1.0, (1e-3, 1e3), "log", unit="r_i/y", allowed=POSITIVE, doc="outer proportional gain"),
        Param("Ti_o_s", math.inf, unit="s", allowed=Interval(0.0, low_open=True, allow_inf=True),
              doc="outer integral time (inf: none)"),
        Param("Td_o_s", 0.0, unit="s", allowed=NONNEG, doc="outer derivative time"),
        Param("K_i", 1.0, (1e-3, 1e3), "log", unit="u/y_i", allowed=POSITIVE, doc="inner proportional gain"),
        Param("Ti_i_s", 1.0, (1e-3, 1e3), "log", unit="s", allowed=Interval(0.0, low_open=True, allow_inf=True),
              doc="inner integral time (inf: none)"),
        Param("Td_i_s", 0.0, unit="s", allowed=NONNEG, doc="inner derivative time"),
        Param("r_i_min", -math.inf, unit="y_i", allowed=_EXT, doc="inner set point lower limit"),
        Param("r_i_max", math.inf, unit="y_i", allowed=_EXT, doc="inner set point upper limit"),
        *_common("pid_cascade"),
    ))

    @classmethod
    def coeffs(cls, v, plant):
        h = plant.period_s
        outer = pid_coeffs(float(v["K_o"]), float(v["Ti_o_s"]), float(v["Td_o_s"]), h,
                           {**v, "u_min": v["r_i_min"], "u_max": v["r_i_max"]})
        inner = pid_coeffs(float(v["K_i"]), float(v["Ti_i_s"]), float(v["Td_i_s"]), h, v)
        return np.concatenate([outer, inner])

    @classmethod
    def feedback(cls, cp, plant, z):
        co, ci = pid_tf(cp[:10], z), pid_tf(cp[10:], z)
        out = np.zeros((z.size, plant.n_outputs), dtype=complex)
        out[:, plant.output] += ci * co
        out[:, plant.inner_output] += ci
        return {"outputs": out}

    @classmethod
    def tables(cls, cp, plant):
        return {**_pid_tables(cp[:10], plant.period_s, "outer_"), **_pid_tables(cp[10:], plant.period_s, "inner_")}


class LQRStateFeedback(LoopController):
    """State feedback u = -K x + Nbar r with K from the discrete LQR of tuned diagonal Q, R."""

    name = "lqr_sf"
    kind = KIND_SF

    @classmethod
    def declaration_for(cls, plant: Any) -> ParamSet:
        n, m = (plant.n_states, plant.n_inputs) if plant is not None else (4, 1)
        return ParamSet(f"controller '{cls.name}'", (
            *(Param(f"q{i + 1}", 1.0, (1e-3, 1e3), "log", unit="1/x^2", allowed=POSITIVE,
                    doc=f"LQR state weight Q[{i},{i}] of state {i}") for i in range(n)),
            *(Param(f"r{i + 1}", 1.0, (1e-3, 1e3), "log", unit="1/u^2", allowed=POSITIVE,
                    doc=f"LQR input weight R[{i},{i}] of input {i}") for i in range(m)),
            Param("u_min", -math.inf, unit="u", allowed=_EXT, doc="output lower limit (unset: the actuator's)"),
            Param("u_max", math.inf, unit="u", allowed=_EXT, doc="output upper limit (unset: the actuator's)"),
        ))

    @classmethod
    def declaration(cls) -> ParamSet:
        return cls.declaration_for(None)

    @classmethod
    def _describe_extra(cls) -> dict[str, Any]:
        return {"note": "one q<i> per plant state and one r<j> per input; shown for 4 states, 1 input"}

    @classmethod
    def design(cls, v: Mapping[str, Any], plant: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(K (m, n), Nbar (m,))`` of ``dlqr(Ad, Bd, diag q, diag r)`` and the pre-filter."""
        import control

        a, b = plant.design_model()
        n, m = b.shape
        q = np.diag([float(v[f"q{i + 1}"]) for i in range(n)])
        r = np.diag([float(v[f"r{i + 1}"]) for i in range(m)])
        try:
            k, _, _ = control.dlqr(a, b, q, r)
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise ValueError(f"dlqr has no stabilising solution ({exc})") from None
        k = np.asarray(k, dtype=float)
        cr = plant.tracked_row()
        mat = np.block([[a - np.eye(n), b], [cr[None, :], np.zeros((1, m))]])
        rhs = np.zeros(n + 1)
        rhs[-1] = 1.0
        sol = np.linalg.lstsq(mat, rhs, rcond=None)[0]
        nx, nu = sol[:n], sol[n:]
        return k, nu + k @ nx

    @classmethod
    def coeffs(cls, v, plant):
        k, nbar = cls.design(v, plant)
        n, m = k.shape[1], k.shape[0]
        if float(v["u_min"]) >= float(v["u_max"]):
            raise ValueError(f"u_min {v['u_min']} must be below u_max {v['u_max']}")
        return np.concatenate([[n, m], k.ravel(), nbar, [v["u_min"], v["u_max"]]]).astype(float)

    @classmethod
    def gains(cls, cp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n, m = int(cp[0]), int(cp[1])
        return cp[2:2 + m * n].reshape(m, n), cp[2 + m * n:2 + m * n + m]

    @classmethod
    def feedback(cls, cp, plant, z):
        k, _ = cls.gains(cp)
        return {"states": np.tile(k[0].astype(complex), (z.size, 1))}

    @classmethod
    def tables(cls, cp, plant):
        k, nbar = cls.gains(cp)
        return {"K": {"table": k, "doc": f"state feedback u = -K x + Nbar r at h = {plant.period_s} s (dlqr)",
                      "unit": "u per unit of x"},
                "Nbar": {"table": nbar[:, None], "doc": "reference pre-filter: steady output = r",
                         "unit": "u per unit of r"}}


class OpenLoop(LoopController):
    """No feedback: the reference drives input 0 directly (plant step responses)."""

    name = "open_loop"
    kind = KIND_OPEN
    decl = ParamSet("controller 'open_loop'", ())

    @classmethod
    def coeffs(cls, v, plant):
        return np.zeros(1)

    @classmethod
    def feedback(cls, cp, plant, z):
        return {"outputs": np.zeros((z.size, plant.n_outputs), dtype=complex)}

    @classmethod
    def tables(cls, cp, plant):
        return {}
