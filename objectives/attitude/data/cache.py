"""Synthetic recordings by generator name, with an in-process and an optional disk cache."""

from __future__ import annotations

import functools
import hashlib
import inspect
import json
import os
from pathlib import Path

import numpy as np

from objectives.attitude.data.bench6dof import bench6dof
from objectives.attitude.data.bench_common import _SENSOR_KEYS
from objectives.attitude.data.recording import Recording
from objectives.attitude.data.tilt1d import tilt1d

__all__ = ["synthetic", "GENERATORS", "GENERATOR_VERSION"]

#: Generators known to :func:`synthetic`.
GENERATORS = {"bench6dof": bench6dof, "tilt1d": tilt1d}
#: Bumped whenever a generator's output changes, so stale disk-cache files are not reused.
GENERATOR_VERSION = 2


def _freeze(name: str, value):
    """Hashable, order-independent form of a keyword value (numbers, strings, bools, None,
    sequences and arrays of them)."""
    if value is None or isinstance(value, (bool, int, float, str, np.integer, np.floating, np.bool_)):
        return value.item() if isinstance(value, np.generic) else value
    if isinstance(value, (list, tuple, np.ndarray)):
        return tuple(_freeze(name, v) for v in (value.tolist() if isinstance(value, np.ndarray) else value))
    raise ValueError(f"synthetic: keyword {name!r} must be a number, string, bool, None or a sequence "
                     f"of them (to be cached), got {type(value).__name__}")


def _thaw(value):
    return list(value) if isinstance(value, tuple) else value


def _allowed_keywords(generator: str) -> list[str]:
    params = inspect.signature(GENERATORS[generator]).parameters
    names = [p for p, v in params.items() if v.kind is not inspect.Parameter.VAR_KEYWORD]
    extra = list(_SENSOR_KEYS) + (["acc_resolution_g", "acc_range_g"] if generator == "tilt1d" else [])
    return names + extra


def _cache_dir() -> Path:
    env = os.environ.get("TUNER_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "tuner"


def _disk_path(generator: str, key: tuple) -> Path:
    digest = hashlib.sha1(repr((GENERATOR_VERSION, generator, key)).encode()).hexdigest()[:20]
    return _cache_dir() / f"synthetic-{generator}-{digest}.npz"


def _save_npz(rec: Recording, path: Path) -> None:
    arrays = {"gyr": rec.gyr, "acc": rec.acc, "dt": np.array(rec.dt), "motion": rec.motion}
    if rec.mag is not None:
        arrays["mag"] = rec.mag
    if rec.quat is not None:
        arrays["quat"] = rec.quat
    for k, v in rec.extra.items():
        arrays[f"extra__{k}"] = v
    meta = {"name": rec.name, "frame": rec.frame, "units": dict(rec.units), "source": rec.source}
    arrays["meta"] = np.array(json.dumps(meta))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    os.replace(tmp, path)


def _load_npz(path: Path) -> Recording:
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["meta"]))
        return Recording(
            name=meta["name"], gyr=z["gyr"], acc=z["acc"], mag=z["mag"] if "mag" in z else None,
            dt=float(z["dt"]), quat=z["quat"] if "quat" in z else None, motion=z["motion"],
            frame=meta["frame"], units=meta["units"], source=meta["source"],
            extra={k[len("extra__"):]: z[k] for k in z.files if k.startswith("extra__")},
        )


@functools.lru_cache(maxsize=16)
def _cached(generator: str, key: tuple, disk: bool) -> Recording:
    kwargs = {k: _thaw(v) for k, v in key}
    path = _disk_path(generator, key) if disk else None
    if path is not None and path.exists():
        try:
            return _load_npz(path)
        except (OSError, ValueError, KeyError):
            pass  # unreadable or partial file: regenerate and overwrite below
    rec = GENERATORS[generator](**kwargs)
    if path is not None:
        _save_npz(rec, path)
    return rec


def synthetic(generator: str, *, disk_cache: bool | None = None, **kwargs) -> Recording:
    """A synthetic recording by generator name, cached.

    Parameters
    ----------
    generator : {"bench6dof", "tilt1d"}
        Which bench (:func:`bench6dof`, :func:`tilt1d`).
    disk_cache : bool or None
        Also keep the recording as ``.npz`` in ``$TUNER_CACHE`` (default ``~/.cache/tuner``) and
        reuse it across processes. None: only when the ``TUNER_CACHE`` environment variable is set.
    **kwargs
        The generator's keywords (numbers, strings, bools, None, sequences); unknown ones are a
        ``ValueError`` that lists the allowed ones.

    Returns
    -------
    Recording
        The same object for repeated calls with equal keywords in one process (an in-process LRU
        cache of 16 recordings); treat its arrays as read-only.
    """
    if generator not in GENERATORS:
        raise ValueError(f"unknown synthetic generator {generator!r}; allowed: {', '.join(GENERATORS)}")
    allowed = _allowed_keywords(generator)
    bad = sorted(set(kwargs) - set(allowed))
    if bad:
        raise ValueError(f"synthetic generator {generator!r}: unknown keyword(s) {bad}; "
                         f"allowed: {', '.join(allowed)}")
    key = tuple(sorted((k, _freeze(k, v)) for k, v in kwargs.items()))
    disk = bool(os.environ.get("TUNER_CACHE")) if disk_cache is None else bool(disk_cache)
    return _cached(generator, key, disk)

