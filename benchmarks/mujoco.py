"""MuJoCo plants: evaluation throughput and the share spent in MuJoCo; a balancing LQR over perturbed models.

``python -m benchmarks.run --full --only mujoco`` (needs the mujoco extra) writes ``benchmarks/results/mujoco.md``,
``mujoco.json`` and the figures ``mujoco_dip_*.png``; the wheeled-pendulum cross-check is
:mod:`benchmarks.mujoco_wmp` (its own page).

1. **Throughput.** The cart-pole of ``configs/examples/mujoco_cartpole_lqr.yaml`` (MJCF, 5 s at 500 Hz: 2500
   periods of one 2 ms MuJoCo step, LQR from MuJoCo's linearisation): evaluations per second serial (one call
   of the objective: LQR design, compiled loop, scoring) and through ``evaluate_batch`` on 1 and 2 threads
   (the ``backend: threads`` path) over a population of candidates, in wall time and per CPU second; the share
   of an evaluation spent in MuJoCo is the CPU time MuJoCo alone takes for the same trajectory
   (``mujoco.rollout`` of the recorded controls from the same initial state, one thread), divided by the
   serial evaluation's CPU time. The LQR design solves a
   small Riccati equation with LAPACK; the measurement runs in a child process with ``OPENBLAS_NUM_THREADS=1``
   (on a shared 2-core machine a multi-threaded BLAS makes those small solves many times slower), stated.
2. **A balancing LQR over perturbed models.** The double inverted pendulum on a cart of
   ``configs/examples/mujoco_dip_lqr.yaml``: Q tuned (R fixed) by PSO on the nominal model and the eight
   corners and eight samples of +-20 % on the cart's and both links' masses (robust), and the same tuning on
   the nominal model alone (nominal); both and the untuned default LQR (Q = I) are then run on 200 held-out
   models drawn apart (masses uniform in +-20 %, validate seed 1; the tuning samples from tune seed 0), 10 s
   from the lower link 0.1 rad off upright; a model passes when neither link leaves 0.5 rad of the one below.
   Target: robust pass rate >= 95 %. The tuning models are not among the held-out ones, so the held-out rate is
   not optimistic.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from benchmarks.common import RESULTS_DIR, fmt, md_table

__all__ = ["run", "throughput"]

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "configs" / "examples"


def _objective(name: str, **over: Any):
    from objectives.control.objective import ClosedLoopObjective

    section = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())["objective"]
    section.update(over)
    return ClosedLoopObjective.from_config(section, base_dir=EXAMPLES)


def throughput(n_candidates: int = 64, reps: int = 3) -> dict[str, Any]:
    """The cart-pole's evaluations per second and MuJoCo's share (module docstring), in this process."""
    import mujoco
    import mujoco.rollout

    obj = _objective("mujoco_cartpole_lqr")
    loop = obj.loop
    rng = np.random.default_rng(0)
    names = obj.decl.names()
    cands = [{k: float(10 ** rng.uniform(-1, 2)) for k in names} for _ in range(n_candidates)]
    obj(cands[0])  # compile, load caches
    obj.evaluate_batch(cands[:2], 2)
    clock = time.process_time  # CPU time of this process: the machine's other load does not enter it
    serial, serial_wall = [], []
    for _ in range(reps):
        t, w = clock(), time.perf_counter()
        evs = [obj(c) for c in cands]
        serial.append(clock() - t)
        serial_wall.append(time.perf_counter() - w)
    t_eval, t_eval_wall = min(serial) / n_candidates, min(serial_wall) / n_candidates
    t = clock()
    for c in cands:
        obj.coeffs(c)
    t_design = (clock() - t) / n_candidates
    cp = obj.coeffs(cands[0])
    data = loop._data(0)
    t_runs = []
    for _ in range(reps):
        t = clock()
        for _ in range(16):
            run = loop.run_case(cp, 0, data)
        t_runs.append((clock() - t) / 16)
    t_run = min(t_runs)
    p = loop.plant
    n = loop._sc.t.size
    ctrl = np.repeat(run["u"], p.n_sub, axis=0)[None, :, :]  # the recorded controls, per MuJoCo step
    d = p.new_data()
    p.reset_data(d, loop._sc.qpos_offset, loop._sc.qvel_offset)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(p.mj, spec))
    mujoco.mj_getState(p.mj, d, state0, spec)
    t_mj = []
    for _ in range(reps):
        t = clock()
        for _ in range(16):
            states, _ = mujoco.rollout.rollout(p.mj, d, state0[None, :], ctrl)
        t_mj.append((clock() - t) / 16)
    t_mujoco = min(t_mj)
    # the rollout's qpos after each period against the loop's outputs (the cart's and the pole's positions)
    same = float(np.max(np.abs(states[0, p.n_sub - 1::p.n_sub, 1:1 + p.mj.nq][:-1] - run["y"][1:, :])))
    threads, cpu = {}, {}
    for k in (1, 2):
        best, best_cpu = np.inf, np.inf
        for _ in range(reps):
            t, c = time.perf_counter(), time.process_time()
            got = obj.evaluate_batch(cands, k)
            best, best_cpu = min(best, time.perf_counter() - t), min(best_cpu, time.process_time() - c)
        assert all(a.fitness == b.fitness for a, b in zip(evs, got))
        threads[k], cpu[k] = n_candidates / best, n_candidates / best_cpu
    return {"periods": int(n), "mujoco_steps_per_eval": int(n * p.n_sub), "timestep_s": p.timestep_s,
            "serial_evals_per_s": 1.0 / t_eval_wall, "serial_evals_per_cpu_s": 1.0 / t_eval, "eval_s": t_eval,
            "design_s": t_design, "loop_s": t_run,
            "mujoco_alone_s": t_mujoco, "mujoco_share_of_eval": t_mujoco / t_eval,
            "mujoco_share_of_loop": t_mujoco / t_run, "rollout_vs_loop_max_diff": same,
            "threads_evals_per_s": {str(k): v for k, v in threads.items()},
            "threads_evals_per_cpu_s": {str(k): v for k, v in cpu.items()}, "candidates": n_candidates,
            "failed": sum(e.status != "ok" for e in evs), "load_avg": list(os.getloadavg())}


def _throughput_child(smoke: bool) -> dict[str, Any]:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    code = ("import json, sys; from benchmarks.mujoco import throughput; "
            f"print(json.dumps(throughput({8 if smoke else 64}, {1 if smoke else 3})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True,
                         check=True, timeout=1800)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _tune(name: str, over: dict[str, Any], pop: int, gens: int, n_jobs: int) -> dict[str, Any]:
    from tuner.config import config_from_dict
    from tuner.run import run as tuner_run

    raw = yaml.safe_load((EXAMPLES / f"{name}.yaml").read_text())
    raw["objective"].update(over)
    raw["optimizer"] = {"method": "pso", "population": pop, "generations": gens}
    raw["parallel"] = {"backend": "threads", "n_jobs": n_jobs}
    cfg = config_from_dict(raw, source=f"benchmarks/mujoco.py ({name})", base_dir=EXAMPLES)
    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        res = tuner_run(cfg, run_dir=Path(d) / "run", quiet=True, report=False)
        wall = time.perf_counter() - t
    return {"params": dict(res.best.params), "fitness": res.best_fitness, "wall_s": wall, "evals": pop * gens}


def _traces(obj: Any, params: dict[str, Any], n: int) -> list[np.ndarray]:
    """The two links' angles over time on the first ``n`` held-out models."""
    from objectives.control.plants.mujoco.batch import run_all

    loop = obj.loop
    cases = loop._unc.held_out_set()[:n]
    n = len(cases)  # a smoke run draws fewer held-out models than the figure shows
    plants = loop._held_plants[:n]
    runs = run_all(loop, [(loop.coeffs(params), j) for j in range(n)], 2, plants, cases)
    return [r["y"][: r["n_done"], 1:3] for r in runs]


def _figures(obj: Any, variants: dict[str, dict[str, Any]], held: dict[str, dict], out: Path) -> dict[str, str]:
    from objectives.control.figure import new_figure, save_figure

    t = obj.loop._sc.t
    fig = new_figure((9, 4.2))
    axs = fig.subplots(1, 2, sharey=True)
    for ax, label in zip(axs, ("nominal", "robust")):
        for tr in _traces(obj, variants[label], 60):
            ax.plot(t[: tr.shape[0]], tr[:, 0], color="tab:blue", lw=0.5, alpha=0.5)
            ax.plot(t[: tr.shape[0]], tr[:, 1], color="tab:red", lw=0.5, alpha=0.5)
        ax.axhline(0.5, color="k", ls=":", lw=0.8)
        ax.axhline(-0.5, color="k", ls=":", lw=0.8)
        ax.set_title(f"LQR tuned {label}: held-out pass rate {held[label]['pass_rate']:.1%}", fontsize=9)
        ax.set_xlabel("time (s)")
        ax.grid(True, alpha=0.3)
    axs[0].set_ylabel("hinge1 (blue), hinge2 (red) (rad)")
    fig.suptitle("double inverted pendulum, 60 of 200 held-out models (masses +-20 %), 0.1 rad start", fontsize=10)
    f1 = save_figure(fig, out / "mujoco_dip_traces.png")
    fig = new_figure((6, 3.4))
    ax = fig.subplots()
    for label, color in (("defaults", "tab:gray"), ("nominal", "tab:blue"), ("robust", "tab:red")):
        costs = np.sort(np.asarray(held[label]["costs"], dtype=float))  # a failed model (NaN) is left out
        ax.plot(np.arange(costs.size), costs, ".", ms=3, color=color,
                label=f"{label} (pass {held[label]['pass_rate']:.1%})")
    ax.set_yscale("log")
    ax.set_xlabel("held-out model (sorted)")
    ax.set_ylabel("cost (ISE + 1e-4 effort)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    f2 = save_figure(fig, out / "mujoco_dip_costs.png")
    return {"held-out traces": f1.name, "held-out costs": f2.name}


def robust_dip(smoke: bool, n_jobs: int, out: Path) -> dict[str, Any]:
    """Part 2 of the module docstring."""
    pop, gens = (4, 2) if smoke else (16, 10)
    held_n = 10 if smoke else 200
    unc = yaml.safe_load((EXAMPLES / "mujoco_dip_lqr.yaml").read_text())["objective"]["uncertainty"]
    robust = _tune("mujoco_dip_lqr", {}, pop, gens, n_jobs)
    nominal = _tune("mujoco_dip_lqr", {"uncertainty": None}, pop, gens, n_jobs)
    judge = _objective("mujoco_dip_lqr", uncertainty={**unc, "validate": {"samples": held_n, "seed": 1}})
    variants = {"defaults": {}, "nominal": nominal["params"], "robust": robust["params"]}
    held = {}
    for label, params in variants.items():
        from objectives.control.plants.mujoco.report import held_out_scores

        h = held_out_scores(judge.loop, params, n_jobs)
        held[label] = {"pass_rate": h.pass_rate, **h.stats(), "causes": h.causes(), "why": h.why,
                       "costs": [float(c) for c in h.costs]}
    figs = _figures(judge, variants, held, out)
    # beyond the tuning range: +-40 % masses and twice the start angle (how much margin each design keeps)
    stress_unc = {**unc, "validate": {"samples": held_n, "seed": 7},
                  "parameters": {k: {"rel": 0.4} for k in unc["parameters"]}}
    sc = yaml.safe_load((EXAMPLES / "mujoco_dip_lqr.yaml").read_text())["objective"]["scenario"]
    stress = _objective("mujoco_dip_lqr", uncertainty=stress_unc, scenario={**sc, "initial": {"hinge1": 0.2}})
    from objectives.control.plants.mujoco.report import held_out_scores

    beyond = {label: held_out_scores(stress.loop, params, n_jobs).pass_rate for label, params in variants.items()}
    return {"robust": robust, "nominal": nominal, "held_out": held, "figures": figs, "held_out_models": held_n,
            "tuning_models": len(_objective("mujoco_dip_lqr").loop.cases), "budget": f"PSO {pop} x {gens}",
            "stress_pass_rate": beyond}


def run(smoke: bool = False, n_jobs: int = 2, out_dir: Path | None = None, **_: Any) -> dict[str, Any]:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return {"results": {}, "targets": [], "markdown": "skipped: the mujoco extra is not installed"}
    out = Path(out_dir) if out_dir else (RESULTS_DIR if not smoke else Path(tempfile.mkdtemp()))
    tp = _throughput_child(smoke)
    dip = robust_dip(smoke, n_jobs, out)
    h = dip["held_out"]
    rows = [[k, fmt(v["pass_rate"] * 100, 4) + " %", fmt(v["cost_median"], 4), fmt(v["cost_p95"], 4),
             "; ".join(f"{n} x {c}" for c, n in v["causes"][:2]) or "-",
             fmt(dip["stress_pass_rate"][k] * 100, 4) + " %"] for k, v in h.items()]
    md = "\n".join([
        "### Throughput: MuJoCo cart-pole, 5 s at 500 Hz",
        "",
        f"One evaluation = LQR design + {tp['periods']} periods of the compiled loop ({tp['mujoco_steps_per_eval']} "
        f"MuJoCo steps of {tp['timestep_s']:g} s) + scoring; {tp['candidates']} candidates (log-uniform Q, R), "
        f"OPENBLAS_NUM_THREADS=1, load average at the end {', '.join(f'{x:.1f}' for x in tp['load_avg'])} on 2 "
        "shared cores: the wall-clock rates are what this process got of a machine other jobs kept busy (a second "
        "thread finds no free core), the CPU-time rates and shares are the process's own (on 2 idle cores the 2 "
        "threads' wall rate would be bounded by twice the rate per CPU second; not measured, the machine was not "
        "idle). The rollout follows the loop's trajectory exactly "
        f"(largest difference {tp['rollout_vs_loop_max_diff']:.1g}).",
        "",
        md_table(["measure", "value"], [
            ["evaluations / s, serial (one core)", fmt(tp["serial_evals_per_s"], 4)],
            ["evaluations per CPU second, serial", fmt(tp["serial_evals_per_cpu_s"], 4)],
            ["evaluations / s, backend threads, 1 thread", fmt(tp["threads_evals_per_s"]["1"], 4)],
            ["evaluations / s, backend threads, 2 threads", fmt(tp["threads_evals_per_s"]["2"], 4)],
            ["evaluations per CPU second, 1 and 2 threads",
             f"{fmt(tp['threads_evals_per_cpu_s']['1'], 4)}, {fmt(tp['threads_evals_per_cpu_s']['2'], 4)}"],
            ["one evaluation (CPU s)", fmt(tp["eval_s"], 4)],
            ["  LQR design (CPU s)", fmt(tp["design_s"], 4)],
            ["  compiled loop (CPU s)", fmt(tp["loop_s"], 4)],
            ["MuJoCo alone, same trajectory (mujoco.rollout, one thread) (CPU s)", fmt(tp["mujoco_alone_s"], 4)],
            ["share of an evaluation in MuJoCo", fmt(tp["mujoco_share_of_eval"] * 100, 3) + " %"],
            ["share of the compiled loop in MuJoCo", fmt(tp["mujoco_share_of_loop"] * 100, 3) + " %"],
        ]),
        "",
        "### A balancing LQR over perturbed models: double inverted pendulum on a cart",
        "",
        f"Q tuned by {dip['budget']} ({dip['robust']['evals']} evaluations each): robust on {dip['tuning_models']} "
        f"models (nominal, 8 corners, 8 samples of +-20 % on the three masses), nominal on the nominal model alone; "
        f"scored on {dip['held_out_models']} held-out models drawn apart (uniform +-20 % on the three masses), "
        "10 s from 0.1 rad; a model passes when neither link leaves 0.5 rad of the one below. Wall time of the "
        f"tunings {fmt(dip['robust']['wall_s'], 3)} s (robust), {fmt(dip['nominal']['wall_s'], 3)} s (nominal).",
        "",
        md_table(["LQR", "held-out pass rate", "cost median", "cost 95th pct", "failures",
                  "beyond: +-40 %, 0.2 rad"], rows),
        "",
        "The last column is outside what the robust design was tuned for (another seed, masses +-40 %, the lower "
        "link 0.2 rad off upright): how much margin each design keeps.",
        "",
        "![held-out traces](mujoco_dip_traces.png)",
        "",
        "![held-out costs](mujoco_dip_costs.png)",
    ])
    targets = [{"target": "robust LQR upright 10 s on held-out +-20 % masses >= 95 %",
                "value": f"{h['robust']['pass_rate']:.1%}", "pass": h["robust"]["pass_rate"] >= 0.95},
               {"target": "MuJoCo cart-pole evaluation (5 s at 500 Hz) stated in evaluations/s on 2 cores",
                "value": f"{tp['threads_evals_per_s']['2']:.0f} /s, {tp['mujoco_share_of_eval']:.0%} in MuJoCo",
                "pass": True}]
    if not smoke:
        (out / "mujoco.md").write_text("# MuJoCo plants\n\n" + (__doc__ or "").split("\n\n", 1)[1] + "\n" + md + "\n")
    for v in h.values():
        v.pop("why", None)
    return {"results": {"throughput": tp, "dip": dip}, "targets": targets, "markdown": md,
            "figures": {k: v for k, v in dip["figures"].items()}}


if __name__ == "__main__":  # python -m benchmarks.mujoco [--smoke]: this page alone (SUMMARY.md untouched)
    from benchmarks.common import run_alone

    run_alone("mujoco", run)
