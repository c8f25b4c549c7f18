"""CSV export of a recording (the format :mod:`objectives.attitude.data.csv` reads back)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from objectives.attitude.data.recording import Recording

__all__ = ["to_csv", "csv_columns"]


def csv_columns(rec: Recording) -> list[str]:
    """Column names :func:`to_csv` writes for ``rec``, in order."""
    cols = ["t", "gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z"]
    if rec.mag is not None:
        cols += ["mag_x", "mag_y", "mag_z"]
    if rec.quat is not None:
        cols += ["q_w", "q_x", "q_y", "q_z"]
    cols.append("motion")
    for k, v in rec.extra.items():
        if v.ndim == 1:
            cols.append(k)
        elif v.ndim == 2 and v.shape[1] == 3:
            cols += [f"{k}_{a}" for a in "xyz"]
        else:
            cols += [f"{k}_{i}" for i in range(int(np.prod(v.shape[1:])))]
    return cols


def to_csv(rec: Recording, path) -> Path:
    """Write a recording to CSV for inspection (and for the CSV loader).

    One header line of comma-separated names (:func:`csv_columns`): ``t`` (s), ``gyr_x..z``
    (rad/s), ``acc_x..z`` (m/s^2), ``mag_x..z`` (if any), ``q_w, q_x, q_y, q_z`` (truth, if any),
    ``motion`` (0/1), then every extra signal (``name`` for (N,), ``name_x..z`` for (N, 3),
    ``name_0..`` otherwise). Values use 17 significant digits, so ``numpy.loadtxt(path,
    delimiter=",", skiprows=1)`` gives the arrays back bit for bit. Frame and units are not in
    the file: frame is ``rec.frame``, units those of :class:`Recording`.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    path = Path(path)
    blocks = [rec.time[:, None], rec.gyr, rec.acc]
    if rec.mag is not None:
        blocks.append(rec.mag)
    if rec.quat is not None:
        blocks.append(rec.quat)
    blocks.append(rec.motion.astype(float)[:, None])
    for v in rec.extra.values():
        blocks.append(v.reshape(rec.n, -1))
    data = np.concatenate(blocks, axis=1)
    cols = csv_columns(rec)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    return path
