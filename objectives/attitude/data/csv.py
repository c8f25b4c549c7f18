"""CSV recordings with a column map (inline or in a YAML file).

A column map names the CSV columns of each signal::

    columns:
      time: t                      # optional; else give rate_hz (or dt)
      gyr: [gx, gy, gz]
      acc: [ax, ay, az]
      mag: [mx, my, mz]            # optional
      quat: [qw, qx, qy, qz]       # optional truth, (w, x, y, z) order of the columns listed
      motion: moving               # optional; non-zero = metrics use the sample
    gyr_unit: deg/s                # rad/s (default) | deg/s
    acc_unit: g                    # m/s^2 (default) | g
    mag_unit: uT                   # any label; filters normalise mag
    time_unit: ms                  # s (default) | ms | us | ns
    frame: NED                     # earth frame of the truth: ENU (default) | NED
    quat_convention: earth_to_sensor   # sensor_to_earth (default) | earth_to_sensor (conjugated on load)

Every error names the file and the column (and the first bad row, counted from 1 after the header).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.data.recording import Recording, RecordingError

__all__ = ["load_csv", "GYR_UNITS", "ACC_UNITS", "TIME_UNITS", "CSV_OPTIONS", "RATE_RANGE_HZ", "csv_keys"]

#: gyr unit -> factor to rad/s
GYR_UNITS = {"rad/s": 1.0, "deg/s": np.pi / 180.0, "dps": np.pi / 180.0}
#: acc unit -> factor to m/s^2 (standard gravity for "g")
ACC_UNITS = {"m/s^2": 1.0, "m/s2": 1.0, "g": 9.80665}
#: time unit -> factor to s
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
_SIGNALS = {"gyr": 3, "acc": 3, "mag": 3, "quat": 4, "time": 1, "motion": 1}
#: options accepted next to ``columns`` (by :func:`load_csv` and in a YAML column map)
CSV_OPTIONS = (
    "gyr_unit", "acc_unit", "mag_unit", "time_unit", "rate_hz", "dt", "frame", "name",
    "quat_convention", "delimiter", "jitter_tol",
)


def csv_keys() -> list[dict[str, Any]]:
    """Every key of a ``csv:`` data spec with its default and its allowed values (``tuner describe csv``)."""
    def one_of(table: Mapping[str, Any]) -> str:
        return "one of " + ", ".join(table)

    return [
        {"name": "path", "default": None, "doc": "the CSV file (header row of column names), relative to the config"},
        {"name": "columns", "default": None,
         "doc": "column map, inline or a YAML file: signal -> column name(s); signals "
                + ", ".join(f"{k} ({n})" for k, n in _SIGNALS.items()) + "; gyr and acc required"},
        {"name": "gyr_unit", "default": "rad/s", "doc": f"{one_of(GYR_UNITS)} (converted to rad/s)"},
        {"name": "acc_unit", "default": "m/s^2", "doc": f"{one_of(ACC_UNITS)} (g = 9.80665 m/s^2)"},
        {"name": "mag_unit", "default": "1", "doc": "any label (filters normalise mag; values not converted)"},
        {"name": "time_unit", "default": "s",
         "doc": f"{one_of(TIME_UNITS)}; the stamps must imply {RATE_RANGE_HZ[0]:g} Hz to "
                f"{RATE_RANGE_HZ[1] / 1e3:g} kHz"},
        {"name": "rate_hz", "default": None, "doc": "a number > 0 (Hz): without a time column (or checked against it)"},
        {"name": "dt", "default": None, "doc": "a number > 0 (s): without a time column, instead of rate_hz"},
        {"name": "frame", "default": "ENU", "doc": "earth frame of the truth: ENU or NED"},
        {"name": "name", "default": None, "doc": "recording name (default: the file stem)"},
        {"name": "quat_convention", "default": "sensor_to_earth",
         "doc": "sensor_to_earth or earth_to_sensor (conjugated on load)"},
        {"name": "delimiter", "default": ",", "doc": "field separator, e.g. ',' ';' or '\\t'"},
        {"name": "jitter_tol", "default": 0.05, "doc": "a number > 0: allowed deviation of a time step from the "
                                                        "mean, as a fraction of it"},
    ]


def _column_names(path: Path, signal: str, spec: Any, ncols: int) -> list[str]:
    names = [spec] if isinstance(spec, str) else spec
    if not isinstance(names, (list, tuple)) or not all(isinstance(c, str) for c in names):
        raise RecordingError(f"{path}: column map for {signal!r} must list column names, got {spec!r}")
    if len(names) != ncols:
        raise RecordingError(f"{path}: column map for {signal!r} needs {ncols} column(s), got {list(names)}")
    return list(names)


def _unit(path: Path, what: str, unit: str, table: Mapping[str, float]) -> float:
    try:
        return table[str(unit).strip()]
    except KeyError:
        raise RecordingError(f"{path}: {what} {unit!r} is not one of {sorted(table)}") from None


#: sampling rates (Hz) a time column may imply; outside them the time unit is wrong
RATE_RANGE_HZ = (1.0, 100e3)


def _check_time_rate(path: Path, column: str, t: np.ndarray, time_unit: str) -> None:
    """``RecordingError`` naming ``time_unit`` when the median step of ``t`` (s) implies a rate outside
    :data:`RATE_RANGE_HZ` (e.g. millisecond stamps read as seconds: 0.29 Hz instead of 286 Hz)."""
    steps = np.diff(t)
    steps = steps[steps > 0]
    if steps.size == 0:
        return  # non-increasing time: Recording.from_time says so
    rate = 1.0 / float(np.median(steps))
    lo, hi = RATE_RANGE_HZ
    if lo <= rate <= hi:
        return
    fits = [u for u, f in TIME_UNITS.items() if lo <= rate * TIME_UNITS[time_unit] / f <= hi]
    hint = (f"; with time_unit {fits[0]!r} it would be {rate * TIME_UNITS[time_unit] / TIME_UNITS[fits[0]]:.4g} Hz"
            if fits else "")
    raise RecordingError(f"{path}: time_unit: {time_unit!r} makes the time column {column!r} imply {rate:.4g} Hz, "
                         f"outside {lo:g} Hz to {hi / 1e3:g} kHz; allowed time_unit values: "
                         f"{', '.join(TIME_UNITS)} (the unit of the time stamps){hint}")


def load_csv(
    path: str | Path,
    columns: Mapping[str, Any],
    *,
    gyr_unit: str = "rad/s",
    acc_unit: str = "m/s^2",
    mag_unit: str = "1",
    time_unit: str = "s",
    rate_hz: float | None = None,
    dt: float | None = None,
    frame: str = "ENU",
    name: str | None = None,
    quat_convention: str = "sensor_to_earth",
    delimiter: str = ",",
    jitter_tol: float = 0.05,
) -> Recording:
    """Read a CSV file with a header row into a :class:`Recording`.

    Parameters
    ----------
    path : path
        The CSV file (first row: column names).
    columns : mapping
        Signal -> column name(s): ``gyr``, ``acc`` (3 each, required), ``mag`` (3), ``quat`` (4,
        w, x, y, z), ``time`` (1), ``motion`` (1). Extra columns of the file are ignored.
    gyr_unit, acc_unit, time_unit : str
        Units of the columns, converted to rad/s, m/s^2 and s (see ``GYR_UNITS`` etc.).
    mag_unit : str
        Label stored in ``Recording.units``; magnetometer values are not converted.
    rate_hz, dt : float, optional
        Sampling rate or sample time when there is no ``time`` column (give one of them). With a
        ``time`` column, ``rate_hz`` is checked against the stamps (1 % tolerance).
    frame : {"ENU", "NED"}
        Earth frame of the truth quaternions.
    name : str, optional
        Recording name; default the file stem.
    quat_convention : {"sensor_to_earth", "earth_to_sensor"}
        What the truth columns describe; earth-to-sensor quaternions are conjugated on load.
    delimiter : str
        Field separator.
    jitter_tol : float
        Allowed deviation of a time interval from the mean ``dt``, as a fraction of ``dt``.

    Raises
    ------
    RecordingError
        Missing file or column (with the columns present), non-numeric cells, NaN in gyr/acc/mag
        (with the column and row), unknown units, non-monotonic or non-uniform time stamps.
    """
    import pandas as pd

    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: file not found")
    if not isinstance(columns, Mapping):
        raise RecordingError(
            f"{path}: 'columns' must map signals to column names, got {type(columns).__name__}"
        )
    unknown = sorted(set(columns) - set(_SIGNALS))
    if unknown:
        raise RecordingError(
            f"{path}: unknown signal(s) {unknown} in the column map; allowed: {sorted(_SIGNALS)}"
        )
    for req in ("gyr", "acc"):
        if req not in columns:
            raise RecordingError(f"{path}: the column map needs {req!r} (3 column names)")
    gyr_f = _unit(path, "gyr_unit", gyr_unit, GYR_UNITS)
    acc_f = _unit(path, "acc_unit", acc_unit, ACC_UNITS)
    time_f = _unit(path, "time_unit", time_unit, TIME_UNITS)
    if quat_convention not in ("sensor_to_earth", "earth_to_sensor"):
        raise RecordingError(
            f"{path}: quat_convention must be 'sensor_to_earth' or 'earth_to_sensor', got {quat_convention!r}"
        )
    if isinstance(jitter_tol, bool) or not isinstance(jitter_tol, (int, float)) or not jitter_tol > 0:
        raise RecordingError(f"{path}: jitter_tol must be a number > 0 (a fraction of the mean time step), "
                             f"got {jitter_tol!r}")
    wanted = {sig: _column_names(path, sig, spec, _SIGNALS[sig]) for sig, spec in columns.items()}
    try:
        df = pd.read_csv(path, sep=delimiter, skipinitialspace=True)
    except Exception as exc:  # pandas raises several parser/IO error types
        raise RecordingError(f"{path}: cannot read as CSV ({type(exc).__name__}: {exc})") from None
    df.columns = [str(c).strip() for c in df.columns]
    present = list(df.columns)
    for sig, names in wanted.items():
        for c in names:
            if c not in present:
                raise RecordingError(f"{path}: column {c!r} (for {sig!r}) not found; the file has {present}")
    if len(df) < 2:
        raise RecordingError(f"{path}: needs at least 2 data rows, got {len(df)}")

    def numeric(sig: str, finite: bool) -> np.ndarray:
        cols = []
        for c in wanted[sig]:
            raw = df[c]
            vals = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
            not_num = np.isnan(vals) & raw.notna().to_numpy()
            if not_num.any():
                i = int(np.argmax(not_num))
                raise RecordingError(f"{path}: column {c!r} row {i + 1}: {raw.iloc[i]!r} is not a number")
            if finite and not np.isfinite(vals).all():
                i = int(np.argmax(~np.isfinite(vals)))
                raise RecordingError(
                    f"{path}: column {c!r} ({sig}) has {int((~np.isfinite(vals)).sum())} empty or non-finite "
                    f"value(s), first at row {i + 1}"
                )
            cols.append(vals)
        return np.column_stack(cols) if len(cols) > 1 else cols[0]

    gyr = numeric("gyr", True) * gyr_f
    acc = numeric("acc", True) * acc_f
    mag = numeric("mag", True) if "mag" in wanted else None
    quat = numeric("quat", False) if "quat" in wanted else None
    if quat is not None and quat_convention == "earth_to_sensor":
        quat = quat * np.array([1.0, -1.0, -1.0, -1.0])
    motion = None
    if "motion" in wanted:
        m = numeric("motion", False)
        motion = np.nan_to_num(m, nan=0.0) != 0
    units = {"gyr": "rad/s", "acc": "m/s^2", "mag": str(mag_unit)}
    common = dict(name=name or path.stem, gyr=gyr, acc=acc, mag=mag, quat=quat, motion=motion,
                  frame=str(frame).upper(), units=units, source=str(path))
    if "time" in wanted:
        t = numeric("time", True) * time_f
        _check_time_rate(path, wanted["time"][0], t, str(time_unit).strip())
        if dt is not None:
            raise RecordingError(f"{path}: give either a 'time' column or 'dt', not both")
        return Recording.from_time(t, jitter_tol=jitter_tol, rate_hz=rate_hz, **common)
    if (rate_hz is None) == (dt is None):
        raise RecordingError(f"{path}: without a 'time' column give exactly one of 'rate_hz' or 'dt'")
    try:
        step = float(dt) if dt is not None else 1.0 / float(rate_hz)
    except (TypeError, ValueError, ZeroDivisionError):
        raise RecordingError(
            f"{path}: 'rate_hz'/'dt' must be positive numbers, got {rate_hz!r}/{dt!r}"
        ) from None
    return Recording(dt=step, **common)
