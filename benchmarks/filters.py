"""Filter throughput: samples per second per core of every filter, next to other libraries.

For each filter of the registry, on a 300 s, 1 kHz synthetic recording (``bench6dof``; ``tilt1d``
for the 1-D filters) and on a BROAD trial: the fastest of several timed runs after a warm-up run,
in this one process (one core), in CPU time of the thread (the fastest run: on a shared machine the time
other processes hold the core is not counted). The public ``Filter(**defaults).run(recording)`` is timed, i.e. the
kernel plus its thin wrapper (initial quaternion, frame conversion), as an objective calls it.
Compile time is measured apart: the first call in a fresh process with an empty numba cache
(``NUMBA_CACHE_DIR`` pointed at a new directory), minus nothing (it includes the short run).

Peers, timed in the same process on the same data:

* the ``ahrs`` package's implementation of the same algorithm (Madgwick, Mahony, Complementary
  for LCF, EKF, UKF for QUKF): a Python loop per sample, so it is timed on the first
  ``slow_samples`` samples;
* ``imufusion`` (x-io Fusion, C): a different, later revision of Madgwick's algorithm, driven by
  one Python call per sample (its Python API has no batch call), compared with Madgwick and Mahony;
* VQF's C++ ``BasicVQF.updateBatch`` and ``VQF.updateBatch`` (the whole array in one C++ call).

Floor: a bare numba loop that only integrates the gyro (quaternion exp map, product, normalise,
write the output). ``cost ratio`` = floor rate / filter rate: how many times the work of the
minimal kernel each filter costs per sample.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np
from numba import njit

from benchmarks.common import best_cpu_rate, fmt, md_table, median_rate, peer

__all__ = ["run", "gyro_integration"]

#: our filter -> the ahrs class of the same algorithm (and how to call it)
AHRS_SAME = {"madgwick": "Madgwick", "mahony": "Mahony", "lcf": "Complementary", "ekf": "EKF", "qukf": "UKF"}
_COMPILE_SNIPPET = """
import time, sys
from objectives.attitude.data import synthetic
from objectives.attitude.filters import get_filter
name = sys.argv[1]
rec = synthetic.synthetic("tilt1d" if name.endswith("1d") else "bench6dof", duration_s=2.0, seed=3)
f = get_filter(name)()
t = time.perf_counter(); f.run(rec); first = time.perf_counter() - t
t = time.perf_counter(); f.run(rec); second = time.perf_counter() - t
print(first - second)
"""


@njit(cache=True)
def gyro_integration(gyr, dt, q0):
    """The floor: q_k = normalise(q_{k-1} (x) exp(w_k dt / 2)), output (N, 4). No correction at all."""
    n = gyr.shape[0]
    out = np.empty((n, 4))
    w, x, y, z = q0[0], q0[1], q0[2], q0[3]
    for k in range(n):
        gx, gy, gz = gyr[k, 0] * dt * 0.5, gyr[k, 1] * dt * 0.5, gyr[k, 2] * dt * 0.5
        a = np.sqrt(gx * gx + gy * gy + gz * gz)
        c = np.cos(a)
        s = np.sin(a) / a if a > 1e-12 else 1.0
        dw, dx, dy, dz = c, gx * s, gy * s, gz * s
        w, x, y, z = (w * dw - x * dx - y * dy - z * dz, w * dx + x * dw + y * dz - z * dy,
                      w * dy - x * dz + y * dw + z * dx, w * dz + x * dy - y * dx + z * dw)
        nn = 1.0 / np.sqrt(w * w + x * x + y * y + z * z)
        w, x, y, z = w * nn, x * nn, y * nn, z * nn
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = w, x, y, z
    return out


def _compile_time(name: str) -> float | None:
    """Seconds of the first call in a fresh process with an empty numba cache (compile), or None."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with tempfile.TemporaryDirectory() as d:
        env = {**os.environ, "NUMBA_CACHE_DIR": d, "PYTHONPATH": root}
        try:
            p = subprocess.run([sys.executable, "-c", _COMPILE_SNIPPET, name], capture_output=True, text=True,
                               env=env, cwd=root, timeout=300)
            return float(p.stdout.strip().splitlines()[-1])
        except Exception:
            return None


def _ahrs_call(mod, cls: str, g, a, m, f: float):
    C = getattr(mod.filters, cls)
    if cls == "Madgwick":
        return lambda: C(gyr=g, acc=a, mag=m, frequency=f, gain=0.1)
    if cls == "Mahony":
        return lambda: C(gyr=g, acc=a, mag=m, frequency=f, k_P=0.5, k_I=0.01)
    if cls == "Complementary":
        return lambda: C(gyr=g, acc=a, mag=m, frequency=f, gain=0.98)
    if cls == "EKF":
        return lambda: C(gyr=g, acc=a, mag=m, frequency=f, frame="ENU")
    return lambda: C(gyr=g, acc=a, mag=m, frequency=f)


#: least samples/s of the quaternion UKFs as a fraction of the EKF's in the same run
UKF_VS_EKF = {"qukf": 0.2, "qraukf": 0.12}


def _measure(rec, names: list[str], repeats: int, slow_n: int) -> dict[str, Any]:
    from objectives.attitude.filters import get_filter

    gyr, acc = np.ascontiguousarray(rec.gyr), np.ascontiguousarray(rec.acc)
    mag = None if rec.mag is None else np.ascontiguousarray(rec.mag)
    n, dt = rec.n, rec.dt
    out: dict[str, Any] = {"samples": n, "dt": dt, "ours": {}, "peers": {}}
    out["floor"] = best_cpu_rate(lambda: gyro_integration(gyr, dt, np.array([1.0, 0, 0, 0])), n, max(repeats, 5))
    for name in names:
        flt = get_filter(name)()
        try:
            reps = repeats if name not in ("qukf", "qraukf") else max(3, repeats // 2)
            out["ours"][name] = best_cpu_rate(lambda flt=flt: flt.run(rec), n, reps)
        except Exception as exc:  # e.g. a 1-D filter on data it does not accept
            out["ours"][name] = {"error": f"{type(exc).__name__}: {exc}"}
    m = min(slow_n, n)
    g, a = gyr[:m], acc[:m]
    mg = None if mag is None else mag[:m]
    ahrs = peer("ahrs")
    if ahrs is not None and mag is not None:
        for ours, cls in AHRS_SAME.items():
            try:
                out["peers"][f"ahrs.{cls}"] = {**median_rate(_ahrs_call(ahrs, cls, g, a, mg, 1.0 / dt), m, 1),
                                               "same_as": ours}
            except Exception as exc:
                out["peers"][f"ahrs.{cls}"] = {"error": f"{type(exc).__name__}: {exc}", "same_as": ours}
    imuf = peer("imufusion")
    if imuf is not None and mag is not None:
        gd, ag = np.degrees(g), a / 9.81

        def fusion():
            x = imuf.Ahrs()
            x.set_sample_period(dt)
            for i in range(m):
                x.update(gd[i], ag[i], mg[i])
        out["peers"]["imufusion.Ahrs (per-sample call)"] = {**median_rate(fusion, m, 2), "same_as": "madgwick"}
    vqf = peer("vqf")
    if vqf is not None and mag is not None:
        out["peers"]["vqf.BasicVQF.updateBatch"] = {
            **best_cpu_rate(lambda: vqf.BasicVQF(dt).updateBatch(gyr, acc, mag), n, repeats), "same_as": "madgwick"}
        out["peers"]["vqf.VQF.updateBatch"] = {
            **best_cpu_rate(lambda: vqf.VQF(dt).updateBatch(gyr, acc, mag), n, repeats), "same_as": "vqf"}
    return out


def run(smoke: bool = False, **_: Any) -> dict[str, Any]:
    from objectives.attitude.data import synthetic
    from objectives.attitude.data.broad import broad_trials, default_broad_dir, load_broad
    from objectives.attitude.filters import filter_names

    names = filter_names()
    six = [n for n in names if not n.endswith("1d")]
    one = [n for n in names if n.endswith("1d")]
    dur = 5.0 if smoke else 300.0
    repeats = 2 if smoke else 5
    slow_n = 300 if smoke else 3000
    t0 = time.perf_counter()
    datasets = {}
    rec6 = synthetic.synthetic("bench6dof", duration_s=dur, rate_hz=1000, seed=11)
    datasets[f"bench6dof {dur:g} s at 1 kHz"] = _measure(rec6, six, repeats, slow_n)
    rec1 = synthetic.synthetic("tilt1d", duration_s=dur, rate_hz=1000, seed=11)
    datasets[f"tilt1d {dur:g} s at 1 kHz"] = _measure(rec1, one, repeats, slow_n)
    missing = [p for p in ("ahrs", "imufusion", "vqf") if peer(p) is None]
    bdir = default_broad_dir()
    if bdir.exists() and broad_trials(bdir):
        trial = "07_undisturbed_fast_rotation_B" if "07_undisturbed_fast_rotation_B" in broad_trials(bdir) \
            else broad_trials(bdir)[0]
        rec = load_broad(bdir / f"{trial}.mat")
        if smoke:
            rec = rec.slice(0, 3000) if hasattr(rec, "slice") else rec
        datasets[f"BROAD {trial}"] = _measure(rec, six, repeats, slow_n)
    compile_s = {} if smoke else {n: _compile_time(n) for n in names}
    wall = time.perf_counter() - t0
    # --- tables and targets ---------------------------------------------------------------
    lines, targets = [], []
    for title, d in datasets.items():
        floor = d["floor"]["rate"]
        lines.append(f"\n**{title}** ({d['samples']} samples; floor = bare numba gyro integration, "
                     f"{fmt(floor)} samples/s)\n")
        rows = []
        for name, r in d["ours"].items():
            if "error" in r:
                rows.append([name, "error", r["error"][:60], "-", "-", "-", "-"])
                continue
            peer_rates = {k: v for k, v in d["peers"].items() if v.get("same_as") == name and "rate" in v}
            ahrs_r = next((v["rate"] for k, v in peer_rates.items() if k.startswith("ahrs.")), None)
            vqf_r = d["peers"].get("vqf.BasicVQF.updateBatch", {}).get("rate")
            fus_r = d["peers"].get("imufusion.Ahrs (per-sample call)", {}).get("rate")
            full_vqf = d["peers"].get("vqf.VQF.updateBatch", {}).get("rate") if name in ("vqf", "realtime") else None
            rows.append([name, r["rate"], floor / r["rate"],
                         None if ahrs_r is None else r["rate"] / ahrs_r,
                         vqf_r and r["rate"] / vqf_r, fus_r and r["rate"] / fus_r, full_vqf and r["rate"] / full_vqf])
            if ahrs_r is not None:
                targets.append({"target": f"{name} >= 500x ahrs per sample ({title})",
                                "value": r["rate"] / ahrs_r, "pass": r["rate"] / ahrs_r >= 500})
            if name in ("madgwick", "mahony"):
                for lib, rate in (("BasicVQF C++ batch", vqf_r), ("imufusion C", fus_r)):
                    if rate:
                        targets.append({"target": f"{name} >= {lib} per sample ({title})",
                                        "value": r["rate"] / rate, "pass": r["rate"] >= rate})
            if name == "realtime" and full_vqf:  # issue 41: our causal filter against VQF's own C++, same data
                targets.append({"target": f"realtime >= VQF C++ batch (VQF.updateBatch) per sample ({title})",
                                "value": r["rate"] / full_vqf, "pass": r["rate"] >= full_vqf})
        ekf_r = d["ours"].get("ekf", {}).get("rate")
        for name, least in UKF_VS_EKF.items():  # issue 16: the UKFs' cost relative to the EKF, same run
            rate = d["ours"].get(name, {}).get("rate")
            if ekf_r and rate:
                targets.append({"target": f"{name} >= {least}x the ekf's samples/s ({title})",
                                "value": rate / ekf_r, "pass": rate / ekf_r >= least})
        lines.append(md_table(["filter", "samples/s", "cost vs floor (x)", "x ahrs same algo", "x BasicVQF batch",
                               "x imufusion", "x VQF batch"], rows))
        prow = [[k, v.get("rate"), v.get("samples"), v.get("same_as"), v.get("error", "")]
                for k, v in d["peers"].items()]
        if prow:
            lines.append("\nPeers on the same data (ahrs and imufusion timed on the first "
                         f"{slow_n} samples):\n")
            lines.append(md_table(["peer", "samples/s", "samples timed", "compared with", "error"], prow))
    if compile_s:
        lines.append("\nCompile time (first call, empty numba cache, fresh process), seconds:\n")
        lines.append(md_table(["filter", "compile s"], [[k, v] for k, v in compile_s.items()]))
    if missing:
        lines.append(f"\nMissing peers (not installed): {', '.join(missing)}")
    c_res = _c_rows(smoke)
    if c_res is not None:  # the exported C filters next to the numba kernels (benchmarks/c_filters.py)
        lines.append("\nExported C filters (`tuner export --format c-filter`), next to the numba kernels:\n")
        lines.append(c_res["markdown"])
        targets += c_res["targets"]
    return {"results": {"datasets": datasets, "compile_s": compile_s, "missing_peers": missing, "wall_s": wall,
                        "c_filters": None if c_res is None else c_res["results"]},
            "markdown": "\n".join(lines), "targets": targets}


def _c_rows(smoke: bool) -> dict[str, Any] | None:
    """:func:`benchmarks.c_filters.run`, or None without a C compiler."""
    from objectives.attitude.cexport.build import find_compiler

    if find_compiler() is None:
        return None
    from benchmarks import c_filters

    return c_filters.run(smoke=smoke)
