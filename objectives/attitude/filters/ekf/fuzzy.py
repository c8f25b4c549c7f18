"""The FAEKF's fuzzy scaling of R (Odry et al. 2020, section 4.3, eqs. 28-31, Table 1): its sets and singletons
(defaults, search bounds, declarations) and the numba kernel of the crisp scale ``K_k`` per sample. The
filter class is :class:`objectives.attitude.filters.ekf.FAEKF`."""

from __future__ import annotations

import numpy as np
from numba import njit

from objectives.fuzzy import fuzzify, grid_rules, sugeno_mu
from objectives.jit import uncached
from objectives.params import ANY_REAL, POSITIVE, Param
from tuner.space import Real

__all__ = ["FUZZY_INPUTS", "FUZZY_UNITS", "FUZZY_SETS", "FUZZY_DEFAULTS", "K_DEFAULTS", "FUZZY_BOUNDS", "K_BOUNDS",
           "SEARCHED_K", "rule_consequent_index", "faekf_rules", "fuzzy_scale", "fuzzy_scale_inner", "mf_name",
           "fuzzy_params", "fuzzy_decl"]


# ---------------------------------------------------------------------------------------------
# fuzzy scaling of R (section 4.3, eqs. 28-31, Table 1)
# ---------------------------------------------------------------------------------------------
#: fuzzy inputs in kernel order: vibration frequency (Hz), external acceleration (g), magnetic
#: perturbation (normalised units)
FUZZY_INPUTS = ("vib", "acc", "mag")
FUZZY_UNITS = {"vib": "Hz", "acc": "g", "mag": "nu"}
FUZZY_SETS = ("Z", "S", "B")

#: Default Gaussian sets ``(mean, std)`` per input and set. Figure 3 of the paper (the sets) is not
#: in the text; we cover each input's range with three sets whose neighbours cross at 0.5
#: (``std = spacing / (2 sqrt(2 ln 2))``): ``f`` over 0..10 Hz (``f_thr``, eq. 25), ``a_ext`` over
#: 0..1 g and ``h_ext`` over 0..1 nu (the accumulated measures of eqs. 26-27 average the 0-16 g and
#: 0-5 nu peaks of section 5.3 over L = 400 samples; these ranges cover the bench recordings).
FUZZY_DEFAULTS: dict[str, tuple[float, float]] = {
    "vib_Z": (0.0, 2.1233), "vib_S": (5.0, 2.1233), "vib_B": (10.0, 2.1233),
    "acc_Z": (0.0, 0.21233), "acc_S": (0.5, 0.21233), "acc_B": (1.0, 0.21233),
    "mag_Z": (0.0, 0.21233), "mag_S": (0.5, 0.21233), "mag_B": (1.0, 0.21233),
}
#: Default singletons K1..K7 (not in the text). K1 = 1 keeps R in the undisturbed state, as the
#: paper describes ("in these static cases, the adaptive strategy does not modify the noise
#: variances"); the others grow roughly geometrically up to 100.
K_DEFAULTS = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0)
#: search bounds of the set parameters: (mean low, mean high, std low, std high) per input
FUZZY_BOUNDS = {"vib": (0.0, 10.0, 0.1, 10.0), "acc": (0.0, 2.0, 0.01, 2.0), "mag": (0.0, 2.0, 0.01, 2.0)}
#: search bounds of the singletons. The lower bound is 1: Table 1's rules only ever *raise* R with
#: the intensity of the disturbances (section 4.3: "R should be increased according to the intensity
#: of the measures"), and K1 = 1 is the undisturbed state. With K < 1 allowed, PSO on a few short
#: recordings picked K3 ~ 0.3 (the rule of a big magnetic perturbation alone), i.e. trusted the
#: perturbed magnetometer *more*, which fits the training recordings and costs heading on held-out ones.
K_BOUNDS = (1.0, 1000.0)
#: The singletons of the default space: K1 is not searched. R_k = K_k rho (eq. 31) depends on rho and the
#: singletons only through their products, so (c rho, K / c) is the same filter for every c > 0 (tested: bit for
#: bit when c is a power of two): one direction of (rho, K1..K7) changes nothing. Holding K1 at 1, the undisturbed
#: state where "the adaptive strategy does not modify the noise variances", removes it: rho is then the
#: undisturbed R and K2..K7 >= 1 its growth with the disturbance. With K1 searched, the better optimum of the
#: bench6dof problem was a thin ridge along that direction; PSO with the paper's settings (30 x 30) found it
#: in 2 of 10 seeds with K1 searched and in 19 of 30 with K1 = 1, the trust region in 26 of 30
#: (benchmarks/results/auto_rules.md). A ``parameters:`` section that gives K1 bounds searches it.
SEARCHED_K = ("K2", "K3", "K4", "K5", "K6", "K7")


def rule_consequent_index(i_f: int, i_a: int, i_h: int) -> int:
    """Table 1: rule with set indices (0=Z, 1=S, 2=B) of f, a_ext, h_ext -> 0-based index of its K."""
    return i_f + i_a + i_h


def faekf_rules(kappa: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Table 1 as arrays for :mod:`objectives.fuzzy`: (27, 3) antecedents and (27,) consequents."""
    rules = grid_rules([3, 3, 3])
    return rules, np.ascontiguousarray(np.asarray(kappa, dtype=np.float64)[rules.sum(axis=1)])


@njit(cache=True)
def fuzzy_scale(vib, acc, mag, mf_kind, mf_params, rules, consequents, out):
    """Crisp scale ``K_k`` of R for every sample (eqs. 28-31, Table 1), with :mod:`objectives.fuzzy`.

    Parameters
    ----------
    vib, acc, mag : (N,) float64
        Vibration frequency (Hz), external acceleration (g), magnetic perturbation (nu).
    mf_kind, mf_params : (3, 3) int64, (3, 3, 4) float64
        Gaussian sets ``(mean, std)`` of the inputs (vib, acc, mag) x sets (Z, S, B).
    rules, consequents : (27, 3) int64, (27,) float64
        Table 1 (:func:`faekf_rules`).
    out : (N,) float64, out
        ``K = sum_i kappa^i gamma^i / sum_i gamma^i`` with ``gamma^i`` the min of the rule's three
        memberships (zero-order Sugeno, min-AND). If no rule fires (every membership underflows)
        the output is the mean of the singletons (:func:`objectives.fuzzy.sugeno_mu`).
    """
    n = vib.shape[0]
    mu = np.empty(mf_kind.shape)
    xk = np.empty(3)
    for k in range(n):
        xk[0] = vib[k]
        xk[1] = acc[k]
        xk[2] = mag[k]
        fuzzify(xk, mf_kind, mf_params, mu)
        out[k] = sugeno_mu(mu, rules, consequents, 0, np.nan)


#: the uncached twin other kernels call (objectives.jit)
fuzzy_scale_inner = uncached(fuzzy_scale)


def mf_name(inp: str, s: str, what: str) -> str:
    return f"{inp}_{s}_{what}_{FUZZY_UNITS[inp]}"


def fuzzy_params(tunable: bool) -> tuple[Real, ...]:
    out = []
    for inp in FUZZY_INPUTS:
        lo_m, hi_m, lo_s, hi_s = FUZZY_BOUNDS[inp]
        for s in FUZZY_SETS:
            mean, std = FUZZY_DEFAULTS[f"{inp}_{s}"]
            n_mean, n_std = mf_name(inp, s, "mean"), mf_name(inp, s, "std")
            d_mean = f"centre of the Gaussian set {s} of the {inp} input (eq. 28 b_ij)"
            d_std = f"standard deviation of the Gaussian set {s} of the {inp} input (eq. 28 c_ij)"
            if tunable:
                out.append(Real(n_mean, lo_m, hi_m, unit=FUZZY_UNITS[inp], doc=d_mean))
                out.append(Real(n_std, lo_s, hi_s, scale="log", unit=FUZZY_UNITS[inp], doc=d_std))
            else:
                out.append(Real(n_mean, fixed=mean, unit=FUZZY_UNITS[inp], doc=d_mean))
                out.append(Real(n_std, fixed=std, unit=FUZZY_UNITS[inp], doc=d_std))
    return tuple(out)


def fuzzy_decl() -> tuple[Param, ...]:
    """The 18 set parameters as declarations (fixed by default; bounds in :data:`FUZZY_BOUNDS`)."""
    out = []
    for r in fuzzy_params(tunable=False):
        std = r.name.split("_")[2] == "std"
        out.append(Param(r.name, r.fixed, unit=r.unit, doc=r.doc, eq="eq. 28", allowed=POSITIVE if std else ANY_REAL))
    return tuple(out)
