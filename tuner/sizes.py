"""Size checks before an allocation a config controls, against memory and time.

A config can ask for any number: ``scenario.duration_s: 1e9``, ``period_s: 1e-12`` or a synthetic recording
of 10^6 s at 1 kHz ended in out-of-memory tracebacks (up to 14.6 TiB requested), and a transfer function of
order 3000 or a 100 s delay in a closed loop whose linear analysis holds every delayed sample as a state
gave no answer within a minute. As for the optimiser's population and generations
(:data:`tuner.config.MAX_COUNT`), each size is checked before anything is allocated for it, here, against
one written limit, and refused as a ``ValueError`` naming the key (one ``error:`` line):

- :data:`MAX_SAMPLES` samples of one simulated or synthetic signal (a duration over a period, or times a
  rate): 10 million, 2.8 hours at 1 kHz. The arrays of one signal then take at most a few GB, and one
  evaluation stays within seconds to minutes.
- :data:`MAX_LOOP_STATES` states of a linear closed loop (plant states, delayed samples, controller states):
  500. Its poles (an eigenvalue problem of that size, growing as the cube) are computed at every
  evaluation.
- :data:`MAX_MODEL_ORDER` states of an LTI plant model (a transfer function's denominator degree, a
  zero-pole-gain's poles, a state space's A): 200.
- :data:`MAX_SAMPLES` also bounds the samples of a job's scenarios together (``scenarios:``, a list: each
  holds its signals and noise), and :data:`MAX_MODELS` the models of one model set (``uncertainty:``'s
  ``tune.samples`` plus corners, ``validate.samples``): 10,000, each a built plant (and for an LTI model set its
  frequency responses) in memory.
- :data:`MAX_LOOP_SAMPLES` sample steps of one pass over a model set and the scenarios (models x samples of
  all scenarios; one evaluation of a candidate on the tuning set, the held-out scoring once after the run):
  10^9, about a minute of the compiled loop.
"""

from __future__ import annotations

import math

__all__ = ["MAX_SAMPLES", "MAX_LOOP_STATES", "MAX_MODEL_ORDER", "MAX_MODELS", "MAX_LOOP_SAMPLES", "check_samples",
           "samples", "check_count"]

#: the most samples of one simulated or synthetic signal
MAX_SAMPLES = 10_000_000
#: the most states of a linear closed loop whose poles are computed at every evaluation
MAX_LOOP_STATES = 500
#: the most states of an LTI plant model
MAX_MODEL_ORDER = 200
#: the most models in one model set (the tuning set, or the held-out set)
MAX_MODELS = 10_000
#: the most sample steps of one pass over a model set and every scenario (models x samples of all scenarios)
MAX_LOOP_SAMPLES = 1_000_000_000


def check_count(key: str, n: float, limit: int, what: str, hint: str = "") -> int:
    """``n`` as an int, or a ``ValueError`` naming ``key`` when it is not a finite number up to ``limit``."""
    if not (isinstance(n, (int, float)) and math.isfinite(n)) or n > limit:
        shown = f"{n:,.0f}" if isinstance(n, (int, float)) and math.isfinite(n) else repr(n)
        raise ValueError(f"{key}: {what} is {shown}; at most {limit:,} are allowed{'; ' + hint if hint else ''}")
    return int(n)


def check_samples(key: str, n: float, what: str = "the signal") -> int:
    """``n`` samples of one signal, checked against :data:`MAX_SAMPLES` (``what`` says whose)."""
    return check_count(key, n, MAX_SAMPLES, f"{what}'s length in samples",
                       "shorten the duration or lengthen the period (a typo such as 1e9 s or 1e-12 s?)")


def samples(key: str, duration_s: float, period_s: float, what: str = "the signal") -> int:
    """``round(duration_s / period_s)`` samples, checked by :func:`check_samples` before any array exists."""
    if not (math.isfinite(duration_s) and math.isfinite(period_s) and period_s > 0):
        raise ValueError(f"{key}: a finite duration and a period > 0 s are needed, got {duration_s!r} s over "
                         f"{period_s!r} s")
    return check_samples(key, round(duration_s / period_s), what)
