"""docs/papers.md rows of the thesis's chapter 2 (Odry 2020): the wheeled mobile pendulum.

Tables 2.4-2.5 (section 2.2's designs, untuned, over sensor-noise seeds), F of eq. 2.39 at Table 2.7's
initial and optimised values, the PSO of section 2.3.4 over tuning seeds (with its per-term
improvements), the yaw-gain box read off Table 2.7 (a sensitivity study) and the tuned fuzzy scheme
against the tuned PID (peaks of section 2.3.4), each number typed in as printed in the thesis.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks.papers_common import (
    TIME_TOL_S,
    Row,
    config_raw,
    iv_gain,
    iv_ratio,
    printed,
    tune_cmd,
    tuned,
)

F_INIT, F_OPT = "0.1049", "0.0558"
#: section 2.3.4: the thesis's improvement of each MAE term of eq. 2.39 by tuning (%)
F_TERMS = (("mae_nu", "speed", "13"), ("mae_xi", "yaw rate", "59"), ("mae_omega3", "IB rate", "36"))
#: Table 2.7's optimised u3 is 2.398 V/s; the box just above it was read off that result
U3_BOX = 3.0
#: Table 2.4 (simulation): (quantity, unit, linear, fuzzy, tolerance)
TABLE_24 = (("rise", "0-90 % rise time of the first speed step", "s", "0.73", "0.9", TIME_TOL_S),
            ("t5", "5 % settling time of the first speed step", "s", "0.82", "1.78", TIME_TOL_S),
            ("ovs_nu", "speed overshoot of the first step", "m/s", "0.0083", "0.036", 0.0),
            ("ovs_ib", "IB overshoot (peak IB angle)", "deg", "29.9", "25.6", 0.0),
            ("t5deg", "IB settling time within 5 deg", "s", "0.85", "1.19", TIME_TOL_S))
#: Table 2.5 as legible: fuzzy SAE, SSE, STAE, STSE and linear SAE of e_nu, e_xi, e_omega3 and log10 of the product
TABLE_25 = {("flc", "sae"): ("30.4780", "128.7299", "4.2689e3", "7.2240"),
            ("flc", "sse"): ("6.5300", "218.3223", "1.1638e5", "8.2199"),
            ("flc", "stae"): ("85.6093", "512.2402", "9.4892e3", "8.6192"),
            ("flc", "stse"): ("20.3829", "955.1933", "1.6724e5", "9.5127"),
            ("lqg", "sae"): ("30.8451", "150.3294", "3.7218e3", "7.2370")}
#: the section 2.2.3.1 profile (xi_d 0.5, 0, -1.2, 0 rad/s) with the step spacing that fits Table 2.5's time
#: ratios best (docs/control-cost.md section 2)
SEC22_HOLD_S = 2.06
#: the step spacings that fit Table 2.5 equally (docs/control-cost.md section 2) and the run lengths after the
#: last step that the text leaves open (one half to two holds)
F_SPACINGS_S = (1.94, 2.00, 2.08)
F_TAILS = (0.5, 1.0, 1.5, 2.0)


def _profile(hold: float, yaw_deg_s: Sequence[float], tail: float = 1.0) -> dict:
    return {"duration_s": round(hold * (3 + tail), 6),
            "steps": [{"t": round(hold * i, 6), "v": v, "yaw_rate_deg_s": w}
                      for i, (v, w) in enumerate(zip((0.4, 0.0, -0.2, 0.0), yaw_deg_s))]}


def _objective(config: str = "wmp_fuzzy_protective.yaml", **over):
    from benchmarks.papers_common import PAPERS
    from objectives.control.objective import ClosedLoopObjective

    section = dict(config_raw(config)["objective"])
    section.update(over)
    return ClosedLoopObjective.from_config(section, PAPERS)


def _table_24(obj, params: dict) -> dict[str, float]:
    from objectives.control.plants.wmp.metrics import settling_time_s

    ev = obj(params)
    sim = obj.simulate(params)
    y, ref = sim["outputs"], sim["references"]
    ts = 0.01
    hold = int(np.flatnonzero(np.diff(ref[:, 0]) != 0)[0]) + 1
    return {"rise": ev.metrics["rise_time_nu_s"], "t5": settling_time_s(y[:, 0], ref[:, 0], ts, 0, 0.05 * 0.4),
            "ovs_nu": float(np.max(y[:hold, 0]) - 0.4), "ovs_ib": ev.metrics["peak_theta3_deg"],
            "t5deg": ev.metrics["settle_theta3_s"], **ev.metrics}


def tables_24_25_rows(noise_seeds: Sequence[int]) -> list[Row]:
    """Tables 2.4-2.5: section 2.2's fuzzy (``flc``) and linear (``lqg``) designs, untuned."""
    from objectives.control.objective import ClosedLoopObjective

    yaw = tuple(np.degrees(x) for x in (0.5, 0.0, -1.2, 0.0))
    m = {c: [] for c in ("flc", "lqg")}
    for c in m:
        for s in noise_seeds:
            obj = ClosedLoopObjective(controller=c, profile=_profile(SEC22_HOLD_S, yaw), noise_seed=int(s))
            m[c].append(_table_24(obj, obj.defaults))
    seeds = "sensor-noise seeds"
    cmd = (f"python -m benchmarks.papers (Tables 2.4-2.5: controllers flc, lqg at their defaults, section 2.2.3.1 "
           f"profile, {SEC22_HOLD_S} s steps)")
    rows = []
    for key, what, unit, lin, fuz, tol in TABLE_24:
        f, li = np.array([r[key] for r in m["flc"]]), np.array([r[key] for r in m["lqg"]])
        fuzzy_larger = float(fuz) > float(lin)
        for name, vals, paper in (("fuzzy", f, fuz), ("linear", li, lin)):
            holds = (f > li) if fuzzy_larger else (f < li)
            rows.append(Row(f"Section 2.2's {name} design: {what}", "Table 2.4 (simulation)", f"{paper} {unit}", cmd,
                            printed(paper), vals, direction=f"fuzzy {'>' if fuzzy_larger else '<'} linear",
                            holds=holds, tol=tol, unit=unit, seeds=seeds))
    errs = ("nu", "xi", "omega3", "log10_prod")
    for (c, meas), printed_vals in TABLE_25.items():
        name = "fuzzy" if c == "flc" else "linear"
        for e, pv in zip(errs, printed_vals):
            vals = np.array([r[f"{meas}_{e}"] for r in m[c]])
            if meas == "sae":  # the only legible linear row: fuzzy lower on e_nu, e_xi and overall, higher on e_omega3
                f, li = (np.array([r[f"sae_{e}"] for r in m[k]]) for k in ("flc", "lqg"))
                holds, direction = ((f > li), "fuzzy > linear") if e == "omega3" else ((f < li), "fuzzy < linear")
            else:
                holds, direction = (), "-"
            what = f"{meas.upper()} of e_{e}" if e != "log10_prod" else f"{meas.upper()} overall (eq. 2.36, log10)"
            rows.append(Row(f"Section 2.2's {name} design: {what}", "Table 2.5", pv, cmd, printed(pv), vals,
                            direction=direction, holds=holds, seeds=seeds))
    return rows


def f_band_rows() -> list[Row]:
    """F at Table 2.7's initial values over the step spacings and run lengths the text leaves open; the
    ratio F(Table 2.7 optimised) / F(initial), which the run length does not move."""
    from objectives.control.plants.wmp.controllers.fuzzy import THESIS_OPTIMISED

    yaw = (30.0, 0.0, -70.0, 0.0)
    f0s, ratios = [], []
    for hold in F_SPACINGS_S:
        for tail in F_TAILS:
            # F of eq. 2.39 itself: the tracking requirements (ours, section 4 of docs/control-cost.md) are off
            obj = _objective(profile=_profile(hold, yaw, tail), duration_s=None, requirements={})
            f0 = obj(obj.defaults).fitness
            f0s.append(f0)
            opt = dict(obj.defaults, **{k: v for k, v in THESIS_OPTIMISED.items() if k not in obj.fixed})
            ratios.append(obj(opt).fitness / f0)
    band = f"{min(f0s):.4f}-{max(f0s):.4f}"
    inside = min(f0s) <= float(F_INIT) <= max(f0s)
    return [Row("Eq. 2.39 (SI) at Table 2.7's initial parameters", "section 2.3.4, F_init", F_INIT,
                "python -m benchmarks.papers (F band: step spacings 1.94-2.08 s, run end 0.5-2 holds after the last "
                "step)", printed(F_INIT), f0s, kind="untestable",
                ours=f"band {band} over step spacings {', '.join(map(str, F_SPACINGS_S))} s x run end "
                     f"{', '.join(map(str, F_TAILS))} holds after the last step ({len(f0s)} settings; the thesis's "
                     f"value {'lies inside' if inside else 'lies outside'} the band; configs: 2 s, 1 hold: "
                     f"{f0s[F_SPACINGS_S.index(2.0) * len(F_TAILS) + F_TAILS.index(1.0)]:.4f})"),
            Row("Table 2.7's optimised parameters improve F: ratio F_opt / F_init (independent of the run length)",
                "section 2.3.4, Table 2.7", f"{F_OPT} / {F_INIT}",
                "python -m benchmarks.papers (F band rows)", iv_ratio(printed(F_OPT), printed(F_INIT)), ratios,
                direction="ratio < 1", holds=np.array(ratios) < 1.0, seeds="spacing x run-length settings")]


def _get(best: dict, section: str, key: str) -> float:
    """A number of a run's best.yaml; NaN when the run had no successful evaluation (a failed row)."""
    return float(best.get(section, {}).get(key, np.nan))


def pso_rows(budget: tuple[int, int], seeds: Sequence[int], out: Path, light: bool = False) -> list[Row]:
    """Section 2.3.4: the PSO improves F of the protective fuzzy scheme (with its per-term gains), the u3 box
    read off Table 2.7 (sensitivity study), and the tuned fuzzy scheme against the tuned PID (peaks)."""
    pop, gen = budget
    cfg = "wmp_fuzzy_protective.yaml"
    b_str = f"--set optimizer.population={pop} --set optimizer.generations={gen}"
    runs = [tuned(cfg, pop, gen, out, seed=s, light=light) for s in seeds]
    boxed = [tuned(cfg, pop, gen, out, (f"parameters.u3={{low: 0.1, high: {U3_BOX}}}",), "-u3box", seed=s,
                   light=light) for s in seeds]
    pid = [tuned("wmp_pid.yaml", pop, gen, out, seed=s, light=light) for s in seeds]
    obj = _objective()
    m0 = obj(obj.defaults).metrics
    f0 = obj(obj.defaults).fitness
    gain = np.array([100.0 * (1.0 - _get(r, "evaluation", "best_fitness") / f0) for r in runs])
    gain_box = np.array([100.0 * (1.0 - _get(r, "evaluation", "best_fitness") / f0) for r in boxed])
    paper_gain = iv_gain(printed(F_INIT), printed(F_OPT))
    rows = [Row("PSO improves F of the protective fuzzy scheme (eq. 2.39, from Table 2.7's initial values)",
                "section 2.3.4", "46.8 % lower (0.1049 -> 0.0558)", tune_cmd(cfg, b_str), paper_gain, gain,
                direction="improvement > 0", holds=gain > 0, unit="%", seeds="tuning seeds"),
            Row("PSO with the yaw gain u3 bounded at 3 V/s (read off Table 2.7's optimised u3 = 2.398)",
                "section 2.3.4, Table 2.7", "46.8 % lower",
                tune_cmd(cfg, b_str, (f"parameters.u3={{low: 0.1, high: {U3_BOX}}}",)), paper_gain, gain_box,
                kind="sensitivity", unit="%", seeds="tuning seeds")]
    for key, label, t in F_TERMS:
        g = np.array([100.0 * (1.0 - _get(r, "metrics", key) / m0[key]) for r in runs])
        rows.append(Row(f"The PSO improves the {label} MAE term of eq. 2.39", "section 2.3.4", f"{t} % lower",
                        tune_cmd(cfg, b_str), printed(t), g, direction="improvement > 0", holds=g > 0, unit="%",
                        seeds="tuning seeds"))
    for key, label, pf, pp in (("peak_theta3_deg", "peak IB angle (deg)", "46.8", "56.8"),
                               ("peak_current_A", "peak current (A)", "0.32", "0.54")):
        f = np.array([_get(r, "metrics", key) for r in runs])
        p = np.array([_get(r, "metrics", key) for r in pid])
        for name, vals, pv in (("fuzzy", f, pf), ("PID", p, pp)):
            rows.append(Row(f"Tuned {name} scheme, {label}: the fuzzy scheme's is lower than the PID's",
                            "section 2.3.4 (Figs. 2.16-2.17 text)", pv,
                            tune_cmd("{wmp_fuzzy_protective,wmp_pid}.yaml", b_str), printed(pv), vals,
                            direction="fuzzy < PID", holds=f < p, seeds="tuning seeds"))
    return rows


def control_rows(budget: tuple[int, int], seeds: Sequence[int], out: Path, light: bool = False) -> list[Row]:
    """Every chapter-2 row (``light``: see :func:`benchmarks.papers_common.tuned`)."""
    return tables_24_25_rows(seeds) + f_band_rows() + pso_rows(budget, seeds, out, light)


__all__ = ["control_rows", "tables_24_25_rows", "f_band_rows", "pso_rows"]
