"""ROS bags (ROS 1 ``.bag``, ROS 2 SQLite ``.db3`` or bag folder, MCAP ``.mcap``).

Read with `rosbags` (pure Python) through a *topic map*, a YAML file saying which
topic and message field fill each canonical signal::

    vehicle: f1tenth                  # optional; read_rosbag(vehicle=...) overrides it
    clock: /sensors/imu/raw           # optional; default: the topic of 'ax'
    stamp: header                     # header (default) or bag: which time stamps a message
    max_gap: 0.25                     # optional [s]; longer gaps in a topic are not bridged
    types:                            # optional; message definitions (.msg text) that are
      ackermann_msgs/msg/AckermannDrive: |       # not in rosbags' built-in type stores
        float32 steering_angle
        ...
    signals:
      ax:    {topic: /sensors/imu/raw, field: linear_acceleration.x}
      psi:   {topic: /pf/pose/odom, field: pose.pose.orientation, convert: yaw}
      steer: {topic: /drive, field: drive.steering_angle, hold: true}
      omega_rl: {topic: /joint_states, field: "velocity[2]"}
    extras:                           # optional; non-canonical columns, same entries
      vx_motor: {topic: /sensors/core, field: state.speed, scale: 2.1673e-4, optional: true}

Entries take ``topic`` and ``field`` (a dotted path, ``name[i]`` indexes an array;
required), ``unit`` (optional, one of :data:`roadgrip.io.mapping.UNITS`, default SI
as REP 103 prescribes), ``scale`` and ``offset`` (the value is ``scale * unit(raw) +
offset``, e.g. one over a steering gain; default 1 and 0), ``convert: yaw`` (the
heading of a quaternion field, unwrapped), ``hold`` (zero-order hold instead of
linear interpolation, for commands) and ``optional`` (skip the entry, and say so in
the metadata, when its topic is not in the bag).

**Time base.** Each message is stamped by its ``header.stamp`` (``stamp: header``;
messages without a header use the bag's receive time) or by the receive time
(``stamp: bag``). Per topic, messages are sorted by stamp and exact duplicates
dropped. The output clock is the stamps of the clock topic (by default the
IMU topic of ``ax``, the fastest sensor in usual stacks) inside the span that
every mapped topic covers; the other topics are interpolated linearly onto it
(held signals: the last value at or before the tick), never extrapolated, and
ticks inside a gap longer than ``max_gap`` are dropped
(:func:`roadgrip.io.resample.resample`). ``t`` is zero at the first tick; the
absolute time of that tick is ``meta.extra['t_origin_ns']``. The rate of every
topic in the bag (median stamp interval) is in ``meta.extra['source_rates_hz']``,
which ``roadgrip info`` lists.
"""

from __future__ import annotations

import math
import re
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from roadgrip.drive import SIGNAL_COLUMNS, Drive, DriveValidationError
from roadgrip.io.mapping import QUANTITY_OF, UNITS, map_vehicle, read_map
from roadgrip.io.resample import resample
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "BAG_SUFFIXES",
    "is_rosbag",
    "load_topic_map",
    "read_rosbag",
    "shipped_topic_maps",
    "typestore_for",
    "write_f1tenth_bag",
]

BAG_SUFFIXES = (".bag", ".mcap", ".db3")
"""File suffixes read as ROS bags (a ROS 2 bag folder holds ``metadata.yaml``)."""

_TOP_KEYS = {"vehicle", "clock", "stamp", "max_gap", "types", "signals", "extras", "description"}
_ENTRY_KEYS = {"topic", "field", "unit", "scale", "offset", "convert", "hold", "optional"}
_FIELD_PART = re.compile(r"^([A-Za-z_]\w*)(?:\[(\d+)\])?$")


def is_rosbag(path: str | Path) -> bool:
    """Whether ``path`` looks like a ROS bag: a ``.bag``/``.mcap``/``.db3`` file or a
    folder holding ``metadata.yaml``."""
    p = Path(path)
    if p.is_dir():
        return (p / "metadata.yaml").is_file()
    return p.suffix.lower() in BAG_SUFFIXES


def shipped_topic_maps() -> list[str]:
    """Names of the topic maps shipped in ``roadgrip/data/topics`` (``'f1tenth'``, ...)."""
    folder = resources.files("roadgrip") / "data" / "topics"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def _shipped_or_given(spec: str | Path | dict[str, Any]) -> str | Path | dict[str, Any]:
    """The parsed shipped map where ``spec`` names one (and no such file exists), else ``spec``."""
    if not isinstance(spec, dict) and not Path(spec).exists() and str(spec) in shipped_topic_maps():
        return yaml.safe_load((resources.files("roadgrip") / "data" / "topics" / f"{spec}.yaml").read_text())
    return spec


def load_topic_map(spec: str | Path | dict[str, Any]) -> dict[str, Any]:
    """Read and check a topic map (module docstring).

    Parameters
    ----------
    spec : str, Path or dict
        A YAML file, the name of a shipped map (:func:`shipped_topic_maps`) or a
        parsed map.

    Returns
    -------
    dict
        The map, with every entry's defaults filled in.

    Raises
    ------
    ValueError
        Unknown keys, a target that is not a canonical signal, a missing topic or
        field, a unit that does not fit its signal, a bad scale, offset or convert.
    """
    given = _shipped_or_given(spec)
    m, name = read_map(given, kind="topic map", file_kind="topic map", section="signals", top_keys=_TOP_KEYS,
                       missing_hint=f" (shipped maps: {', '.join(shipped_topic_maps())})")
    if given is not spec:
        name = f"{spec}.yaml"
    if m.get("stamp", "header") not in ("header", "bag"):
        raise ValueError(f"{name}: stamp must be 'header' or 'bag', got {m['stamp']!r}")
    gap = m.get("max_gap")
    if gap is not None and (isinstance(gap, bool) or not isinstance(gap, int | float) or not gap > 0):
        raise ValueError(f"{name}: max_gap must be a positive number of seconds, got {gap!r}")
    types = m.get("types") or {}
    if not isinstance(types, dict) or not all(isinstance(v, str) for v in types.values()):
        raise ValueError(f"{name}: 'types' maps message type names to .msg definitions (text)")
    out = {**m, "types": types, "stamp": m.get("stamp", "header")}
    for section in ("signals", "extras"):
        entries = m.get(section) or {}
        if not isinstance(entries, dict):
            raise ValueError(f"{name}: '{section}' must map column names to entries")
        out[section] = {str(k): _check_entry(name, section, str(k), v) for k, v in entries.items()}
    bad = sorted((set(out["signals"]) - set(QUANTITY_OF)) | ({"t"} & set(out["signals"])))
    if bad:
        raise ValueError(
            f"{name}: {bad} not canonical signal(s) a topic can fill "
            f"({', '.join(c for c in SIGNAL_COLUMNS if c != 't')}); time comes from the stamps"
        )
    clash = sorted(set(out["extras"]) & (set(SIGNAL_COLUMNS) | set(out["signals"])))
    if clash:
        raise ValueError(f"{name}: extra column(s) {clash} clash with canonical columns")
    topics = {e["topic"] for e in out["signals"].values()}
    clock = m.get("clock")
    if clock is None:
        clock = out["signals"]["ax"]["topic"] if "ax" in out["signals"] else sorted(topics)[0]
    elif clock not in topics:
        raise ValueError(f"{name}: clock topic {clock!r} fills no signal (topics: {sorted(topics)})")
    out["clock"] = clock
    return out


def _check_entry(name: str, section: str, target: str, entry: Any) -> dict[str, Any]:
    where = f"{name}: {section[:-1]} {target!r}"
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: expected a mapping with 'topic' and 'field'")
    bad = sorted(set(entry) - _ENTRY_KEYS)
    if bad:
        raise ValueError(f"{where}: unknown key(s) {bad}; known: {sorted(_ENTRY_KEYS)}")
    for req in ("topic", "field"):
        if not isinstance(entry.get(req), str) or not entry[req]:
            raise ValueError(f"{where}: missing {req!r}")
    for part in entry["field"].split("."):
        if not _FIELD_PART.match(part):
            raise ValueError(f"{where}: bad field path {entry['field']!r} (a.b.c or a.b[2])")
    unit = entry.get("unit")
    factor = 1.0
    if unit is not None:
        if str(unit) not in UNITS:
            raise ValueError(f"{where}: unknown unit {unit!r}; known: {', '.join(UNITS)}")
        quantity, factor = UNITS[str(unit)]
        if target in QUANTITY_OF and quantity != QUANTITY_OF[target]:
            raise ValueError(
                f"{where}: unit {unit!r} measures {quantity}, but {target!r} is a {QUANTITY_OF[target]}"
            )
    nums = {}
    for key, default in (("scale", 1.0), ("offset", 0.0)):
        v = entry.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise ValueError(f"{where}: {key} must be a finite number, got {v!r}")
        nums[key] = float(v)
    if nums["scale"] == 0:
        raise ValueError(f"{where}: scale must be non-zero")
    convert = entry.get("convert")
    if convert not in (None, "yaw"):
        raise ValueError(f"{where}: convert must be 'yaw' (quaternion heading), got {convert!r}")
    return {
        "topic": entry["topic"], "field": entry["field"], "unit": unit, "factor": factor,
        **nums, "convert": convert, "hold": bool(entry.get("hold", False)),
        "optional": bool(entry.get("optional", False)),
    }


def typestore_for(topic_map: dict[str, Any] | None = None, ros1: bool = False):
    """rosbags type store: ROS 2 Humble (or ROS 1 Noetic) plus the map's ``types``.

    Parameters
    ----------
    topic_map : dict, optional
        A map from :func:`load_topic_map`; its ``types`` (message type name -> .msg
        text) are registered with ``rosbags.typesys.get_types_from_msg``.
    ros1 : bool
        Start from the ROS 1 Noetic store.

    Returns
    -------
    rosbags.typesys.store.Typestore
    """
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    types: dict = {}
    for typename, text in ((topic_map or {}).get("types") or {}).items():
        types.update(get_types_from_msg(text, typename))
    if types:
        store.register(types)
    return store


def _get_field(msg: Any, path: str) -> Any:
    obj = msg
    for part in path.split("."):
        name, index = _FIELD_PART.match(part).groups()
        obj = getattr(obj, name)
        if index is not None:
            obj = obj[int(index)]
    return obj


def _yaw(q: Any) -> float:
    """Heading [rad] of a quaternion (rotation about z after removing roll and pitch)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _stamp_ns(msg: Any, bag_ns: int, use_header: bool) -> int:
    if use_header:
        header = getattr(msg, "header", None)
        if header is not None:
            return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)
    return int(bag_ns)


def _median_rate(ns: np.ndarray) -> float:
    if len(ns) < 2:
        return float("nan")
    d = np.diff(np.sort(ns))
    d = d[d > 0]
    return float(1e9 / np.median(d)) if len(d) else float("nan")


def _collect(path: Path, m: dict[str, Any]) -> tuple[dict, dict, dict]:
    """Read the bag once: per mapped topic its stamps and raw values, per topic its rates."""
    from rosbags.highlevel import AnyReader

    entries = {**m["signals"], **m["extras"]}
    by_topic: dict[str, dict[str, dict]] = {}
    for col, e in entries.items():
        by_topic.setdefault(e["topic"], {})[col] = e
    ros1 = path.suffix.lower() == ".bag"
    try:
        reader = AnyReader([path], default_typestore=typestore_for(m, ros1=ros1))
        reader.open()
    except Exception as exc:  # rosbags raises several reader and storage errors
        raise ValueError(f"{path.name}: not a readable ROS bag: {exc}") from None
    try:
        present = {c.topic: c.msgtype for c in reader.connections}
        stamps: dict[str, list[int]] = {t: [] for t in present}
        values: dict[str, dict[str, list]] = {t: {c: [] for c in by_topic[t]} for t in by_topic if t in present}
        use_header = m["stamp"] == "header"
        for conn, bag_ns, raw in reader.messages():
            topic = conn.topic
            if topic not in values:
                stamps[topic].append(bag_ns)
                continue
            try:
                msg = reader.deserialize(raw, conn.msgtype)
            except Exception as exc:
                raise ValueError(f"{path.name}: cannot decode {conn.msgtype} on {topic}: {exc}") from None
            stamps[topic].append(_stamp_ns(msg, bag_ns, use_header))
            for col, e in by_topic[topic].items():
                try:
                    v = _get_field(msg, e["field"])
                    values[topic][col].append(_yaw(v) if e["convert"] == "yaw" else float(v))
                except (AttributeError, IndexError, TypeError, ValueError) as exc:
                    raise ValueError(
                        f"{path.name}: field {e['field']!r} (for {col!r}) not readable as a "
                        f"number in {conn.msgtype} on {topic}: {exc}"
                    ) from None
    finally:
        reader.close()
    return present, {t: np.asarray(s, dtype=np.int64) for t, s in stamps.items()}, values


def read_rosbag(
    path: str | Path,
    topics: str | Path | dict[str, Any] = "f1tenth",
    vehicle: str | Path | VehicleParams | None = None,
) -> Drive:
    """Read a ROS 1 / ROS 2 (SQLite or MCAP) bag through a topic map.

    Parameters
    ----------
    path : str or Path
        ``.bag``, ``.mcap`` or ``.db3`` file, or a ROS 2 bag folder.
    topics : str, Path or dict
        Topic map (module docstring): a YAML file, a shipped map's name, or a parsed map.
    vehicle : preset name, YAML path or VehicleParams, optional
        Overrides the map's ``vehicle``; one of the two is required.

    Returns
    -------
    Drive
        Canonical signals on the clock topic's stamps (module docstring), extras as
        extra columns. ``meta.extra`` holds ``format`` (``'rosbag'``), ``topic_map``,
        ``clock_topic``, ``t_origin_ns``, ``source_rates_hz`` and ``source_counts``
        (every topic in the bag), ``topics_unused``, ``entries_skipped`` (optional
        entries whose topic is absent) and ``interpolation``.

    Raises
    ------
    ValueError
        Unreadable bag or map, a required topic or field missing (the message lists
        the topics present), topics that do not overlap in time, or a failed
        :class:`~roadgrip.drive.Drive` validation.
    """
    p = Path(path)
    if not p.exists():
        raise ValueError(f"no such file or folder: {p}")
    m = load_topic_map(topics)
    veh = map_vehicle(m, vehicle, "read_rosbag", "topic map")
    present, stamps, values = _collect(p, m)
    skipped, missing = [], []
    for col, e in {**m["signals"], **m["extras"]}.items():
        if e["topic"] not in present:
            (skipped if e["optional"] else missing).append(f"{col} <- {e['topic']}")
    if missing:
        raise ValueError(
            f"{p.name}: topic(s) of {missing} not in the bag; topics present: "
            + ", ".join(f"{t} ({present[t]})" for t in sorted(present))
        )
    if m["clock"] not in values:
        raise ValueError(f"{p.name}: the clock topic {m['clock']!r} is not in the bag")
    hold = [c for c, e in {**m["signals"], **m["extras"]}.items() if e["hold"]]
    ns_streams: dict[str, tuple[np.ndarray, dict[str, np.ndarray]]] = {}
    for topic, cols in values.items():
        ns = stamps[topic]
        if len(ns) == 0:
            raise ValueError(f"{p.name}: topic {topic} holds no messages")
        order = np.argsort(ns, kind="stable")
        ns_sorted = ns[order]
        keep = np.ones(len(ns_sorted), dtype=bool)
        keep[:-1] = np.diff(ns_sorted) != 0  # of equal stamps keep the last received
        idx = order[keep]
        ns_streams[topic] = (ns[idx], {c: np.asarray(v, dtype=float)[idx] for c, v in cols.items()})
    clock_ns = ns_streams[m["clock"]][0]
    lo = max(s[0][0] for s in ns_streams.values())
    hi = min(s[0][-1] for s in ns_streams.values())
    clock_ns = clock_ns[(clock_ns >= lo) & (clock_ns <= hi)]
    if len(clock_ns) == 0:
        raise ValueError(f"{p.name}: the mapped topics do not overlap in time")
    origin = int(clock_ns[0])
    streams = {}
    for topic, (ns, cols) in ns_streams.items():
        frame = {"t": (ns - origin) * 1e-9}
        for col, v in cols.items():
            e = m["signals"].get(col) or m["extras"][col]
            if e["convert"] == "yaw":
                v = np.unwrap(v)
            frame[col] = e["scale"] * (v * e["factor"]) + e["offset"]
        streams[topic] = pd.DataFrame(frame)
    df = resample(streams, clock=(clock_ns - origin) * 1e-9, hold=hold, max_gap=m.get("max_gap"))
    canon = [c for c in SIGNAL_COLUMNS if c in df.columns]
    df = df[canon + [c for c in m["extras"] if c in df.columns]]
    extra = {
        "format": "rosbag",
        "topic_map": {sec: {k: {kk: vv for kk, vv in e.items() if kk != "factor"} for k, e in m[sec].items()}
                      for sec in ("signals", "extras")},
        "clock_topic": m["clock"],
        "stamp": m["stamp"],
        "t_origin_ns": origin,
        "source_rates_hz": {t: _median_rate(stamps[t]) for t in sorted(present)},
        "source_counts": {t: len(stamps[t]) for t in sorted(present)},
        "topics_unused": sorted(set(present) - set(values)),
        "entries_skipped": skipped,
        "interpolation": (
            f"linear onto the stamps of {m['clock']} (held signals: last value at or before "
            "each tick), never extrapolated; ticks outside any topic's span "
            + (f"or inside a gap over {m['max_gap']} s " if m.get("max_gap") else "")
            + "dropped"
        ),
    }
    try:
        return Drive.from_frame(df.reset_index(drop=True), veh, source=str(p), extra=extra)
    except DriveValidationError as exc:  # name the file, as the other readers do
        raise DriveValidationError(f"{p.name}: {exc}") from None


F1TENTH_ERPM_GAIN = 4614.0
"""F1TENTH ``speed_to_erpm_gain`` [ERPM / (m/s)] (f1tenth_system's vesc.yaml)."""


def write_f1tenth_bag(drive: Drive, path: str | Path, *, t0_ns: int = 1_700_000_000_000_000_000) -> None:
    """Write a drive as an F1TENTH bag: the topics of the shipped ``f1tenth`` map.

    Every sample becomes one message on each of ``/sensors/imu/raw``
    (``sensor_msgs/msg/Imu``: ``ax``, ``ay``, ``yaw_rate``), ``/odom``
    (``nav_msgs/msg/Odometry``: ``vx``), ``/drive``
    (``ackermann_msgs/msg/AckermannDriveStamped``: ``steer``, float32),
    ``/sensors/core`` (``vesc_msgs/msg/VescStateStamped``: ``vx`` times
    :data:`F1TENTH_ERPM_GAIN`) and, where the drive has a pose, ``/pf/pose/odom``
    (``x``, ``y``, ``psi`` as a quaternion), header-stamped at ``t0_ns + t``.
    For replaying simulated drives through a ROS stack and for examples.

    Parameters
    ----------
    drive : Drive
        Needs ``ax``, ``ay``, ``yaw_rate``, ``vx`` and ``steer``.
    path : str or Path
        ``.bag`` (ROS 1), ``.mcap`` (ROS 2 MCAP) or another name (a ROS 2 SQLite bag
        folder); must not exist.
    t0_ns : int
        Absolute time of ``t = 0`` [ns].
    """
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin, Writer

    p = Path(path)
    ros1 = p.suffix.lower() == ".bag"
    store = typestore_for(load_topic_map("f1tenth"), ros1=ros1)
    T = store.types
    if ros1:
        writer = Writer1(p)
    else:
        plugin = StoragePlugin.MCAP if p.suffix.lower() == ".mcap" else StoragePlugin.SQLITE3
        writer = Writer(p, version=9, storage_plugin=plugin)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    d = drive.data
    pose = drive.has_pose
    zeros9, zeros36 = np.zeros(9), np.zeros(36)
    vec = T["geometry_msgs/msg/Vector3"]
    quat = T["geometry_msgs/msg/Quaternion"]
    vesc_fields = [f for f in T["vesc_msgs/msg/VescState"].__dataclass_fields__ if f != "__msgtype__"]

    def header(ns: int):
        stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        if ros1:
            return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="base_link")
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id="base_link")

    def odometry(ns: int, x=0.0, y=0.0, psi=0.0, vx=0.0):
        q = quat(x=0.0, y=0.0, z=math.sin(psi / 2), w=math.cos(psi / 2))
        pose_msg = T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                                             orientation=q), covariance=zeros36)
        twist = T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=vec(x=vx, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)),
            covariance=zeros36)
        return T["nav_msgs/msg/Odometry"](header=header(ns), child_frame_id="base_link", pose=pose_msg, twist=twist)

    topics = {"/sensors/imu/raw": "sensor_msgs/msg/Imu", "/odom": "nav_msgs/msg/Odometry",
              "/drive": "ackermann_msgs/msg/AckermannDriveStamped",
              "/sensors/core": "vesc_msgs/msg/VescStateStamped"}
    if pose:
        topics["/pf/pose/odom"] = "nav_msgs/msg/Odometry"
    writer.open()
    try:
        conns = {t: writer.add_connection(t, ty, typestore=store) for t, ty in topics.items()}

        def put(topic: str, ns: int, msg: Any) -> None:
            writer.write(conns[topic], ns, serialize(msg, topics[topic]))

        for row in d.itertuples(index=False):
            ns = t0_ns + round(float(row.t) * 1e9)
            put("/sensors/imu/raw", ns, T["sensor_msgs/msg/Imu"](
                header=header(ns), orientation=quat(x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=zeros9,
                angular_velocity=vec(x=0.0, y=0.0, z=row.yaw_rate), angular_velocity_covariance=zeros9,
                linear_acceleration=vec(x=row.ax, y=row.ay, z=0.0), linear_acceleration_covariance=zeros9))
            put("/odom", ns, odometry(ns, vx=row.vx))
            cmd = T["ackermann_msgs/msg/AckermannDrive"](steering_angle=row.steer, steering_angle_velocity=0.0,
                                                         speed=row.vx, acceleration=0.0, jerk=0.0)
            put("/drive", ns, T["ackermann_msgs/msg/AckermannDriveStamped"](header=header(ns), drive=cmd))
            state = {f: 0 if f in ("displacement", "distance_traveled", "fault_code", "controller_id") else 0.0
                     for f in vesc_fields}
            state["speed"] = row.vx * F1TENTH_ERPM_GAIN
            put("/sensors/core", ns, T["vesc_msgs/msg/VescStateStamped"](
                header=header(ns), state=T["vesc_msgs/msg/VescState"](**state)))
            if pose:
                put("/pf/pose/odom", ns, odometry(ns, x=row.x, y=row.y, psi=row.psi))
    finally:
        writer.close()
