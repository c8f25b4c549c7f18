"""The YAML face every closed loop shares: reading the loop's settings from the ``objective:`` mapping and
putting the config key in front of a construction error. A loop class inherits :class:`LoopYaml` and
declares its keys."""

from __future__ import annotations

import pathlib
from collections.abc import Mapping
from typing import Any, ClassVar

__all__ = ["LoopYaml"]


class LoopYaml:
    """Mixin of a loop class: ``settings_from_config`` and ``error_key`` from the class's declarations."""

    #: every settings key the loop takes (besides kind, plant, controller, fixed)
    KEYS: ClassVar[frozenset[str]]
    #: keys whose value must be a mapping when given
    MAPPINGS: ClassVar[tuple[str, ...]]
    #: keys copied as a dict (an empty one when absent or null)
    SECTIONS: ClassVar[tuple[str, ...]]
    #: keys copied as given, only when given and not null
    OPTIONAL: ClassVar[tuple[str, ...]]
    #: the plant named in the unknown-key error
    WHAT: ClassVar[str] = "a plant mapping"

    @classmethod
    def settings_from_config(cls, section: Mapping[str, Any], base_dir: pathlib.Path | None) -> dict[str, Any]:
        """The loop's settings of the YAML ``objective:`` mapping; unknown keys and non-mappings are
        ``ValueError`` naming the key."""
        allowed = cls.KEYS | {"kind", "plant", "controller", "fixed"}
        unknown = sorted(set(section) - allowed)
        if unknown:
            raise ValueError(f"objective.{unknown[0]}: unknown key for {cls.WHAT}; allowed: {sorted(allowed)}")
        for k in ("fixed", *cls.MAPPINGS):
            if section.get(k) is not None and not isinstance(section[k], Mapping):
                raise ValueError(f"objective.{k}: expected a mapping, got {section[k]!r}")
        out = {"period_s": section.get("period_s", 0.01), **{k: dict(section.get(k) or {}) for k in cls.SECTIONS}}
        out.update({k: section[k] for k in cls.OPTIONAL if section.get(k) is not None})
        return out

    @staticmethod
    def error_key(msg: str) -> str:
        """``msg`` with the config key it concerns in front (``objective.fixed`` for a controller value)."""
        if msg.startswith("objective"):
            return msg
        return f"{'objective.fixed' if msg.startswith('controller') else 'objective'}: {msg}"
