"""Controllers of MuJoCo plants (family ``mujoco``): PIDs per joint, and LQR from MuJoCo's linearisation.

- ``joint_pid``: one two-degree-of-freedom PID per loop (``objective.plant.loops``: output -> actuator,
  by default output i drives actuator i), all loops at once; each the discrete PID block of the generic
  loop (Åström & Murray, Feedback Systems, 2nd ed., section 11.5: forward-Euler integral, filtered
  backward-difference derivative, anti-windup by back-calculation or clamping) with its actuator's range
  as its output limits, so its anti-windup sees the saturation. Gains per loop ``<loop>_K``,
  ``<loop>_Ti_s``, ``<loop>_Td_s``, set-point weights ``<loop>_b``, ``<loop>_c``; shared ``N``,
  ``antiwindup``, ``Tt_s``. ``<loop>`` is the output's name (made an identifier).
- ``lqr_fd``: state feedback on the plant's state (:mod:`.model`) from the discrete LQR of the period
  model of :mod:`.linearize` (MuJoCo's ``mjd_transitionFD`` at the operating point of a keyframe):
  ``K = (R + Bd' P Bd)^-1 Bd' P Ad`` with ``P`` the solution of the discrete algebraic Riccati equation
  and ``Q = diag(q_<state>)``, ``R = diag(r_<actuator>)`` tuned. Set points of outputs that are positions
  or velocities in the state are reached through the steady state of the linear model
  (``[Ad - I, Bd; C, 0] [Nx; Nu] = [0; I]``, the reference pre-filter of Franklin, Powell & Emami-Naeini):
  ``u = u_op + Nu rd - K (x - Nx rd)`` with ``rd`` the set points' change from the operating point.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from objectives.control.kinds import KIND_MJ_LQR, KIND_MJ_PID
from objectives.control.plants.controllers import pid_coeffs
from objectives.control.plants.kernels import PID_COEFFS
from objectives.params import NONNEG, POSITIVE, Declared, Interval, Param, ParamSet

__all__ = ["MujocoController", "JointPID", "LinearizedLQR", "identifier", "lqr_gain", "set_point_gains"]

_AW = ("backcalc", "clamp", "none")


def identifier(name: str) -> str:
    """``name`` as a parameter-name part: every character that is not a letter, digit or ``_`` becomes ``_``."""
    s = re.sub(r"\W", "_", name)
    return s if s and not s[0].isdigit() else f"_{s}"


class MujocoController(Declared):
    """Base of the ``mujoco`` family: ``declaration_for(plant)``, ``coeffs(values, plant, tracked)``,
    ``tables(cp, plant)``."""

    name: ClassVar[str] = ""
    kind: ClassVar[int] = KIND_MJ_PID
    family: ClassVar[str] = "mujoco"
    #: what the loop measures for it: the state (state feedback) or the outputs
    state_feedback: ClassVar[bool] = False

    @classmethod
    def declaration_for(cls, plant: Any) -> ParamSet:
        raise NotImplementedError

    @classmethod
    def declaration(cls) -> ParamSet:
        return cls.declaration_for(None)

    @classmethod
    def coeffs(cls, v: Mapping[str, Any], plant: Any, tracked: Sequence[int] = ()) -> np.ndarray:
        raise NotImplementedError

    @classmethod
    def tables(cls, cp: np.ndarray, plant: Any) -> dict[str, dict[str, Any]]:
        raise NotImplementedError


def _loop_labels(plant: Any) -> list[str]:
    if plant is None:
        return ["joint1"]
    outs = [identifier(plant.output_names[o]) for o, _ in plant.loops]
    ins = [identifier(plant.input_names[i]) for _, i in plant.loops]
    return [o if outs.count(o) == 1 else f"{o}_{a}" for o, a in zip(outs, ins)]


class JointPID(MujocoController):
    """Two-degree-of-freedom PIDs, one per loop (output -> actuator), several loops at once."""

    name = "joint_pid"
    kind = KIND_MJ_PID

    @classmethod
    def declaration_for(cls, plant: Any) -> ParamSet:
        if plant is not None and not plant.loops:
            raise ValueError("joint_pid needs loops: give objective.plant.loops ([[output, actuator], ...])")
        per = []
        for lab in _loop_labels(plant):
            per += [Param(f"{lab}_K", 1.0, (1e-3, 1e3), "log", unit="u/y", allowed=POSITIVE,
                          doc=f"loop {lab}: proportional gain"),
                    Param(f"{lab}_Ti_s", 1.0, (1e-3, 1e2), "log", unit="s",
                          allowed=Interval(0.0, low_open=True, allow_inf=True),
                          doc=f"loop {lab}: integral time (inf: no integral action)"),
                    Param(f"{lab}_Td_s", 0.01, (1e-4, 1.0), "log", unit="s", allowed=NONNEG,
                          doc=f"loop {lab}: derivative time"),
                    Param(f"{lab}_b", 1.0, unit="1", allowed=NONNEG, doc=f"loop {lab}: set-point weight, proportional"),
                    Param(f"{lab}_c", 0.0, unit="1", allowed=NONNEG, doc=f"loop {lab}: set-point weight, derivative")]
        return ParamSet(f"controller '{cls.name}'", (
            *per,
            Param("N", 10.0, unit="1", allowed=POSITIVE, doc="derivative filter of every loop: time constant Td / N"),
            Param("antiwindup", "backcalc", choices=_AW, doc="integrator anti-windup of every loop"),
            Param("Tt_s", 0.0, unit="s", allowed=NONNEG, doc="back-calculation tracking time (0: sqrt(Ti Td))"),
        ))

    @classmethod
    def _describe_extra(cls) -> dict[str, Any]:
        return {"note": "one set <loop>_K, _Ti_s, _Td_s, _b, _c per loop of objective.plant.loops (shown for one "
                        "loop named joint1)"}

    @classmethod
    def coeffs(cls, v, plant, tracked=()):
        rows = [float(len(plant.loops))]
        for lab, (o, i) in zip(_loop_labels(plant), plant.loops):
            lo, hi = plant.ulim[i]
            loop = {"N": v["N"], "antiwindup": v["antiwindup"], "Tt_s": v["Tt_s"], "b": v[f"{lab}_b"],
                    "c": v[f"{lab}_c"], "u_min": lo, "u_max": hi}
            cp = pid_coeffs(float(v[f"{lab}_K"]), float(v[f"{lab}_Ti_s"]), float(v[f"{lab}_Td_s"]), plant.period_s,
                            loop)
            rows += [float(o), float(i), *cp]
        return np.array(rows, dtype=float)

    @classmethod
    def tables(cls, cp, plant):
        n = int(cp[0])
        blocks = cp[1:].reshape(n, 2 + PID_COEFFS)
        loops = ", ".join(f"{plant.output_names[int(r[0])]} -> {plant.input_names[int(r[1])]}" for r in blocks)
        return {"gains": {"table": blocks[:, 2:],
                          "doc": f"one row per loop ({loops}) at h = {plant.period_s} s: [K, b, c, ki, ad, bd, aw, "
                                 "kt, u_min, u_max]; v = K (b r - y) + I + D; "
                                 "D = ad D + bd ((c r - y) - (c r - y)_prev); u = clip(v, u_min, u_max); "
                                 "I += ki (r - y) + (aw == 1: kt (u - v); aw == 2: no update while saturated towards "
                                 "the error); loops on one actuator add",
                          "unit": "u per unit of y (K, ki, bd); 1 (b, c, ad, aw, kt); u (limits)"},
                "loops": {"table": blocks[:, :2], "doc": f"[output index, actuator index] per loop: {loops}",
                          "unit": "1"}}


def lqr_gain(ad: np.ndarray, bd: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``K = (R + Bd' P Bd)^-1 Bd' P Ad`` with ``P`` the stabilising solution of the discrete Riccati
    equation; ``ValueError`` when there is none (the closed loop ``Ad - Bd K`` is checked)."""
    import scipy.linalg

    try:
        p = scipy.linalg.solve_discrete_are(ad, bd, q, r)
        k = np.linalg.solve(r + bd.T @ p @ bd, bd.T @ p @ ad)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise ValueError(f"the Riccati equation has no stabilising solution ({exc})") from None
    rho = float(np.max(np.abs(np.linalg.eigvals(ad - bd @ k)))) if ad.size else 0.0
    if not (np.all(np.isfinite(k)) and rho < 1.0):
        raise ValueError(f"the LQR does not stabilise the linearisation (largest closed-loop |pole| {rho:.6g}); "
                         "leave uncontrollable coordinates out of objective.plant.state_joints")
    return k


def set_point_gains(ad: np.ndarray, bd: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``(Nx (n, p), Nu (m, p), residual)``: the steady state and input that hold the outputs ``rows @ x``
    at a unit set point each (least squares; a residual above ~1e-9 means no steady state reaches it)."""
    n, m = bd.shape
    p = rows.shape[0]
    mat = np.block([[ad - np.eye(n), bd], [rows, np.zeros((p, m))]])
    rhs = np.vstack([np.zeros((n, p)), np.eye(p)])
    sol = np.linalg.lstsq(mat, rhs, rcond=None)[0]
    res = float(np.max(np.abs(mat @ sol - rhs))) if p else 0.0
    return sol[:n], sol[n:], res


class LinearizedLQR(MujocoController):
    """LQR state feedback designed on MuJoCo's linearisation at the operating point (a keyframe)."""

    name = "lqr_fd"
    kind = KIND_MJ_LQR
    state_feedback = True

    @classmethod
    def declaration_for(cls, plant: Any) -> ParamSet:
        states = plant.state_names if plant is not None else ["joint1", "joint1_vel"]
        inputs = plant.input_names if plant is not None else ["actuator1"]
        return ParamSet(f"controller '{cls.name}'", (
            *(Param(f"q_{identifier(s)}", 1.0, (1e-3, 1e3), "log", unit="1/x^2", allowed=POSITIVE,
                    doc=f"LQR state weight Q of {s}") for s in states),
            *(Param(f"r_{identifier(a)}", 1.0, (1e-3, 1e3), "log", unit="1/u^2", allowed=POSITIVE,
                    doc=f"LQR input weight R of actuator {a}") for a in inputs),
        ))

    @classmethod
    def _describe_extra(cls) -> dict[str, Any]:
        return {"note": "one q_<state> per state entry (q_<joint>, q_<joint>_vel, q_act_<actuator>) and one "
                        "r_<actuator> per controlled actuator; shown for one hinge and one actuator"}

    @classmethod
    def design(cls, v: Mapping[str, Any], plant: Any) -> np.ndarray:
        """The gain ``K`` (m, n) of the weights in ``v``."""
        ad, bd = plant.design_model()
        q = np.diag([float(v[f"q_{identifier(s)}"]) for s in plant.state_names])
        r = np.diag([float(v[f"r_{identifier(a)}"]) for a in plant.input_names])
        return lqr_gain(ad, bd, q, r)

    @classmethod
    def coeffs(cls, v, plant, tracked=()):
        k = cls.design(v, plant)
        ad, bd = plant.design_model()
        tracked = list(tracked)
        rows = np.array([plant.state_row(i) for i in tracked]).reshape(len(tracked), plant.n_states)
        nx, nu, _ = set_point_gains(ad, bd, rows)
        r_op = plant.operating_outputs()[tracked] if tracked else np.zeros(0)
        n, m, p = plant.n_states, plant.n_inputs, len(tracked)
        return np.concatenate([[n, m, p], k.ravel(), nx.ravel(), nu.ravel(), plant.ctrl_op[plant.inp_adr],
                               np.array(tracked, dtype=float), r_op]).astype(float)

    @classmethod
    def gains(cls, cp: np.ndarray) -> dict[str, np.ndarray]:
        """The parts of a coefficient array: K, Nx, Nu, u_op, the tracked outputs and their operating values."""
        n, m, p = int(cp[0]), int(cp[1]), int(cp[2])
        o = np.cumsum([3, m * n, n * p, m * p, m, p, p])
        return {"K": cp[o[0]:o[1]].reshape(m, n), "Nx": cp[o[1]:o[2]].reshape(n, p), "Nu": cp[o[2]:o[3]].reshape(m, p),
                "u_op": cp[o[3]:o[4]], "tracked": cp[o[4]:o[5]].astype(int), "r_op": cp[o[5]:o[6]]}

    @classmethod
    def tables(cls, cp, plant):
        g = cls.gains(cp)
        states = ", ".join(plant.state_names)
        tracked = ", ".join(plant.output_names[i] for i in g["tracked"]) or "none"
        out = {"K": {"table": g["K"], "doc": f"u = u_op + Nu rd - K (x - Nx rd) at h = {plant.period_s} s; x = "
                                             f"({states}) from the operating point (positions: mj_differentiatePos)",
                     "unit": "u per unit of x"},
               "u_op": {"table": g["u_op"][:, None], "doc": f"operating-point inputs ({', '.join(plant.input_names)})",
                        "unit": "u"},
               "qpos_op": {"table": plant.qpos_op[:, None], "doc": "operating point qpos (the keyframe's)",
                           "unit": "m or rad"}}
        if g["tracked"].size:
            out.update({"Nx": {"table": g["Nx"], "doc": f"steady state per unit set point of ({tracked})",
                               "unit": "x per unit of r"},
                        "Nu": {"table": g["Nu"], "doc": f"steady input per unit set point of ({tracked})",
                               "unit": "u per unit of r"},
                        "r_op": {"table": g["r_op"][:, None], "doc": f"operating values of ({tracked}); rd = r - r_op",
                                 "unit": "y"}})
        return out

