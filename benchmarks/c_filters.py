"""Speed and size of the exported C filters (objectives/attitude/cexport) next to the numba kernels.

For each filter configuration (defaults, and with the robust blocks as configs/broad_*.yaml use them) on the
synthetic bench (60 s at 1 kHz) and on a BROAD trial: samples per second of CPU time (the fastest of ``repeats``
interleaved rounds; on a shared machine wall-clock medians mostly measure the other processes) of

* the numba model, ``Filter(**values).run(recording)`` (kernel and its thin wrapper, as an objective calls it);
* the C, double and float, compiled with ``-O2`` (and double with ``-O2 -ffast-math``, and with
  ``-DBX_LIBM_TRIG``: libm's sin and cos as the kernel calls them instead of the port's series), over the whole
  recording in one ctypes call of ``PREFIX_run`` (the streaming ``PREFIX_update`` per sample inside);
* imufusion (x-io Fusion, C), where installed: its Python API has one call per sample, so its rate is bounded
  by that call; it is a different, later revision of Madgwick's algorithm.

Size: ``.text`` + ``.rodata`` bytes of the ``-O2`` object (``size -A``) and ``sizeof`` of the filter struct
(the whole state, configuration included) and of the params struct, per precision.

Run alone: ``python -m benchmarks.c_filters [--smoke]`` writes ``benchmarks/results/c_filters.md`` and
``c_filters.json``; ``benchmarks.filters`` adds the same rows to its report.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import fmt, md_table, median_rate, peer

__all__ = ["run", "measure", "sizes", "CONFIGS"]

#: label -> (filter name, values)
CONFIGS = {
    "madgwick": ("madgwick", {}),
    "madgwick robust": ("madgwick", {"beta": 0.034, "mag_rejection": True, "rest_bias": True}),
    "mahony": ("mahony", {}),
    "mahony robust": ("mahony", {"Kp": 0.7, "Ki": 0.01, "mag_rejection": True, "rest_bias": True,
                                 "acc_lp_tau_s": 2.0}),
    "ekf": ("ekf", {}),
    "ekf robust": ("ekf", {"p0_b": 1e-4, "gyro_sample": "current", "huber_deg": 5.0, "acc_gate": 0.3,
                           "mag_rejection": True, "rest_bias": True, "acc_lp_tau_s": 4.6}),
    "lcf": ("lcf", {}),
    "ncf": ("ncf", {}),
    "ccf": ("ccf", {}),
    "ccf robust": ("ccf", {"alpha_mode": "tau", "tau_s": 0.2, "Kp": 2.0, "Ki": 0.05, "acc_gate": 0.3,
                           "mag_rejection": True, "mag_weight": 0.5}),
    "realtime": ("realtime", {}),
    "realtime broad": ("realtime", {"mag_first_at_rest": True, "tau_mag_s": 22.46, "mag_recover_tau_s": 10.98}),
    "imu_tools_madgwick": ("imu_tools_madgwick", {}),
    "valenti": ("valenti", {}),
}
#: the thesis's tilt filters, timed on the tilt bench (thesis 3.1.2) at its 800 Hz
TILT_CONFIGS = {"kf1d": ("kf1d", {}), "akf1d": ("akf1d", {})}
#: (precision, flags, column): ``-DBX_LIBM_TRIG`` builds the port with libm's sin and cos, the kernel's own, in place
#: of its series (``cexport/templates/trig.c``): the same operations as the numba kernel, so that column compares the
#: code around the math
_VARIANTS = (("double", ("-O2",), "C double -O2"), ("float", ("-O2",), "C float -O2"),
             ("double", ("-O2", "-ffast-math"), "C double -O2 -ffast-math"),
             ("double", ("-O2", "-DBX_LIBM_TRIG"), "C double -O2, libm sin/cos"))
#: the issue's bound on numba's time over its C port's (double, -O2, no fast-math)
WITHIN = 1.25


def _filter(label: str):
    from objectives.attitude.filters import get_filter

    name, values = {**CONFIGS, **TILT_CONFIGS}[label]
    return get_filter(name)(**values)


def _builds(flt, rate_hz: float, tmp: Path, variants=_VARIANTS) -> dict[str, Any]:
    from objectives.attitude.cexport import render_c_filter
    from objectives.attitude.cexport.build import CFilter, compile_shared

    out = {}
    for precision, opt, key in variants:
        files = render_c_filter(flt, rate_hz=rate_hz, precision=precision, prefix="BX")
        out[key] = CFilter(compile_shared(files, tmp / f"{flt.name}-{len(out)}-{id(flt)}", opt), "BX", precision)
    return out


def _best_rates(fns: dict[str, Any], n: int, rounds: int) -> dict[str, float]:
    """Samples/s of each of ``fns`` (each processes ``n`` samples) from its fastest of ``rounds`` calls, timed in
    CPU time of this thread (``time.thread_time``: the time another process holds the core is not counted), the
    calls interleaved (one of each per round after a warm-up call), so that what load remains (shared caches)
    hits every variant alike."""
    best = {k: float("inf") for k in fns}
    for fn in fns.values():
        fn()
    for _ in range(rounds):
        for k, fn in fns.items():
            t = time.thread_time()
            fn()
            best[k] = min(best[k], time.thread_time() - t)
    return {k: n / v for k, v in best.items()}


def measure(rec, repeats: int, tmp: Path, variants=_VARIANTS, configs=None) -> dict[str, Any]:
    """Samples/s of every configuration's numba model and C builds on ``rec`` (best of ``repeats`` rounds)."""
    n = rec.n
    out: dict[str, Any] = {"samples": n, "rows": {}}
    gyr, acc, mag = (None if a is None else np.ascontiguousarray(a) for a in (rec.gyr, rec.acc, rec.mag))
    for label in configs or CONFIGS:
        flt = _filter(label)
        fns = {"numba": lambda flt=flt: flt.run(rec)}
        for key, c in _builds(flt, 1.0 / rec.dt, tmp, variants).items():
            g, a, m = (None if x is None else np.ascontiguousarray(x, dtype=c.dtype) for x in (gyr, acc, mag))
            fns[key] = lambda c=c, g=g, a=a, m=m: c.run(g, a, m, rec.dt)
        out["rows"][label] = _best_rates(fns, n, repeats)
    imuf = peer("imufusion")
    if imuf is not None and mag is not None and configs is None:
        m_n = min(n, 20000)
        gd, ag, mg = np.degrees(gyr[:m_n]), acc[:m_n] / 9.81, mag[:m_n]

        def fusion():
            x = imuf.Ahrs()
            x.set_sample_period(rec.dt)
            for i in range(m_n):
                x.update(gd[i], ag[i], mg[i])
        out["imufusion"] = median_rate(fusion, m_n, 2)["rate"]
    return out


def sizes(tmp: Path, precisions=("double", "float"), configs=None) -> dict[str, Any]:
    """Object code (``.text`` + ``.rodata``, -O2) and struct sizes in bytes per configuration (``configs``, labels
    of :data:`CONFIGS` and :data:`TILT_CONFIGS`; None: all) and precision."""
    from objectives.attitude.cexport import render_c_filter
    from objectives.attitude.cexport.build import STRICT_FLAGS, find_compiler

    cc = find_compiler()
    out: dict[str, Any] = {}
    for label in configs or {**CONFIGS, **TILT_CONFIGS}:
        for precision in precisions:
            d = tmp / f"size-{label.replace(' ', '_')}-{precision}"
            d.mkdir(parents=True, exist_ok=True)
            for name, text in render_c_filter(_filter(label), rate_hz=100.0, precision=precision,
                                              prefix="SZ").items():
                (d / name).write_text(text)
            subprocess.run([*cc, *STRICT_FLAGS, "-O2", "-c", str(d / "sz.c"), "-o", str(d / "sz.o")], check=True)
            sec = {}
            for line in subprocess.run(["size", "-A", str(d / "sz.o")], capture_output=True, text=True,
                                       check=True).stdout.splitlines():
                parts = line.split()
                if len(parts) >= 2 and parts[1].isdigit():
                    sec[parts[0]] = int(parts[1])
            code = sum(v for k, v in sec.items() if k.startswith((".text", ".rodata")))
            (d / "main.c").write_text('#include <stdio.h>\n#include "sz.h"\nint main(void) { printf("%lu %lu\\n", '
                                      "(unsigned long)sizeof(SZ_filter), (unsigned long)sizeof(SZ_params)); "
                                      "return 0; }\n")
            subprocess.run([*cc, "-std=c99", "-o", str(d / "main"), str(d / "main.c")], check=True)
            st, pa = subprocess.run([str(d / "main")], capture_output=True, text=True, check=True).stdout.split()
            out[f"{label} ({precision})"] = {"code_bytes": code, "state_bytes": int(st), "params_bytes": int(pa)}
    return out


def run(smoke: bool = False, **_: Any) -> dict[str, Any]:
    from objectives.attitude.data import synthetic
    from objectives.attitude.data.broad import broad_trials, default_broad_dir, load_broad

    t0 = time.perf_counter()
    repeats = 2 if smoke else 9
    data = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        dur = 5.0 if smoke else 60.0
        variants = _VARIANTS[:1] if smoke else _VARIANTS  # smoke: C double -O2 only, no BROAD trial
        data[f"bench6dof {dur:g} s at 1 kHz"] = measure(
            synthetic.synthetic("bench6dof", duration_s=dur, rate_hz=1000, seed=11), repeats, tmp, variants)
        data[f"tilt1d {dur:g} s at 800 Hz"] = measure(
            synthetic.synthetic("tilt1d", duration_s=dur, rate_hz=800, seed=11), repeats, tmp, variants,
            list(TILT_CONFIGS))
        bdir = default_broad_dir()
        if not smoke and bdir.exists() and "07_undisturbed_fast_rotation_B" in broad_trials(bdir):
            data["BROAD 07_undisturbed_fast_rotation_B"] = measure(
                load_broad(bdir / "07_undisturbed_fast_rotation_B.mat"), repeats, tmp)
        # smoke: measure() compiled every configuration with the same strict flags; one of each kind here
        size = sizes(tmp, ("double",), ["madgwick", "kf1d"]) if smoke else sizes(tmp)
    lines, targets = [], []
    cols = ["numba"] + [key for _, _, key in variants]
    ratio_cols = [c for c in ("C double -O2", "C double -O2, libm sin/cos") if c in cols]
    for title, d in data.items():
        lines.append(f"\n**{title}** ({d['samples']} samples), samples/s (one core; C over the whole recording "
                     "in one call):\n")
        rows = [[label] + [r[c] for c in cols] + [r[c] / r["numba"] for c in ratio_cols]
                for label, r in d["rows"].items()]
        lines.append(md_table(["filter"] + cols + [f"{c} / numba" for c in ratio_cols], rows))
        if "imufusion" in d:
            lines.append(f"\nimufusion.Ahrs (x-io Fusion C, one Python call per sample): {fmt(d['imufusion'])} "
                         "samples/s on the first 20000 samples.\n")
        for label, r in d["rows"].items():
            for c in ratio_cols:
                targets.append({"target": f"{label}: numba within {WITHIN}x of {c} ({title})",
                                "value": r[c] / r["numba"], "pass": r[c] <= WITHIN * r["numba"]})
    lines.append("\nSize in bytes (object code `.text` + `.rodata` at -O2; the filter struct holds the whole "
                 "state and its configuration):\n")
    lines.append(md_table(["filter (precision)", "code bytes", "state bytes (filter struct)", "params bytes"],
                          [[k, v["code_bytes"], v["state_bytes"], v["params_bytes"]] for k, v in size.items()]))
    return {"results": {"datasets": data, "sizes": size, "wall_s": time.perf_counter() - t0},
            "markdown": "\n".join(lines), "targets": targets}


if __name__ == "__main__":
    res = run(smoke="--smoke" in sys.argv)
    out = Path(__file__).resolve().parent / "results"
    if "--smoke" not in sys.argv:
        (out / "c_filters.json").write_text(json.dumps(res["results"], indent=1, default=float))
        tgt = "\n".join(f"- {'PASS' if t['pass'] else 'FAIL'} {t['target']}: {t['value']:.3g}" for t in res["targets"])
        (out / "c_filters.md").write_text("# C filters: speed and size\n\nWritten by `python -m benchmarks.c_filters`"
                                          " (module docstring: what is measured).\n" + res["markdown"]
                                          + f"\n\nTargets (every numba kernel within {WITHIN}x of its C port's time, "
                                          "double, -O2, no fast-math; the libm column runs the same "
                                          "operations as the kernel):\n\n" + tgt + "\n")
    print(res["markdown"])
