"""Slow, literal reference of the protective fuzzy scheme (thesis 2.3.1, Tables 2.3, 2.6, 2.7).

Plain Python with the Gamma sets written out as formulas, rules as explicit (antecedents, consequent)
lists, min AND and weighted average (eq. 2.27); independent of objectives.fuzzy and the kernels.
"""

from __future__ import annotations

import math


def gamma_left(x, peak, foot):
    """Gamma(-inf, peak, foot): 1 up to ``peak``, falls linearly to 0 at ``foot`` (peak <= foot)."""
    if x <= peak:
        return 1.0
    if x >= foot:
        return 0.0
    return (foot - x) / (foot - peak)


def gamma_right(x, foot, peak):
    """Gamma(foot, peak, inf): 0 up to ``foot``, rises to 1 at ``peak``, then 1."""
    if x >= peak:
        return 1.0
    if x <= foot:
        return 0.0
    return (x - foot) / (peak - foot)


def gamma_zero(x, half):
    """Gamma(-half, 0, half); a spike at 0 when half == 0."""
    if half <= 0:
        return 1.0 if x == 0 else 0.0
    return max(0.0, 1.0 - abs(x) / half)


def nzp(x, p1, p2, p3):
    return {"N": gamma_left(x, -p1, -p2), "Z": gamma_zero(x, p1 - p3), "P": gamma_right(x, p2, p1)}


def weighted_average(rules):
    """rules: list of (firing strength, singleton)."""
    num = sum(w * k for w, k in rules)
    den = sum(w for w, _ in rules)
    return num / den if den > 0 else 0.0


def flc1_protective(e_nu, i_abs, v):
    """(U_P, U_I) of Table 2.6 at speed error e_nu (m/s) and current magnitude i_abs (A)."""
    e = nzp(e_nu, v["p11"], v["p12"], v["p13"])
    s = gamma_left(i_abs, 0.0, v["d11"])
    big = gamma_right(i_abs, v["d12"], max(v["d13"], v["d12"]))
    if v["d13"] <= v["d12"]:
        big = 1.0 if i_abs >= v["d12"] else 0.0
    u11, u12, u13 = v["u11"], v["u12"], v["u13"]
    up = weighted_average(
        [
            (e["Z"], 0.0),
            (e["P"], u11),
            (e["N"], -u11),
            (min(e["Z"], s), 0.0),
            (min(e["P"], big), u12),
            (min(e["N"], big), -u12),
        ]
    )
    ui = weighted_average([(e["Z"], 0.0), (e["P"], u13), (e["N"], -u13)])
    return up, ui


def flc2(e_th_deg, e_om_deg_s, v):
    """PD-type FLC2 (Table 2.3, eq. 2.29)."""
    a = nzp(e_th_deg, v["p21"], v["p22"], v["p23"])
    b = nzp(e_om_deg_s, v["d21"], v["d22"], v["d23"])
    table = {
        "N": {"N": "N", "Z": "N", "P": "Z"},
        "Z": {"N": "N", "Z": "Z", "P": "P"},
        "P": {"N": "Z", "Z": "P", "P": "P"},
    }
    val = {"N": -v["u2"], "Z": 0.0, "P": v["u2"]}
    return weighted_average([(min(a[i], b[j]), val[table[i][j]]) for i in "NZP" for j in "NZP"])


def flc3(e_xi_deg_s, v):
    """PI-type FLC3 increment (V/s) at yaw-rate error e_xi (deg/s)."""
    m = nzp(e_xi_deg_s, v["p31"], v["p32"], v["p33"])
    return weighted_average([(m["N"], -v["u3"]), (m["Z"], 0.0), (m["P"], v["u3"])])


def protective_step(v, state, nu_d, xi_d, meas, ts):
    """One step of the scheme; state = [int_I, int_xi] (modified); returns (u1, u2) in V."""
    up, ui = flc1_protective(nu_d - meas[0], abs(meas[4]), v)
    state[0] += ts * ui
    u_th = flc2(math.degrees(meas[1]), math.degrees(meas[2]), v)
    state[1] += ts * flc3(math.degrees(xi_d - meas[3]), v)
    u_nu = up + state[0]
    return u_nu + u_th - state[1], u_nu + u_th + state[1]
