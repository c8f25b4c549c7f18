"""Loader for the BROAD benchmark (Laidig et al., Data 6(7):72, 2021).

Each trial is a MATLAB ``.mat`` file (or the equivalent ``.hdf5`` of the dataset's ``data_hdf5``
folder, read when h5py is installed) with keys ``imu_gyr``, ``imu_acc``, ``imu_mag`` (uT),
``opt_quat`` (w-x-y-z, sensor-to-earth, ENU, NaN where markers were lost), ``movement`` and
``sampling_rate``. See ``../shared/data/broad/README.md``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from objectives.attitude.data.recording import Recording, RecordingError, _check_finite_rows

__all__ = ["load_broad", "broad_trials", "default_broad_dir"]

_KEYS = ("imu_gyr", "imu_acc", "imu_mag", "opt_quat", "movement", "sampling_rate")


def default_broad_dir() -> Path:
    """``../shared/data/broad`` relative to the project root in a clone (where tests and configs expect it).

    An installed package has no project root (``parents[3]`` is inside the environment), so there the same
    relative path is taken from the current directory, as a config's ``dir: ../shared/data/broad`` is."""
    root = Path(__file__).resolve().parents[3]
    base = root if (root / "pyproject.toml").is_file() else Path.cwd()
    return base.parent / "shared" / "data" / "broad"


def _read_mat(path: Path) -> dict:
    import scipy.io

    try:
        return scipy.io.loadmat(str(path))
    except Exception as exc:  # scipy raises several types for corrupt/truncated files
        whole = f"{type(exc).__name__}: {exc}"
    # Find the first key that cannot be read, so the message says what is lost (truncated files
    # keep the variables written before the cut).
    for k in _KEYS:
        try:
            found = k in scipy.io.loadmat(str(path), variable_names=[k])
            why = whole
        except Exception as exc:
            found, why = False, f"{type(exc).__name__}: {exc}"
        if not found:
            raise RecordingError(
                f"{path}: cannot read key {k!r} from the MATLAB .mat file (truncated or corrupt? {why})"
            )
    raise RecordingError(f"{path}: cannot read as a MATLAB .mat file ({whole})")


def _read_hdf5(path: Path) -> dict:
    try:
        import h5py
    except ImportError:
        raise RecordingError(f"{path}: reading .hdf5 needs h5py (pip install 'tuner[hdf5]')") from None
    try:
        with h5py.File(path, "r") as f:
            out = {}
            for k in _KEYS:
                if k in f:
                    a = np.asarray(f[k])
                    # MATLAB-written HDF5 stores arrays transposed
                    if a.ndim == 2 and k != "sampling_rate" and a.shape[0] in (1, 3, 4) and a.shape[1] > 4:
                        a = a.T
                    out[k] = a
            return out
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read as HDF5 ({exc})") from None


def load_broad(path: str | Path, name: str | None = None) -> Recording:
    """Read one BROAD trial into a :class:`Recording` (frame ENU, mag in uT).

    Raises
    ------
    RecordingError
        The file is missing, unreadable or truncated, a key is missing or has the wrong shape, or
        gyr/acc/mag hold NaN; the message names the file and the key.
    """
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: file not found")
    d = _read_hdf5(path) if path.suffix in (".hdf5", ".h5") else _read_mat(path)
    missing = [k for k in _KEYS if k not in d]
    if missing:
        raise RecordingError(f"{path}: missing key(s) {missing}; a BROAD trial needs {list(_KEYS)}")
    sr = np.asarray(d["sampling_rate"], dtype=float).ravel()
    rate = float(sr[0]) if sr.size else np.nan
    if not (np.isfinite(rate) and rate > 0):
        raise RecordingError(f"{path}: 'sampling_rate' must be a positive number of Hz, got {rate}")
    arrays = {}
    n = None
    for key, ncols in (("imu_gyr", 3), ("imu_acc", 3), ("imu_mag", 3), ("opt_quat", 4)):
        try:
            a = np.asarray(d[key], dtype=float)
        except (TypeError, ValueError):
            raise RecordingError(f"{path}: key {key!r} is not numeric") from None
        if a.ndim != 2 or a.shape[1] != ncols:
            raise RecordingError(f"{path}: key {key!r} must have shape (N, {ncols}), got {a.shape}")
        if n is None:
            n = a.shape[0]
        elif a.shape[0] != n:
            raise RecordingError(f"{path}: key {key!r} has {a.shape[0]} samples, 'imu_gyr' has {n}")
        if key != "opt_quat":  # truth may be NaN (markers lost); the IMU signals may not
            _check_finite_rows(str(path), f"key {key!r}", a)
        arrays[key] = a
    movement = np.asarray(d["movement"]).ravel()
    if movement.shape[0] != n:
        raise RecordingError(f"{path}: key 'movement' has {movement.shape[0]} samples, 'imu_gyr' has {n}")
    return Recording(
        name=name or path.stem,
        gyr=arrays["imu_gyr"],
        acc=arrays["imu_acc"],
        mag=arrays["imu_mag"],
        dt=1.0 / rate,
        quat=arrays["opt_quat"],
        motion=movement,
        frame="ENU",
        units={"gyr": "rad/s", "acc": "m/s^2", "mag": "uT"},
        source=str(path),
    )


def broad_trials(directory: str | Path | None = None) -> list[str]:
    """Names of the trials present in ``directory`` (sorted), from their ``.mat`` files."""
    directory = Path(directory) if directory else default_broad_dir()
    return sorted(p.stem for p in directory.glob("*.mat"))


def broad_groups(directory: str | Path | None = None) -> dict[str, list[str]]:
    """Trial groups of the published index (``trials.json``): group name -> trial names."""
    directory = Path(directory) if directory else default_broad_dir()
    index = json.loads((directory / "trials.json").read_text())
    groups: dict[str, list[str]] = {}
    for trial, info in index["trials"].items():
        for g in info["groups"]:
            groups.setdefault(g, []).append(trial)
    return groups
