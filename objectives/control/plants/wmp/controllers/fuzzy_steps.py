"""Numba step functions of the fuzzy controllers (see :mod:`.fuzzy` for the method and the sources).

Kept apart from :mod:`.fuzzy` so that :mod:`.kernels` can import them without importing the plant
(``fuzzy`` -> ``base`` -> ``wmp`` -> ``kernels`` would be circular). Parameter-array layout: offsets
below; :class:`.fuzzy.FLC`, :class:`.fuzzy.ProtectiveFuzzy` and :class:`.fuzzy.LUTFuzzy` build it.

The steps are not cached on their own: they are compiled into the closed-loop driver, whose cache entry
holds them (rules 2 and 3 of :mod:`objectives.jit`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from objectives.fuzzy import AND_MIN, TRAP, fuzzify, lut_interp, sugeno_mu

# set indices
_N, _Z, _P = 0, 1, 2
_S, _L = 0, 1

#: rule tables (constant; numba freezes module-level arrays into the compiled code)
RULES_PI = np.array([[_N], [_Z], [_P]], dtype=np.int64)  # Table 2.3, PI-type
RULES_PD = np.array([[a, b] for a in (_N, _Z, _P) for b in (_N, _Z, _P)], dtype=np.int64)  # Table 2.3
PD_SIGNS = np.array([-1, -1, 0, -1, 0, 1, 0, 1, 1], dtype=float)  # N N Z / N Z P / Z P P
RULES_PROT = np.array([[_Z, -1], [_P, -1], [_N, -1], [_Z, _S], [_P, _L], [_N, _L]], dtype=np.int64)  # 2.6
RULES_PROT_I = np.array([[_Z, -1], [_P, -1], [_N, -1]], dtype=np.int64)  # Table 2.6, integral tag
KIND1 = np.full((1, 3), TRAP, dtype=np.int64)
KIND2 = np.full((2, 3), TRAP, dtype=np.int64)

LUT_SIZE = 40  #: grid points per input of the MCU tables (section 2.2.3.1)

# parameter-array layout (offsets into p)
_TS = 0
_F1_MF, _F1_C, _F1_CI = 1, 25, 31  # FLC1: (2,3,4) sets, 6 U_P singletons, 3 U_I singletons
_F2_MF, _F2_C = 34, 58  # FLC2: (2,3,4) sets, 9 singletons
_F3_MF, _F3_C = 67, 79  # FLC3: (1,3,4) sets, 3 singletons
FUZZY_PARAM_SIZE = 82
#: state: [0] integral of FLC1, [1] integral of FLC3, [2:4] input scratch, [4:10] memberships (2, 3)
FLC_STATE_SIZE = 10


# --------------------------------------------------------------------------------------------------
# numba steps
# --------------------------------------------------------------------------------------------------
@njit(cache=False)  # compiled into the closed-loop driver: see the module docstring
def _fis(p, mf_off, n_in, rules, c_off, x0, x1, s):
    """One Sugeno evaluation (eqs. 2.27-2.29) with sets p[mf_off:] (n_in, 3, 4), singletons p[c_off:]."""
    xs = s[2:4]
    xs[0] = x0
    xs[1] = x1
    mu = s[4 : 4 + 3 * n_in].reshape((n_in, 3))
    mf = p[mf_off : mf_off + 12 * n_in].reshape((n_in, 3, 4))
    if n_in == 1:
        fuzzify(xs, KIND1, mf, mu)
    else:
        fuzzify(xs, KIND2, mf, mu)
    return sugeno_mu(mu, rules, p[c_off : c_off + rules.shape[0]], AND_MIN, 0.0)


@njit(cache=False)  # compiled into the closed-loop driver: see the module docstring
def _flc2_flc3_step(p, s, ref, meas):
    """FLC2 (eq. 2.29) and FLC3 (eq. 2.30, time-integrated); returns (u_theta3, u_xi) in V."""
    d = 180.0 / math.pi
    u_th = _fis(p, _F2_MF, 2, RULES_PD, _F2_C, meas[1] * d, meas[2] * d, s)
    s[1] += p[_TS] * _fis(p, _F3_MF, 1, RULES_PI, _F3_C, ref[1] - meas[3], 0.0, s)
    return u_th, s[1]


@njit(cache=False)  # compiled into the closed-loop driver: see the module docstring
def _flc_step(p, s, ref, meas, u_out):
    """Cascade FLC1-3 of section 2.2.2: PI-type FLC1 (eq. 2.28, time-integrated), FLC2, FLC3, eq. 2.31."""
    s[0] += p[_TS] * _fis(p, _F1_MF, 1, RULES_PI, _F1_C, ref[0] - meas[0], 0.0, s)
    u_th, u_xi = _flc2_flc3_step(p, s, ref, meas)
    u_out[0] = s[0] + u_th - u_xi
    u_out[1] = s[0] + u_th + u_xi


@njit(cache=False)  # compiled into the closed-loop driver: see the module docstring
def _protective_step(p, s, ref, meas, u_out):
    """Protective PI-type FLC1 (section 2.3.1, Table 2.6) + FLC2 + FLC3, combined by eq. 2.31.

    u_nu = U_P(e_nu, |I_A|) + integral of U_I(e_nu) dt.
    """
    e = ref[0] - meas[0]
    u_p = _fis(p, _F1_MF, 2, RULES_PROT, _F1_C, e, abs(meas[4]), s)
    # the integral tag reuses the memberships just computed (rules 1-3 of Table 2.6)
    mu = s[4:10].reshape((2, 3))
    s[0] += p[_TS] * sugeno_mu(mu, RULES_PROT_I, p[_F1_CI : _F1_CI + 3], AND_MIN, 0.0)
    u_th, u_xi = _flc2_flc3_step(p, s, ref, meas)
    u_nu = u_p + s[0]
    u_out[0] = u_nu + u_th - u_xi
    u_out[1] = u_nu + u_th + u_xi


@njit
def lut_nearest(table, x_range, y_range, x, y):
    """Eq. 2.32: ``table[round((x - x_min) / res_x), round((y - y_min) / res_y)]``, indices clamped.

    ``table`` (nx, ny) holds the values at ``x_min + i res_x``, ``y_min + j res_y`` with
    ``res = (max - min) / (n - 1)``; NaN inputs map to index 0.
    """
    nx, ny = table.shape
    fx = (x - x_range[0]) / (x_range[1] - x_range[0]) * (nx - 1)
    fy = (y - y_range[0]) / (y_range[1] - y_range[0]) * (ny - 1)
    i = 0
    j = 0
    if fx > 0.0:
        i = min(int(math.floor(fx + 0.5)), nx - 1)
    if fy > 0.0:
        j = min(int(math.floor(fy + 0.5)), ny - 1)
    return table[i, j]


@njit(cache=False)  # compiled into the closed-loop driver: see the module docstring
def _lut_lookup(p, o, x, y, mode):
    """Table number at offset ``o`` of p: header (nx, ny, x_lo, x_hi, y_lo, y_hi), then nx*ny values."""
    nx = int(p[o])
    ny = int(p[o + 1])
    t = p[o + 6 : o + 6 + nx * ny].reshape((nx, ny))
    if mode == 0:
        return lut_nearest(t, p[o + 2 : o + 4], p[o + 4 : o + 6], x, y)
    return lut_interp(t, p[o + 2 : o + 4], p[o + 4 : o + 6], x, y)


@njit(cache=False)  # compiled into the closed-loop driver: see the module docstring
def _lut_step(p, s, ref, meas, u_out):
    """LUT1-3 version of the protective scheme (eqs. 2.32-2.33): p = (Ts, mode, o1P, o1I, o2, o3, tables).

    Tables: LUT1P(e_nu m/s, |I_A| A), LUT1I(e_nu), LUT2(e_theta3 deg, e_omega3 deg/s), LUT3(e_xi rad/s);
    one-input tables have ny = 2 identical columns over y in [0, 1]. mode 0 = nearest (eq. 2.32),
    1 = bilinear. The integrators are the same as in :func:`_protective_step`.
    """
    ts = p[0]
    mode = int(p[1])
    d = 180.0 / math.pi
    e = ref[0] - meas[0]
    u_p = _lut_lookup(p, int(p[2]), e, abs(meas[4]), mode)
    s[0] += ts * _lut_lookup(p, int(p[3]), e, 0.0, mode)
    u_th = _lut_lookup(p, int(p[4]), meas[1] * d, meas[2] * d, mode)
    s[1] += ts * _lut_lookup(p, int(p[5]), ref[1] - meas[3], 0.0, mode)
    u_nu = u_p + s[0]
    u_out[0] = u_nu + u_th - s[1]
    u_out[1] = u_nu + u_th + s[1]
