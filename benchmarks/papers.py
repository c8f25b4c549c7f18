"""Reproduce the seeds' headline claims from the configs in ``configs/papers/`` and write ``docs/papers.md``.

Each claim is measured either at the paper's own parameter values (the config's defaults, scored on
its held-out recordings: no tuning involved) or by a tuning run of the config at a reduced budget
(``--set optimizer.population=... optimizer.generations=...``) in a run directory under
``runs/papers/``. F at the thesis's initial parameters and the thesis-size PSO (150 x 150) of the
protective fuzzy scheme are measured here; the four-controller comparison is quoted from
``docs/control-cost.md`` (a 40 x 40 sweep of four controllers).

    python -m benchmarks.papers            # about 11 minutes on 2 cores, writes docs/papers.md
    python -m benchmarks.papers --smoke    # tiny budgets, for the tests
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
PAPERS = ROOT / "configs" / "papers"


@dataclass
class Row:
    """One line of docs/papers.md: a claim, the paper's number, ours, the verdict and the command."""

    claim: str
    paper: str
    ours: str
    verdict: str
    command: str


def default_score(config: str, which: str = "test") -> float:
    """Fitness of a paper config's default parameters (the paper's values) on one split."""
    from tuner.config import load_config
    from tuner.run import _build

    objective, _ = _build(load_config(PAPERS / config, n_jobs=1))
    params = objective.default_params()
    if not hasattr(objective, "score"):  # single-scenario objectives (closed loop): the evaluation itself
        ev = objective(params)
        if ev.status != "ok":
            raise ValueError(f"{config}: defaults could not be evaluated: {ev.error}")
        return float(ev.fitness)
    score = objective.score(params, which)
    if not score.ok:
        raise ValueError(f"{config}: defaults could not be scored on {which!r}: {score.failed}")
    return float(score.fitness)


def tuned(config: str, population: int | None, generations: int | None, out: Path, sets: tuple[str, ...] = (),
          tag: str = "", max_evals: int | None = None) -> dict:
    """Run ``config`` into ``out/<stem><tag>`` at a PSO budget (``population`` x ``generations``) or, with
    ``max_evals``, at that many evaluations of the config's own method (plus ``--set`` overrides ``sets``);
    return its best.yaml."""
    run_dir = out / (Path(config).stem + tag)
    if run_dir.exists():  # runs/papers/ belongs to this script: each call measures afresh
        shutil.rmtree(run_dir)
    cmd = [sys.executable, "-m", "tuner", "run", str(PAPERS / config), "-q", "--run-dir", str(run_dir)]
    if max_evals is not None:
        cmd += ["--set", f"optimizer.max_evals={max_evals}"]
    else:
        cmd += ["--set", f"optimizer.population={population}", "--set", f"optimizer.generations={generations}"]
    for kv in sets:
        cmd += ["--set", kv]
    subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    return yaml.safe_load((run_dir / "best.yaml").read_text())


def qraukf_rows() -> list[Row]:
    """Chiella 2019, Tables 1-2: QRAUKF vs QUKF at the paper's values (no tuning)."""
    u, r = default_score("qukf_chiella.yaml"), default_score("qraukf_chiella.yaml")
    ratio = u / r
    ok = 7.0 / 3.0 <= ratio <= 7.0 * 3.0
    return [Row("QRAUKF beats the QUKF under slow magnetic disturbances and linear accelerations "
                "(mean total RMSE, held-out 40 Hz recordings, paper's Q/R, untuned)",
                "QUKF/QRAUKF about 7x (heading 13.0 vs 1.84 deg; 2.36 vs 0.16 deg)",
                f"{u:.2f} vs {r:.2f} deg: {ratio:.1f}x",
                "reproduces (within 3x of 7x)" if ok else f"ratio {ratio:.1f}x outside 2.3-21x",
                "python -m benchmarks.papers  (default_score of configs/papers/q*ukf_chiella.yaml)")]


#: rad^2 -> deg^2: eq. 3.18 in the thesis's degrees (Table 3.6), our mse_1d in rad^2
DEG2 = (180.0 / 3.141592653589793) ** 2


#: searched initial bias variance of the KF family (thesis 3.1.3.1 fixes P0 = 0; docs/tilt-bench.md section 4),
#: with the filters' own ranges of rho, q00, q11 (a config without ``parameters`` searches those by default)
TILT_P0 = {
    "thesis_kf1d.yaml": ("parameters.rho={low: 0.008, high: 0.45, scale: log}",
                         "parameters.q00={low: 7.0e-9, high: 2.0e-6, scale: log}",
                         "parameters.q11={low: 1.0e-13, high: 2.0e-8, scale: log}"),
    "thesis_akf1d.yaml": ("parameters.rho={low: 0.005, high: 0.43, scale: log}",
                          "parameters.q00={low: 1.0e-8, high: 8.0e-7, scale: log}",
                          "parameters.q11={low: 1.0e-12, high: 5.0e-11, scale: log}"),
    "thesis_akf1d_fuzzy.yaml": (),
}
P0_BIAS = "parameters.p0_bias={low: 1.0e-8, high: 1.0e-2, scale: log}"


def _tilt_ordering(ev: dict) -> tuple[str, str]:
    """``(ours, verdict)`` of held-out evaluations ``{label: best.yaml evaluation}``: mean MSE in deg^2,
    ranked, and the best filter of each held-out recording."""
    test = {k: e["test_fitness"] * DEG2 for k, e in ev.items()}
    per = {k: [m["mse_1d"] * DEG2 for m in e["test"].values()] for k, e in ev.items()}
    n_rec = len(next(iter(per.values())))
    wins = [min(per, key=lambda k, i=i: per[k][i]) for i in range(n_rec)]
    order = sorted(test, key=test.get)
    ours = " < ".join(f"{k} {test[k]:.3f}" for k in order) + "; best per recording: " + ", ".join(wins)
    verdict = "reproduces" if order[0].startswith("AKF") else f"deviates: {order[0]} best (docs/tilt-bench.md)"
    return ours, verdict


def tilt_rows(pop: int, gen: int, out: Path) -> list[Row]:
    """Thesis 3.1, Tables 3.1-3.6: ordering of the tuned tilt estimators on the four held-out recordings
    (MSE of eq. 3.18 in deg^2, as Table 3.6), as the thesis tunes them (P0 = 0) and with the KF family's
    initial bias variance searched (docs/tilt-bench.md)."""
    names = {"KF": "thesis_kf1d.yaml", "AKF": "thesis_akf1d.yaml", "AKF+fuzzy": "thesis_akf1d_fuzzy.yaml",
             "Mahony": "thesis_mahony1d.yaml", "Madgwick": "thesis_madgwick1d.yaml"}
    ev = {k: tuned(v, pop, gen, out)["evaluation"] for k, v in names.items()}
    ev_p0 = {**{k: e for k, e in ev.items() if k in ("Mahony", "Madgwick")},
             **{k: tuned(v, pop, gen, out, TILT_P0[v] + (P0_BIAS,), "_p0")["evaluation"]
                for k, v in names.items() if v in TILT_P0}}
    paper = ("AKF < KF ~ Mahony < Madgwick; AKF best on all 4 (Table 3.6: AKF 1.43-2.26, KF 1.55-2.64, "
             "Mahony 1.58-2.33, Madgwick 2.12-4.10)")
    cmd = (f"python -m tuner run configs/papers/thesis_<f>.yaml --set optimizer.population={pop} "
           f"--set optimizer.generations={gen}")
    ours, verdict = _tilt_ordering(ev)
    ours_p0, verdict_p0 = _tilt_ordering(ev_p0)
    return [Row(f"The adaptive KF is the best tilt estimator (held-out MSE deg^2, mean of 4 recordings, "
                f"PSO {pop} x {gen} each, P0 = 0 as in the thesis)", paper, ours, verdict, cmd),
            Row(f"The same with the KF family's initial bias variance p0_bias searched (PSO {pop} x {gen})",
                paper, ours_p0, verdict_p0,
                cmd + " --set 'parameters.p0_bias={low: 1.0e-8, high: 1.0e-2, scale: log}' (+ rho, q00, q11 ranges)")]


def faekf_rows(pop: int, gen: int, out: Path) -> list[Row]:
    """FAEKF paper, section 5.2: the tuned FAEKF beats the tuned EKF on held-out bench recordings."""
    ekf = tuned("ekf_bench6dof.yaml", pop, gen, out)["evaluation"]["test_fitness"]
    fa = tuned("faekf_bench6dof.yaml", pop, gen, out)["evaluation"]["test_fitness"]
    gain = 100.0 * (1.0 - fa / ekf)
    return [Row(f"The tuned FAEKF beats the tuned EKF (held-out Euler MSE, geometric mean, PSO {pop} x {gen})",
                "52-87 % lower error", f"EKF {ekf:.3g}, FAEKF {fa:.3g}: {gain:.0f} % lower",
                "reproduces" if 52.0 <= gain else ("same direction, smaller" if gain > 0 else "deviates"),
                f"python -m tuner run configs/papers/{{ekf,faekf}}_bench6dof.yaml --set optimizer.population={pop} "
                f"--set optimizer.generations={gen}")]


#: evaluations per CCF/NCF tuning (the configs' own budget: 300, as PSO 20 x 15 before)
CCF_EVALS = 300
#: the seed's reading of eq. (14): alpha a per-sample weight fed back into the state (50 Hz data)
CCF_PER_SAMPLE = ("objective.fixed.alpha_mode=per_sample", "objective.fixed.alpha_rate_hz=50.0",
                  "parameters.alpha.low=0.5", "parameters.alpha.high=0.9999")
#: the rate-independent time-constant form (alpha_mode: tau): tau_s searched on a log scale, alpha unused
CCF_TAU = ("objective.fixed.alpha_mode=tau", "parameters.alpha={fixed: 0.7}",
           "parameters.tau_s={low: 0.02, high: 100.0, scale: log}")


def ccf_rows(evals: int, out: Path) -> list[Row]:
    """Narkhede 2021, Tables 1-3: the tuned CCF is no worse than the tuned NCF (held-out, 50 Hz).

    ``configs/papers/ccf_narkhede.yaml`` is eq. (14) as written (``alpha_mode: static``, the weight of
    eq. (15)); the seed's per-sample reading and the time-constant form are measured alongside with the
    same data and the same evaluation budget of the configs' method (``auto``).
    """
    best = {f: tuned(f"{f}_narkhede.yaml", None, None, out, max_evals=evals) for f in ("ccf", "ncf")}
    best["ccf_per_sample"] = tuned("ccf_narkhede.yaml", None, None, out, CCF_PER_SAMPLE, "_per_sample", evals)
    best["ccf_tau"] = tuned("ccf_narkhede.yaml", None, None, out, CCF_TAU, "_tau", evals)
    c, n, cs, ct = (best[f]["evaluation"]["test_fitness"] for f in ("ccf", "ncf", "ccf_per_sample", "ccf_tau"))
    alpha, alpha_s = best["ccf"]["params"]["alpha"], best["ccf_per_sample"]["params"]["alpha"]
    tau, kp_tau = best["ccf_tau"]["params"]["tau_s"], best["ccf_tau"]["params"]["Kp"]
    verdict = "CCF no worse" if c <= n * 1.01 else f"CCF {100 * (c / n - 1):.1f} % worse"
    c0, n0 = default_score("ccf_narkhede.yaml"), default_score("ncf_narkhede.yaml")
    budget = f"{evals} evaluations of `auto` each"
    return [Row("At the paper's values (alpha 0.7, Kp 25, Ki 0.1; Table 3) the CCF beats the NCF (held-out RMSE, deg)",
                "CCF lowest RMSE on all 8 datasets", f"CCF {c0:.2f} vs NCF {n0:.2f}",
                "CCF no worse" if c0 <= n0 * 1.01 else f"CCF {100 * (c0 / n0 - 1):.1f} % worse",
                "python -m benchmarks.papers (default_score of configs/papers/{ccf,ncf}_narkhede.yaml)"),
            Row(f"The CCF (eq. 14 as written) is more accurate than the NCF (held-out total RMSE, deg, {budget})",
                "CCF lowest RMSE on all 8 datasets",
                f"CCF {c:.3f} (alpha {alpha:.4f}) vs NCF {n:.3f}; per-sample alpha (seed's reading) {cs:.3f} "
                f"(alpha {alpha_s:.4f})",
                verdict + ("" if cs <= n * 1.01 else f"; per-sample reading {100 * (cs / n - 1):.1f} % worse"),
                "python -m tuner run configs/papers/{ccf,ncf}_narkhede.yaml"),
            Row(f"The CCF with the time-constant blend (alpha_mode tau, issue 12) against the NCF (held-out, {budget})",
                "-", f"CCF {ct:.3f} (tau {tau:.3g} s, Kp {kp_tau:.3g} 1/s) vs NCF {n:.3f}",
                "CCF no worse" if ct <= n * 1.01 else f"CCF {100 * (ct / n - 1):.1f} % worse",
                "python -m tuner run configs/papers/ccf_narkhede.yaml --set objective.fixed.alpha_mode=tau "
                "--set 'parameters.alpha={fixed: 0.7}' --set 'parameters.tau_s={low: 0.02, high: 100.0, scale: log}'")]


#: upper bound of the yaw gain u3 (V/s) in the box-sensitivity row: just above Table 2.7's optimised 2.398
U3_BOX = 3.0

#: terms of eq. 2.39 and the thesis's improvements of each after tuning (section 2.3.4)
F_TERMS = (("mae_nu", "speed", 13.0), ("mae_xi", "yaw rate", 59.0), ("mae_omega3", "IB rate", 36.0))


def control_rows(pop: int, gen: int, out: Path) -> list[Row]:
    """Thesis ch. 2: F at Table 2.7's initial parameters and the thesis-size PSO (measured), the tuned
    comparison of four controllers (quoted: a 40 x 40 sweep of four controllers)."""
    f0 = default_score("wmp_fuzzy_protective.yaml", "train")
    best = tuned("wmp_fuzzy_protective.yaml", pop, gen, out)
    ev = best["evaluation"]
    f_init, f_best = ev["initial_fitness"], ev["best_fitness"]
    gain = 100.0 * (1.0 - f_best / f_init)
    m_best = best["metrics"]
    m_init = _initial_metrics("wmp_fuzzy_protective.yaml")
    terms = ", ".join(f"{label} {100 * (1 - m_best[k] / m_init[k]):.0f} % (thesis {t:.0f} %)"
                      for k, label, t in F_TERMS)
    # the same PSO with only the yaw gain's box changed: just above Table 2.7's optimised u3 = 2.398
    boxed = tuned("wmp_fuzzy_protective.yaml", pop, gen, out, sets=(f"parameters.u3={{low: 0.1, high: {U3_BOX}}}",),
                  tag="-u3box")
    f_boxed = boxed["evaluation"]["best_fitness"]
    gain_boxed = 100.0 * (1.0 - f_boxed / f_init)
    return [
        Row("Eq. 2.39 at Table 2.7's initial parameters (SI units, thesis_2s profile)", "0.1049",
            f"{f0:.4f} ({100 * (f0 / 0.1049 - 1):+.1f} %)",
            "within 5 %" if abs(f0 / 0.1049 - 1) <= 0.05 else "outside 5 % (docs/control-cost.md section 3)",
            "python -m benchmarks.papers (default_score of configs/papers/wmp_fuzzy_protective.yaml)"),
        Row(f"PSO {pop} x {gen} improves F of the protective fuzzy scheme", "0.1049 -> 0.0558 (-46.8 %)",
            f"{f_init:.4f} -> {f_best:.4f} ({-gain:.1f} %); MAE terms: {terms}",
            "within 40-55 %" if 40.0 <= gain <= 55.0 else
            ("larger improvement than the thesis (docs/control-cost.md section 3)" if gain > 55.0 else "smaller"),
            f"python -m tuner run configs/papers/wmp_fuzzy_protective.yaml --set optimizer.population={pop} "
            f"--set optimizer.generations={gen}"),
        Row(f"The same PSO with the yaw gain u3 bounded at {U3_BOX} V/s instead of 10 (the thesis gives no FLC "
            "bounds; Table 2.7: u3 1.5 -> 2.398)", "0.1049 -> 0.0558 (-46.8 %)",
            f"{f_init:.4f} -> {f_boxed:.4f} ({-gain_boxed:.1f} %; F_opt {100 * (f_boxed / 0.0558 - 1):+.1f} % "
            f"from the thesis's), u3 = {boxed['params']['u3']:.3f}",
            "within 40-55 %: the excess improvement of the row above is the yaw gain's box "
            "(docs/control-cost.md section 3)" if 40.0 <= gain_boxed <= 55.0 else "outside 40-55 %",
            f"python -m tuner run configs/papers/wmp_fuzzy_protective.yaml --set optimizer.population={pop} "
            f"--set optimizer.generations={gen} --set 'parameters.u3={{low: 0.1, high: {U3_BOX}}}'"),
        Row("Tuned fuzzy beats tuned PID on F and both peaks, same requirements (quoted, 40 x 40, seed 1)",
            "IB 46.8 vs 56.8 deg, current 0.32 vs 0.54 A",
            "F 0.0491 vs 0.0629; IB 29.4 vs 31.0 deg; current 0.230 vs 0.180 A",
            "partly: F and IB peak yes, current peak no (docs/control-cost.md section 6)",
            "python -m tuner sweep configs/papers/wmp_compare.yaml  (~5 min)"),
    ]


def _initial_metrics(config: str) -> dict:
    """Metrics of a closed-loop paper config at its initial (Table 2.7) parameters."""
    from tuner.config import load_config
    from tuner.run import _build

    objective, _ = _build(load_config(PAPERS / config, n_jobs=1))
    return dict(objective(objective.default_params()).metrics)


def write(rows: list[Row], path: Path, seconds: float, notes: str) -> None:
    """Write the claims table and the deviations to ``path``."""
    head = ("# The seeds' headline claims, reproduced\n\nGenerated by `make papers` "
            f"(`python -m benchmarks.papers`, {seconds:.0f} s on this machine). Configs: `configs/papers/`.\n\n"
            "| claim | paper | ours | verdict | command |\n|---|---|---|---|---|\n")
    body = "".join(f"| {r.claim} | {r.paper} | {r.ours} | {r.verdict} | `{r.command}` |\n" for r in rows)
    path.write_text(head + body + "\n" + notes)


NOTES = """## Deviations and open points

- **QRAUKF/QUKF.** The paper's recordings are 40 Hz robot-arm runs; ours are the synthetic 6-DOF
  bench at 40 Hz without vibration, with magnetic perturbations of 0.1-0.5 earth field or linear
  accelerations up to 0.5 g (the configs' header). With the bench's default 0.5-5 earth-field
  perturbations (the FAEKF paper's range) the same untuned filters give QUKF 28.9 vs QRAUKF 0.16 deg
  (175x, 40 Hz; 73x at 1 kHz): the QUKF follows a field several times the earth's, while the Hampel
  identifier rejects such gross outliers outright. The 80-300x of issue 14 came from that setting,
  not from the QUKF's parameters (which are the paper's). Measured by hand, two seeds each, 120 s:
  magnetic 0.1-0.5: 2.48 vs 0.27 deg (9.2x at 40 Hz, 6.1x at 1 kHz); acceleration 0.5 g: 3.08 vs
  0.52 deg (5.9x; 4.1x at 1 kHz). Tuned at a small budget (PSO 10 x 6), the QUKF's R alone brings
  it to 1.46 deg on the held-out pair, the QRAUKF to 0.33 deg (4.4x).
- **CCF (Narkhede 2021): alpha.** Eq. (14) defines the CCF in continuous time as a static mix,
  x_hat = alpha x_int + (1 - alpha) x_a, where x_int integrates the gyro rates plus the PI of eq. (12)
  on x_a - x_hat; eq. (15) is its transfer function (denominator s^2 + alpha Kp s + alpha Ki and a
  direct feed-through 1 - alpha of x_a). The seed's implementation fed the blend back into the
  state every sample (eq. (8) discretised), which makes alpha a per-sample weight whose time
  constant depends on the unstated sampling rate. `alpha_mode: static` is eq. (14) as written
  (alpha dimensionless, rate-independent); the paper config uses it over the paper's alpha range
  [0, 1] (alpha = 1 is the NCF bit for bit); `per_sample` (default, bit-identical to the seed's
  kernel, digest test) and `tau` (the recursive blend by its time constant tau_s of eq. (9),
  alpha = tau / (tau + dt), with the Kp step taken exactly, 1 - exp(-Kp dt): the same filter at
  every rate and bounded at any gain, issue 12) stay selectable.
- **CCF vs NCF, measured** (held-out total RMSE, deg; 300 evaluations of `auto` each, which is
  CMA-ES for 2-3 parameters at that budget; seeds 1-5). NCF 2.4357 on every seed (Kp 0.208,
  Ki 0.0099). Eq. (14): 2.4263-2.4273 (alpha 0.986, Kp 0.207), 0.35 % below the NCF on every seed;
  time-constant form 2.398-2.402 (tau 4.9-5.6 s, Kp 0.012-0.032), 1.5 % below; per-sample reading
  2.387-2.411 (alpha 0.996-0.998 at 50 Hz, i.e. tau = alpha dt / (1 - alpha) of about 5 s, the same
  filter as the time-constant form), 1.0-2.0 % below. The CCF's training error is below the NCF's on
  every seed (2.7918 vs 2.8033), as it must be: alpha = 1 is the NCF. With the PSO 20 x 15 these configs
  used before (the same 300 evaluations) the 3-D search missed the narrow ridge near alpha = 1 on some
  seeds: eq. (14) 2.433 / 2.539 / 2.442 on seeds 1-3 (2.4 % worse than the NCF on training data at seed
  2) and the per-sample reading 2.528, which is why the CCF had looked worse; the optimiser, not the
  filter, was the cause. So the paper's cascade brings a real but small gain on our disturbed
  synthetic bench (0.35-2 %), nothing like Tables 1-2. At the paper's values (alpha 0.7, Kp 25,
  Ki 0.1) eq. (14) puts the CCF 3.7 % below the NCF (16.90 vs 17.55 deg; the per-sample reading is
  1.8 % above, 17.87), but both follow every disturbance there (Kp = 25 1/s trusts the accelerometer
  and magnetometer within 40 ms), seven times the tuned error. The paper also tunes Kp, Ki and
  alpha per axis (Table 3); ours share them.
- **Tilt bench** (docs/tilt-bench.md). MSEs are deg^2 as eq. 3.18 and Table 3.6 (`mse_1d` x 3282.8;
  the former 1e-3 rad^2 were 1.5-2.2 deg^2). The configs run the bench's `thesis` profile, checked
  against 3.1.2: a 350 s training recording and four held-out ones of 120/170/155/150 s, oscillation
  below 6.5 Hz, rate below 800 deg/s, plate acceleration below 1.5 g, gyro drift 14 deg / 100 s and 41 deg
  / 300 s (thesis: about 15 and 40), the sensor 2 cm above the axle so that vibration spoils the
  accelerometer tilt as 3.1.2.2 says (MSE 160-230 deg^2 vibrating, 540-770 accelerating, 2-5 at rest;
  alpha_hat of eq. 3.22 up to 0.36-0.44 g, thesis about 0.35 g), a start at rest. "AKF" keeps the
  project's fixed fuzzy system (K1..K5 = 1, 3, 10, 30, 100; input ranges 6.5 Hz and 0.35 g); "AKF+fuzzy"
  (`configs/papers/thesis_akf1d_fuzzy.yaml`) searches the input ranges and K1..K5 with rho, q00, q11
  (Fig. 3.9, the thesis's sets, is missing from the text). Budgets are reduced (PSO 20 x 15 each;
  thesis 30 x 30 / 20 x 20 / 10 x 10). Measured over seeds 1-3: with P0 = 0 as in the thesis, Mahony is
  best on every held-out recording (0.25 deg^2; KF 0.42-0.55, AKF 0.72-0.74, AKF+fuzzy 0.72-0.87,
  Madgwick 0.80), because the KF family starts certain of a zero gyro bias and its slow tuned filters
  learn the 0.14 deg/s bias over tens of seconds: 67-86 % of their held-out squared error falls in the
  first 60 s. With an initial bias variance searched, the KF family leads (KF 0.13-0.16, AKF 0.18-0.22,
  AKF+fuzzy 0.09-0.21 against Mahony 0.25), and AKF+fuzzy is best at one seed of three (0.088, 41 %
  below the KF). The fuzzy scale misjudges horizontal acceleration (eq. 3.22 is second order in it:
  K 3.4 in accelerating phases against 12.1 in vibrating ones, where the accelerometer error is 24 deg
  RMS against 13), and the searched fuzzy system fits the training recording (-35 to -64 % against the
  KF) more than it carries over. Our MSEs are 3-10 times below Table 3.6's.
- **Thesis ch. 2 (pendulum).** F_init = 0.1122 (+6.9 %). No reading of the text closes the gap
  (docs/control-cost.md section 3): the units, sensor noise (0.1120 with ideal sensors), the gyro
  instead of the true IB rate, the current per motor (0.1123) and the integration step (0.1122 at
  0.25 ms) move F by 0.2 % at most. Only the profile's timing moves it: Table 2.5's time-weighted
  integrals fit step spacings of 1.94-2.08 s equally well, over which F_init spans 0.1092-0.1145
  (+4.1 to +9.2 %; we use the round 2 s), and the run length after the last step is not stated
  (8.5 s instead of 8 s: 0.1056, within 5 %). Nothing supports one value over another, and the model's own limits
  show elsewhere: Table 2.5's absolute error integrals are not reproduced (SAE of the speed error of
  the section 2.2 fuzzy design 79 vs 30.5, of the IB rate 3-4x), and the thesis's tuned parameters
  improve F by 40 % on our model for every run length (thesis 46.8 %). The PSO (150 x 150, 22,500
  simulations) improves F by 57.3 %: it improves every term of eq. 2.39 more than the thesis's tuned
  controller did (speed MAE -32 % vs -13 %, yaw -73 % vs -59 %, IB rate -59 % vs -36 %) and ends
  with the IB-rate universe d21 and the yaw gain u3 at our search bounds (993 of 1000 deg/s, 9.90 of
  10 V/s; the thesis states no FLC bounds). The excess is the yaw gain's box: the same PSO with u3
  bounded at 3 V/s (just above Table 2.7's optimised 2.398), nothing else changed, improves F by
  51 % and ends within 2 % of the thesis's F_opt = 0.0558 (next row of the table); wider boxes than
  ours give 58.9 %. Which box the thesis searched is not in the text, so the configs keep ours.
- **Verdicts at the committed budgets (seeded, so `make papers` repeats them).** QRAUKF/QUKF 6.9x
  (target within 3x of 7x: met). CCF vs NCF: met on seeds 1-5 for all three
  readings (eq. (14) 0.35 %, the time-constant form 1.5 % below the NCF at the committed seed).
  Tilt (thesis profile, deg^2): with P0 = 0 tuned Mahony stays best (0.25; KF 0.55, AKF 0.73,
  AKF+fuzzy 0.78 at seed 1): target "AKF best" not met, explained by the KF's start with P0 = 0; with
  the initial bias variance searched the KF family leads and AKF+fuzzy is best at one seed of three
  (docs/tilt-bench.md). FAEKF vs EKF -73 % (paper 52-87 %: met; -56 % while K1 was searched too).
  F_init +6.9 % (target 5 %: not met) and PSO -57.3 % in our search box (target 40-55 %: not met;
  -51 % with the yaw gain bounded just above the thesis's optimum), both explained above.
- **Control.** F_init and the 150 x 150 PSO are measured by `make papers`; the four-controller
  comparison is quoted from docs/control-cost.md, not rerun here.
"""


def main(argv: list[str] | None = None) -> int:
    """Command line: measure every claim and write docs/papers.md (``--out`` for another path)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="tiny budgets (tests)")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "papers.md")
    ap.add_argument("--runs", type=Path, default=ROOT / "runs" / "papers")
    args = ap.parse_args(argv)
    pop, gen = (4, 2) if args.smoke else (20, 15)
    thesis_pso = (4, 2) if args.smoke else (150, 150)  # section 2.3.3.3: n_pop = n_gen = 150
    t0 = time.perf_counter()
    rows = (qraukf_rows() + control_rows(*thesis_pso, args.runs) + ccf_rows(8 if args.smoke else CCF_EVALS, args.runs)
            + tilt_rows(pop, gen, args.runs) + faekf_rows(pop, gen, args.runs))
    write(rows, args.out, time.perf_counter() - t0, NOTES)
    print(args.out.read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
