"""The thesis's 1-D tilt bench (Odry 2020, 3.1.2) measured, and the tuned tilt filters' errors by condition.

Two tables for ``docs/tilt-bench.md``:

- :func:`bench_stats` of each recording of ``configs/papers/thesis_*.yaml`` (and of the bench's first
  default recordings): the quantities 3.1.2.2 and Fig. 3.11 characterise the thesis's measurements by
  (oscillation frequency, angular velocity, external acceleration, gyro drift, the accelerometer
  tilt's error);
- :func:`condition_errors`: the tuned filters of ``runs/tilt/<filter>_s<seed>`` (written by
  ``python -m tuner run configs/papers/thesis_<filter>.yaml --run-dir ...``) rerun on the held-out
  recordings, their squared tilt error (eq. 3.18, deg^2) split by recording and by the bench's phase
  (static, calm, vibrating, accelerating, vibrating+accelerating), with the adaptive KF's fuzzy
  scale ``K`` per phase.

    python -m benchmarks.tilt_bench stats
    python -m benchmarks.tilt_bench errors --runs runs/tilt --seeds 1 2 3
    python -m benchmarks.tilt_bench explain --runs runs/tilt --seeds 1 2 3
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
PAPERS = ROOT / "configs" / "papers"
#: phase codes of the tilt bench (objectives.attitude.data.bench_common.PHASES) and their short names
PHASE_NAMES = {0: "static", 1: "calm", 2: "vibrating", 3: "accelerating", 5: "vib+acc"}
FILTERS = ("kf1d", "akf1d", "akf1d_fuzzy", "mahony1d", "madgwick1d")
DEG2 = math.degrees(1.0) ** 2  # rad^2 -> deg^2


def accelerometer_tilt(rec) -> np.ndarray:
    """Eq. 3.6 in the bench's axes: ``atan2(acc_x, -acc_z)`` (NED) or ``atan2(-acc_x, acc_z)`` (ENU), rad."""
    s = -1.0 if rec.frame.upper() == "NED" else 1.0
    return np.arctan2(-s * rec.acc[:, 0], s * rec.acc[:, 2])


def gyro_drift_deg(rec, t_s: float) -> float:
    """Angle error of the integrated gyro (``gyr[:, 1]``, started at the true angle) after ``t_s`` s, deg;
    NaN if the recording is shorter."""
    k = int(round(t_s / rec.dt))
    if k >= rec.n:
        return float("nan")
    err = np.cumsum(rec.gyr[:-1, 1] - rec.extra["true_gyr"][:-1, 1]) * rec.dt
    return float(math.degrees(err[k - 1]))


def bench_stats(rec, window: int = 400) -> dict:
    """What 3.1.2.2 and Fig. 3.11 state about a measurement, for one tilt-bench recording.

    Returns
    -------
    dict
        ``duration_s``; ``osc_share`` (share of samples oscillating), ``f_max_hz`` (true oscillation
        frequency), ``fhat_max_hz`` and ``fhat_share`` (eq. 3.21 estimate: max and share nonzero);
        ``rate_max_dps``, ``rate_share_10dps`` (share with |rate| > 10 deg/s), ``rate_p80_dps``;
        ``ext_max_g`` (the plate's horizontal acceleration, without the lever arm's), ``ext_share``
        (share > 0.01 g), ``ext_p80_g`` (80th percentile where applied); ``ahat_max_g`` (eq. 3.22);
        ``drift100_deg``, ``drift300_deg``; ``acc_mse_deg2`` and per phase ``acc_mse_<phase>``
        (eq. 3.6's error); ``acc_sat_share`` (samples at the accelerometer's range).
    """
    from objectives.attitude import disturbance as dis

    g = 9.81
    rate = np.abs(rec.extra["true_gyr"][:, 1])
    plate = rec.extra["true_ext_acc"] - rec.extra.get("lever_acc", 0.0)
    ext = np.abs(plate[:, 0]) / g
    f = rec.extra["vib_freq_hz"]
    phase = rec.extra["phase"].astype(int)
    fhat = dis.vibration_frequency(rec.gyr, rec.dt, window, 512, math.radians(10.0), axis=1, f_thr=8.0)
    ahat = dis.external_acceleration(rec.acc, window)
    err2 = (accelerometer_tilt(rec) - rec.extra["angle"]) ** 2 * DEG2
    applied = ext > 0.01
    out = {
        "duration_s": rec.n * rec.dt,
        "osc_share": float(np.mean(f > 0)), "f_max_hz": float(f.max()),
        "fhat_max_hz": float(fhat.max()), "fhat_share": float(np.mean(fhat > 0)),
        "rate_max_dps": float(np.degrees(rate.max())), "rate_share_10dps": float(np.mean(rate > math.radians(10))),
        "rate_p80_dps": float(np.degrees(np.percentile(rate, 80))),
        "ext_max_g": float(ext.max()), "ext_share": float(np.mean(applied)),
        "ext_p80_g": float(np.percentile(ext[applied], 80)) if applied.any() else 0.0,
        "ahat_max_g": float(ahat.max()),
        "drift100_deg": gyro_drift_deg(rec, 100.0), "drift300_deg": gyro_drift_deg(rec, 300.0),
        "acc_mse_deg2": float(err2.mean()),
        "acc_sat_share": float(np.mean(np.abs(rec.acc) >= 1.999 * g)),
    }
    for code, name in PHASE_NAMES.items():
        m = phase == code
        out[f"acc_mse_{name}"] = float(err2[m].mean()) if m.any() else float("nan")
    return out


def config_recordings(config: str = "thesis_kf1d.yaml") -> list[tuple[str, dict]]:
    """``(split, generator keywords)`` of every recording of a tilt paper config."""
    doc = yaml.safe_load((PAPERS / config).read_text())
    data = doc["objective"]["data"]
    return [(split, dict(item["synthetic"])) for split in ("train", "test") for item in data[split]]


def _recording(kw: dict):
    from objectives.attitude.data.cache import synthetic

    kw = dict(kw)
    return synthetic(kw.pop("generator"), **kw)


STAT_COLUMNS = (
    ("duration_s", "s", "{:.0f}"), ("osc_share", "osc. share", "{:.2f}"), ("f_max_hz", "f max Hz", "{:.2f}"),
    ("fhat_max_hz", "f^ max Hz", "{:.2f}"), ("fhat_share", "f^ > 0", "{:.2f}"),
    ("rate_max_dps", "rate max deg/s", "{:.0f}"), ("rate_share_10dps", "rate > 10 deg/s", "{:.2f}"),
    ("rate_p80_dps", "rate p80", "{:.0f}"), ("ext_max_g", "ext max g", "{:.2f}"),
    ("ext_share", "ext > 0.01 g", "{:.2f}"), ("ahat_max_g", "alpha^ max g", "{:.2f}"),
    ("drift100_deg", "drift 100 s deg", "{:.1f}"), ("drift300_deg", "drift 300 s deg", "{:.1f}"),
    ("acc_mse_deg2", "acc MSE deg^2", "{:.0f}"), ("acc_mse_static", "static", "{:.1f}"),
    ("acc_mse_calm", "calm", "{:.1f}"), ("acc_mse_vibrating", "vibrating", "{:.0f}"),
    ("acc_mse_accelerating", "accel.", "{:.0f}"), ("acc_mse_vib+acc", "vib+acc", "{:.0f}"),
)


def stats_markdown(items: list[tuple[str, dict]]) -> str:
    """One markdown row of :func:`bench_stats` per ``(label, generator keywords)``."""
    head = "| recording | " + " | ".join(c[1] for c in STAT_COLUMNS) + " |\n"
    rows = [head, "|---" * (len(STAT_COLUMNS) + 1) + "|\n"]
    for label, kw in items:
        st = bench_stats(_recording(kw))
        cells = ["-" if not np.isfinite(st[k]) else fmt.format(st[k]) for k, _, fmt in STAT_COLUMNS]
        rows.append(f"| {label} | " + " | ".join(cells) + " |\n")
    return "".join(rows)


def _mean(x: np.ndarray) -> float:
    """Mean, NaN for no samples (a phase absent from short recordings)."""
    return float(x.mean()) if x.size else float("nan")


def condition_errors(run_dir: Path) -> dict:
    """Squared tilt error (deg^2) of a tuning run's best parameters on its held-out recordings, by
    recording and by phase.

    The run's own objective (``config.yaml``) scores ``best.yaml``'s parameters with its outputs kept,
    so the per-recording numbers are those of the run's report.

    Returns
    -------
    dict
        ``per_recording`` (list of MSE, deg^2), ``per_phase`` ({phase: MSE pooled over the held-out
        recordings}), ``share`` ({phase: share of held-out samples}), ``K_per_phase`` ({phase: mean
        fuzzy scale}, adaptive KF only), ``fitness`` (the run's stored test fitness, rad^2).
    """
    best = yaml.safe_load((run_dir / "best.yaml").read_text())
    objective = _objective(run_dir)
    score = objective.score(best["params"], "test", keep_outputs=True)
    per_rec, sq, codes, ks = [], [], [], []
    for rec in objective.recordings("test"):
        res = score.outputs[rec.name]
        e2 = (res.diagnostics["angle"] - rec.extra["angle"]) ** 2 * DEG2
        per_rec.append(float(e2.mean()))
        sq.append(e2)
        codes.append(rec.extra["phase"].astype(int))
        if "K" in res.diagnostics:
            ks.append(res.diagnostics["K"])
    sq, codes = np.concatenate(sq), np.concatenate(codes)
    out = {"per_recording": per_rec, "fitness": best["evaluation"]["test_fitness"],
           "per_phase": {p: _mean(sq[codes == c]) for c, p in PHASE_NAMES.items()},
           "share": {p: float(np.mean(codes == c)) for c, p in PHASE_NAMES.items()}}
    if ks:
        k = np.concatenate(ks)
        out["K_per_phase"] = {p: _mean(k[codes == c]) for c, p in PHASE_NAMES.items()}
    return out


def errors_markdown(runs: Path, seeds: list[int]) -> str:
    """Tables of :func:`condition_errors` for every filter and seed found under ``runs``."""
    lines = ["| filter | seed | held-out MSE deg^2 (mean) | rec. 1 | rec. 2 | rec. 3 | rec. 4 | "
             + " | ".join(PHASE_NAMES.values()) + " | K by phase (AKF) |\n",
             "|---" * (8 + len(PHASE_NAMES)) + "|\n"]
    for f in FILTERS:
        for s in seeds:
            d = runs / f"{f}_s{s}"
            if not (d / "best.yaml").exists() or "evaluation" not in yaml.safe_load((d / "best.yaml").read_text()):
                continue  # missing or not finished
            r = condition_errors(d)
            k = ", ".join(f"{v:.1f}" for v in r["K_per_phase"].values()) if "K_per_phase" in r else "-"
            lines.append(f"| {f} | {s} | {np.mean(r['per_recording']):.3f} ({r['fitness'] * DEG2:.3f}) | "
                         + " | ".join(f"{v:.3f}" for v in r["per_recording"]) + " | "
                         + " | ".join(f"{v:.3f}" for v in r["per_phase"].values()) + f" | {k} |\n")
    return "".join(lines)


def _objective(run_dir: Path):
    """The objective of a run directory's ``config.yaml`` (as ``tuner.run.resume`` reads it), serial."""
    from tuner.rundir import RunDir
    from tuner.setup import build, run_config

    rd = RunDir(run_dir)
    raw = rd.config()
    raw.setdefault("parallel", {})["n_jobs"] = 1
    return build(run_config(rd, raw))[0]


def start_errors(run_dir: Path, p0_bias: float = 1e-4, head_s: float = 60.0) -> dict:
    """Held-out MSE (deg^2) of a KF-family run's best parameters as tuned (thesis 3.1.3.1: ``P0 = 0``) and
    with an initial bias variance ``p0_bias`` ((rad/s)^2), with the share of the squared error in the
    first ``head_s`` seconds of each recording."""
    best = yaml.safe_load((run_dir / "best.yaml").read_text())["params"]
    objective = _objective(run_dir)
    out = {}
    for label, params in (("p0_0", best), ("p0_bias", {**best, "p0_bias": p0_bias})):
        sc = objective.score(params, "test", keep_outputs=True)
        head = tot = 0.0
        for rec in objective.recordings("test"):
            e2 = (sc.outputs[rec.name].diagnostics["angle"] - rec.extra["angle"]) ** 2
            k = int(round(head_s / rec.dt))
            head, tot = head + float(e2[:k].sum()), tot + float(e2.sum())
        out[label] = sc.fitness * DEG2
        out[label + "_head_share"] = head / tot
    return out


#: integral gains Ki (1/s^2) of :func:`damping_sweep`: four per decade from 1e-5 to 0.1
KI_GRID = tuple(float(k) for k in np.logspace(-5, -1, 17))


def damping_sweep(zetas: tuple[float, ...] = (0.4, 0.707, 1.0, 2.0), ki_grid: tuple[float, ...] = KI_GRID) -> dict:
    """Best training MSE (deg^2) of the Mahony tilt filter with ``Kp = 2 zeta sqrt(Ki)`` for each damping
    ``zeta`` (its loop ``s^2 + Kp s + Ki``), and its held-out MSE there.

    A steady-state KF of eqs. 3.9-3.10 has the same loop with ``K1^2 = q00/rho + 2 K2`` (continuous
    Riccati solution; rates per second), so its damping ``K1 / (2 sqrt(K2))`` is at least ``1/sqrt(2)``
    whatever rho, q00, q11 and the fuzzy scale of R: Mahony's ``Kp, Ki`` reach below it.
    """
    from tuner.config import load_config
    from tuner.run import _build

    objective, _ = _build(load_config(PAPERS / "thesis_mahony1d.yaml", n_jobs=1))
    base = objective.default_params()
    out = {}
    for z in zetas:
        scored = [(objective.score({**base, "Kp": 2 * z * math.sqrt(ki), "Ki": ki}, "train").fitness, ki)
                  for ki in ki_grid]
        f, ki = min(scored)
        kp = 2 * z * math.sqrt(ki)
        out[z] = {"Kp": kp, "Ki": ki, "train": f * DEG2,
                  "test": objective.score({**base, "Kp": kp, "Ki": ki}, "test").fitness * DEG2}
    return out


def explain_markdown(runs: Path, seeds: list[int]) -> str:
    """The two measurements behind the ordering (docs/tilt-bench.md section 4)."""
    lines = ["| run | held-out MSE deg^2, P0 = 0 | share in first 60 s | with p0_bias 1e-4 | share in first 60 s |\n",
             "|---|---|---|---|---|\n"]
    for f in ("kf1d", "akf1d", "akf1d_fuzzy"):
        for s in seeds:
            d = runs / f"{f}_s{s}"
            if (d / "best.yaml").exists() and "evaluation" in yaml.safe_load((d / "best.yaml").read_text()):
                r = start_errors(d)
                lines.append(f"| {f} s{s} | {r['p0_0']:.3f} | {r['p0_0_head_share']:.2f} | {r['p0_bias']:.3f} | "
                             f"{r['p0_bias_head_share']:.2f} |\n")
    lines += ["\n| damping zeta (Mahony, Kp = 2 zeta sqrt(Ki)) | Kp 1/s | Ki 1/s^2 | training MSE deg^2 | held-out |\n",
              "|---|---|---|---|---|\n"]
    for z, r in damping_sweep().items():
        lines.append(f"| {z} | {r['Kp']:.4f} | {r['Ki']:.3g} | {r['train']:.3f} | {r['test']:.3f} |\n")
    return "".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line: ``stats`` (bench table) or ``errors`` (tuned filters by condition), markdown on stdout."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("stats", "errors", "explain"))
    ap.add_argument("--runs", type=Path, default=ROOT / "runs" / "tilt")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    args = ap.parse_args(argv)
    if args.what == "stats":
        items = [(f"thesis {split} seed {kw['seed']}", kw) for split, kw in config_recordings()]
        items += [(f"default 60 s seed {s}", {"generator": "tilt1d", "duration_s": 60, "seed": s}) for s in (1, 2)]
        print(stats_markdown(items))
    elif args.what == "errors":
        print(errors_markdown(args.runs, args.seeds))
    else:
        print(explain_markdown(args.runs, args.seeds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
