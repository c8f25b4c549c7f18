"""PID on Åström and Hägglund's benchmark systems: tuned by tuner over five seeds, against the constrained
optimum and against the AMIGO and SIMC rules detuned to the same robustness limit.

The problem on each plant is :mod:`benchmarks.pid_plants`'s (the sampled loop, load-step IAE, Ms <= 1.4); its
optimum is :mod:`benchmarks.pid_optimum`'s independent dense global search (stored with its method in
``benchmarks/results/pid_optimum.json``). Per plant and seed (1-5), ``tuner.run`` tunes the PID (PSO,
:data:`POP` x :data:`GENS` evaluations, serial); the result is scored by the independent code of
:mod:`benchmarks.pid_optimum` (IAE of the sampled loop; Ms on 10^5 frequencies with its peaks zoomed), so
neither the cost nor the constraint is the tuner's own reading:

- **tuned / optimum**: the tuned IAE over the optimum's, median and worst over the seeds;
- **Ms violations**: a tuned PID whose reference Ms exceeds 1.4 by more than :data:`MS_TOL` (the tuner reads
  Ms on its own grid, refined at the peaks: a violation means that reading was low);
- **rules at the limit**: AMIGO (on the least-squares and on the method-of-areas FOTD fit of the step
  response) and SIMC (the half rule on the known transfer function; on the least-squares FOTD fit for the
  oscillatory plants, where the half rule does not apply), each as published and detuned along its own knob
  (AMIGO's gain factor, SIMC's ``tau_c / theta``) until the reference Ms meets 1.4
  (:func:`objectives.control.plants.rules.detune_to_ms`); whether any of them beats the tuner on any seed;
- the wall and CPU time of each whole ``tuner.run``.

Done when: median tuned / optimum <= 1.01, worst <= 1.05, no Ms violation above 1e-4, no plant where a rule
at the limit beats the tuner on any seed, every tuning under 10 s. Results in
``benchmarks/results/pid_benchmark.md`` (and ``.json``).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import md_table
from benchmarks.pid_plants import MS_MAX, N_FILTER, PLANTS, box, continuous, plant_section, scale

__all__ = ["run", "rules", "tune", "compare", "POP", "GENS", "SEEDS", "MS_TOL"]

#: the tuner's budget per tuning (PSO, serial): 3000 evaluations
POP, GENS = 20, 150
SEEDS = (1, 2, 3, 4, 5)
#: how far above the limit a reference Ms counts as a violation
MS_TOL = 1e-4


def rules(name: str, ms_of: Any) -> dict[str, dict[str, Any]]:
    """``{rule: {"pid": (K, Ti, Td) as published, "limit": (K, Ti, Td) detuned to Ms <= 1.4 by ``ms_of``,
    "knob": its knob value}}`` for plant ``name`` (module docstring)."""
    from objectives.control.plants.rules import (
        amigo_detuned,
        detune_to_ms,
        fit_fotd,
        half_rule,
        simc_detuned,
    )

    num, den, delay = continuous(name)
    h, dur = scale(name)
    t, y = _step(num, den, delay, h, dur)
    out, fams = {}, {}
    for fit in ("lsq", "area"):
        m = fit_fotd(t, y, fit)
        fams[f"AMIGO ({fit})"] = ((lambda a, m=m: amigo_detuned(m, a)), "down")
    hr = PLANTS[name][3]
    if hr is not None:
        sopdt = half_rule(*hr)
    else:  # complex poles: the half rule does not apply; SIMC on the least-squares FOTD fit
        m = fit_fotd(t, y, "lsq")
        sopdt = (m.K, m.T, 0.0, m.L)
    fams["SIMC"] = ((lambda lam: simc_detuned(sopdt, lam)), "up")
    for rule, (family, toward) in fams.items():
        d = detune_to_ms(family, lambda p: ms_of(np.asarray(p)), MS_MAX, toward)
        out[rule] = {"pid": family(1.0), "limit": d.pid, "knob": d.knob}
    return out


def _step(num: list[float], den: list[float], delay: float, h: float, dur: float) -> tuple[np.ndarray, np.ndarray]:
    """The plant's unit step response sampled at ``h`` over ``dur`` (python-control; the delay shifts it)."""
    import control

    t = np.arange(0, dur, h)
    y = control.step_response(control.tf(num, den), T=t).outputs.reshape(-1)
    d = int(round(delay / h))
    return t, np.r_[np.zeros(d), y[: y.size - d]]


def tune(name: str, seed: int, pop: int = POP, gens: int = GENS) -> tuple[dict[str, float], float, float]:
    """The PID of plant ``name`` tuned by ``tuner.run`` (serial PSO, no report); its parameters, the wall and the
    CPU time (s) of the whole run."""
    from tuner.config import config_from_dict
    from tuner.run import run as tuner_run

    raw = {"name": "pid-bench", "seed": seed, "objective": plant_section(name),
           "parameters": {k: {"low": lo, "high": hi, "scale": "log"} for k, (lo, hi) in box(name).items()},
           "optimizer": {"method": "pso", "population": pop, "generations": gens},
           "parallel": {"backend": "serial"}}
    with tempfile.TemporaryDirectory() as d:
        raw["output"] = d
        cfg = config_from_dict(raw, source="benchmarks/pid_benchmark.py", base_dir=Path(d))
        t, c = time.perf_counter(), time.process_time()
        res = tuner_run(cfg, quiet=True, report=False)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    return dict(res.best_params), wall, cpu


def _score(problem: Any, p: Any) -> dict[str, float]:
    """The reference IAE and Ms of ``p = (K, Ti, Td)`` on ``problem`` (:class:`benchmarks.pid_optimum.Problem`)."""
    p = np.asarray(p, dtype=float)
    return {"iae": problem.iae(p), "ms": problem.ms_loop(p)}


def compare(optimum_iae: float, tuned: list[dict[str, float]], rules_at_limit: dict[str, dict[str, float]],
            ms_max: float = MS_MAX, ms_tol: float = MS_TOL) -> dict[str, Any]:
    """One plant's verdicts from the reference scores: ``tuned`` one ``{"iae", "ms"}`` per seed, each rule at the
    limit ``{"iae", "ms"}``: the ratios to the optimum (median, worst), the seeds whose Ms exceeds ``ms_max``
    by more than ``ms_tol``, and the rules (feasible at the limit) that beat the tuner on some seed, with those
    seeds."""
    ratios = [t["iae"] / optimum_iae for t in tuned]
    violations = [i for i, t in enumerate(tuned) if not t["ms"] <= ms_max + ms_tol]
    beaten = {}
    for rule, r in rules_at_limit.items():
        if r["ms"] <= ms_max + ms_tol and math.isfinite(r["iae"]):
            seeds = [i for i, t in enumerate(tuned) if r["iae"] < t["iae"]]
            if seeds:
                beaten[rule] = seeds
    return {"ratios": ratios, "median": float(np.median(ratios)), "worst": float(max(ratios)),
            "ms_violations": violations, "rules_beat_tuner": beaten}


def run(smoke: bool = False, n_jobs: int = 1, **_: Any) -> dict[str, Any]:
    from benchmarks.pid_optimum import Problem, load_optimum

    pop, gens = (6, 2) if smoke else (POP, GENS)
    seeds = SEEDS[:2] if smoke else SEEDS
    names = list(PLANTS)[:2] if smoke else list(PLANTS)
    opt = load_optimum()["plants"]
    tune(names[0], 1, 2, 1)  # warm-up: imports and the numba cache load are not part of one tuning
    results, rows, walls, cpus = {}, [], [], []
    for name in names:
        pb = Problem(name)
        rs = rules(name, pb.ms_loop)
        at_limit = {r: {**_score(pb, v["limit"]), "knob": v["knob"], "published": _score(pb, v["pid"])}
                    for r, v in rs.items()}
        tuned = []
        for seed in seeds:
            p, wall, cpu = tune(name, seed, pop, gens)
            walls.append(wall)
            cpus.append(cpu)
            tuned.append({**p, **_score(pb, [p["K"], p["Ti_s"], p["Td_s"]]), "wall_s": wall, "cpu_s": cpu})
        v = compare(opt[name]["iae"], tuned, at_limit)
        results[name] = {"optimum": opt[name], "tuned": tuned, "rules": at_limit, **v}
        best_rule = min(at_limit.items(), key=lambda kv: kv[1]["iae"] if kv[1]["ms"] <= MS_MAX + MS_TOL else math.inf)
        rows.append([name, f"{opt[name]['iae']:.4g}", f"{v['median']:.4f}", f"{v['worst']:.4f}",
                     f"{max(t['ms'] for t in tuned):.5f}", str(len(v["ms_violations"])),
                     f"{best_rule[0]} {best_rule[1]['iae'] / opt[name]['iae']:.3f}",
                     ", ".join(f"{r} (seeds {', '.join(str(seeds[i]) for i in s)})"
                               for r, s in v["rules_beat_tuner"].items()) or "none",
                     f"{max(t['cpu_s'] for t in tuned):.2f}"])
    every = [r for res in results.values() for r in res["ratios"]]
    n_viol = sum(len(res["ms_violations"]) for res in results.values())
    beaten = [n for n, res in results.items() if res["rules_beat_tuner"]]
    targets = [
        {"target": "median tuned / optimum <= 1.01", "value": f"{np.median(every):.4f}",
         "pass": bool(np.median(every) <= 1.01)},
        {"target": "worst tuned / optimum <= 1.05", "value": f"{max(every):.4f}", "pass": bool(max(every) <= 1.05)},
        {"target": f"no Ms violation above {MS_TOL:g} (reference Ms, 10^5 frequencies)",
         "value": f"{n_viol} of {len(every)}", "pass": n_viol == 0},
        {"target": "no rule at Ms <= 1.4 beats the tuner on any seed", "value": ", ".join(beaten) or "none",
         "pass": not beaten},
        {"target": "each tuning under 10 s", "value": f"CPU max {max(cpus):.2f} s, wall max {max(walls):.2f} s",
         "pass": bool(max(cpus) < 10.0)},
    ]
    load = os.getloadavg()[0]
    md = [f"Per plant: the optimum's load IAE, tuned / optimum over seeds {', '.join(map(str, seeds))} (median, "
          f"worst; PSO {pop} x {gens} = {pop * gens} evaluations per tuning, serial, the whole `tuner.run` "
          "without its report), the largest reference Ms of the tuned PIDs and the violations above "
          f"{MS_MAX} + {MS_TOL:g}, the best rule at the limit (its IAE over the optimum's), the rules at the limit "
          "that beat the tuner on some seed, and the largest CPU time of one tuning (load average "
          f"{load:.1f} on {os.cpu_count()} cores at the end). Every IAE and Ms is the independent reference's "
          "(`benchmarks/pid_optimum.py`).", "",
          md_table(["plant", "optimum IAE", "tuned / opt. median", "worst", "max Ms", "Ms > 1.4001",
                    "best rule at Ms <= 1.4 (/ opt.)", "rules beating the tuner", "CPU s"], rows), "",
          "Rules as published and at the limit (reference IAE and Ms; knob: AMIGO's gain factor, SIMC's "
          "tau_c / theta; 1 = as published):", ""]
    rrows = []
    for name, res in results.items():
        for rule, r in res["rules"].items():
            pub = r["published"]
            rrows.append([name, rule, f"{pub['iae']:.4g}" if math.isfinite(pub["iae"]) else "unstable",
                          f"{pub['ms']:.3f}", f"{r['knob']:.4g}", f"{r['iae']:.4g}", f"{r['ms']:.4f}"])
    md += [md_table(["plant", "rule", "published IAE", "published Ms", "knob at the limit", "IAE at the limit",
                     "Ms at the limit"], rrows)]
    out = {"results": results, "markdown": "\n".join(md), "targets": targets,
           "budget": {"pop": pop, "gens": gens, "seeds": list(seeds)}}
    if not smoke:
        from benchmarks import pid_robust
        from benchmarks.common import RESULTS_DIR

        robust = pid_robust.run()
        out["robust"] = robust["results"]
        md += ["", "## Robust part", "", (pid_robust.__doc__ or "").split("\n\n", 1)[1].strip(), "",
               robust["markdown"], "", "## The price of robustness", "", *tradeoff(Path(RESULTS_DIR))]
        out["markdown"] = "\n".join(md)

        write_markdown(out, Path(RESULTS_DIR) / "pid_benchmark.md")
        (Path(RESULTS_DIR) / "pid_benchmark.json").write_text(json.dumps(
            {"results": results, "robust": out["robust"], "targets": targets, "budget": out["budget"],
             "n_filter": N_FILTER}, indent=1, default=float) + "\n")
    return out


def tradeoff(results_dir: Path) -> list[str]:
    """``configs/pid_ms_tradeoff.yaml`` swept (the load IAE against the Ms limit on P1 n=4, three seeds): its
    sweep report's figure copied to ``pid_ms_tradeoff.png`` beside the results, and the Markdown with the
    medians."""
    import shutil

    from tuner.plots import swept
    from tuner.plots.context import SweepContext
    from tuner.sweep import collect, run_sweep

    config = Path(__file__).resolve().parents[1] / "configs" / "pid_ms_tradeoff.yaml"
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        run_sweep(config, sweep_dir=Path(d) / "sw", jobs=2, quiet=True)
        wall = time.perf_counter() - t
        data = swept.data(SweepContext(Path(d) / "sw", collect(Path(d) / "sw")))
        shutil.copy(Path(d) / "sw" / "figures" / swept.FILE, results_dir / "pid_ms_tradeoff.png")
    (series,) = data["series"]
    rows = [[f"{x:g}", f"{y:.4g}"] for x, y in zip(series["mx"], series["my"])]
    return [f"`python -m tuner sweep configs/pid_ms_tradeoff.yaml` ({len(series['x'])} jobs, {wall:.0f} s wall on "
            "2 processes): the load IAE of the PID tuned on P1 n=4 (PSO 20 x 150) against the Ms limit it must meet, "
            "the median over seeds 1-3; the sweep report draws it (`tuner/plots/swept.py`).", "",
            md_table(["Ms limit", "median load IAE"], rows), "", "![IAE against the Ms limit](pid_ms_tradeoff.png)"]


def write_markdown(out: dict[str, Any], path: Path) -> Path:
    """``benchmarks/results/pid_benchmark.md``: the method (module docstring), the tables and the targets."""
    text = "# PID benchmark: tuner against the optimum and the rules at the limit\n\n" + \
        (__doc__ or "").split("\n\n", 1)[1] + "\n" + out["markdown"] + "\n\n## Targets\n\n" + \
        "\n".join(f"- {t['target']}: {t['value']} ({'pass' if t['pass'] else 'FAIL'})" for t in out["targets"]) + "\n"
    path.write_text(text)
    return path


if __name__ == "__main__":
    import sys

    print(run(smoke="--smoke" in sys.argv)["markdown"])
