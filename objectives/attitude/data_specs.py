"""The ``data`` value of the filter objective's config: split into tuning and held-out specs, checked early.

The forms (a list, ``{train, test}``, ``{all, kfold}``) are described in :mod:`objectives.attitude.objective`;
a k-fold split becomes one ``("kfold-train" | "kfold-test", items, k, fold)`` spec per side there.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["split_data", "check_specs"]


def split_data(data: Any) -> tuple[list, list]:
    """(train specs, test specs) from the ``data`` value (see module docstring)."""
    if isinstance(data, list):
        return list(data), []
    if not isinstance(data, Mapping):
        raise ValueError(f"objective.data: expected a list of data specs or {{train, test}}, got {data!r}")
    if "train" in data:
        bad = sorted(set(data) - {"train", "test"})
        if bad:
            raise ValueError(f"objective.data.{bad[0]}: unknown key; allowed: train, test")
        train, test = data["train"], data.get("test", [])
        for key, v in (("train", train), ("test", test)):
            if not isinstance(v, list) or (key == "train" and not v):
                raise ValueError(f"objective.data.{key}: expected a non-empty list of data specs")
        return list(train), list(test)
    if "all" in data:
        bad = sorted(set(data) - {"all", "kfold"})
        if bad:
            raise ValueError(f"objective.data.{bad[0]}: unknown key; allowed: all, kfold")
        items = data["all"]
        kf = data.get("kfold") or {}
        if not isinstance(items, list) or not items:
            raise ValueError("objective.data.all: expected a non-empty list of data specs")
        if not isinstance(kf, Mapping) or set(kf) - {"k", "fold"}:
            raise ValueError("objective.data.kfold: expected {k: int, fold: int}")
        return [("kfold", items, int(kf.get("k", 0)), int(kf.get("fold", 0)))], []
    raise ValueError("objective.data: a mapping needs 'train' (and 'test') or 'all' (with 'kfold')")


def check_specs(specs: list, base_dir: Path, where: str) -> None:
    """Fail early (at config load) on missing files and unknown kinds, without loading data."""
    from objectives.attitude.data.loaders import KINDS

    for i, spec in enumerate(specs):
        if not isinstance(spec, Mapping) or len(spec) != 1:
            raise ValueError(f"{where}[{i}]: expected a one-key mapping out of {list(KINDS)}, got {spec!r}")
        (kind, opts), = spec.items()
        if kind not in KINDS:
            raise ValueError(f"{where}[{i}]: unknown data kind {kind!r}; allowed: {list(KINDS)}")
        opts = opts or {}
        if kind == "csv":
            p = Path(str(opts.get("path", "")))
            p = p if p.is_absolute() else base_dir / p
            if not p.is_file():
                raise ValueError(f"{where}[{i}].csv.path: " + (("not a file" if p.exists() else "file not found")
                                 + f": {p}" if opts.get("path") else "missing (required): the CSV file"))
        if kind == "rosbag":
            p = Path(str(opts.get("path", "")))
            p = p if p.is_absolute() else base_dir / p
            if not opts.get("path") or not p.exists():
                raise ValueError(f"{where}[{i}].rosbag.path: " + (f"not found: {p}" if opts.get("path") else
                                 "missing (required): a ROS 1 .bag file or a ROS 2 bag directory"))
        if kind == "broad":
            from objectives.attitude.data.broad import default_broad_dir

            d = Path(str(opts["dir"])) if opts.get("dir") else default_broad_dir()
            d = d if d.is_absolute() else base_dir / d
            if not d.is_dir():
                raise ValueError(f"{where}[{i}].broad.dir: directory not found: {d}")
