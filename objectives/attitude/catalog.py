"""What ``tuner describe`` and ``tuner list metrics|data`` say about the attitude domain.

:func:`explain` answers one name (a filter, a metric or a data source) with a plain dict; the
filter objective's ``catalog()``/``explain()`` hooks hand it to the engine, which never imports
this package.
"""

from __future__ import annotations

import inspect
from typing import Any

__all__ = ["METRICS", "METRIC_DOCS", "data_sources", "explain", "metric_names"]

#: the metrics ``objective.metric`` may name
METRICS = ("euler_mse_geomean", "euler_rmse_mean", "mse_1d", "broad_mean_rmse", "broad_total_rmse",
           "heading_rmse_mean", "inclination_rmse_mean")

#: metric name -> (unit, definition, equation) for ``objective.metric`` (lower is better)
METRIC_DOCS: dict[str, tuple[str, str, str]] = {
    "euler_mse_geomean": ("rad^2", "cube root of the product of the per-axis Euler MSEs over the recordings; "
                          "metric_options.weights are per-axis exponents, normalize: true takes the geometric "
                          "mean of all MSEs", "FAEKF paper eq. 35"),
    "euler_rmse_mean": ("deg", "mean over recordings of the mean per-axis Euler RMSE", ""),
    "mse_1d": ("rad^2", "mean square error of the tilt angle, mean over recordings", "thesis eq. 3.18"),
    "broad_mean_rmse": ("deg", "mean over recordings of BROAD's total RMSE on motion samples (the criterion "
                        "of BROAD's trial-agnostic good parameters)", "Laidig et al. 2021, BROAD"),
    "broad_total_rmse": ("deg", "BROAD's total RMSE pooled over the motion samples of all recordings",
                         "Laidig et al. 2021, BROAD"),
    "heading_rmse_mean": ("deg", "mean over recordings of the RMSE of the heading error (the error quaternion's "
                          "turn about the vertical): the same at any mounting, unlike the Euler yaw",
                          "Laidig et al. 2021, BROAD"),
    "inclination_rmse_mean": ("deg", "mean over recordings of the RMSE of the inclination error (the error "
                              "quaternion's tilt of the vertical): the same at any mounting, unlike roll and pitch",
                              "Laidig et al. 2021, BROAD"),
}
_METRIC_OPTIONS = {"weights": "(3,) per-axis exponents of euler_mse_geomean (default [1, 1, 1])",
                   "normalize": "euler_mse_geomean: geometric mean of all MSEs instead of the cube root "
                                "(default false)"}
_HEADING_OPTION = {"heading_offset": "none (default) or remove: per recording, the truth is first turned about "
                                     "the vertical by the constant heading offset that fits the estimate best "
                                     "(closed-form least squares, objectives.attitude.metrics.heading_offset)"}
_CUT = {"start_s": "first second kept (optional); a window is named file@start-stop (e.g. imu@10s-70s)",
        "stop_s": "last second kept (optional)"}


def metric_names() -> list[str]:
    return list(METRICS)


def _doc_params(doc: str) -> dict[str, str]:
    """``{name: text}`` from the ``Parameters`` section of a generator's NumPy-style docstring (the synthetic
    generators document their keywords there; ``a, b : type`` lines give several names the same text)."""
    out: dict[str, str] = {}
    lines = inspect.cleandoc(doc or "").splitlines()
    try:
        i = next(k for k, ln in enumerate(lines) if ln.strip() == "Parameters") + 2
    except StopIteration:
        return out
    names: list[str] = []
    for k in range(i, len(lines)):
        ln = lines[k]
        if ln and not ln.startswith(" "):
            if k + 1 < len(lines) and lines[k + 1].startswith("---"):  # the next section (Returns...)
                break
            names = [n.strip() for n in ln.split(" :")[0].split(",")]
            if not all(n.isidentifier() for n in names):
                names = []
            for n in names:
                out[n] = ""
        elif ln.strip() and names:
            for n in names:
                out[n] = (out[n] + " " + ln.strip()).strip()
    return out


def _generator_keys(name: str) -> list[dict[str, Any]]:
    """Keyword, default and unit hint of every key a synthetic generator accepts."""
    from objectives.attitude.data.cache import GENERATORS, _allowed_keywords

    sig = inspect.signature(GENERATORS[name]).parameters
    docs = _doc_params(GENERATORS[name].__doc__ or "")
    out = []
    for key in _allowed_keywords(name):
        p = sig.get(key)
        default = None if p is None or p.default is inspect.Parameter.empty else p.default
        doc = docs.get(key) or ("" if p is not None else "sensor model override (objectives.attitude.data.imu_model)")
        out.append({"name": key, "default": list(default) if isinstance(default, tuple) else default, "doc": doc})
    return out


def data_sources() -> dict[str, dict[str, Any]]:
    """``{name: description}`` of every data source a data spec may name (broad, csv, synthetic:<gen>)."""
    from objectives.attitude.data.cache import GENERATORS
    from objectives.attitude.data.csv import csv_keys
    from objectives.attitude.data.rosbag import rosbag_keys

    out: dict[str, dict[str, Any]] = {
        "broad": {"summary": "BROAD trials (.mat/.hdf5, Laidig et al. 2021, CC-BY-4.0)",
                  "spec": "{broad: {dir, trial | trials: [..] | all | <group>, start_s, stop_s}}",
                  "keys": [{"name": "dir", "default": "../shared/data/broad", "doc": "directory of the trials"},
                           {"name": "trial", "default": None, "doc": "one trial name"},
                           {"name": "trials", "default": None, "doc": "list, 'all' or a group of trials.json"},
                           *({"name": k, "default": None, "doc": d} for k, d in _CUT.items())]},
        "csv": {"summary": "your own recording as CSV with a column map",
                "spec": "{csv: {path, columns: {gyr: [..], acc: [..], mag: [..], quat: [..], time: t}, ...}}",
                "keys": [*csv_keys(),
                         *({"name": k, "default": None, "doc": d} for k, d in _CUT.items())]},
        "rosbag": {"summary": "a ROS 1 bag or a ROS 2 bag (sqlite3, MCAP): sensor_msgs/Imu, MagneticField and a "
                              "pose, transform, tf or odometry topic as truth (needs the extra .[ros]; "
                              "`tuner bag PATH` lists a bag's topics)",
                   "spec": "{rosbag: {path, imu: /imu/data_raw, mag: /imu/mag, truth: /mocap/pose, ...}}",
                   "keys": [*rosbag_keys(),
                            *({"name": k, "default": None, "doc": d} for k, d in _CUT.items())]},
    }
    for gen, fn in sorted(GENERATORS.items()):
        doc = (fn.__doc__ or "").strip().splitlines()
        out[gen] = {"summary": f"synthetic generator: {doc[0] if doc else gen}",
                    "spec": f"{{synthetic: {{generator: {gen}, ...}}}}", "keys": _generator_keys(gen)}
    return out


def explain(name: str) -> dict[str, Any] | None:
    """The description of ``name`` as a filter, metric or data source, else ``None``.

    Returns
    -------
    dict with ``section`` (filters, metrics, data), ``name``, ``summary`` and ``params`` (a list of
    dicts with name, default, bounds, scale, unit, doc, eq), or None when the name is none of these.
    """
    from objectives.attitude.filters import filter_names, get_filter

    if name in filter_names():
        return {"section": "filters", **get_filter(name).describe()}
    if name in METRIC_DOCS:
        unit, doc, eq = METRIC_DOCS[name]
        opts = {**(_METRIC_OPTIONS if name == "euler_mse_geomean" else {}),
                **(_HEADING_OPTION if name != "mse_1d" else {})}
        params = [{"name": k, "default": None, "unit": "", "doc": d, "eq": ""} for k, d in opts.items()]
        return {"section": "metrics", "name": name, "summary": doc, "unit": unit, "eq": eq,
                "usage": f"objective: {{kind: filter, metric: {name}}}", "params": params}
    sources = data_sources()
    if name in sources:
        s = sources[name]
        return {"section": "data", "name": name, "summary": s["summary"], "usage": s["spec"],
                "params": [{"unit": "", "eq": "", **k} for k in s["keys"]]}
    return None
