"""Samples per second per core of Madgwick, Mahony, LCF/NCF/CCF against other libraries.

Runs in one process (one core): our numba kernels on a BROAD trial (and on a 300 s, 1 kHz
synthetic recording), the same algorithms in the ``ahrs`` package (a Python loop per sample,
timed on a slice), ``imufusion`` (x-io Fusion, C with a Python call per sample; a different
algorithm, Madgwick's later revision) and VQF's C++ ``BasicVQF.updateBatch`` / full
``VQF.updateBatch``. Libraries that are not installed are skipped. Prints a table; not a test.

    .venv/bin/python benchmarks/filters_speed_comparison.py [--trial NAME] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from objectives.attitude.data.broad import broad_trials, default_broad_dir, load_broad
from objectives.attitude.data.synthetic import simulate_imu
from objectives.attitude.filters.complementary import complementary_batch
from objectives.attitude.filters.madgwick import madgwick_batch
from objectives.attitude.filters.mahony import mahony_batch


def _rate(fn, n, repeats):
    fn()  # warm-up (numba compile / cache load)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return n / float(np.median(times))


def _synthetic(n, dt):
    t = np.arange(n) * dt
    h = 0.5 * np.stack([0.6 * np.sin(0.7 * t), 0.4 * np.sin(0.5 * t + 1), 2.5 * np.sin(0.15 * t)], 1)
    c, s = np.cos(h), np.sin(h)
    q = np.stack([c[:, 0] * c[:, 1] * c[:, 2] + s[:, 0] * s[:, 1] * s[:, 2],
                  s[:, 0] * c[:, 1] * c[:, 2] - c[:, 0] * s[:, 1] * s[:, 2],
                  c[:, 0] * s[:, 1] * c[:, 2] + s[:, 0] * c[:, 1] * s[:, 2],
                  c[:, 0] * c[:, 1] * s[:, 2] - s[:, 0] * s[:, 1] * c[:, 2]], 1)
    return simulate_imu(q, dt, frame="ENU", rng=np.random.default_rng(0), gyr_noise=0.002, acc_noise=0.01,
                        mag_noise=0.001)


def measure(gyr, acc, mag, dt, repeats, slow_n):
    n = len(gyr)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    rows = []
    ours = {
        "madgwick MARG (ours)": lambda: madgwick_batch(gyr, acc, mag, dt, q0, 0.1),
        "madgwick IMU (ours)": lambda: madgwick_batch(gyr, acc, None, dt, q0, 0.1),
        "mahony MARG (ours)": lambda: mahony_batch(gyr, acc, mag, dt, q0, 0.5, 0.01),
        "mahony IMU (ours)": lambda: mahony_batch(gyr, acc, None, dt, q0, 0.5, 0.01),
        "lcf (ours)": lambda: complementary_batch(gyr, acc, mag, dt, np.zeros(3), 0.98),
        "ncf (ours)": lambda: complementary_batch(gyr, acc, mag, dt, np.zeros(3), 1.0, 25.0, 0.1),
        "ccf (ours)": lambda: complementary_batch(gyr, acc, mag, dt, np.zeros(3), 0.7, 25.0, 0.1),
    }
    for name, fn in ours.items():
        rows.append((name, _rate(fn, n, repeats)))
    m = min(slow_n, n)
    g, a, mg = gyr[:m], acc[:m], mag[:m]
    try:
        import ahrs
        f = 1.0 / dt
        rows.append(("madgwick MARG (ahrs)", _rate(
            lambda: ahrs.filters.Madgwick(gyr=g, acc=a, mag=mg, frequency=f, gain=0.1), m, 1)))
        rows.append(("madgwick IMU (ahrs)", _rate(
            lambda: ahrs.filters.Madgwick(gyr=g, acc=a, frequency=f, gain=0.1), m, 1)))
        rows.append(("mahony MARG (ahrs)", _rate(
            lambda: ahrs.filters.Mahony(gyr=g, acc=a, mag=mg, frequency=f, k_P=0.5, k_I=0.01), m, 1)))
    except ImportError:
        pass
    try:
        import imufusion

        def fusion():
            ahrs_ = imufusion.Ahrs()
            ahrs_.set_sample_period(dt)
            gd = np.degrees(g)
            ag = a / 9.81
            for i in range(m):
                ahrs_.update(gd[i], ag[i], mg[i])
        rows.append(("x-io Fusion AHRS (imufusion, per-sample call)", _rate(fusion, m, 1)))
    except ImportError:
        pass
    try:
        import vqf

        def basic():
            vqf.BasicVQF(dt).updateBatch(gyr, acc, mag)

        def full():
            vqf.VQF(dt).updateBatch(gyr, acc, mag)
        rows.append(("BasicVQF.updateBatch (vqf C++)", _rate(basic, n, repeats)))
        rows.append(("VQF.updateBatch (vqf C++)", _rate(full, n, repeats)))
    except ImportError:
        pass
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trial", default=None, help="BROAD trial name (default: the first present)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--slow-samples", type=int, default=20000, help="samples for Python-loop libraries")
    args = ap.parse_args()
    datasets = []
    trials = broad_trials(default_broad_dir()) if default_broad_dir().exists() else []
    if trials:
        name = args.trial or trials[0]
        rec = load_broad(default_broad_dir() / f"{name}.mat")
        datasets.append((f"BROAD {name} ({rec.n} samples)", rec))
    rec = _synthetic(300_000, 0.001)
    datasets.append(("synthetic 300 s at 1 kHz", rec))
    for title, rec in datasets:
        gyr, acc, mag = (np.ascontiguousarray(x) for x in (rec.gyr, rec.acc, rec.mag))
        rows = measure(gyr, acc, mag, rec.dt, args.repeats, args.slow_samples)
        print(f"\n{title}: samples/s on one core (median of {args.repeats} after warm-up)")
        print(f"{'filter':48s} {'samples/s':>14s}")
        for name, r in rows:
            print(f"{name:48s} {r:14,.0f}")


if __name__ == "__main__":
    main()
