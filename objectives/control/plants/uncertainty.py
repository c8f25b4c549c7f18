"""Plant uncertainty: ranges and distributions of plant parameters, and the seeded model sets they give.

YAML (``objective:``)::

    uncertainty:
      parameters:                       # name -> range or distribution
        tf.num[0]: {rel: 0.3}           # uniform in nominal x (1 -+ 0.3)
        tf.den[0]: [0.004, 0.006]       # uniform in [low, high] (also {uniform: [low, high]})
        delay_s: [0.1, 0.2]             # input delay, rounded to whole controller periods
        params.m: {normal: {std: 0.02}} # mean: the nominal value (or mean:); truncated at +-3 std
      tune: {corners: true, samples: 4, seed: 1}   # the tuning set: nominal + 2^k corners + samples
      validate: {samples: 200, seed: 2}            # the held-out set, scored after the run

(Inside a flow mapping ``{...}`` YAML reads ``[`` as a list: quote such names there, ``{"tf.num[0]": ...}``.)
Which names a plant accepts is its kind's to say (:attr:`objectives.control.plants.base.PlantKind.uncertain`):
LTI plants their coefficients (``tf.num[i]``, ``tf.den[i]``, ``zpk.z[i]``, ``zpk.p[i]``, ``zpk.k``,
``ss.A[i][j]``, ``ss.B[i][j]``, ...), Python plants their ``params.<name>``, FMU plants their
``parameters.<name>``, and every plant ``delay_s``. A name a plant does not have is an error listing
those it has.

Model sets. The **tuning set** is the nominal plant (model 0), then, with ``corners``, every combination
of each parameter's two ends (a range's low and high; a normal's mean -+ 2 std), at most
:data:`MAX_CORNERS`, then ``samples`` models drawn from the distributions with ``default_rng(seed)``
(independent; a normal by inverting its CDF on the truncated interval). The **held-out set** is
``validate.samples`` models drawn the same way from ``validate.seed`` (a different default seed), never
seen by the tuning: the loop scores the tuned controller on it after the run, as the test recordings of
a filter (pass rate of every requirement, worst margins, the cost's distribution). Each model is the
kind's builder called on the perturbed spec (:attr:`~objectives.control.plants.base.PlantKind.perturb`),
so a perturbed model is checked like the nominal one; one that cannot be built is an error naming it.
"""

from __future__ import annotations

import copy
import difflib
import itertools
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tuner.sizes import MAX_MODELS, check_count

__all__ = ["Dist", "Uncertainty", "uncertainty_from_spec", "ModelDraw", "draw_models", "set_path", "spec_leaves",
           "MAX_CORNERS", "DELAY", "check_largest_delay"]

#: the most corners a tuning set may have (2^6: six parameters)
MAX_CORNERS = 64
#: the name of the input delay every plant of the generic loop has (rounded to whole periods)
DELAY = "delay_s"
#: where a normal's corners sit and where it is truncated, in standard deviations
NORMAL_CORNER, NORMAL_TRUNC = 2.0, 3.0
_TOKEN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]|\.")


def _path(name: str) -> list[Any]:
    """``"ss.A[1][0]"`` -> ``["ss", "A", 1, 0]``; ValueError for a malformed name."""
    out: list[Any] = []
    pos = 0
    while pos < len(name):
        m = _TOKEN.match(name, pos)
        if m is None:
            raise ValueError(f"malformed parameter name {name!r}")
        if m.group(1) is not None:
            out.append(m.group(1))
        elif m.group(2) is not None:
            out.append(int(m.group(2)))
        pos = m.end()
    if not out or not isinstance(out[0], str):
        raise ValueError(f"malformed parameter name {name!r}")
    return out


def set_path(spec: Mapping[str, Any], values: Mapping[str, float]) -> dict[str, Any]:
    """A deep copy of ``spec`` with each ``name: value`` set at the path ``name`` names (``a.b[i][j]``);
    a scalar where an index points becomes a one-element list first."""
    out = copy.deepcopy(dict(spec))
    for name, value in values.items():
        keys = _path(name)
        node: Any = out
        for k, nxt in zip(keys[:-1], keys[1:]):
            child = node[k] if not isinstance(k, str) else node.get(k)
            if isinstance(nxt, int) and not isinstance(child, list):
                child = np.atleast_1d(np.asarray(child, dtype=float)).tolist() if child is not None else []
            elif child is None:
                child = {}
            node[k] = child
            node = child
        node[keys[-1]] = float(value)
    return out


def spec_leaves(prefix: str, value: Any) -> dict[str, float]:
    """Every number of ``value`` (a number, a list, a list of lists) by its path under ``prefix``."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return {prefix: float(arr)}
    return {prefix + "".join(f"[{i}]" for i in idx): float(arr[idx]) for idx in np.ndindex(arr.shape)}


@dataclass(frozen=True)
class Dist:
    """The distribution of one parameter: ``uniform`` on ``[low, high]`` or ``normal`` (``mean``, ``std``,
    truncated at -+ :data:`NORMAL_TRUNC` std)."""

    name: str
    kind: str
    low: float
    high: float
    mean: float = math.nan
    std: float = math.nan

    def corners(self) -> tuple[float, float]:
        if self.kind == "normal":
            return self.mean - NORMAL_CORNER * self.std, self.mean + NORMAL_CORNER * self.std
        return self.low, self.high

    def sample(self, u: np.ndarray) -> np.ndarray:
        """Values of the uniform numbers ``u`` in [0, 1) (inverse CDF)."""
        if self.kind == "normal":
            from scipy.special import ndtr, ndtri

            a, b = ndtr(-NORMAL_TRUNC), ndtr(NORMAL_TRUNC)
            return self.mean + self.std * ndtri(a + u * (b - a))
        return self.low + u * (self.high - self.low)

    def text(self) -> str:
        if self.kind == "normal":
            return f"normal(mean {self.mean:.6g}, std {self.std:.4g}, truncated at {NORMAL_TRUNC:g} std)"
        return f"uniform [{self.low:.6g}, {self.high:.6g}]"


def _finite(key: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{key}: must be a finite number, got {v!r}")
    return float(v)


def _dist(name: str, spec: Any, nominal: float, key: str) -> Dist:
    """One parameter's distribution from its YAML form (module docstring)."""
    if isinstance(spec, list) or (isinstance(spec, Mapping) and set(spec) == {"uniform"}):
        pair = spec if isinstance(spec, list) else spec["uniform"]
        if not isinstance(pair, list) or len(pair) != 2:
            raise ValueError(f"{key}: a range is [low, high], got {pair!r}")
        lo, hi = _finite(f"{key}[0]", pair[0]), _finite(f"{key}[1]", pair[1])
        if not lo < hi:
            raise ValueError(f"{key}: need low < high, got [{lo:g}, {hi:g}]")
        if not lo <= nominal <= hi:
            raise ValueError(f"{key}: the nominal value {nominal:g} is outside [{lo:g}, {hi:g}]; the range must "
                             "hold it")
        return Dist(name, "uniform", lo, hi)
    if isinstance(spec, Mapping) and set(spec) == {"rel"}:
        r = _finite(f"{key}.rel", spec["rel"])
        if not 0.0 < r < 1.0:
            raise ValueError(f"{key}.rel: a relative range in (0, 1) (0.2: -+20 %), got {r:g}")
        if nominal == 0.0:
            raise ValueError(f"{key}.rel: the nominal value is 0, so a relative range is empty; give [low, high]")
        lo, hi = sorted((nominal * (1 - r), nominal * (1 + r)))
        return Dist(name, "uniform", lo, hi)
    if isinstance(spec, Mapping) and set(spec) == {"normal"}:
        body = spec["normal"]
        if not isinstance(body, Mapping) or not {"std"} <= set(body) <= {"std", "mean"}:
            raise ValueError(f"{key}.normal: {{std: s}} and optionally mean (default: the nominal value), got {body!r}")
        std = _finite(f"{key}.normal.std", body["std"])
        if std <= 0:
            raise ValueError(f"{key}.normal.std: must be > 0, got {std:g}")
        mean = _finite(f"{key}.normal.mean", body.get("mean", nominal))
        return Dist(name, "normal", mean - NORMAL_TRUNC * std, mean + NORMAL_TRUNC * std, mean, std)
    raise ValueError(f"{key}: [low, high], {{uniform: [low, high]}}, {{rel: r}} or {{normal: {{std: s, mean: m}}}}, "
                     f"got {spec!r}")


@dataclass(frozen=True)
class Uncertainty:
    """A parsed ``uncertainty:`` block: the distributions and the two sets' sizes and seeds."""

    dists: tuple[Dist, ...]
    nominal: dict[str, float]
    corners: bool = True
    samples: int = 4
    seed: int = 1
    validate_samples: int = 200
    validate_seed: int = 2

    @property
    def names(self) -> list[str]:
        return [d.name for d in self.dists]

    def tuning_size(self) -> int:
        return 1 + (2 ** len(self.dists) if self.corners else 0) + self.samples


def _int(key: str, v: Any, lo: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        raise ValueError(f"{key}: must be an integer >= {lo}, got {v!r}")
    return v


def uncertainty_from_spec(spec: Any, kind: Any, plant_spec: Mapping[str, Any], period_s: float) -> Uncertainty | None:
    """The ``uncertainty`` block checked against the plant's perturbable parameters (``kind.uncertain``);
    None when absent; ``ValueError`` naming the key otherwise."""
    key = "objective.uncertainty"
    if spec is None:
        return None
    if not isinstance(spec, Mapping) or set(spec) - {"parameters", "tune", "validate"}:
        raise ValueError(f"{key}: a mapping of parameters, tune and validate, got "
                         f"{sorted(spec) if isinstance(spec, Mapping) else spec!r}")
    if kind.uncertain is None:
        raise ValueError(f"{key}: plant kind {kind.key!r} declares no parameter an uncertainty block may perturb")
    have = dict(kind.uncertain(plant_spec))
    params = spec.get("parameters")
    if not isinstance(params, Mapping) or not params:
        raise ValueError(f"{key}.parameters: a non-empty mapping of parameter: range or distribution; this plant "
                         f"has {_listing(have)}")
    dists = []
    for name, d in params.items():
        if name not in have:
            close = difflib.get_close_matches(str(name), list(have), n=3)
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise ValueError(f"{key}.parameters.{name}: not a parameter of this plant{hint}; it has {_listing(have)}")
        dist = _dist(name, d, have[name], f"{key}.parameters.{name}")
        if name == DELAY and dist.low < 0:
            raise ValueError(f"{key}.parameters.{name}: a delay is >= 0 s; the range reaches {dist.low:g} s")
        dists.append(dist)
    tune = spec.get("tune") or {}
    val = spec.get("validate") or {}
    for k, m, allowed in (("tune", tune, {"corners", "samples", "seed"}), ("validate", val, {"samples", "seed"})):
        if not isinstance(m, Mapping) or set(m) - allowed:
            raise ValueError(f"{key}.{k}: a mapping of {', '.join(sorted(allowed))}, got {m!r}")
    corners = tune.get("corners", True)
    if not isinstance(corners, bool):
        raise ValueError(f"{key}.tune.corners: true or false, got {corners!r}")
    if corners and 2 ** len(dists) > MAX_CORNERS:
        raise ValueError(f"{key}.tune.corners: {len(dists)} parameters have {2 ** len(dists)} corners (at most "
                         f"{MAX_CORNERS}); set corners: false and tune on samples")
    u = Uncertainty(tuple(dists), {d.name: have[d.name] for d in dists}, corners,
                    _int(f"{key}.tune.samples", tune.get("samples", 4), 0),
                    _int(f"{key}.tune.seed", tune.get("seed", 1), 0),
                    _int(f"{key}.validate.samples", val.get("samples", 200), 1),
                    _int(f"{key}.validate.seed", val.get("seed", 2), 0))
    # each model is a built plant (and its frequency responses) in memory: bounded before any is drawn
    check_count(f"{key}.tune.samples", u.tuning_size(), MAX_MODELS, "the tuning set's size in models (nominal, "
                "corners and samples)")
    check_count(f"{key}.validate.samples", u.validate_samples, MAX_MODELS, "the held-out set's size in models")
    if u.corners is False and u.samples == 0:
        raise ValueError(f"{key}.tune: without corners and samples the tuning set is the nominal plant alone; give "
                         "samples or corners: true")
    return u


def _listing(have: Mapping[str, float], n: int = 12) -> str:
    names = list(have)
    more = f", ... ({len(names)} in all)" if len(names) > n else ""
    return ", ".join(names[:n]) + more if names else "none"


@dataclass(frozen=True)
class ModelDraw:
    """The models of a set before they are built: a label and the perturbed values of each."""

    labels: tuple[str, ...]
    values: tuple[dict[str, float], ...]


def _snap(values: dict[str, float], period_s: float) -> dict[str, float]:
    if DELAY in values:
        values[DELAY] = max(0.0, round(values[DELAY] / period_s) * period_s)
    return values


def draw_models(u: Uncertainty, which: str, period_s: float) -> ModelDraw:
    """The ``tuning`` set (nominal, corners, samples) or the ``held-out`` set (samples) of ``u``; the delay
    is rounded to whole periods."""
    labels: list[str] = []
    values: list[dict[str, float]] = []
    if which == "tuning":
        labels.append("nominal")
        values.append(dict(u.nominal))
        if u.corners:
            ends = [d.corners() for d in u.dists]
            for signs in itertools.product((0, 1), repeat=len(u.dists)):
                labels.append("corner " + "".join("-+"[s] for s in signs))
                values.append({d.name: ends[i][s] for i, (d, s) in enumerate(zip(u.dists, signs))})
        n, seed = u.samples, u.seed
    else:
        n, seed = u.validate_samples, u.validate_seed
    if n:
        draws = np.random.default_rng(seed).random((n, len(u.dists)))
        cols = [d.sample(draws[:, j]) for j, d in enumerate(u.dists)]
        for i in range(n):
            labels.append(f"sample {i + 1}")
            values.append({d.name: float(cols[j][i]) for j, d in enumerate(u.dists)})
    return ModelDraw(tuple(labels), tuple(_snap(v, period_s) for v in values))


def check_largest_delay(u: Uncertainty, kind: Any, spec: Mapping[str, Any], period_s: float, base_dir: Any) -> None:
    """The plant at the largest delay the block can draw (a range's high end, a normal's truncation), other
    values nominal, built once before any model set: a delay the builder refuses (its size checks,
    :mod:`tuner.sizes`) is one error line before tuning, not after the run when the held-out set is drawn."""
    dist = next((d for d in u.dists if d.name == DELAY), None)
    if dist is None:
        return
    high = dist.mean + NORMAL_TRUNC * dist.std if dist.kind == "normal" else dist.high
    values = _snap({**u.nominal, DELAY: high}, period_s)
    try:
        kind.build((kind.perturb or set_path)(spec, values), period_s, base_dir, "objective.plant")
    except ValueError as exc:
        raise ValueError(f"objective.uncertainty.parameters.{DELAY}: the largest delay it can draw "
                         f"({values[DELAY]:g} s) cannot be built: {exc}") from None
