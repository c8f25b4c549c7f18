"""Time series of a filter run for the reports: which recording is worst, and the ``traces.json`` document.

Errors are shown as **heading and inclination error**, as BROAD does (Laidig et al. 2021, "BROAD - A
Benchmark for Robust Inertial Orientation Estimation", Data 6(7):72, section 4; the same split is used
by VQF, Laidig & Seel 2023): with ``q_err = q_est * conj(q_true)`` in the earth frame (z vertical),

- **inclination error** = the angle between the estimated and the true vertical axis (seen from the
  sensor), ``2 acos(sqrt(w^2 + z^2))``: roll and pitch errors together, in [0, 180] deg;
- **heading error** = the remaining rotation about the vertical, ``2 atan(|z / w|)``, in [0, 180] deg.

Unlike roll/pitch/yaw differences these do not jump at +-180 deg and do not depend on the Euler
convention (:func:`objectives.attitude.metrics.broad_error_angles` computes them; tests check them against
the closed form of a rotation about the vertical followed by a tilt).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["error_angles_deg", "recording_score", "worst_first", "traces_doc", "POINTS"]

#: samples per plotted series (every k-th sample; the page stays a few MB for the 16 BROAD trials)
POINTS = 1500


def error_angles_deg(q_est: np.ndarray, q_true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heading and inclination error (deg), each (N,), of estimates against truth (both (N, 4), w first)."""
    from objectives.attitude.metrics import broad_error_angles

    a = broad_error_angles(np.asarray(q_est, float), np.asarray(q_true, float))
    return np.degrees(a.heading_rad), np.degrees(a.inclination_rad)


def recording_score(metrics: Mapping[str, float], metric: str) -> tuple[float, str]:
    """The per-recording number that ranks recordings for ``metric``, and how to name it.

    ``broad_*``: BROAD total RMSE; ``euler_*``: mean of the roll, pitch and yaw RMSE; ``mse_1d``: that
    MSE. NaN (sorted last) when the recording has no such number (no truth).
    """
    if metric == "mse_1d" and "mse_1d" in metrics:
        return float(metrics["mse_1d"]), "MSE (rad^2)"
    if metric.startswith("euler") and all(f"{a}_rmse_deg" in metrics for a in ("roll", "pitch", "yaw")):
        return float(np.mean([metrics[f"{a}_rmse_deg"] for a in ("roll", "pitch", "yaw")])), \
            "mean roll/pitch/yaw RMSE (deg)"
    if "total_rmse_deg" in metrics:
        return float(metrics["total_rmse_deg"]), "total RMSE (deg)"
    return math.nan, ""


def worst_first(scored: list[tuple[str, str, Mapping[str, float]]], metric: str) -> list[int]:
    """Indices of ``scored`` ((split, name, metrics) per recording) from the worst score to the best.

    Ties and recordings without a score keep their order, after the scored ones.
    """
    keys = [recording_score(m, metric)[0] for _, _, m in scored]
    return sorted(range(len(scored)), key=lambda i: (not np.isfinite(keys[i]), -keys[i] if np.isfinite(keys[i])
                                                      else 0.0, i))


def _col(a: np.ndarray, step: int) -> list[Any]:
    v = np.round(np.asarray(a, float)[::step], 4)
    return [None if not np.isfinite(x) else float(x) for x in v]


def traces_doc(items: list[tuple[str, Any, Any, Mapping[str, float]]], metric: str,
               replaces: list[str] = (), points: int = POINTS) -> dict[str, Any]:
    """The ``traces.json`` document (:mod:`tuner.interactive`) of recordings, worst first.

    ``items``: (split, recording, filter result, metrics) per recording, in any order.
    """
    from objectives.attitude.quaternion import euler_zyx

    order = worst_first([(s, r.name, m) for s, r, _, m in items], metric)
    out = []
    for i in order:
        split, rec, res, m = items[i]
        step = max(1, math.ceil(rec.n / points))
        est = np.degrees(euler_zyx(res.quat[::step]))
        tru = np.degrees(euler_zyx(rec.quat[::step])) if rec.quat is not None else None
        panels = []
        for j, ax in enumerate(("roll", "pitch", "yaw")):
            series = [{"name": "truth", "y": _col(tru[:, j], 1), "color": "#222"}] if tru is not None else []
            series.append({"name": "estimate", "y": _col(est[:, j], 1), "color": "#d62728"})
            panels.append({"title": ax, "unit": "deg", "series": series})
        if rec.quat is not None:
            head, incl = error_angles_deg(res.quat[::step], rec.quat[::step])
            panels.append({"title": "heading error", "unit": "deg",
                           "series": [{"name": "heading error", "y": _col(head, 1), "color": "#1f77b4"}]})
            panels.append({"title": "inclination error", "unit": "deg",
                           "series": [{"name": "inclination error", "y": _col(incl, 1), "color": "#2ca02c"}]})
        score, what = recording_score(m, metric)
        label = f"{split}: {rec.name}" + (f" ({what} {score:.4g})" if np.isfinite(score) else "")
        out.append({"name": rec.name, "label": label, "x": _col(rec.time, step), "panels": panels})
    worst = out[0]["name"] if out else ""
    what0 = recording_score(items[order[0]][3], metric)[1] if items else ""
    return {"title": "Estimate vs truth, heading and inclination error", "x_label": "time (s)",
            "select_label": "recording",
            "note": (f"Recordings from the worst to the best ({what0 or 'score'} of the best "
                     f"parameters); the page opens on the worst, {worst}. Heading error: the rotation about the "
                     "vertical; inclination error: the angle between the estimated and the true vertical "
                     "(BROAD's definition; neither wraps at +-180 deg)."),
            "replaces": list(replaces), "items": out}
