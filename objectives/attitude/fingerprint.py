"""The sensor fingerprint of a run's tuning data, and its comparison with new data.

Tuned filter parameters hold for the sensor they were tuned on: gains and noise covariances are
matched to its sampling rate and noise levels, magnetic rejection thresholds to its field, adaptive
rules to its range of motion. A run stores the statistics below (``fingerprint.json``); ``tuner
evaluate --data``, ``tuner verify-c --data``, ``AttitudeFilter.from_run`` (with ``data=``) and
``stream()`` compare new data with them and warn in one line when a statistic lies beyond its
threshold (:data:`THRESHOLDS`).

Statistics (the median over recordings of each recording's value):

- ``rate_hz``: 1 / dt.
- ``gyr_noise``, ``acc_noise``: the white-noise standard deviation at rest (rad/s, m/s^2, the mean over
  axes), estimated as std(x[k+1] - x[k]) / sqrt(2) over pairs of rest samples: for x = s + n with a slowly
  varying s and white n of deviation sigma, the difference has deviation sqrt(2) sigma, so the estimate
  needs no trend removal. Rest: |gyr| < ``REST_GYR`` and ||acc| - g| < ``REST_ACC``.
- ``mag_norm``: the median |mag| (the loader's unit); ``mag_dip_deg``: the median dip angle
  asin(-(acc . mag) / (|acc| |mag|)) at rest, where the accelerometer measures gravity's reaction
  (up, in ENU and NED alike), so a field pointing down has a positive dip.
- ``gyr_p95_dps``: the 95th percentile of |gyr| in deg/s (the range of motion).

Recordings read with an ``align:`` block also keep their estimates (``alignment``), printed at the
run's start.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

G = 9.81
REST_GYR = 0.05  #: rad/s (about 3 deg/s): a hand-held or mounted IMU at rest stays below it
REST_ACC = 0.3  #: m/s^2 from g
MIN_REST = 50  #: rest samples needed for the noise and dip estimates

#: ``name: (kind, limit, why)``: ``ratio`` warns when new/stored lies outside [1/limit, limit], ``abs`` when
#: |new - stored| > limit.
THRESHOLDS: dict[str, tuple[str, float, str]] = {
    "rate_hz": ("ratio", 1.2, "per-sample gains and discretised time constants scale with the rate"),
    "gyr_noise": ("ratio", 2.0, "a factor 2 in deviation is 4 in variance: tuned noise covariances mis-scaled"),
    "acc_noise": ("ratio", 2.0, "a factor 2 in deviation is 4 in variance: tuned noise covariances mis-scaled"),
    "mag_norm": ("ratio", 1.25, "magnetic rejection compares the norm with the reference field's"),
    "mag_dip_deg": ("abs", 10.0, "VQF's dip rejection threshold (magDipTh) is 10 deg"),
    "gyr_p95_dps": ("ratio", 3.0, "adaptive gains and rest detection were tuned on this range of motion"),
}
UNITS = {"rate_hz": " Hz", "gyr_noise": " rad/s", "acc_noise": " m/s^2", "mag_norm": "", "mag_dip_deg": " deg",
         "gyr_p95_dps": " deg/s"}


def _rest(rec: Any) -> np.ndarray:
    gyr, acc = np.asarray(rec.gyr, float), np.asarray(rec.acc, float)
    return (np.linalg.norm(gyr, axis=1) < REST_GYR) & (np.abs(np.linalg.norm(acc, axis=1) - G) < REST_ACC)


def _noise(x: np.ndarray, rest: np.ndarray) -> float | None:
    pair = rest[1:] & rest[:-1]
    if int(pair.sum()) < MIN_REST:
        return None
    d = np.diff(np.asarray(x, float), axis=0)[pair]
    return float(np.mean(np.std(d, axis=0)) / math.sqrt(2.0))


def recording_stats(rec: Any) -> dict[str, float | None]:
    """The statistics of one recording (module docstring); ``None`` where it has no estimate."""
    rest = _rest(rec)
    out: dict[str, float | None] = {"rate_hz": 1.0 / float(rec.dt), "gyr_noise": _noise(rec.gyr, rest),
                                    "acc_noise": _noise(rec.acc, rest), "mag_norm": None, "mag_dip_deg": None,
                                    "gyr_p95_dps": float(np.percentile(np.degrees(np.linalg.norm(rec.gyr, axis=1)),
                                                                       95))}
    if rec.mag is not None:
        mag = np.asarray(rec.mag, float)
        norm = np.linalg.norm(mag, axis=1)
        ok = np.isfinite(norm) & (norm > 0)
        out["mag_norm"] = float(np.median(norm[ok])) if ok.any() else None
        r = rest & ok
        if int(r.sum()) >= MIN_REST:
            acc = np.asarray(rec.acc, float)[r]
            s = -np.sum(acc * mag[r], axis=1) / (np.linalg.norm(acc, axis=1) * norm[r])
            out["mag_dip_deg"] = float(np.degrees(np.arcsin(np.clip(np.median(s), -1.0, 1.0))))
    return out


def fingerprint(recordings: Iterable[Any]) -> dict[str, Any]:
    """The fingerprint of ``recordings``: ``{"stats": {name: median or None}, "thresholds": ...,
    "recordings": {name: stats}, "alignment": {name: estimates}}``."""
    recs = list(recordings)
    per = {r.name: recording_stats(r) for r in recs}
    stats: dict[str, float | None] = {}
    for key in THRESHOLDS:
        vals = [v[key] for v in per.values() if v[key] is not None and math.isfinite(v[key])]
        stats[key] = float(np.median(vals)) if vals else None
    align = {r.name: _alignment(r.meta["alignment"]) for r in recs
             if isinstance(getattr(r, "meta", None), Mapping) and r.meta.get("alignment")}
    doc = {"stats": stats, "thresholds": {k: {"kind": t[0], "limit": t[1], "why": t[2]} for k, t in THRESHOLDS.items()},
           "recordings": per, **({"alignment": align} if align else {})}
    return {**doc, "summary": start_lines(doc)}


#: the alignment estimates a run prints at its start (all are stored)
ALIGN_SHOWN = {"lag_s": " s", "body_angle_deg": " deg", "heading_offset_deg": " deg", "frame_tilt_deg": " deg",
               "gyro_scale": ""}


def _alignment(a: Any) -> dict[str, Any]:
    """An ``align:`` block's estimates (:class:`objectives.attitude.data.alignment.Alignment`) as plain data."""
    return dict(a.as_dict()) if hasattr(a, "as_dict") else dict(a)


def _beyond(key: str, old: float, new: float) -> bool:
    kind, limit, _ = THRESHOLDS[key]
    if kind == "abs":
        return abs(new - old) > limit
    if old <= 0 or new <= 0:
        return old != new
    return not (1.0 / limit <= new / old <= limit)


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def compare(stored: Mapping[str, Any] | None, new: Mapping[str, Any]) -> str | None:
    """One warning line naming every statistic of ``new`` beyond its threshold from ``stored`` (both
    :func:`fingerprint` documents), or ``None`` when all agree (or nothing is stored)."""
    if not stored:
        return None
    old_s, new_s = stored.get("stats") or {}, new.get("stats") or {}
    diffs = []
    for key, (kind, limit, _) in THRESHOLDS.items():
        o, n = old_s.get(key), new_s.get(key)
        if o is None or n is None or not _beyond(key, float(o), float(n)):
            continue
        bound = f"+-{limit:g}{UNITS[key]}" if kind == "abs" else f"x{limit:g}"
        diffs.append(f"{key} {_fmt(n)}{UNITS[key]} vs {_fmt(o)}{UNITS[key]} ({bound})")
    if not diffs:
        return None
    return ("the data differs from the sensor the run was tuned on (tuned values may not hold): " + "; ".join(diffs)
            + " [thresholds: objectives.attitude.fingerprint.THRESHOLDS]")


def rate_warning(stored: Mapping[str, Any] | None, rate_hz: float | None) -> str | None:
    """:func:`compare` for a stream, which knows only its rate before the first sample."""
    if not stored or not rate_hz:
        return None
    return compare(stored, {"stats": {"rate_hz": float(rate_hz)}})


def start_lines(fp: Mapping[str, Any]) -> list[str]:
    """What a run prints at its start: the statistics and any alignment estimates."""
    s = fp.get("stats") or {}
    parts = [f"{k} {_fmt(v)}{UNITS[k]}" for k, v in s.items() if v is not None]
    lines = ["sensor fingerprint: " + ", ".join(parts)]
    for name, a in (fp.get("alignment") or {}).items():
        shown = [f"{k} {_fmt(float(a[k]))}{u}" for k, u in ALIGN_SHOWN.items()
                 if isinstance(a.get(k), (int, float)) and math.isfinite(float(a[k]))]
        lines.append(f"alignment {name}: " + ", ".join(shown))
    return lines


def stored(run_dir: Any) -> dict[str, Any] | None:
    """The fingerprint a run stored (``None`` for a run without one, e.g. from an older tuner)."""
    from tuner.rundir import RunDir

    return RunDir(run_dir).fingerprint()


def warn_filter(flt: Any, rec: Any = None, dt: float | None = None) -> str | None:
    """For a filter built by ``from_run`` (which keeps the run's fingerprint as ``tuned_on``): one
    :class:`UserWarning` when ``rec`` (``run()``'s data) or ``dt`` (a stream's sample time, all it knows
    before its first sample) differs from the tuning data beyond :data:`THRESHOLDS`. Returns the line."""
    import warnings

    fp = getattr(flt, "tuned_on", None)
    if not fp:
        return None
    if rec is not None:
        line = compare(fp, fingerprint([rec]))
    else:
        line = rate_warning(fp, 1.0 / dt if dt else None)
    if line:
        warnings.warn(f"{flt.name}: {line}", UserWarning, stacklevel=3)
    return line
