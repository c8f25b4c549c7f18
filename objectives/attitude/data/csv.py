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

File layout (:mod:`objectives.attitude.data.csv_table`)::

    delimiter: ";"                 # one character (default ",")
    header_rows: 2                 # a names row, then a units row (default 1; 0: columns col1, col2, ...)
    names_row: 1                   # which header row holds the names (default 1)
    decimal: ","                   # decimal mark (default ".")
    comment: "#"                   # lines starting with it are skipped

An empty name cell (a merged cell of a spreadsheet) takes the name to its left with ``.1``, ``.2``, ...
(``gyro;;`` gives ``gyro``, ``gyro.1``, ``gyro.2``).

Time stamps and truth (:mod:`objectives.attitude.data.timebase`)::

    max_dropped_share: 0.05        # rows whose stamp does not increase are dropped (one warning), up to this share
    resample_hz: 100               # IMU interpolated, truth by slerp, onto a uniform grid (needs a time column)
    max_truth_gap_s: 0.05          # truth rows further apart are not interpolated across (NaN there)
    quat_norm_tol: 0.1             # truth rows with | |q| - 1 | above this are NaN
    truth_rate_factor: 3.0         # truth steps faster than this times the gyroscope (+ 1 rad/s) are NaN

A log that repeats the IMU's previous sample (sample-and-hold) is detected and its IMU's own rate reported;
with ``resample_hz`` each IMU sample is used once, at its own time. ``align:`` states or estimates the truth's
lag, the IMU-to-marker rotation and the truth frame's heading (:mod:`objectives.attitude.data.alignment`).
What was dropped, set to NaN and estimated is kept in ``Recording.meta`` (``read``, ``alignment``, ``warnings``).

Every error names the file and the key or column (and the first bad row, counted from 1 after the header).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.data.alignment import AlignSpec, estimate_alignment
from objectives.attitude.data.csv_table import delimiter_hint, numeric_column, read_table
from objectives.attitude.data.recording import Recording, RecordingError
from objectives.attitude.data.timebase import (
    HOLD_SHARE,
    ReadInfo,
    held_rows,
    hold_share,
    imu_clock,
    increasing,
    median_step,
    resample_imu,
    slerp,
    truth_sanity,
)

__all__ = ["load_csv", "from_stamps", "GYR_UNITS", "ACC_UNITS", "TIME_UNITS", "CSV_OPTIONS", "RATE_RANGE_HZ",
           "csv_keys"]

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
    "quat_convention", "delimiter", "jitter_tol", "header_rows", "names_row", "decimal", "comment",
    "max_dropped_share", "resample_hz", "max_truth_gap_s", "quat_norm_tol", "truth_rate_factor", "align",
)
#: defaults of the options that shape reading (the layout ones are csv_table's)
READ_DEFAULTS = {"max_dropped_share": 0.05, "max_truth_gap_s": 0.05, "quat_norm_tol": 0.1, "truth_rate_factor": 3.0}


def csv_keys() -> list[dict[str, Any]]:
    """Every key of a ``csv:`` data spec with its default and its allowed values (``tuner describe csv``)."""
    def one_of(table: Mapping[str, Any]) -> str:
        return "one of " + ", ".join(table)

    return [
        {"name": "path", "default": None, "doc": "the CSV file (header rows: header_rows), relative to the config"},
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
        {"name": "name", "default": None, "doc": "recording name (default: the file stem, and for a window of it "
                                                 "file@start-stop)"},
        {"name": "quat_convention", "default": "sensor_to_earth",
         "doc": "sensor_to_earth or earth_to_sensor (conjugated on load)"},
        {"name": "delimiter", "default": ",", "doc": "field separator, e.g. ',' ';' or '\\t'"},
        {"name": "jitter_tol", "default": 0.05, "doc": "a number > 0: allowed deviation of a time step from the "
                                                        "mean, as a fraction of it (not with resample_hz)"},
        {"name": "header_rows", "default": 1, "doc": "an integer >= 0: rows before the data (names, units, ...); "
                                                     "0: columns are col1, col2, ..."},
        {"name": "names_row", "default": 1, "doc": "which header row holds the column names (from 1); an empty "
                                                   "name cell takes the name to its left with .1, .2, ..."},
        {"name": "decimal", "default": ".", "doc": "the decimal mark: '.' or ','"},
        {"name": "comment", "default": None, "doc": "one character: lines starting with it are skipped"},
        {"name": "max_dropped_share", "default": 0.05,
         "doc": "a number in [0, 1]: rows whose stamp does not increase are dropped with one warning, an error "
                "above this share"},
        {"name": "resample_hz", "default": None,
         "doc": "a number > 0 (Hz): IMU channels interpolated (each sample once, at its own time, when the log "
                "holds samples), truth by slerp, onto a uniform grid; needs a time column"},
        {"name": "max_truth_gap_s", "default": 0.05,
         "doc": "a number > 0 (s): truth rows further apart are not interpolated across (NaN there)"},
        {"name": "quat_norm_tol", "default": 0.1, "doc": "a number in (0, 1): truth rows with | |q| - 1 | above "
                                                        "it are NaN"},
        {"name": "truth_rate_factor", "default": 3.0,
         "doc": "a number >= 1: truth steps faster than this times the gyroscope's largest norm within 0.25 s, "
                "plus 1 rad/s, are NaN (marker swaps)"},
        {"name": "align", "default": None,
         "doc": "{lag: auto | seconds (default 0; > 0: the truth is late), body: auto | none | [w, x, y, z] "
                "(sensor-to-marker, default none), heading: start | mean | none (truth frame's offset from the "
                "IMU's gravity and field, default none), max_lag_s: 0.5}; `tuner align DATA.yaml` prints the "
                "estimates"},
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



def _check_options(path: Path, opts: Mapping[str, Any]) -> None:
    """RecordingError naming the key for a bad reading option (the values of :data:`READ_DEFAULTS`)."""
    def number(v: Any) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v)

    share, gap = opts["max_dropped_share"], opts["max_truth_gap_s"]
    tol, factor, rate = opts["quat_norm_tol"], opts["truth_rate_factor"], opts["resample_hz"]
    if not (number(share) and 0 <= share <= 1):
        raise RecordingError(f"{path}: max_dropped_share: expected a number in [0, 1] (a share of the rows), "
                             f"got {share!r}")
    if not (number(gap) and gap > 0):
        raise RecordingError(f"{path}: max_truth_gap_s: expected a number of seconds > 0, got {gap!r}")
    if not (number(tol) and 0 < tol < 1):
        raise RecordingError(f"{path}: quat_norm_tol: expected a number in (0, 1), got {tol!r}")
    if not (number(factor) and factor >= 1):
        raise RecordingError(f"{path}: truth_rate_factor: expected a number >= 1, got {factor!r}")
    if rate is not None and not (number(rate) and rate > 0):
        raise RecordingError(f"{path}: resample_hz: expected a rate in Hz > 0, got {rate!r}")


def _dropped_stamps(path: Path, t: np.ndarray, column: str, max_share: float) -> tuple[np.ndarray, list[str]]:
    """The rows to keep (stamp after every one before it) and the warning on the dropped ones."""
    keep = increasing(t)
    n_drop = int((~keep).sum())
    if not n_drop:
        return keep, []
    i = int(np.argmax(~keep))
    share = n_drop / t.shape[0]
    rows = f"{n_drop} of {t.shape[0]} rows ({100 * share:.3g} %)"
    first = f"(first at row {i + 1}: {t[i]:.6g} s after {t[:i].max():.6g} s)"
    if share > max_share:
        raise RecordingError(f"{path}: time: {rows} have a stamp not after the one before them {first}; more than "
                             f"max_dropped_share ({max_share:g}) allows: is {column!r} the time column, are the rows "
                             "in order?")
    return keep, [f"{path}: dropped {rows} whose stamp is not after the one before them {first}"]


def _hint_uniform(exc: RecordingError, imu_rate: float | None, warnings: list[str]) -> RecordingError:
    """``exc`` of non-uniform stamps with the options that read such a file, and the rows dropped before."""
    msg = str(exc)
    if "not uniformly sampled" not in msg:
        return exc
    own = f" (the IMU's own rate is {imu_rate:.4g} Hz)" if imu_rate else ""
    dropped = [w.split(": ", 1)[1] for w in warnings if ": dropped " in w]
    return RecordingError(msg.replace("resample the recording first", f"set resample_hz{own} or raise jitter_tol")
                          + (f" ({dropped[0]})" if dropped else ""))


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
    header_rows: int = 1,
    names_row: int = 1,
    decimal: str = ".",
    comment: str | None = None,
    max_dropped_share: float = READ_DEFAULTS["max_dropped_share"],
    resample_hz: float | None = None,
    max_truth_gap_s: float = READ_DEFAULTS["max_truth_gap_s"],
    quat_norm_tol: float = READ_DEFAULTS["quat_norm_tol"],
    truth_rate_factor: float = READ_DEFAULTS["truth_rate_factor"],
    align: Mapping[str, Any] | None = None,
) -> Recording:
    """Read a CSV file into a :class:`Recording` (options in the module docstring).

    Parameters
    ----------
    path : path
        The CSV file.
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
        Earth frame of the truth quaternions (and of the IMU's gravity and field for ``align.heading``).
    name : str, optional
        Recording name; default the file stem.
    quat_convention : {"sensor_to_earth", "earth_to_sensor"}
        What the truth columns describe; earth-to-sensor quaternions are conjugated on load.
    delimiter, header_rows, names_row, decimal, comment
        The file's layout (:mod:`objectives.attitude.data.csv_table`).
    jitter_tol : float
        Allowed deviation of a time interval from the mean ``dt``, as a fraction of ``dt`` (without
        ``resample_hz``).
    max_dropped_share, resample_hz, max_truth_gap_s, quat_norm_tol, truth_rate_factor
        Stamps, resampling and truth sanity (:mod:`objectives.attitude.data.timebase`).
    align : mapping, optional
        ``{lag, body, heading, max_lag_s}`` (:mod:`objectives.attitude.data.alignment`).

    Raises
    ------
    RecordingError
        Naming the file and the key or column: a missing file or column (with the columns present), non-numeric
        cells, NaN in gyr/acc/mag (with the row), unknown units or options, too many stamps that do not increase,
        non-uniform stamps without ``resample_hz``, an alignment the data do not determine.
    """
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
    _check_options(path, {"max_dropped_share": max_dropped_share, "max_truth_gap_s": max_truth_gap_s,
                          "quat_norm_tol": quat_norm_tol, "truth_rate_factor": truth_rate_factor,
                          "resample_hz": resample_hz})
    spec = None if align is None else AlignSpec.from_config(align, f"{path}: align")
    wanted = {sig: _column_names(path, sig, cols, _SIGNALS[sig]) for sig, cols in columns.items()}
    if spec is not None and "quat" not in wanted:
        raise RecordingError(f"{path}: align: needs the truth (a 'quat' column map)")
    if resample_hz is not None and "time" not in wanted:
        raise RecordingError(f"{path}: resample_hz: needs a 'time' column (the stamps to resample from)")
    table = read_table(path, delimiter=delimiter, header_rows=header_rows, names_row=names_row, decimal=decimal,
                       comment=comment)
    for sig, names in wanted.items():
        for c in names:
            if c not in table.names:
                raise RecordingError(f"{path}: column {c!r} (for {sig!r}) not found; the file has {table.names}"
                                     + delimiter_hint(table, delimiter))
    if len(table) < 2:
        raise RecordingError(f"{path}: needs at least 2 data rows, got {len(table)}")

    def numeric(sig: str, finite: bool) -> np.ndarray:
        cols = []
        for c in wanted[sig]:
            vals, bad = numeric_column(table, c)
            if bad >= 0:
                raise RecordingError(f"{path}: column {c!r} row {bad + 1}: {table.frame[c].iloc[bad]!r} is not a "
                                     "number")
            if finite and not np.isfinite(vals).all():
                i = int(np.argmax(~np.isfinite(vals)))
                raise RecordingError(
                    f"{path}: column {c!r} ({sig}) has {int((~np.isfinite(vals)).sum())} empty or non-finite "
                    f"value(s), first at row {i + 1}"
                )
            cols.append(vals)
        return np.column_stack(cols) if len(cols) > 1 else cols[0]

    sig = {"gyr": numeric("gyr", True) * gyr_f, "acc": numeric("acc", True) * acc_f,
           "mag": numeric("mag", True) if "mag" in wanted else None,
           "quat": numeric("quat", False) if "quat" in wanted else None, "motion": None}
    if sig["quat"] is not None and quat_convention == "earth_to_sensor":
        sig["quat"] = sig["quat"] * np.array([1.0, -1.0, -1.0, -1.0])
    if "motion" in wanted:
        sig["motion"] = np.nan_to_num(numeric("motion", False), nan=0.0) != 0
    common = dict(name=name or path.stem, frame=str(frame).upper(), source=str(path),
                  units={"gyr": "rad/s", "acc": "m/s^2", "mag": str(mag_unit)})
    if "time" in wanted:
        t = numeric("time", True) * time_f
        _check_time_rate(path, wanted["time"][0], t, str(time_unit).strip())
        if dt is not None:
            raise RecordingError(f"{path}: give either a 'time' column or 'dt', not both")
        if rate_hz is not None and resample_hz is not None:
            raise RecordingError(f"{path}: rate_hz: not with resample_hz (the rate is resample_hz's)")
        return from_stamps(path, t, sig, common, wanted["time"][0], spec, jitter_tol=jitter_tol, rate_hz=rate_hz,
                            max_dropped_share=max_dropped_share, resample_hz=resample_hz,
                            max_truth_gap_s=max_truth_gap_s, quat_norm_tol=quat_norm_tol,
                            truth_rate_factor=truth_rate_factor)
    if (rate_hz is None) == (dt is None):
        raise RecordingError(f"{path}: without a 'time' column give exactly one of 'rate_hz' or 'dt'")
    try:
        step = float(dt) if dt is not None else 1.0 / float(rate_hz)
    except (TypeError, ValueError, ZeroDivisionError):
        raise RecordingError(
            f"{path}: 'rate_hz'/'dt' must be positive numbers, got {rate_hz!r}/{dt!r}"
        ) from None
    if not (np.isfinite(step) and step > 0):
        raise RecordingError(f"{path}: 'rate_hz'/'dt' must be positive numbers, got {rate_hz!r}/{dt!r}")
    t = np.arange(sig["gyr"].shape[0]) * step
    return from_stamps(path, t, sig, common, "", spec, jitter_tol=jitter_tol, rate_hz=None,
                        max_dropped_share=max_dropped_share, resample_hz=None, max_truth_gap_s=max_truth_gap_s,
                        quat_norm_tol=quat_norm_tol, truth_rate_factor=truth_rate_factor, step=step)


def from_stamps(path: Path, t: np.ndarray, sig: dict, common: dict, column: str, spec: AlignSpec | None, *,
                jitter_tol: float, rate_hz: float | None, max_dropped_share: float, resample_hz: float | None,
                max_truth_gap_s: float, quat_norm_tol: float, truth_rate_factor: float,
                step: float | None = None, warnings: list[str] | None = None,
                meta: Mapping[str, Any] | None = None) -> Recording:
    """The recording of the signals ``sig`` (rows at stamps ``t``, s): stamps cleaned, sample-and-hold found,
    resampled, truth checked and aligned (:mod:`objectives.attitude.data.timebase`); ``step`` is the stated
    sample time of a file without a time column. Also the ROS bag reader's (:mod:`objectives.attitude.data.rosbag`):
    ``warnings`` of its own reading come first, ``meta`` joins the recording's."""
    rows = t.shape[0]
    keep, dropped = _dropped_stamps(path, t, column, max_dropped_share) if column else (np.ones(rows, bool), [])
    warnings = list(warnings or []) + dropped
    t = t[keep]
    sig = {k: (None if v is None else v[keep]) for k, v in sig.items()}
    imu = np.column_stack([sig["gyr"], sig["acc"]] + ([sig["mag"]] if sig["mag"] is not None else []))
    held = held_rows(imu)
    share = hold_share(held, np.linalg.norm(sig["gyr"], axis=1))
    hold = share > HOLD_SHARE
    t_imu, period = imu_clock(t, held, hold)
    hold = t_imu.shape[0] != t.shape[0]
    log_rate = 1.0 / median_step(t)
    imu_rate = 1.0 / period
    if hold:
        fix = ("; each IMU sample is used once, at its own time" if resample_hz is not None else
               f"; set resample_hz (e.g. {imu_rate:.0f}) to use each sample once, at its own time")
        warnings.append(f"{path}: {int(held.sum())} of {t.shape[0]} rows ({100 * held.mean():.3g} %; "
                        f"{100 * share:.3g} % of those in motion, more than {100 * HOLD_SHARE:g} %) repeat the "
                        f"previous IMU sample: the IMU runs at {imu_rate:.4g} Hz, the log at {log_rate:.4g} Hz{fix}")
    quat, n_norm, n_rate = sig["quat"], 0, 0
    if quat is not None:
        quat, n_norm, n_rate = truth_sanity(t, quat, np.linalg.norm(sig["gyr"], axis=1), quat_norm_tol,
                                            truth_rate_factor)
        have = int(np.isfinite(sig["quat"]).all(axis=1).sum())
        if have and n_norm > 0.5 * have:
            raise RecordingError(f"{path}: quat: {n_norm} of {have} truth rows have a norm outside 1 +- "
                                 f"{quat_norm_tol:g}: are the columns a unit quaternion (w, x, y, z)?")
        if have and n_rate > 0.5 * have:
            raise RecordingError(f"{path}: quat: {n_rate} of {have} truth rows turn more than {truth_rate_factor:g} "
                                 "times faster than the gyroscope: check gyr_unit and time_unit")
        for n, why in ((n_norm, f"a norm outside 1 +- {quat_norm_tol:g} (quat_norm_tol)"),
                       (n_rate, f"a step more than {truth_rate_factor:g} times faster than the gyroscope "
                                "(truth_rate_factor)")):
            if n:
                warnings.append(f"{path}: {n} truth row(s) set to NaN: {why}")
    if resample_hz is not None:
        sel = ~held if hold else np.ones(t.shape[0], bool)
        grid, cols = resample_imu(t_imu, period, {k: (None if sig[k] is None else sig[k][sel])
                                                  for k in ("gyr", "acc", "mag", "motion")}, float(resample_hz))
        gap = float(np.max(np.diff(t_imu)))
        if gap > 5 * period:
            warnings.append(f"{path}: the IMU has a gap of {gap:.3g} s ({gap / period:.3g} samples), interpolated "
                            "linearly by resample_hz")
    else:
        grid, cols, gap = t, {k: sig[k] for k in ("gyr", "acc", "mag", "motion")}, float(np.max(np.diff(t)))
    alignment, n_gap = None, 0
    truth = quat
    if quat is not None and (spec is not None or resample_hz is not None):
        if spec is not None:
            try:
                alignment = estimate_alignment(grid, cols["gyr"], cols["acc"], cols["mag"], t, quat, spec,
                                               common["frame"], max_truth_gap_s, where=f"{path}: align")
            except ValueError as exc:  # RecordingError, or a frame the triad refuses
                raise RecordingError(str(exc) if str(exc).startswith(str(path)) else f"{path}: align: {exc}") \
                    from None
            truth = alignment.truth(grid, t, quat, max_truth_gap_s)
            lagged = grid + alignment.lag_s
        else:
            truth, lagged = slerp(t, quat, grid, max_truth_gap_s), grid
        n_gap = int((~np.isfinite(truth).all(axis=1) & np.isfinite(slerp(t, quat, lagged)).all(axis=1)).sum())
        if n_gap:
            warnings.append(f"{path}: {n_gap} truth sample(s) NaN: between truth rows more than max_truth_gap_s "
                            f"({max_truth_gap_s:g} s) apart")
    info = ReadInfo(rows=rows, dropped_stamps=int((~keep).sum()), held_rows=int(held.sum()),
                    log_rate_hz=float(log_rate), imu_rate_hz=float(imu_rate),
                    resampled_hz=None if resample_hz is None else float(resample_hz), largest_imu_gap_s=gap,
                    truth_nan_norm=n_norm, truth_nan_rate=n_rate, truth_nan_gap=n_gap, start_s=float(grid[0]))
    meta = {**(meta or {}), "read": info, "warnings": warnings,
            **({"alignment": alignment} if alignment is not None else {})}
    signals = dict(gyr=cols["gyr"], acc=cols["acc"], mag=cols["mag"], quat=truth, motion=cols["motion"])
    if resample_hz is not None:
        return Recording(dt=1.0 / float(resample_hz), meta=meta, **signals, **common)
    if step is not None:
        return Recording(dt=step, meta=meta, **signals, **common)
    try:
        return Recording.from_time(grid, jitter_tol=jitter_tol, rate_hz=rate_hz, meta=meta, **signals, **common)
    except RecordingError as exc:
        raise _hint_uniform(exc, imu_rate if hold else None, warnings) from None
