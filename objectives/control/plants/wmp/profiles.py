"""Reference profiles: desired linear speed nu_d and yaw rate xi_d as step sequences.

The thesis (section 2.3.4) uses nu_d = {0.4, 0, -0.2, 0} m/s and xi_d = {30, 0, -70, 0} deg/s; the
step times are only visible in its (missing) figures, so :data:`THESIS_PROFILE` holds each value for
2.5 s over a 10 s run (steps at 0, 2.5, 5 and 7.5 s), long enough for the closed loops of
Figs. 2.16-2.17 (settling in ~0.7 s) to settle.

:data:`THESIS_2S_PROFILE` (``profile: thesis_2s``) holds each value for 2 s (8 s run): the step time
that best reproduces the thesis's own Table 2.5, whose time-weighted and plain error integrals
(STAE/SAE, STSE/SSE of eqs. 2.34-2.35) fix the error-weighted mean time of each error signal and
hence the step spacing (docs/control-cost.md: least log-error at holds of 1.94-2.08 s for the fuzzy
and linear schemes together, 2.5 s is 30 % off). The closed-loop configs use it.

YAML form::

    profile: {duration_s: 10.0, steps: [{t: 0, v: 0.4, yaw_rate_deg_s: 30}, {t: 2.5, v: 0, yaw_rate_deg_s: 0}]}

or a name (``profile: thesis``). Each step holds from its time ``t`` (s) until the next one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Profile", "THESIS_PROFILE", "THESIS_2S_PROFILE", "PROFILES", "profile_from_config"]


@dataclass(frozen=True)
class Profile:
    """Step references; ``times_s`` increasing from 0, ``v_ms`` (m/s), ``yaw_deg_s`` (deg/s)."""

    times_s: tuple[float, ...]
    v_ms: tuple[float, ...]
    yaw_deg_s: tuple[float, ...]
    duration_s: float

    def __post_init__(self) -> None:
        n = len(self.times_s)
        if n == 0 or len(self.v_ms) != n or len(self.yaw_deg_s) != n:
            raise ValueError("a profile needs at least one step, each with t, v and yaw_rate_deg_s")
        t = np.asarray(self.times_s, float)
        if not np.all(np.isfinite(t)) or t[0] != 0 or np.any(np.diff(t) <= 0):
            raise ValueError(f"step times must start at 0 and increase, got {list(self.times_s)}")
        if not (math.isfinite(self.duration_s) and self.duration_s > t[-1]):
            raise ValueError(f"duration_s={self.duration_s} must exceed the last step time {t[-1]}")
        if not (np.all(np.isfinite(self.v_ms)) and np.all(np.isfinite(self.yaw_deg_s))):
            raise ValueError("profile values must be finite")

    def sample(self, Ts: float) -> np.ndarray:
        """(N, 2) array of (nu_d m/s, xi_d rad/s) at t_k = k Ts, N = round(duration / Ts) (at most
        :data:`tuner.sizes.MAX_SAMPLES`, checked before anything is allocated)."""
        from tuner.sizes import samples

        n = samples("profile.duration_s", self.duration_s, Ts, "the profile")
        t = np.arange(n) * Ts
        idx = np.searchsorted(np.asarray(self.times_s), t + 1e-9 * Ts, side="right") - 1
        out = np.empty((n, 2))
        out[:, 0] = np.asarray(self.v_ms)[idx]
        out[:, 1] = np.radians(np.asarray(self.yaw_deg_s))[idx]
        return out

    @classmethod
    def from_dict(cls, spec: Mapping[str, Any]) -> Profile:
        allowed = {"duration_s", "steps", "dt_s"}
        unknown = sorted(set(spec) - allowed)
        if unknown:
            raise ValueError(f"profile: unknown key(s) {unknown}; allowed: {sorted(allowed)}")
        steps = spec.get("steps")
        if not isinstance(steps, list) or not steps:
            raise ValueError("profile.steps must be a non-empty list of {t, v, yaw_rate_deg_s}")
        for i, s in enumerate(steps):
            if not isinstance(s, Mapping) or set(s) - {"t", "v", "yaw_rate_deg_s"} or "t" not in s:
                raise ValueError(f"profile.steps[{i}]: expected keys t, v, yaw_rate_deg_s, got {s!r}")
        duration = spec.get("duration_s")
        if duration is None:
            raise ValueError("profile.duration_s is required")
        return cls(
            tuple(float(s["t"]) for s in steps),
            tuple(float(s.get("v", 0.0)) for s in steps),
            tuple(float(s.get("yaw_rate_deg_s", 0.0)) for s in steps),
            float(duration),
        )


THESIS_PROFILE = Profile((0.0, 2.5, 5.0, 7.5), (0.4, 0.0, -0.2, 0.0), (30.0, 0.0, -70.0, 0.0), 10.0)
THESIS_2S_PROFILE = Profile((0.0, 2.0, 4.0, 6.0), (0.4, 0.0, -0.2, 0.0), (30.0, 0.0, -70.0, 0.0), 8.0)
PROFILES = {"thesis": THESIS_PROFILE, "thesis_2s": THESIS_2S_PROFILE}


def profile_from_config(spec: str | Mapping[str, Any] | None) -> Profile:
    """A named profile or a YAML mapping (see the module docstring); ``None`` is the thesis profile."""
    if spec is None:
        return THESIS_PROFILE
    if isinstance(spec, str):
        try:
            return PROFILES[spec]
        except KeyError:
            raise ValueError(f"unknown profile {spec!r}; known: {sorted(PROFILES)}") from None
    if isinstance(spec, Mapping):
        return Profile.from_dict(spec)
    raise ValueError(f"profile must be a name or a mapping, got {spec!r}")
