"""The filter objective's data: the split type, the recordings of both splits and what evaluations reuse.

:class:`~objectives.attitude.objective.FilterObjective` loads each split's recordings once (a
:class:`DataSplit`) and, on the first evaluation of a split, prepares what every evaluation of it reuses
(a :class:`Prepared`, built by :func:`prepare`): the recordings, their groups for group-balanced metrics
and the adaptive filters' disturbance inputs. Neither travels with a pickled objective: a worker process
loads and prepares its own copy, so no precomputed array is sent to workers.

A split is the string ``"train"`` or ``"test"`` (:data:`Split`), the words configs, reports and
histories use; :func:`check_split` turns any other value into a ValueError naming the allowed ones.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import Any, Literal

from objectives.attitude.data.recording import Recording
from objectives.attitude.disturbance import CONTEXT_KEYS
from objectives.attitude.objective_options import recording_groups

__all__ = ["Split", "SPLITS", "check_split", "DataSplit", "Prepared", "prepare"]

#: the tuning (``train``) or held-out (``test``) recordings of an objective
Split = Literal["train", "test"]
SPLITS: tuple[Split, ...] = ("train", "test")


def check_split(split: Any) -> Split:
    """``split`` when it is one of :data:`SPLITS`, else a ValueError naming them."""
    if not isinstance(split, str) or split not in SPLITS:
        raise ValueError(f"split: expected one of {', '.join(SPLITS)}, got {split!r}")
    return split  # type: ignore[return-value]


@dataclass(frozen=True)
class DataSplit:
    """The loaded recordings of each split; None: not loaded yet.

    A split loads on its first use, not both at once: a worker that only tunes never reads the held-out
    recordings, and ``tuner list``-style questions (the sample rate) read only the training ones.
    """

    train: tuple[Recording, ...] | None = None
    test: tuple[Recording, ...] | None = None

    def get(self, split: Split) -> tuple[Recording, ...] | None:
        """The recordings of ``split`` (None: not loaded)."""
        return getattr(self, check_split(split))

    def with_split(self, split: Split, recordings: Iterable[Recording]) -> DataSplit:
        """A copy holding ``recordings`` as ``split``."""
        return replace(self, **{check_split(split): tuple(recordings)})


def context(flt: Any) -> tuple:
    """What ``flt``'s disturbance inputs depend on: its values of ``CONTEXT_KEYS``
    (:mod:`objectives.attitude.disturbance`), so candidates that differ elsewhere share them."""
    return tuple((k, flt.values.get(k)) for k in CONTEXT_KEYS)


@dataclass
class Prepared:
    """What every evaluation on one split reuses (``FilterObjective.prepare``).

    recordings : the split's recordings.
    groups : recording name -> group for a group-balanced metric (None when the metric does not balance
        groups); ``groups_error`` is why they could not be formed, raised where the metric combines
        (:meth:`group_map`), so each evaluation fails as it always did instead of the preparation.
    dist : the adaptive filters' fuzzy inputs by :func:`context`, one entry per recording (None: not yet
        computed). :func:`prepare` fills those of the fixed options; another context (a searched window,
        a ``filter_override``) is computed on first use by :meth:`disturbances`.
    batch : the recordings as the population kernels read them (``objectives.attitude.batch``), built by
        the batch path on its first use: a serial run does not need them.
    """

    split: Split
    recordings: tuple[Recording, ...]
    groups: dict[str, str] | None = None
    groups_error: Exception | None = None
    dist: dict[tuple, list[Any]] = field(default_factory=dict)
    batch: Any = None

    def group_map(self) -> dict[str, str] | None:
        """``groups``, or the error that kept them from being formed."""
        if self.groups_error is not None:
            raise self.groups_error.with_traceback(None)
        return self.groups

    def disturbances(self, flt: Any, i: int) -> Any:
        """``flt.disturbances`` of recording ``i``, computed once per context."""
        per = self.dist.setdefault(context(flt), [None] * len(self.recordings))
        if per[i] is None:
            per[i] = flt.disturbances(self.recordings[i])
        return per[i]


def prepare(obj: Any, split: Split) -> Prepared:
    """The :class:`Prepared` of the filter objective ``obj`` on ``split``.

    Groups are formed when the metric balances them. Disturbance inputs are computed for every recording
    when the filter has them and no searched value changes them (no ``CONTEXT_KEYS`` name is free): they
    are what every candidate uses, as the first evaluation would compute them. A filter that the defaults
    with ``fixed`` do not build, or a recording the measures fail on, leaves them to the evaluations, which
    fail as they always did.
    """
    recs = obj.recordings(split)
    out = Prepared(split, tuple(recs))
    opts = obj.metric_options
    if recs and opts.get("group_balanced", False):
        try:
            out.groups = recording_groups(list(recs), opts.get("groups", "broad"))
        except Exception as exc:  # raised by each evaluation's metric (group_map)
            out.groups_error = exc
    if not recs or not callable(getattr(obj._cls, "disturbances", None)):
        return out
    if set(CONTEXT_KEYS) & set(obj.default_space().free_names):
        return out
    try:
        flt = obj.make_filter({})
        for i in range(len(recs)):
            out.disturbances(flt, i)
    except Exception:  # the evaluations meet it again
        pass
    return out
