"""``tuner align DATA.yaml``: each recording's rates and how its truth aligns with its IMU.

A domain command (the engine's ``tuner.commands`` entry points: an object with ``name``, ``help``,
``add_arguments(parser)`` and ``run(args) -> int``). ``DATA.yaml`` is a list of data specs, a mapping with
``data:`` (as ``tuner evaluate --data`` takes) or a job file (its ``objective.data``, every split). Per
recording it prints the rate, the IMU's own rate (with the log's when the log holds samples), and the
alignment of :mod:`objectives.attitude.data.alignment`: the truth's lag, the IMU-to-marker misalignment, the
truth frame's heading offset (and tilt) and the gyroscope's scale against the truth. A recording read with an
``align:`` block shows what was applied; any other is estimated (``lag: auto, body: auto, heading: start``, or
``heading: none`` without a magnetometer) and shown with the block that would apply it. Bad input is one
``error:`` line and exit status 2.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["AlignCommand", "ALIGN", "align_rows"]


def _specs(doc: Any, source: Path) -> list:
    """The data specs of a ``DATA.yaml`` document (module docstring), every split."""
    from objectives.attitude.data_specs import split_data

    if isinstance(doc, Mapping) and isinstance(doc.get("objective"), Mapping):
        doc = doc["objective"].get("data")
    elif isinstance(doc, Mapping) and "data" in doc:
        doc = doc["data"]
    if doc is None:
        raise ValueError(f"{source}: data: missing; expected a list of data specs, {{data: [...]}} or a job file")
    train, test = split_data(doc)
    specs = []
    for spec in train + test:
        specs += list(spec[1]) if isinstance(spec, tuple) else [spec]
    return specs


def _estimate(rec: Any) -> Any:
    """The alignment of ``rec``: the one its reading applied, else estimated (not applied)."""
    from objectives.attitude.data.alignment import AlignSpec, estimate_alignment

    if "alignment" in rec.meta:
        return rec.meta["alignment"]
    spec = AlignSpec(lag="auto", body="auto", heading="start" if rec.mag is not None else "none")
    return estimate_alignment(rec.time, rec.gyr, rec.acc, rec.mag, rec.time, rec.quat, spec, rec.frame,
                              where=f"{rec.source or rec.name}: align")


def align_rows(path: str | Path) -> list[dict[str, Any]]:
    """One dict per recording of ``path`` (a DATA.yaml): ``name``, ``source``, ``rate_hz``, ``imu_rate_hz``,
    ``log_rate_hz``, ``applied`` (the alignment came from the spec's ``align:``) and the
    :class:`~objectives.attitude.data.alignment.Alignment`'s values (``alignment``; None without truth).

    Raises
    ------
    ValueError
        One line naming the file and the key: unreadable YAML, a bad spec or recording, an alignment the data
        do not determine.
    """
    from objectives.attitude.data.loaders import load_recordings
    from tuner.config import read_yaml

    path = Path(path)
    doc = read_yaml(path, "align")
    try:
        specs = _specs(doc, path)
    except ValueError as exc:
        raise ValueError(str(exc) if str(exc).startswith(str(path)) else f"{path}: {exc}") from None
    rows = []
    for i, spec in enumerate(specs):
        try:
            recs = load_recordings(spec, path.parent)
        except ValueError as exc:  # RecordingError: names the recording's file and key
            raise ValueError(f"{path}: data[{i}]: {exc}") from None
        for rec in recs:
            read = rec.meta.get("read")
            row: dict[str, Any] = {"name": rec.name, "source": rec.source, "rate_hz": rec.rate_hz,
                   "imu_rate_hz": read.imu_rate_hz if read is not None else rec.rate_hz,
                   "log_rate_hz": read.log_rate_hz if read is not None else rec.rate_hz,
                   "applied": "alignment" in rec.meta, "alignment": None}
            if rec.quat is not None:
                try:
                    row["alignment"] = _estimate(rec).as_dict()
                except ValueError as exc:
                    raise ValueError(f"{path}: data[{i}]: {exc}") from None
            rows.append(row)
    return rows


def _round(v: float, digits: int) -> float:
    """``v`` rounded to ``digits`` decimals, 0.0 (never -0.0) when it rounds to zero."""
    return round(v, digits) + 0.0


def _line(row: Mapping[str, Any]) -> str:
    rates = f"{row['rate_hz']:.4g} Hz"
    if math.isfinite(row["imu_rate_hz"]) and abs(row["imu_rate_hz"] - row["log_rate_hz"]) > 1e-3 * row["rate_hz"]:
        rates += f" (the IMU's own {row['imu_rate_hz']:.4g} Hz, the log {row['log_rate_hz']:.4g} Hz)"
    elif math.isfinite(row["imu_rate_hz"]) and abs(row["imu_rate_hz"] - row["rate_hz"]) > 1e-3 * row["rate_hz"]:
        rates += f" (the IMU's own {row['imu_rate_hz']:.4g} Hz)"
    a = row["alignment"]
    if a is None:
        return f"{row['name']}: {rates}; no truth to align"
    b = ", ".join(f"{_round(v, 4):.4f}" for v in a["body"])
    scale = ("gyro scale -" if not math.isfinite(a["gyro_scale"]) else
             f"gyro scale {a['gyro_scale']:.4f} (x {a['gyro_scale_axes'][0]:.4f}, y {a['gyro_scale_axes'][1]:.4f}, "
             f"z {a['gyro_scale_axes'][2]:.4f})")
    how = "applied (align:)" if row["applied"] else "estimated, not applied"
    return (f"{row['name']}: {rates}; lag {1e3 * a['lag_s']:.2f} ms; misalignment {a['body_angle_deg']:.2f} deg "
            f"(sensor to marker [{b}]); heading offset {a['heading_offset_deg']:.2f} deg (frame tilt "
            f"{a['frame_tilt_deg']:.2f} deg); {scale}; {how}")


def _block(row: Mapping[str, Any]) -> str:
    a = row["alignment"]
    heading = "start" if "heading" in a["estimated"] else "none"
    return (f"  align: {{lag: {a['lag_s']:.5f}, body: [{', '.join(f'{_round(v, 5):.5f}' for v in a['body'])}], "
            f"heading: {heading}}}   # or lag: auto, body: auto to estimate them on every read")


class AlignCommand:
    """``tuner align DATA.yaml [--json]`` (module docstring)."""

    name = "align"
    help = ("each recording's rate, the IMU's own rate and how its truth aligns: lag, misalignment, heading "
            "offset, gyro scale")

    @staticmethod
    def add_arguments(parser: Any) -> None:
        parser.add_argument("data", help="a YAML file: a list of data specs, {data: [...]}, or a job file")
        parser.add_argument("--json", action="store_true", help="print the values as JSON")

    @staticmethod
    def run(args: Any) -> int:
        """Print one line per recording (or JSON); ``error: ...`` and 2 on bad input."""
        try:
            rows = align_rows(args.data)
        except ValueError as exc:  # ConfigError, RecordingError: one line naming the file and the key
            print(f"error: {exc}", file=sys.stderr)
            return 2
        except OSError as exc:
            print(f"error: {exc.filename or args.data}: {exc.strerror or exc}", file=sys.stderr)
            return 2
        if getattr(args, "json", False):
            print(json.dumps(rows, indent=1))
            return 0
        for row in rows:
            print(_line(row))
            if row["alignment"] is not None and not row["applied"]:
                print(_block(row))
        return 0


#: the command object the ``tuner.commands`` entry point names
ALIGN = AlignCommand()
