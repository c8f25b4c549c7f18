"""ROS bags as recordings: ROS 1 ``.bag`` files and ROS 2 bags (sqlite3 or MCAP), read with ``rosbags``.

``rosbags`` is pure Python and needs no ROS installation; it is the optional extra ``.[ros]`` (and part of
``dev``). Without it everything else works and a ``rosbag:`` spec is one error naming the extra. A spec::

    rosbag:
      path: flight.bag               # a ROS 1 .bag file, or a ROS 2 bag directory (metadata.yaml + .db3/.mcap)
      imu: /imu/data_raw             # sensor_msgs/Imu (default: the bag's one Imu topic)
      mag: /imu/mag                  # sensor_msgs/MagneticField (optional; tesla, read as uT)
      truth: /mocap/pose             # geometry_msgs/PoseStamped, TransformStamped, nav_msgs/Odometry or a
                                     # tf2_msgs/TFMessage topic (/tf) with truth_child_frame (optional)
      truth_child_frame: imu_marker  # the tf child frame whose transform is the truth (a TFMessage topic)
      world_frame: ENU               # the truth's world frame: ENU (REP-103, default) | NED | NWU
      stamps: header                 # header (header.stamp, default) | bag (the time the bag recorded it)

and every option of a CSV recording that concerns time and truth (``resample_hz``, ``max_dropped_share``,
``max_truth_gap_s``, ``quat_norm_tol``, ``truth_rate_factor``, ``jitter_tol``, ``align``, ``name``), with the
same meaning (:mod:`objectives.attitude.data.csv`, :mod:`objectives.attitude.data.timebase`,
:mod:`objectives.attitude.data.alignment`), plus ``start_s`` / ``stop_s``.

Conventions (REP-103 and REP-145):

- the IMU's angular velocity (rad/s) and linear acceleration (m/s^2, specific force: +g up at rest) are in
  the IMU's own frame (``header.frame_id``); a ``MagneticField`` is in tesla in its frame (read as uT);
- a pose or transform gives the child (body) frame's orientation in the parent (world) frame, i.e. the
  rotation of body vectors into the world: the recording's sensor-to-earth truth with no conjugation;
- the world frame is ENU by REP-103; ``NED`` keeps the recording in NED (the filters then run in NED);
  ``NWU`` (the convention of some older nodes) is turned into ENU by the rotation of +90 deg about up;
- the truth's body is the frame the pose names; when it is not the IMU's frame, ``align: {body: auto}``
  estimates the rotation between them, or ``align: {body: [w, x, y, z]}`` states it.

The rows of the recording are the IMU messages at their stamps (taken relative to the first, from integer
nanoseconds, so epoch stamps lose no precision). The magnetometer is read at those stamps (its own rows where
the stamps coincide, else linearly interpolated; IMU rows outside its span are dropped with a warning); the
truth likewise (its own rows at coinciding stamps, else slerp, never across ``max_truth_gap_s``). From there
the reading is the CSV reader's (:func:`objectives.attitude.data.csv.from_stamps`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from objectives.attitude.data.alignment import AlignSpec
from objectives.attitude.data.recording import RecordingError
from objectives.attitude.data.timebase import slerp

__all__ = ["load_rosbag", "bag_topics", "ROSBAG_OPTIONS", "rosbag_keys", "IMU", "MAG", "TRUTH_TYPES"]

IMU = "sensor_msgs/msg/Imu"
MAG = "sensor_msgs/msg/MagneticField"
POSE, TRANSFORM, ODOM, TF = ("geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/TransformStamped",
                             "nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage")
#: message types a truth topic may carry
TRUTH_TYPES = (POSE, TRANSFORM, ODOM, TF)
WORLD_FRAMES = ("ENU", "NED", "NWU")
#: options of a ``rosbag:`` spec besides ``path`` and the cut (``start_s``/``stop_s``)
ROSBAG_OPTIONS = ("imu", "mag", "truth", "truth_child_frame", "world_frame", "stamps", "name", "jitter_tol",
                  "max_dropped_share", "resample_hz", "max_truth_gap_s", "quat_norm_tol", "truth_rate_factor",
                  "align")
_TESLA_TO_UT = 1e6


def rosbag_keys() -> list[dict[str, Any]]:
    """Every key of a ``rosbag:`` data spec with its default and allowed values (``tuner describe rosbag``)."""
    from objectives.attitude.data.csv import csv_keys

    shared = {k["name"]: k for k in csv_keys()}
    return [
        {"name": "path", "default": None,
         "doc": "a ROS 1 .bag file or a ROS 2 bag directory (sqlite3 or MCAP), relative to the config; "
                "`tuner bag PATH` lists its topics"},
        {"name": "imu", "default": None, "doc": "the sensor_msgs/Imu topic (default: the bag's only one)"},
        {"name": "mag", "default": None, "doc": "a sensor_msgs/MagneticField topic (tesla, read as uT); none: no "
                                                "magnetometer"},
        {"name": "truth", "default": None,
         "doc": "the truth topic: geometry_msgs/PoseStamped, geometry_msgs/TransformStamped, nav_msgs/Odometry "
                "or tf2_msgs/TFMessage (with truth_child_frame); none: no truth"},
        {"name": "truth_child_frame", "default": None,
         "doc": "the child_frame_id whose transform is the truth (needed for a TFMessage topic, checked for the "
                "others when given)"},
        {"name": "world_frame", "default": "ENU",
         "doc": "the truth's world frame: ENU (REP-103), NED, or NWU (turned into ENU: +90 deg about up)"},
        {"name": "stamps", "default": "header", "doc": "header (each message's header.stamp) or bag (the time "
                                                       "the bag recorded it)"},
        {"name": "name", "default": None, "doc": "recording name (default: the bag's name, and for a window of it "
                                                 "bag@start-stop)"},
        *(shared[k] for k in ("jitter_tol", "max_dropped_share", "resample_hz", "max_truth_gap_s", "quat_norm_tol",
                              "truth_rate_factor", "align")),
    ]


def _open(path: Path) -> Any:
    """An open ``AnyReader`` on ``path`` (ROS 1 messages read into ROS 2 types: ``stamp.sec``/``nanosec``)."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise RecordingError(f"{path}: reading a ROS bag needs the optional package rosbags: "
                             "pip install 'attitude-tuner[ros]'") from None
    if not path.exists():
        raise RecordingError(f"{path}: path: not found (a ROS 1 .bag file or a ROS 2 bag directory)")
    reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
    try:
        reader.open()
    except Exception as exc:  # rosbags' own errors (not a bag, unknown storage) have no common base class
        raise RecordingError(f"{path}: path: not a readable ROS bag ({' '.join(str(exc).split())})") from None
    return reader


def bag_topics(path: str | Path) -> list[dict[str, Any]]:
    """One dict per topic of the bag at ``path``: ``topic``, ``type`` (``pkg/msg/Name``), ``count``,
    ``rate_hz`` (from the bag's record times; None for fewer than 2 messages) and ``use`` (the spec key the
    type fits: imu, mag, truth, or empty)."""
    path = Path(path)
    reader = _open(path)
    try:
        out = []
        for topic in sorted(reader.topics):
            info = reader.topics[topic]
            stamps = [ts for _, ts, _ in reader.messages(connections=info.connections)]
            rate = ((len(stamps) - 1) / ((stamps[-1] - stamps[0]) * 1e-9)
                    if len(stamps) > 1 and stamps[-1] > stamps[0] else None)
            use = {IMU: "imu", MAG: "mag"}.get(info.msgtype, "truth" if info.msgtype in TRUTH_TYPES else "")
            out.append({"topic": topic, "type": info.msgtype, "count": len(stamps), "rate_hz": rate, "use": use})
        return out
    finally:
        reader.close()


def _stamp_ns(msg: Any, bag_ns: int, stamps: str) -> int:
    if stamps == "bag":
        return int(bag_ns)
    st = msg.header.stamp
    return int(st.sec) * 1_000_000_000 + int(st.nanosec)


def _topic(reader: Any, path: Path, key: str, topic: Any, types: tuple[str, ...]) -> Any:
    """The connections of ``topic`` after checking it carries one of ``types``."""
    have = {t: i.msgtype for t, i in reader.topics.items()}
    if topic is None:
        fits = [t for t, ty in have.items() if ty in types]
        if len(fits) != 1:
            raise RecordingError(f"{path}: {key}: " + ("no topic" if not fits else f"{len(fits)} topics {fits}")
                                 + f" of type {' or '.join(types)}; name one: the bag has {_listing(have)}")
        topic = fits[0]
    if not isinstance(topic, str) or topic not in have:
        raise RecordingError(f"{path}: {key}: topic {topic!r} not in the bag; it has {_listing(have)}")
    if have[topic] not in types:
        raise RecordingError(f"{path}: {key}: topic {topic!r} carries {have[topic]}; allowed: {', '.join(types)}")
    return reader.topics[topic].connections


def _listing(have: Mapping[str, str]) -> str:
    return ", ".join(f"{t} ({ty})" for t, ty in sorted(have.items())) or "no topics"


def _read_imu(reader: Any, conns: Any, stamps: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    t, gyr, acc, frame = [], [], [], ""
    for conn, ts, raw in reader.messages(connections=conns):
        m = reader.deserialize(raw, conn.msgtype)
        t.append(_stamp_ns(m, ts, stamps))
        w, a = m.angular_velocity, m.linear_acceleration
        gyr.append((w.x, w.y, w.z))
        acc.append((a.x, a.y, a.z))
        frame = frame or m.header.frame_id
    return np.array(t, np.int64), np.array(gyr, float).reshape(-1, 3), np.array(acc, float).reshape(-1, 3), frame


def _read_mag(reader: Any, conns: Any, stamps: str) -> tuple[np.ndarray, np.ndarray]:
    t, mag = [], []
    for conn, ts, raw in reader.messages(connections=conns):
        m = reader.deserialize(raw, conn.msgtype)
        t.append(_stamp_ns(m, ts, stamps))
        f = m.magnetic_field
        mag.append((f.x, f.y, f.z))
    return np.array(t, np.int64), np.array(mag, float).reshape(-1, 3) * _TESLA_TO_UT


def _read_truth(reader: Any, path: Path, conns: Any, stamps: str, child: Any) -> tuple[np.ndarray, np.ndarray]:
    """Stamps (ns) and sensor-to-earth quaternions (w, x, y, z) of the truth topic."""
    t, q, seen = [], [], set()

    def take(stamp: int, rot: Any, child_id: str) -> None:
        seen.add(child_id)
        if child is None or child_id == child:
            t.append(stamp)
            q.append((rot.w, rot.x, rot.y, rot.z))

    for conn, ts, raw in reader.messages(connections=conns):
        m = reader.deserialize(raw, conn.msgtype)
        if conn.msgtype == POSE:
            take(_stamp_ns(m, ts, stamps), m.pose.orientation, child or "")
        elif conn.msgtype == ODOM:
            take(_stamp_ns(m, ts, stamps), m.pose.pose.orientation, m.child_frame_id if child else "")
        elif conn.msgtype == TRANSFORM:
            take(_stamp_ns(m, ts, stamps), m.transform.rotation, m.child_frame_id if child else "")
        else:  # TFMessage: one message holds several transforms
            for tr in m.transforms:
                take(_stamp_ns(tr, ts, stamps), tr.transform.rotation, tr.child_frame_id)
            if child is None:
                raise RecordingError(f"{path}: truth_child_frame: needed with a tf2_msgs/TFMessage truth topic "
                                     "(which transform is the truth?)" + _children(reader, conns))
    if not t and child is None:
        raise RecordingError(f"{path}: truth: the topic has no message")
    if not t:
        raise RecordingError(f"{path}: truth_child_frame: no transform with child frame {child!r}; the topic has "
                             f"{sorted(seen)}")
    t_ns, quat = np.array(t, np.int64), np.array(q, float).reshape(-1, 4)
    order = np.argsort(t_ns, kind="stable")
    return t_ns[order], quat[order]


def _children(reader: Any, conns: Any) -> str:
    names = set()
    for conn, _, raw in reader.messages(connections=conns):
        names.update(tr.child_frame_id for tr in reader.deserialize(raw, conn.msgtype).transforms)
    return f"; its child frames: {sorted(names)}"


def _exact(t_rows: np.ndarray, t_sig: np.ndarray) -> np.ndarray:
    """For each stamp of ``t_rows`` (ns), the row of ``t_sig`` (ns, increasing) with the same stamp, or -1."""
    j = np.clip(np.searchsorted(t_sig, t_rows), 0, t_sig.shape[0] - 1)
    return np.where(t_sig[j] == t_rows, j, -1)


def _quat_at(t_rows: np.ndarray, t_q: np.ndarray, q: np.ndarray, max_gap_s: float) -> np.ndarray:
    exact = _exact(t_rows, t_q)
    out = np.empty((t_rows.shape[0], 4))
    hit = exact >= 0
    out[hit] = q[exact[hit]]
    if (~hit).any():
        t0 = min(int(t_rows[0]), int(t_q[0]))
        out[~hit] = slerp((t_q - t0) * 1e-9, q, (t_rows[~hit] - t0) * 1e-9, max_gap_s)
    return out


def _mag_at(t_rows: np.ndarray, t_m: np.ndarray, mag: np.ndarray) -> np.ndarray:
    exact = _exact(t_rows, t_m)
    out = np.empty((t_rows.shape[0], 3))
    hit = exact >= 0
    out[hit] = mag[exact[hit]]
    if (~hit).any():
        t0 = int(t_m[0])
        x, xp = (t_rows[~hit] - t0) * 1e-9, (t_m - t0) * 1e-9
        out[~hit] = np.column_stack([np.interp(x, xp, mag[:, k]) for k in range(3)])
    return out


def _check_choice(path: Path, key: str, value: Any, allowed: tuple[str, ...]) -> str:
    v = str(value).strip()
    v = v.upper() if key == "world_frame" else v
    if v not in allowed:
        raise RecordingError(f"{path}: {key}: {value!r} is not one of {', '.join(allowed)}")
    return v


def load_rosbag(
    path: str | Path,
    *,
    imu: str | None = None,
    mag: str | None = None,
    truth: str | None = None,
    truth_child_frame: str | None = None,
    world_frame: str = "ENU",
    stamps: str = "header",
    name: str | None = None,
    jitter_tol: float = 0.05,
    max_dropped_share: float = 0.05,
    resample_hz: float | None = None,
    max_truth_gap_s: float = 0.05,
    quat_norm_tol: float = 0.1,
    truth_rate_factor: float = 3.0,
    align: Mapping[str, Any] | None = None,
) -> Any:
    """Read a ROS bag into a :class:`~objectives.attitude.data.recording.Recording` (module docstring).

    Raises
    ------
    RecordingError
        Naming the bag and the key: rosbags missing, not a bag, a topic absent or of another type (with the
        bag's topics), no IMU message, a TF child frame absent (with those present), and every error of the
        CSV reader's time and truth options.
    """
    from objectives.attitude.data.csv import _check_options, from_stamps

    path = Path(path)
    frame = _check_choice(path, "world_frame", world_frame, WORLD_FRAMES)
    stamps = _check_choice(path, "stamps", stamps, ("header", "bag"))
    if isinstance(jitter_tol, bool) or not isinstance(jitter_tol, (int, float)) or not jitter_tol > 0:
        raise RecordingError(f"{path}: jitter_tol: expected a number > 0 (a fraction of the mean time step), "
                             f"got {jitter_tol!r}")
    _check_options(path, {"max_dropped_share": max_dropped_share, "max_truth_gap_s": max_truth_gap_s,
                          "quat_norm_tol": quat_norm_tol, "truth_rate_factor": truth_rate_factor,
                          "resample_hz": resample_hz})
    spec = None if align is None else AlignSpec.from_config(align, f"{path}: align")
    if spec is not None and truth is None:
        raise RecordingError(f"{path}: align: needs the truth (a 'truth' topic)")
    reader = _open(path)
    try:
        t_ns, gyr, acc, imu_frame = _read_imu(reader, _topic(reader, path, "imu", imu, (IMU,)), stamps)
        mag_sig = None if mag is None else _read_mag(reader, _topic(reader, path, "mag", mag, (MAG,)), stamps)
        truth_sig = (None if truth is None else
                     _read_truth(reader, path, _topic(reader, path, "truth", truth, TRUTH_TYPES), stamps,
                                 truth_child_frame))
    finally:
        reader.close()
    if t_ns.shape[0] < 2:
        raise RecordingError(f"{path}: imu: {t_ns.shape[0]} message(s); a recording needs at least 2")
    warnings: list[str] = []
    if mag_sig is not None:
        t_m, m = mag_sig
        order = np.argsort(t_m, kind="stable")
        t_m, m = t_m[order], m[order]
        inside = (t_ns >= t_m[0]) & (t_ns <= t_m[-1])
        if inside.sum() < 2:
            raise RecordingError(f"{path}: mag: its {t_m.shape[0]} message(s) do not overlap the IMU's stamps")
        if not inside.all():
            warnings.append(f"{path}: dropped {int((~inside).sum())} IMU message(s) outside the magnetometer's "
                            "stamps")
            t_ns, gyr, acc = t_ns[inside], gyr[inside], acc[inside]
        mag_rows = _mag_at(t_ns, t_m, m)
    quat = None
    if truth_sig is not None:
        t_q, q = truth_sig
        keep = np.concatenate([[True], np.diff(t_q) > 0])  # a repeated stamp keeps its first transform
        quat = _quat_at(t_ns, t_q[keep], q[keep], max_truth_gap_s)
        if frame == "NWU":
            from objectives.attitude.quaternion import Q_ENU_FROM_NWU, qmul_batch

            quat = qmul_batch(np.asarray(Q_ENU_FROM_NWU, float), quat)
    t0 = int(t_ns[0])
    t = (t_ns - t0) * 1e-9
    sig = {"gyr": gyr, "acc": acc, "mag": None if mag_sig is None else mag_rows, "quat": quat, "motion": None}
    common = dict(name=name or path.stem, frame="ENU" if frame == "NWU" else frame, source=str(path),
                  units={"gyr": "rad/s", "acc": "m/s^2", "mag": "uT"})
    return from_stamps(path, t, sig, common, "header.stamp" if stamps == "header" else "bag time", spec,
                       jitter_tol=jitter_tol, rate_hz=None, max_dropped_share=max_dropped_share,
                       resample_hz=resample_hz, max_truth_gap_s=max_truth_gap_s, quat_norm_tol=quat_norm_tol,
                       truth_rate_factor=truth_rate_factor, warnings=warnings,
                       meta={"rosbag": {"imu_frame_id": imu_frame, "first_stamp_ns": t0, "world_frame": frame}})
