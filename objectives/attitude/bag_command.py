"""``tuner bag PATH``: the topics of a ROS bag, their message types, counts and rates, and which key of a
``rosbag:`` data spec each one fits (``imu``, ``mag``, ``truth``).

A domain command (the engine's ``tuner.commands`` entry points), so the engine names no ROS type.
``tuner describe rosbag`` describes the data source's keys; this command looks into one bag. It needs the
optional extra ``.[ros]`` (rosbags); without it, or on a path that is not a bag, it prints one ``error:`` line
and exits with status 2.
"""

from __future__ import annotations

import json
import sys
from typing import Any

__all__ = ["BagCommand", "BAG"]


class BagCommand:
    """``tuner bag PATH [--json]`` (module docstring)."""

    name = "bag"
    help = "the topics and message types of a ROS 1 or ROS 2 bag, and the rosbag: keys they fit"

    @staticmethod
    def add_arguments(parser: Any) -> None:
        parser.add_argument("path", help="a ROS 1 .bag file or a ROS 2 bag directory (sqlite3 or MCAP)")
        parser.add_argument("--json", action="store_true", help="print the topics as JSON")

    @staticmethod
    def run(args: Any) -> int:
        """Print one line per topic (or JSON); ``error: ...`` and 2 on bad input."""
        from objectives.attitude.data.recording import RecordingError
        from objectives.attitude.data.rosbag import bag_topics

        try:
            topics = bag_topics(args.path)
        except RecordingError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        if getattr(args, "json", False):
            print(json.dumps(topics, indent=1))
            return 0
        width = max([len(t["topic"]) for t in topics] + [5])
        for t in topics:
            rate = "" if t["rate_hz"] is None else f"{t['rate_hz']:.4g} Hz"
            use = f"  -> rosbag: {{{t['use']}: {t['topic']}}}" if t["use"] else ""
            print(f"{t['topic']:<{width}}  {t['type']:<34} {t['count']:>7} msgs  {rate:>10}{use}")
        if not topics:
            print(f"{args.path}: no topics")
        return 0


#: the command object the ``tuner.commands`` entry point names
BAG = BagCommand()
