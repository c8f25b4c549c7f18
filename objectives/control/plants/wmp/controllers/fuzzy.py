"""Fuzzy controllers of the WMP: cascade FLC1-3 (thesis 2.2.2), protective PI fuzzy (2.3.1), LUT (eq. 2.32).

All three are zero-order Sugeno systems with min AND and weighted-average defuzzification (Table 2.2,
eqs. 2.27-2.30), evaluated in the closed-loop kernel with :func:`objectives.fuzzy.fuzzify` and
:func:`objectives.fuzzy.sugeno_mu` on preallocated scratch (no allocation per sample).

Signals (same sign conventions as :mod:`.pid`, so the fuzzy and PID schemes are comparable):

- FLC1 input e_nu = nu_d - nu (m/s); FLC3 input e_xi = xi_d - xi (deg/s);
- FLC2 inputs e_theta3 = +theta3_hat (deg) and e_omega3 = +omega3 (deg/s, the gyro rate): with the
  plant's theta3 > 0 meaning the centre of mass ahead of the axle, the voltage must rise with theta3
  to damp the swing (see the sign note in :mod:`.pid`);
- the protective FLC1 also reads the average motor current as its magnitude |I_A| (A): Table 2.6's
  rules "P and L -> Px" and "N and L -> Nx" only make sense for a current magnitude (the current of
  a negative speed error is negative), and Table 2.7's S = Gamma(-inf, 0, d11) is then a ramp from 1
  at 0 A to 0 at d11;
- outputs combined by eq. 2.31: u1 = u_nu + u_theta3 - u_xi, u2 = u_nu + u_theta3 + u_xi.

Fuzzy sets (Table 2.7; Gamma(a, b, c) is a triangle with feet a, c and peak b, so the outer sets are
shoulders): for an error input with universe p1, gap p2 and Z narrowing p3,
N = Gamma(-inf, -p1, -p2), Z = Gamma(-(p1 - p3), 0, p1 - p3), P = Gamma(p2, p1, inf). With p2 = p3 = 0
this is three uniform triangles, and the weighted average is linear, u * e / p1, inside the universe
and saturates at +-u outside it (so a look-up table clamped to [-p1, p1] is exact outside).
Current sets: S = Gamma(-inf, 0, d11), L = Gamma(d12, d13, inf). Where the parameters make a set
degenerate (p3 >= p1, d13 <= d12) it becomes a spike or a step rather than an error, so the optimiser
never sees an invalid design.

Rule bases:

- Table 2.3, PI-type (FLC1 of 2.2.2, FLC3): N -> N, Z -> Z, P -> P with singletons -u, 0, +u;
- Table 2.3, PD-type (FLC2), rows e_theta3, columns e_omega3 (N, Z, P)::

      N: N N Z
      Z: N Z P
      P: Z P P      singletons N = -u2, Z = 0, P = +u2

- Table 2.6 (protective FLC1), proportional tag U_P: (Z, -) -> Z, (P, -) -> P, (N, -) -> N,
  (Z, S) -> Z, (P, L) -> Px, (N, L) -> Nx with P = +u11, Px = +u12 (the "positive protective
  voltage", smaller than u11, so the weighted average pulls the action down as the current grows,
  the surface of Fig. 2.14), Nx = -u12; integral tag U_I: rules 1-3 with singletons -u13, 0, +u13.
  At full speed error U_P = (u11 + u12 L) / (1 + L) falls monotonically with the current; at small
  errors rule 4 (Z and S -> Z) also fades as the current grows, which raises U_P (with Table 2.7's
  initial values U_P(0.2 m/s) goes 1.20 V -> 1.45 V from 0 to 0.5 A), so the surface is not monotone
  everywhere; the rules are implemented as printed.

Integrators. The PI-type outputs are integrated (eqs. 2.28, 2.30, Figs. 2.6, 2.13). Eqs. 2.28/2.30 add
the raw output per sample, but with Table 2.7's gains that would be 3 V / 0.01 s = 300 V/s at full
error against a 3.3 V supply; we read the integrator of the block diagrams as a time integrator,
u_k = u_{k-1} + Ts * U_k, so u13 and u3 are in V/s. This reading is supported by the thesis's own
numbers: the tuned integral gain of the protective FLC1, u13 / p11 = 5.26 / 0.289 = 18.2 V/(m s), is
close to the tuned PID's K_I1 = 19.07, and the tuned proportional slope u11 / p11 = 3.5 V s/m is of
the PID's order (K_P1 = 8.8); the FLC3 yaw loop with u3 = 1.5 V/s over 30 deg/s is then a stable
integral loop on our model (poles near -8 and -50 1/s) where 1.5 V per sample is unstable (see
:mod:`.pid`).

Parameters (Table 2.7 names; initial values = its "initial" column, which is also section 2.2.2's
design): 15 tuned by default, as the thesis's PSO (section 2.3.3.3) tuned "15 parameters":

========  =========  =================  ==============================================
name      initial    default bounds     meaning
========  =========  =================  ==============================================
p11       0.35       [0.05, 1.0]        FLC1 speed-error universe (m/s)
d11       0.5        [0.05, 1.5]        S foot (A)
d12       0          [0, 1.0]           L foot (A)
d13       0.5        [0.1, 2.0]         L peak (A)
u11       3.0        [0.1, 6.0]         proportional tag gain P/N (V)
u12       1.0        [0, 3.0]           protective gain Px/Nx (V)
u13       1.5        [0.1, 15]          integral tag gain (V/s)
p21       15         [2, 60]            FLC2 theta3 universe (deg)
p23       0          [0, 10]            FLC2 theta3 Z narrowing (deg)
d21       220        [20, 1000]         FLC2 omega3 universe (deg/s)
d23       0          [0, 100]           FLC2 omega3 Z narrowing (deg/s)
u2        0.6        [0.05, 3.0]        FLC2 output gain (V)
p31       30         [5, 90]            FLC3 yaw-rate universe (deg/s)
p33       0          [0, 20]            FLC3 Z narrowing (deg/s)
u3        1.5        [0.1, 10]          FLC3 output gain (V/s)
========  =========  =================  ==============================================

Fixed options (declared without search bounds, tunable by listing them in a config's ``parameters``):
p12 = p22 = d22 = p32 = 0 (the N/P gaps, 0 in both columns of Table 2.7) and p13 = 0. Table 2.7 has
16 entries that differ from zero or change between its columns, while the text says 15 parameters
were tuned; we leave out p13, the only one the thesis's optimiser left within 1 % of its initial value
(0 -> 0.0019 m/s, 0.7 % of p11). The table is partly garbled (the rows of u11-u13); the values read
are the ones above. The bounds are not in the thesis (only the PID ranges are); ours contain both
columns of Table 2.7 with margin.

The thesis's optimised values (Table 2.7, "optimized" column) are :data:`THESIS_OPTIMISED`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from objectives.control.kinds import KIND_WMP_FLC, KIND_WMP_LUT_FUZZY, KIND_WMP_PROTECTIVE_FUZZY
from objectives.control.plants.wmp.controllers.base import Controller
from objectives.control.plants.wmp.controllers.fuzzy_steps import (
    _F1_C,
    _F1_CI,
    _F1_MF,
    _F2_C,
    _F2_MF,
    _F3_C,
    _F3_MF,
    _TS,
    FLC_STATE_SIZE,
    FUZZY_PARAM_SIZE,
    LUT_SIZE,
    PD_SIGNS,
    RULES_PD,
    RULES_PI,
    RULES_PROT,
    RULES_PROT_I,
)
from objectives.fuzzy import TRAP, SugenoFIS, surface
from objectives.params import Interval, Param, ParamSet

__all__ = [
    "FLC",
    "ProtectiveFuzzy",
    "LUTFuzzy",
    "THESIS_OPTIMISED",
    "FLC_STATE_SIZE",
    "LUT_SIZE",
]

#: stands for the infinite feet of the shoulder sets (the parameter array must be finite)
_BIG = 1e30

THESIS_OPTIMISED = {
    "p11": 0.289, "p13": 0.0019, "d11": 0.783, "d12": 0.17, "d13": 0.953,
    "u11": 1.002, "u12": 0.22, "u13": 5.26,
    "p21": 27.04, "p23": 1.122, "d21": 657.93, "d23": 13.301, "u2": 1.068,
    "p31": 16.629, "p33": 3.970, "u3": 2.398,
}  # fmt: skip


# --------------------------------------------------------------------------------------------------
# set construction (Python, once per controller build)
# --------------------------------------------------------------------------------------------------
def nzp_sets(p1: float, p2: float, p3: float) -> np.ndarray:
    """(3, 4) trapezoid parameters of N, Z, P over an error universe (Table 2.7 Gamma sets)."""
    if not p1 > 0:
        raise ValueError(f"universe p1 must be > 0, got {p1}")
    if not 0 <= p2 < p1:
        raise ValueError(f"gap p2 must be in [0, p1={p1}), got {p2}")
    w = max(p1 - p3, 0.0)
    return np.array(
        [
            [-_BIG, -_BIG, -p1, -p2],  # N = Gamma(-inf, -p1, -p2)
            [-w, 0.0, 0.0, w],  # Z = Gamma(-(p1 - p3), 0, p1 - p3)
            [p2, p1, _BIG, _BIG],  # P = Gamma(p2, p1, inf)
        ]
    )


def current_sets(d11: float, d12: float, d13: float) -> np.ndarray:
    """(3, 4) trapezoids S = Gamma(-inf, 0, d11), L = Gamma(d12, max(d13, d12), inf), unused row."""
    if not d11 > 0 or d12 < 0:
        raise ValueError(f"need d11 > 0 and d12 >= 0, got d11={d11}, d12={d12}")
    return np.array(
        [
            [-_BIG, -_BIG, 0.0, d11],
            [d12, max(d13, d12), _BIG, _BIG],
            [_BIG, _BIG, _BIG, _BIG],  # unused (membership 0)
        ]
    )


def _flc2_flc3(v: dict[str, Any], p: np.ndarray) -> None:
    p[_F2_MF : _F2_MF + 12] = nzp_sets(v["p21"], v["p22"], v["p23"]).ravel()
    p[_F2_MF + 12 : _F2_MF + 24] = nzp_sets(v["d21"], v["d22"], v["d23"]).ravel()
    p[_F2_C : _F2_C + 9] = PD_SIGNS * v["u2"]
    p[_F3_MF : _F3_MF + 12] = nzp_sets(math.radians(v["p31"]), math.radians(v["p32"]),
                                       math.radians(v["p33"])).ravel()  # fmt: skip
    p[_F3_C : _F3_C + 3] = np.array([-1.0, 0.0, 1.0]) * v["u3"]


# --------------------------------------------------------------------------------------------------
# Python classes
# --------------------------------------------------------------------------------------------------
def _p(name: str, default: float, bounds: tuple[float, float] | None, unit: str, doc: str,
       eq: str = "Table 2.7") -> Param:
    """A fuzzy-controller parameter: any finite number, searched linearly within ``bounds`` (None: fixed)."""
    return Param(name, default, bounds, unit=unit, doc=doc, eq=eq)


#: FLC2 (oscillation) and FLC3 (yaw) parameters shared by the fuzzy controllers (Fig. 2.12, Table 2.7)
_FLC23 = (
    _p("p21", 15.0, (2.0, 60.0), "deg", "FLC2 theta3 universe (N peak / P peak)"),
    _p("p22", 0.0, None, "deg", "FLC2 theta3 N/P gap"),
    _p("p23", 0.0, (0.0, 10.0), "deg", "FLC2 theta3 Z narrowing"),
    _p("d21", 220.0, (20.0, 1000.0), "deg/s", "FLC2 omega3 universe"),
    _p("d22", 0.0, None, "deg/s", "FLC2 omega3 N/P gap"),
    _p("d23", 0.0, (0.0, 100.0), "deg/s", "FLC2 omega3 Z narrowing"),
    _p("u2", 0.6, (0.05, 3.0), "V", "FLC2 output gain"),
    _p("p31", 30.0, (5.0, 90.0), "deg/s", "FLC3 yaw-rate universe", "eq. 2.30, Table 2.7"),
    _p("p32", 0.0, None, "deg/s", "FLC3 N/P gap", "eq. 2.30"),
    _p("p33", 0.0, (0.0, 20.0), "deg/s", "FLC3 Z narrowing", "eq. 2.30, Table 2.7"),
    _p("u3", 1.5, (0.1, 10.0), "V/s", "FLC3 output gain (integrated)", "eq. 2.30, Table 2.7"),
)


class _FuzzyBase(Controller):
    state_size = FLC_STATE_SIZE

    def _build(self, v):
        return self._direct(v)

    def _flc1_speed_sets(self, v) -> np.ndarray:
        """A fresh parameter array holding the sample time and FLC1's speed-error sets (Fig. 2.6)."""
        p = np.zeros(FUZZY_PARAM_SIZE)
        p[_TS] = self.sensors.Ts_s
        p[_F1_MF : _F1_MF + 12] = nzp_sets(v["p11"], v["p12"], v["p13"]).ravel()
        return p

    def fis(self, values: dict[str, Any] | None = None) -> dict[str, SugenoFIS]:
        """The controller's fuzzy systems as :class:`objectives.fuzzy.SugenoFIS` (for surfaces/tables).

        Keys: ``flc1`` (and ``flc1_i`` for the integral tag of the protective FLC1), ``flc2``, ``flc3``.
        Inputs in the units of the module docstring (FLC3 in deg/s here, rad/s in the kernel).
        """
        p = self._direct(self.resolve(values))
        out = self._fis_flc1(p)
        out["flc2"] = SugenoFIS(TRAP, p[_F2_MF : _F2_MF + 24].reshape(2, 3, 4), RULES_PD,
                                p[_F2_C : _F2_C + 9], default=0.0)  # fmt: skip
        mf3 = p[_F3_MF : _F3_MF + 12].reshape(1, 3, 4) * (180.0 / math.pi)
        out["flc3"] = SugenoFIS(TRAP, mf3, RULES_PI, p[_F3_C : _F3_C + 3], default=0.0)
        return out

    def surfaces(self, values: dict[str, Any] | None = None, n: int = 41) -> dict[str, dict[str, Any]]:
        """Action surfaces (Figs. 2.19-2.20): ``{name: {x, y, z (nx, ny), x_label, y_label, z_label}}``."""
        v = self.resolve(values)
        f = self.fis(v)
        out = {}
        if "flc1_i" in f:  # protective FLC1: proportional tag over (e_nu, |I_A|)
            x = np.linspace(-1.2 * v["p11"], 1.2 * v["p11"], n)
            y = np.linspace(0.0, 1.2 * max(v["d11"], v["d13"]), n)
            out["flc1"] = {"x": x, "y": y, "z": surface(f["flc1"], x, y), "x_label": "e_nu (m/s)",
                           "y_label": "|I_A| (A)", "z_label": "U_P (V)"}  # fmt: skip
        x = np.linspace(-1.2 * v["p21"], 1.2 * v["p21"], n)
        y = np.linspace(-1.2 * v["d21"], 1.2 * v["d21"], n)
        out["flc2"] = {"x": x, "y": y, "z": surface(f["flc2"], x, y), "x_label": "e_theta3 (deg)",
                       "y_label": "e_omega3 (deg/s)", "z_label": "u_theta3 (V)"}  # fmt: skip
        return out


class FLC(_FuzzyBase):
    """Cascade FLC1-3 of section 2.2.2 (Fig. 2.6): PI-type speed, PD-type oscillation, PI-type yaw.

    FLC1 parameters: p11 (m/s, universe of e_nu, 0.35), p12 = 0, p13 (Z narrowing, 0) and u1 (V/s,
    the +-3 V output range of Delta u_nu, integrated in time: see the module docstring). FLC2/FLC3 as in
    :class:`ProtectiveFuzzy`.
    """

    name = "flc"
    kind = KIND_WMP_FLC
    decl = ParamSet("controller 'flc'", (
        _p("p11", 0.35, (0.05, 1.0), "m/s", "FLC1 speed-error universe", "Fig. 2.6"),
        _p("p12", 0.0, None, "m/s", "FLC1 N/P gap", "Fig. 2.6"),
        _p("p13", 0.0, (0.0, 0.2), "m/s", "FLC1 Z narrowing", "Fig. 2.6"),
        _p("u1", 3.0, (0.1, 15.0), "V/s", "FLC1 output gain (integrated)", "Fig. 2.6"),
    ) + _FLC23)

    def _direct(self, v):
        """The parameter array of the direct (fuzzy-inference) step."""
        p = self._flc1_speed_sets(v)
        p[_F1_C : _F1_C + 3] = np.array([-1.0, 0.0, 1.0]) * v["u1"]
        _flc2_flc3(v, p)
        return p

    def _fis_flc1(self, p):
        return {"flc1": SugenoFIS(TRAP, p[_F1_MF : _F1_MF + 12].reshape(1, 3, 4), RULES_PI,
                                  p[_F1_C : _F1_C + 3], default=0.0)}  # fmt: skip


class ProtectiveFuzzy(_FuzzyBase):
    """Protective PI-type FLC1 (section 2.3.1, Fig. 2.13, Table 2.6) with FLC2 and FLC3 (Fig. 2.12).

    The 15 tuned parameters, their initial values (Table 2.7) and bounds are in the module docstring.
    """

    name = "protective_fuzzy"
    kind = KIND_WMP_PROTECTIVE_FUZZY
    decl = ParamSet("controller 'protective_fuzzy'", (
        _p("p11", 0.35, (0.05, 1.0), "m/s", "FLC1 speed-error universe"),
        _p("p12", 0.0, None, "m/s", "FLC1 N/P gap"),
        _p("p13", 0.0, None, "m/s", "FLC1 Z narrowing (fixed: see module docstring)"),
        _p("d11", 0.5, (0.05, 1.5), "A", "current set S foot", "Table 2.6, Table 2.7"),
        _p("d12", 0.0, (0.0, 1.0), "A", "current set L foot", "Table 2.6, Table 2.7"),
        _p("d13", 0.5, (0.1, 2.0), "A", "current set L peak", "Table 2.6, Table 2.7"),
        _p("u11", 3.0, (0.1, 6.0), "V", "proportional tag gain (P, N)", "Table 2.6, Table 2.7"),
        _p("u12", 1.0, (0.0, 3.0), "V", "protective voltage (Px, Nx)", "Table 2.6, Table 2.7"),
        _p("u13", 1.5, (0.1, 15.0), "V/s", "integral tag gain", "Table 2.6, Table 2.7"),
    ) + _FLC23)

    def _direct(self, v):
        """The parameter array of the direct (fuzzy-inference) step."""
        p = self._flc1_speed_sets(v)
        p[_F1_MF + 12 : _F1_MF + 24] = current_sets(v["d11"], v["d12"], v["d13"]).ravel()
        p[_F1_C : _F1_C + 6] = (
            np.array([0.0, 1.0, -1.0, 0.0, 0.0, 0.0]) * v["u11"] + np.array([0.0, 0.0, 0.0, 0.0, 1.0, -1.0]) * v["u12"]
        )
        p[_F1_CI : _F1_CI + 3] = np.array([0.0, 1.0, -1.0]) * v["u13"]
        _flc2_flc3(v, p)
        return p

    def _fis_flc1(self, p):
        mf = p[_F1_MF : _F1_MF + 24].reshape(2, 3, 4)
        return {
            "flc1": SugenoFIS(TRAP, mf, RULES_PROT, p[_F1_C : _F1_C + 6], default=0.0),
            "flc1_i": SugenoFIS(TRAP, mf, RULES_PROT_I, p[_F1_CI : _F1_CI + 3], default=0.0),
        }

    def tables(self, values: dict[str, Any] | None = None, size: int = LUT_SIZE) -> dict[str, dict[str, Any]]:
        """LUT1-3 of section 2.2.3.1 (``size`` x ``size`` grids over each FLC's universes).

        Returns ``{name: {"table": (nx, ny) with table[i, j] at x_i, y_j, "x_range", "y_range"}}`` for
        ``lut1_p`` (U_P over e_nu m/s x |I_A| A), ``lut1_i`` (U_I over e_nu, ny = 2 equal columns),
        ``lut2`` (u_theta3 over e_theta3 deg x e_omega3 deg/s) and ``lut3`` (Delta u_xi over e_xi rad/s).
        The ranges are the universes, outside which every fuzzy output is constant, so clamping the
        inputs to them (eq. 2.32) is exact there.
        """
        if int(size) != size or size < 2:
            raise ValueError(f"table size must be an integer >= 2, got {size}")
        size = int(size)
        v = self.resolve(values)
        f = self.fis(v)
        i_hi = max(v["d11"], v["d13"], 1e-6)
        xr1 = (-v["p11"], v["p11"])
        one = (0.0, 1.0)
        xr3 = (-math.radians(v["p31"]), math.radians(v["p31"]))

        def one_input(fis, xr, scale=1.0):
            col = fis(np.linspace(xr[0], xr[1], size)[:, None] * scale)
            return np.repeat(np.asarray(col, float)[:, None], 2, axis=1)

        return {
            "lut1_p": {"table": surface(f["flc1"], np.linspace(*xr1, size), np.linspace(0.0, i_hi, size)),
                       "x_range": xr1, "y_range": (0.0, i_hi)},
            "lut1_i": {"table": one_input(f["flc1_i"].__class__(
                TRAP, f["flc1_i"].mf_params[:1], f["flc1_i"].rules[:, :1], f["flc1_i"].consequents,
                default=0.0), xr1), "x_range": xr1, "y_range": one},
            "lut2": {"table": surface(f["flc2"], np.linspace(-v["p21"], v["p21"], size),
                                      np.linspace(-v["d21"], v["d21"], size)),
                     "x_range": (-v["p21"], v["p21"]), "y_range": (-v["d21"], v["d21"])},
            "lut3": {"table": one_input(f["flc3"], xr3, 180.0 / math.pi), "x_range": xr3, "y_range": one},
        }  # fmt: skip

    def export_tables(self, values: dict[str, Any] | None = None) -> dict[str, dict[str, Any]]:
        """LUT1-3 for :func:`tuner.export.to_c`: rows follow y (the transpose of :meth:`tables`).

        One-input tables (``lut1_i``, ``lut3``) are a single row (ny = 1, y_range (0, 0)). The size is
        the ``lut_size`` option of :class:`LUTFuzzy`, else 40 (section 2.2.3.1).
        """
        v = self.resolve(values)
        return _export(self.tables(v, v.get("lut_size", LUT_SIZE)))


class LUTFuzzy(ProtectiveFuzzy):
    """The protective scheme run through 40 x 40 look-up tables, as on the robot's MCU (eqs. 2.32-2.33).

    Same 15 tuned parameters as :class:`ProtectiveFuzzy`; the tables are generated from the direct
    fuzzy systems at every build. Options: ``lut_size`` (grid points per input, 40 as in the thesis)
    and ``lut_mode`` (0: nearest entry by eq. 2.32's rounding, as the MCU; 1: bilinear interpolation
    with :func:`objectives.fuzzy.lut_interp`).
    """

    name = "lut"
    kind = KIND_WMP_LUT_FUZZY
    decl = ParamSet("controller 'lut'", ProtectiveFuzzy.decl.params + (
        Param("lut_size", LUT_SIZE, unit="1", doc="grid points per input", eq="eq. 2.32",
              allowed=Interval(2.0), integer=True),
        Param("lut_mode", 0, choices=(0, 1), doc="0 nearest (eq. 2.32), 1 bilinear", eq="eq. 2.32"),
    ))

    def _build(self, v):
        tabs = self.tables(v, v["lut_size"])
        head = [self.sensors.Ts_s, float(v["lut_mode"]), 0.0, 0.0, 0.0, 0.0]
        body: list[np.ndarray] = []
        off = len(head)
        for k, name in enumerate(("lut1_p", "lut1_i", "lut2", "lut3")):
            t = tabs[name]
            arr = np.asarray(t["table"], float)
            head[2 + k] = off
            block = np.concatenate([[arr.shape[0], arr.shape[1], *t["x_range"], *t["y_range"]], arr.ravel()])
            body.append(block)
            off += block.size
        return np.concatenate([np.asarray(head)] + body)


def _export(tabs: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    out = {}
    for name, t in tabs.items():
        arr = np.asarray(t["table"], float)
        if name in ("lut1_i", "lut3"):  # one input: a single row over x
            out[name] = {"table": arr[:, :1].T.copy(), "x_range": tuple(t["x_range"]), "y_range": (0.0, 0.0)}
        else:
            out[name] = {"table": arr.T.copy(), "x_range": tuple(t["x_range"]), "y_range": tuple(t["y_range"])}
    return out
