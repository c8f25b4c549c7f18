"""What the command modules share: the usage error (one ``error:`` line, exit 2) and argument types."""

from __future__ import annotations

import argparse

__all__ = ["UsageError", "fraction"]


class UsageError(Exception):
    """Bad arguments or a path that is not what the command needs: ``error: <message>``, exit 2."""


def fraction(text: str) -> float:
    """A number in (0, 1] (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1], got {text!r}") from None
    if not 0 < value <= 1:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1], got {text!r}")
    return value
