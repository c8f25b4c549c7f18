"""Small ROS bags written with rosbags' own writers (ROS 1 .bag, ROS 2 sqlite3 and MCAP) from a recording with
known truth, and the same recording as a CSV file, for the bag reader's tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from objectives.attitude.data.recording import Recording

T0_NS = 1_733_356_800_123_456_789  # an epoch stamp: the reader must keep nanoseconds
FORMATS = ("ros1", "sqlite3", "mcap")


def stamps_ns(rec: Recording, offset_ns: int = 0) -> np.ndarray:
    return T0_NS + offset_ns + np.round(np.arange(rec.n) * rec.dt * 1e9).astype(np.int64)


def _time(typestore, ns: int):
    return typestore.types["builtin_interfaces/msg/Time"](sec=int(ns // 1_000_000_000),
                                                           nanosec=int(ns % 1_000_000_000))


def _header(typestore, ns: int, frame: str, ros1: bool):
    H = typestore.types["std_msgs/msg/Header"]
    return H(seq=0, stamp=_time(typestore, ns), frame_id=frame) if ros1 else H(stamp=_time(typestore, ns),
                                                                              frame_id=frame)


def write_bag(path: Path, rec: Recording, fmt: str, *, truth: str = "pose", mag: bool = True,
              truth_quat: np.ndarray | None = None, mag_offset_ns: int = 0, extra_tf_child: str | None = None) -> Path:
    """``rec`` as a bag at ``path`` (a .bag file for ros1, else a directory): /imu (Imu, frame imu_link),
    /imu/mag (MagneticField, tesla: rec.mag * 1e-6), and the truth as ``pose`` (/truth PoseStamped),
    ``odom`` (/truth Odometry), ``transform`` (/truth TransformStamped) or ``tf`` (/tf TFMessage with the
    child frame ``imu_link``, and ``extra_tf_child`` beside it, rotated, as a distractor)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ros1 = fmt == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in ts.types:  # rosbags' noetic store lacks it: its one-line definition
        from rosbags.typesys import get_types_from_msg

        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    T = ts.types
    if ros1:
        writer = Writer1(path)
    else:
        writer = Writer2(path, version=9,
                         storage_plugin=StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3)
    ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    V, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    quat = rec.quat if truth_quat is None else truth_quat
    t_ns = stamps_ns(rec)
    zeros9 = np.zeros(9)
    kind = {"pose": "geometry_msgs/msg/PoseStamped", "odom": "nav_msgs/msg/Odometry",
            "transform": "geometry_msgs/msg/TransformStamped", "tf": "tf2_msgs/msg/TFMessage"}[truth]
    with writer:
        c_imu = writer.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=ts)
        c_mag = writer.add_connection("/imu/mag", "sensor_msgs/msg/MagneticField", typestore=ts) if mag else None
        c_tr = writer.add_connection("/tf" if truth == "tf" else "/truth", kind, typestore=ts)
        for i in range(rec.n):
            ns = int(t_ns[i])
            m = T["sensor_msgs/msg/Imu"](
                header=_header(ts, ns, "imu_link", ros1), orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.array([-1.0, *zeros9[1:]]),
                angular_velocity=V(x=rec.gyr[i, 0], y=rec.gyr[i, 1], z=rec.gyr[i, 2]),
                angular_velocity_covariance=zeros9,
                linear_acceleration=V(x=rec.acc[i, 0], y=rec.acc[i, 1], z=rec.acc[i, 2]),
                linear_acceleration_covariance=zeros9)
            writer.write(c_imu, ns, ser(m, "sensor_msgs/msg/Imu"))
            if mag:
                mns = ns + mag_offset_ns
                f = rec.mag[i] * 1e-6
                mm = T["sensor_msgs/msg/MagneticField"](header=_header(ts, mns, "imu_link", ros1),
                                                        magnetic_field=V(x=f[0], y=f[1], z=f[2]),
                                                        magnetic_field_covariance=zeros9)
                writer.write(c_mag, mns, ser(mm, "sensor_msgs/msg/MagneticField"))
            q = quat[i]
            qq = Q(x=q[1], y=q[2], z=q[3], w=q[0])
            hdr = _header(ts, ns, "world", ros1)
            pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                                               orientation=qq)
            tf = T["geometry_msgs/msg/Transform"](translation=V(x=0.0, y=0.0, z=0.0), rotation=qq)
            if truth == "pose":
                msg = T[kind](header=hdr, pose=pose)
            elif truth == "odom":
                cov = np.zeros(36)
                msg = T[kind](header=hdr, child_frame_id="imu_link",
                              pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
                              twist=T["geometry_msgs/msg/TwistWithCovariance"](
                                  twist=T["geometry_msgs/msg/Twist"](linear=V(x=0.0, y=0.0, z=0.0),
                                                                     angular=V(x=0.0, y=0.0, z=0.0)),
                                  covariance=cov))
            else:
                st = T["geometry_msgs/msg/TransformStamped"](header=hdr, child_frame_id="imu_link", transform=tf)
                if truth == "transform":
                    msg = st
                else:
                    other = T["geometry_msgs/msg/Transform"](translation=V(x=1.0, y=0.0, z=0.0),
                                                             rotation=Q(x=1.0, y=0.0, z=0.0, w=0.0))
                    extra = ([T["geometry_msgs/msg/TransformStamped"](header=hdr, child_frame_id=extra_tf_child,
                                                                      transform=other)]
                             if extra_tf_child else [])
                    msg = T[kind](transforms=[*extra, st])
            writer.write(c_tr, ns, ser(msg, kind))
    return path


def write_csv(path: Path, rec: Recording) -> Path:
    """``rec`` as a CSV whose time column holds the bag's stamps relative to the first (as the reader computes
    them), mag in uT and the truth (w, x, y, z)."""
    t_ns = stamps_ns(rec)
    t = (t_ns - t_ns[0]) * 1e-9
    cols = np.column_stack([t, rec.gyr, rec.acc, (rec.mag * 1e-6) * 1e6, rec.quat])
    np.savetxt(path, cols, delimiter=",", fmt="%.17g", comments="",
               header="t,gx,gy,gz,ax,ay,az,mx,my,mz,qw,qx,qy,qz")
    return path


CSV_COLUMNS = {"time": "t", "gyr": ["gx", "gy", "gz"], "acc": ["ax", "ay", "az"], "mag": ["mx", "my", "mz"],
               "quat": ["qw", "qx", "qy", "qz"]}
