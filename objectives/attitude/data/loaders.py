"""One entry point from a config's data spec to :class:`Recording` objects.

A data spec is a one-key mapping (the YAML ``data:`` list holds such items)::

    {broad: {dir: ../shared/data/broad, trial: 24_disturbed_tapping_A}}
    {broad: {dir: ..., trials: [01_undisturbed_slow_rotation_A, 24_disturbed_tapping_A]}}  # load_recordings
    {csv: {path: runs/log.csv, columns: {gyr: [gx, gy, gz], acc: [ax, ay, az]}, rate_hz: 100}}
    {csv: {path: runs/log.csv, columns: maps/imu.yaml}}     # column map (and units) in a YAML file
    {rosbag: {path: flight.bag, imu: /imu/data_raw, mag: /imu/mag, truth: /mocap/pose}}  # ROS 1 or 2 bag
    {synthetic: {generator: bench6dof, duration_s: 160, rate_hz: 1000, seed: 1}}

``broad``, ``csv`` and ``rosbag`` also take ``start_s`` / ``stop_s`` (seconds from the first sample) to cut the
recording; a window is named after its file and its bounds (``imu@10s-70s``, :func:`window_name`) unless
the spec states a ``name``, so windows of one file have distinct names. Relative paths are resolved
against ``base_dir`` (the directory of the config file). Every kind also takes ``dataset: NAME``, the label of
the dataset the recordings belong to (default: the kind, e.g. ``broad``); it goes into ``meta["dataset"]`` and
``validation: {cv: {by: dataset}}`` leaves one dataset out at a time.
Errors are :class:`RecordingError` naming the spec item and the key.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from objectives.attitude.data.recording import Recording, RecordingError

__all__ = ["dataset_label", "load_recording", "load_recordings", "window_name", "KINDS"]

KINDS = ("broad", "csv", "rosbag", "synthetic")
_CUT = ("start_s", "stop_s")


def _split(spec: Any) -> tuple[str, dict]:
    if not isinstance(spec, Mapping) or len(spec) != 1:
        raise RecordingError(f"data spec must be a mapping with one key out of {list(KINDS)}, got {spec!r}")
    (kind, opts), = spec.items()
    if kind not in KINDS:
        raise RecordingError(f"data spec: unknown kind {kind!r}; allowed: {list(KINDS)}")
    if opts is None:
        opts = {}
    if not isinstance(opts, Mapping):
        raise RecordingError(f"data spec {kind!r}: expected a mapping of options, got {opts!r}")
    return kind, dict(opts)


def _resolve(path: Any, base_dir: Path) -> Path:
    p = Path(str(path)).expanduser()
    return p if p.is_absolute() else (base_dir / p)


def _check_keys(kind: str, opts: Mapping, allowed: tuple[str, ...]) -> None:
    unknown = sorted(set(opts) - set(allowed))
    if unknown:
        raise RecordingError(f"data spec {kind!r}: unknown key(s) {unknown}; allowed: {sorted(allowed)}")


def window_name(name: str, start_s: Any, stop_s: Any) -> str:
    """The default name of a window of recording ``name``: ``name@10s-70s`` (``@0s-30s``, ``@60s-end``)."""
    def fmt(v: Any) -> str:
        return f"{float(v):g}s"

    return f"{name}@{fmt(start_s or 0)}-{'end' if stop_s is None else fmt(stop_s)}"


def _cut(rec: Recording, kind: str, opts: Mapping, rename: bool = True) -> Recording:
    """``rec`` cut to ``opts``' ``start_s``/``stop_s``; a window is named :func:`window_name` unless
    ``rename`` is False (a ``name`` the spec states)."""
    start_s, stop_s = opts.get("start_s"), opts.get("stop_s")
    if start_s is None and stop_s is None:
        return rec
    try:
        i0 = 0 if start_s is None else int(round(float(start_s) / rec.dt))
        i1 = rec.n if stop_s is None else int(round(float(stop_s) / rec.dt))
    except (TypeError, ValueError):
        raise RecordingError(f"data spec {kind!r}: start_s/stop_s must be numbers of seconds") from None
    if not (0 <= i0 < i1 <= rec.n) or i1 - i0 < 2:
        raise RecordingError(
            f"data spec {kind!r}: start_s={start_s!r}, stop_s={stop_s!r} select samples {i0}:{i1} of "
            f"{rec.n} ({rec.duration_s:.6g} s) in {rec.name!r}"
        )
    return rec.slice(i0, i1, name=window_name(rec.name, start_s, stop_s) if rename else None)


def _broad_path(directory: Path, trial: str) -> Path:
    from objectives.attitude.data.broad import broad_trials

    name = str(trial)
    p = directory / name
    if p.suffix in (".mat", ".hdf5", ".h5") and p.exists():
        return p
    for ext in (".mat", ".hdf5"):
        if (directory / f"{name}{ext}").exists():
            return directory / f"{name}{ext}"
    have = broad_trials(directory) if directory.is_dir() else []
    raise RecordingError(
        f"data spec 'broad': trial {name!r} not found in {directory}"
        + (f"; available: {have}" if have else " (directory missing or empty)")
    )


def _broad_dir(opts: Mapping, base_dir: Path) -> Path:
    from objectives.attitude.data.broad import default_broad_dir

    return _resolve(opts["dir"], base_dir) if opts.get("dir") else default_broad_dir()


def _load_csv(opts: dict, base_dir: Path) -> Recording:
    import yaml

    from objectives.attitude.data.csv import CSV_OPTIONS, load_csv

    _check_keys("csv", opts, ("path", "columns", *CSV_OPTIONS, *_CUT))
    if "path" not in opts:
        raise RecordingError("data spec 'csv': needs 'path'")
    columns = opts.get("columns")
    options = {k: opts[k] for k in CSV_OPTIONS if k in opts}
    if isinstance(columns, (str, Path)):
        map_path = _resolve(columns, base_dir)
        try:
            loaded = yaml.safe_load(map_path.read_text())
        except OSError as exc:
            raise RecordingError(f"data spec 'csv': cannot read column map {map_path} ({exc})") from None
        except yaml.YAMLError as exc:
            raise RecordingError(f"{map_path}: not valid YAML ({' '.join(str(exc).split())})") from None
        if not isinstance(loaded, Mapping):
            raise RecordingError(f"{map_path}: a column map must be a mapping, got {type(loaded).__name__}")
        if "columns" in loaded:  # a full map: columns plus unit options
            unknown = sorted(set(loaded) - {"columns", *CSV_OPTIONS})
            if unknown:
                raise RecordingError(
                    f"{map_path}: unknown key(s) {unknown}; allowed: columns, {list(CSV_OPTIONS)}"
                )
            options = {**{k: v for k, v in loaded.items() if k != "columns"}, **options}
            columns = loaded["columns"]
        else:
            columns = loaded
    if columns is None:
        raise RecordingError("data spec 'csv': needs 'columns' (a mapping or a YAML file)")
    rec = load_csv(_resolve(opts["path"], base_dir), columns, **options)
    return _cut(rec, "csv", opts, rename="name" not in options)


def _load_rosbag(opts: dict, base_dir: Path) -> Recording:
    from objectives.attitude.data.rosbag import ROSBAG_OPTIONS, load_rosbag

    _check_keys("rosbag", opts, ("path", *ROSBAG_OPTIONS, *_CUT))
    if "path" not in opts:
        raise RecordingError("data spec 'rosbag': needs 'path' (a ROS 1 .bag file or a ROS 2 bag directory)")
    rec = load_rosbag(_resolve(opts["path"], base_dir), **{k: opts[k] for k in ROSBAG_OPTIONS if k in opts})
    return _cut(rec, "rosbag", opts, rename="name" not in opts)


def dataset_label(spec: Mapping[str, Any]) -> tuple[dict[str, Any], str]:
    """``(spec without its dataset key, the label)``: a source's ``dataset:`` label (a non-empty string), by
    default the source's kind (``broad``, ``csv``, ``rosbag``, ``synthetic``), so recordings of one kind share
    a dataset unless labelled."""
    kind, opts = _split(spec)
    label = opts.pop("dataset", kind)
    if not isinstance(label, str) or not label.strip():
        raise RecordingError(f"data spec {kind!r}: 'dataset' must be a non-empty text naming the dataset "
                             f"(e.g. 'lab_b'), got {label!r}")
    return {kind: opts}, label.strip()


def _labelled(rec: Recording, label: str) -> Recording:
    return replace(rec, meta={**rec.meta, "dataset": label})


def load_recording(spec: Mapping[str, Any], base_dir: str | Path = ".") -> Recording:
    """The one :class:`Recording` a data spec describes (see the module docstring); its ``meta["dataset"]`` is
    the spec's ``dataset:`` label (:func:`dataset_label`)."""
    spec, label = dataset_label(spec)
    return _labelled(_load_one(spec, base_dir), label)


def _load_one(spec: Mapping[str, Any], base_dir: str | Path = ".") -> Recording:
    """The one :class:`Recording` a data spec describes (see the module docstring).

    Parameters
    ----------
    spec : mapping
        ``{broad: {dir, trial, start_s, stop_s}}``, ``{csv: {path, columns, ...}}`` or
        ``{synthetic: {generator, ...}}`` (the generator's keyword arguments).
    base_dir : path
        Directory against which relative paths are resolved.

    Raises
    ------
    RecordingError
        Bad spec (unknown kind or key, missing trial) or bad data (from the loaders).
    """
    base_dir = Path(base_dir)
    kind, opts = _split(spec)
    if kind == "broad":
        from objectives.attitude.data.broad import load_broad

        _check_keys("broad", opts, ("dir", "trial", *_CUT))
        if "trial" not in opts:
            raise RecordingError("data spec 'broad': needs 'trial' (use load_recordings for 'trials')")
        rec = load_broad(_broad_path(_broad_dir(opts, base_dir), opts["trial"]))
        return _cut(rec, "broad", opts)
    if kind == "csv":
        return _load_csv(opts, base_dir)
    if kind == "rosbag":
        return _load_rosbag(opts, base_dir)
    # synthetic: generators live in their own module, imported only when used
    from objectives.attitude.data.cache import synthetic

    if "generator" not in opts:
        raise RecordingError("data spec 'synthetic': needs 'generator'")
    generator = opts.pop("generator")
    rec = synthetic(generator, **opts)
    if not isinstance(rec, Recording):
        raise RecordingError(f"data spec 'synthetic': generator {generator!r} returned {type(rec).__name__}")
    return rec


def load_recordings(spec: Mapping[str, Any], base_dir: str | Path = ".") -> list[Recording]:
    """All recordings of a data spec: like :func:`load_recording`, and ``broad`` may list ``trials``.

    ``trials`` is a list of trial names, ``all`` (every ``.mat`` in ``dir``), or a group name of the
    BROAD index (``trials.json``, e.g. ``undisturbed``).
    """
    base_dir = Path(base_dir)
    spec, label = dataset_label(spec)
    kind, opts = _split(spec)
    if kind != "broad" or "trials" not in opts:
        return [_labelled(_load_one(spec, base_dir), label)]
    from objectives.attitude.data.broad import broad_groups, broad_trials

    if "trial" in opts:
        raise RecordingError("data spec 'broad': give 'trial' or 'trials', not both")
    _check_keys("broad", opts, ("dir", "trials", *_CUT))
    directory = _broad_dir(opts, base_dir)
    trials = opts.pop("trials")
    if isinstance(trials, str):
        if trials == "all":
            names = broad_trials(directory)
        else:
            groups = broad_groups(directory) if (directory / "trials.json").exists() else {}
            if trials not in groups:
                raise RecordingError(
                    f"data spec 'broad': trials={trials!r} is neither 'all' nor a group of "
                    f"{directory / 'trials.json'} ({sorted(groups)})"
                )
            present = set(broad_trials(directory))
            names = [t for t in groups[trials] if t in present]
        if not names:
            raise RecordingError(f"data spec 'broad': trials={trials!r} selects no file in {directory}")
    elif isinstance(trials, (list, tuple)) and trials:
        names = [str(t) for t in trials]
    else:
        raise RecordingError(
            f"data spec 'broad': 'trials' must be a non-empty list, 'all' or a group, got {trials!r}"
        )
    directory = directory.resolve()  # already resolved against base_dir: do not resolve twice
    return [_labelled(_load_one({"broad": {**opts, "dir": str(directory), "trial": t}}, base_dir), label)
            for t in names]
