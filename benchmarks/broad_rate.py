"""Rate independence: the same filter values scored on the 16 BROAD trials resampled to lower rates, and on
the synthetic 6-DOF bench at 286 Hz and 1 kHz.

BROAD records at 2000/7 Hz (285.7 Hz). Each trial's gyroscope, accelerometer and magnetometer are decimated
with anti-aliasing (``scipy.signal.resample_poly``, zero-phase polyphase FIR, ``padtype="line"`` so the ends
do not ring) by the exact rational factor to 100 Hz (7/20) and 50 Hz (7/40); the truth and the motion mask
are taken at the nearest original sample of each new time (within 1.75 ms). The filters are run with the
same values at every rate (their time constants are in s), and the BROAD total RMSE (deg, motion samples)
is tabulated per group. The bench (``bench6dof``, FAEKF paper 5.1: vibration, external accelerations up to
2 g, magnetic perturbations) is generated with the same seeds at 1000 Hz and 2000/7 Hz.

Examples::

    python benchmarks/broad_rate.py --config configs/broad_realtime.yaml
    python benchmarks/broad_rate.py --filter realtime --values tau_acc_s=3 tau_mag_s=9
"""

from __future__ import annotations

import argparse
import sys
import time
from fractions import Fraction

import numpy as np

try:
    from benchmarks.broad_cv_common import BROAD_DIR, RESULTS_MD, broad_folds, pairs, publish
except ImportError:  # run as a script
    from broad_cv_common import BROAD_DIR, RESULTS_MD, broad_folds, pairs, publish

from objectives.attitude.data.recording import Recording  # noqa: E402

BROAD_RATE_HZ = 2000.0 / 7.0


def resample_recording(rec: Recording, rate_hz: float) -> Recording:
    """``rec`` decimated to ``rate_hz`` with anti-aliasing (see the module docstring)."""
    from scipy.signal import resample_poly

    ratio = Fraction(rate_hz * rec.dt).limit_denominator(1000)
    up, down = ratio.numerator, ratio.denominator
    if up == down:
        return rec

    def rs(x):
        return np.ascontiguousarray(resample_poly(x, up, down, axis=0, padtype="line"))

    gyr, acc = rs(rec.gyr), rs(rec.acc)
    mag = None if rec.mag is None else rs(rec.mag)
    n = gyr.shape[0]
    dt = rec.dt * down / up
    idx = np.minimum(np.rint(np.arange(n) * dt / rec.dt).astype(int), rec.gyr.shape[0] - 1)
    quat = None if rec.quat is None else rec.quat[idx]
    motion = None if rec.motion is None else rec.motion[idx]
    return Recording(rec.name, gyr, acc, mag, dt, quat=quat, motion=motion, frame=rec.frame, units=rec.units,
                     source=f"{rec.source} resampled to {rate_hz:g} Hz")


def score(filter_name: str, values: dict, recs: list[Recording]) -> np.ndarray:
    """BROAD total RMSE (deg) of the filter on each recording (accmag start, 180 for a diverged run)."""
    from objectives.attitude.filters import get_filter
    from objectives.attitude.metrics import broad_errors

    cls = get_filter(filter_name)
    flt = cls(**{k: v for k, v in values.items() if k in cls.defaults})
    out = np.empty(len(recs))
    for i, rec in enumerate(recs):
        q = flt.run(rec)
        e = broad_errors(q, rec.quat, rec.motion).total_rmse_deg
        out[i] = e if np.isfinite(e) else 180.0
    return out


def config_values(path: str) -> tuple[str, dict]:
    """``(filter, fixed values)`` of a config; the tuned values are given with ``--values``."""
    import yaml

    raw = yaml.safe_load(open(path))
    return raw["objective"]["filter"], dict(raw["objective"].get("fixed") or {})


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--filter", default="realtime")
    ap.add_argument("--config", default="", help="take the filter and its fixed values from this config")
    ap.add_argument("--values", nargs="*", default=[], help="NAME=VALUE (added to the config's fixed values)")
    ap.add_argument("--label", default="tuned")
    ap.add_argument("--rates", default="100,50")
    ap.add_argument("--bench-seeds", default="1,2,3")
    ap.add_argument("--bench-duration", type=float, default=60.0)
    ap.add_argument("--data", default=str(BROAD_DIR))
    ap.add_argument("--out", default=str(RESULTS_MD))
    ap.add_argument("--no-vqf", action="store_true", help="skip VQF's defaults as a reference row")
    a = ap.parse_args(argv)

    from objectives.attitude.trials import load_trial

    name, values = (config_values(a.config) if a.config else (a.filter, {}))
    values.update(pairs(a.values, "--values"))
    paths, groups, _ = broad_folds(a.data)
    names = list(paths)
    order = list(dict.fromkeys(groups[n] for n in names))
    base = [load_trial(paths[n]) for n in names]
    rates = [float(r) for r in a.rates.split(",") if r]
    setups = [(f"{name} {a.label}", name, values)]
    if not a.no_vqf:
        setups.append(("vqf defaults", "vqf", {}))
    t0 = time.perf_counter()
    rows = []
    for label, flt, vals in setups:
        s0 = score(flt, vals, base)
        rows.append((label, f"{BROAD_RATE_HZ:.1f}", s0, None))
        for r in rates:
            rs = score(flt, vals, [resample_recording(rec, r) for rec in base])
            rows.append((label, f"{r:g}", rs, rs.mean() - s0.mean()))
    lines = [f"\n### Rate independence: {name} {values} ({a.label})\n",
             f"`python benchmarks/broad_rate.py {' '.join(argv or sys.argv[1:])}` ({time.perf_counter() - t0:.0f} s, "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}); BROAD total RMSE (deg), the same values at "
             "every rate.", "",
             "| filter | rate (Hz) | mean | change from 285.7 Hz | " + " | ".join(order) + " |",
             "|---" * (4 + len(order)) + "|"]
    for label, rate, s, d in rows:
        gm = [np.mean([s[i] for i, n in enumerate(names) if groups[n] == g]) for g in order]
        lines.append(f"| {label} | {rate} | {s.mean():.3f} | {'' if d is None else f'{d:+.3f}'} | "
                     + " | ".join(f"{v:.2f}" for v in gm) + " |")
    seeds = [int(x) for x in a.bench_seeds.split(",") if x]
    if seeds:
        from objectives.attitude.data.synthetic import bench6dof

        lines += ["", f"Synthetic bench (`bench6dof`, {a.bench_duration:g} s, seeds {seeds}), total RMSE (deg), "
                  "mean over seeds:", "", "| filter | 285.7 Hz | 1000 Hz | change |", "|---|---|---|---|"]
        for label, flt, vals in setups:
            lo = score(flt, vals, [bench6dof(a.bench_duration, BROAD_RATE_HZ, s) for s in seeds]).mean()
            hi = score(flt, vals, [bench6dof(a.bench_duration, 1000.0, s) for s in seeds]).mean()
            lines.append(f"| {label} | {lo:.3f} | {hi:.3f} | {hi - lo:+.3f} |")
    publish(a.out, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
