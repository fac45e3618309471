"""ROS bag reader: a simulated drive written with rosbags' own writers and read back."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadgrip.drive import SIGNAL_COLUMNS, WHEEL_COLUMNS
from roadgrip.io import detect_format, read_drive
from roadgrip.io.rosbag import load_topic_map, read_rosbag, typestore_for

T0_NS = 1_700_000_000_123_456_789  # absolute time of the first sample [ns]
ERPM_GAIN = 4614.0  # F1TENTH speed_to_erpm_gain [ERPM / (m/s)]


@pytest.fixture(scope="module")
def source():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("f1tenth-patches", seed=3, duration=8.0)


def _topic_map(**over):
    """The shipped F1TENTH map with the four wheel speeds from /joint_states."""
    m = load_topic_map("f1tenth")
    raw = {"types": m["types"], "vehicle": "f1tenth", "clock": m["clock"], "stamp": "header",
           "signals": {k: {kk: vv for kk, vv in e.items() if kk != "factor" and vv is not None}
                       for k, e in m["signals"].items()},
           "extras": {k: {kk: vv for kk, vv in e.items() if kk != "factor" and vv is not None}
                      for k, e in m["extras"].items()}}
    for i, c in enumerate(WHEEL_COLUMNS):
        raw["signals"][c] = {"topic": "/joint_states", "field": f"velocity[{i}]"}
    raw.update(over)
    return raw


class _Bag:
    """Writes messages of the drive's signals with one of rosbags' writers."""

    def __init__(self, path, kind, topic_map):
        self.kind = kind
        self.ros1 = kind == "ros1"
        self.store = typestore_for(load_topic_map(topic_map), ros1=self.ros1)
        T = self.store.types
        self.T = T
        if self.ros1:
            from rosbags.rosbag1 import Writer

            self.writer = Writer(path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
            self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.conns = {}

    def __enter__(self):
        self.writer.open()
        return self

    def __exit__(self, *exc):
        self.writer.close()

    def header(self, ns):
        T = self.T
        stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        if self.ros1:
            return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="base_link")
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id="base_link")

    def write(self, topic, msgtype, ns, msg):
        if topic not in self.conns:
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.store)
        data = (self.store.serialize_ros1 if self.ros1 else self.store.serialize_cdr)(msg, msgtype)
        self.writer.write(self.conns[topic], ns, data)

    def vec(self, x=0.0, y=0.0, z=0.0):
        return self.T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def imu(self, ns, ax, ay, r):
        T = self.T
        q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
        cov = np.zeros(9)
        msg = T["sensor_msgs/msg/Imu"](header=self.header(ns), orientation=q, orientation_covariance=cov,
                                       angular_velocity=self.vec(z=r), angular_velocity_covariance=cov,
                                       linear_acceleration=self.vec(ax, ay), linear_acceleration_covariance=cov)
        self.write("/sensors/imu/raw", "sensor_msgs/msg/Imu", ns, msg)

    def odom(self, topic, ns, x=0.0, y=0.0, psi=0.0, vx=0.0):
        T = self.T
        q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(psi / 2), w=math.cos(psi / 2))
        pose = T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                                             orientation=q), covariance=np.zeros(36))
        twist = T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=self.vec(vx), angular=self.vec()), covariance=np.zeros(36))
        msg = T["nav_msgs/msg/Odometry"](header=self.header(ns), child_frame_id="base_link", pose=pose, twist=twist)
        self.write(topic, "nav_msgs/msg/Odometry", ns, msg)

    def drive_cmd(self, ns, steer):
        T = self.T
        cmd = T["ackermann_msgs/msg/AckermannDrive"](steering_angle=steer, steering_angle_velocity=0.0,
                                                     speed=0.0, acceleration=0.0, jerk=0.0)
        msg = T["ackermann_msgs/msg/AckermannDriveStamped"](header=self.header(ns), drive=cmd)
        self.write("/drive", "ackermann_msgs/msg/AckermannDriveStamped", ns, msg)

    def joints(self, ns, omegas):
        T = self.T
        msg = T["sensor_msgs/msg/JointState"](header=self.header(ns), name=["fl", "fr", "rl", "rr"],
                                              position=np.zeros(4), velocity=np.asarray(omegas, float),
                                              effort=np.zeros(4))
        self.write("/joint_states", "sensor_msgs/msg/JointState", ns, msg)

    def core(self, ns, erpm):
        T = self.T
        state = T["vesc_msgs/msg/VescState"](*([0.0] * 7), speed=erpm, voltage_input=12.0, charge_drawn=0.0,
                                             charge_regen=0.0, energy_drawn=0.0, energy_regen=0.0,
                                             displacement=0, distance_traveled=0, fault_code=0, pid_pos_now=0.0,
                                             controller_id=0, ntc_temp_mos1=0.0, ntc_temp_mos2=0.0,
                                             ntc_temp_mos3=0.0, avg_vd=0.0, avg_vq=0.0)
        msg = T["vesc_msgs/msg/VescStateStamped"](header=self.header(ns), state=state)
        self.write("/sensors/core", "vesc_msgs/msg/VescStateStamped", ns, msg)


def _ns(t):
    return T0_NS + round(float(t) * 1e9)


def write_drive_bag(path, kind, drive, topic_map):
    """Every signal of ``drive`` at every sample, on the F1TENTH topics (+ /joint_states)."""
    d = drive.data
    with _Bag(path, kind, topic_map) as bag:
        for row in d.itertuples(index=False):
            ns = _ns(row.t)
            bag.imu(ns, row.ax, row.ay, row.yaw_rate)
            bag.odom("/odom", ns, vx=row.vx)
            bag.odom("/pf/pose/odom", ns, x=row.x, y=row.y, psi=row.psi)
            bag.drive_cmd(ns, row.steer)
            bag.joints(ns, [getattr(row, c) for c in WHEEL_COLUMNS])
            bag.core(ns, row.vx * ERPM_GAIN)


def _bag_path(tmp_path, kind):
    return tmp_path / {"mcap": "run.mcap", "sqlite3": "run_db", "ros1": "run.bag"}[kind]


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_round_trip_every_canonical_column(tmp_path, source, kind):
    m = _topic_map()
    path = _bag_path(tmp_path, kind)
    write_drive_bag(path, kind, source, m)
    assert detect_format(path) == "rosbag"  # .mcap, .bag, or a ROS 2 folder with metadata.yaml
    got = read_drive(path, format="rosbag", topics=m)
    src = source.data
    assert got.n == source.n
    assert list(got.data.columns) == [*SIGNAL_COLUMNS, "vx_motor"]
    np.testing.assert_allclose(got.t, src["t"] - src["t"].iloc[0], rtol=0, atol=1e-9)  # ns stamps
    for c in ("ax", "ay", "yaw_rate", "vx", "x", "y", *WHEEL_COLUMNS):  # float64 fields: exact
        np.testing.assert_array_equal(got.col(c), src[c].to_numpy(float), err_msg=c)
    # AckermannDrive.steering_angle is float32
    np.testing.assert_array_equal(got.col("steer"), src["steer"].to_numpy(np.float32).astype(float))
    # heading through a quaternion and atan2, unwrapped (the simulated sensor wraps it)
    dpsi = np.angle(np.exp(1j * (got.col("psi") - src["psi"].to_numpy(float))))
    np.testing.assert_allclose(dpsi, 0.0, rtol=0, atol=1e-12)
    assert np.abs(np.diff(got.col("psi"))).max() < 0.5 < np.abs(np.diff(src["psi"])).max()
    np.testing.assert_allclose(got.data["vx_motor"], src["vx"], rtol=1e-5)
    ex = got.meta.extra
    assert ex["format"] == "rosbag" and ex["clock_topic"] == "/sensors/imu/raw"
    assert ex["t_origin_ns"] == _ns(src["t"].iloc[0])
    rate = source.meta.sample_rate
    assert set(ex["source_rates_hz"]) == {"/sensors/imu/raw", "/odom", "/pf/pose/odom", "/drive",
                                          "/joint_states", "/sensors/core"}
    for topic, hz in ex["source_rates_hz"].items():
        assert hz == pytest.approx(rate, rel=1e-6), topic
    assert got.vehicle.name == "f1tenth"


def test_alignment_interpolates_and_holds_never_extrapolates(tmp_path):
    """IMU at 100 Hz for 0-2 s; odometry speed a ramp at 20 Hz from 0.5 s; steering held at 10 Hz."""
    m = _topic_map(signals={
        "ax": {"topic": "/sensors/imu/raw", "field": "linear_acceleration.x"},
        "ay": {"topic": "/sensors/imu/raw", "field": "linear_acceleration.y"},
        "yaw_rate": {"topic": "/sensors/imu/raw", "field": "angular_velocity.z"},
        "vx": {"topic": "/odom", "field": "twist.twist.linear.x"},
        "steer": {"topic": "/drive", "field": "drive.steering_angle", "hold": True, "scale": 0.5},
    }, extras={})
    t_imu = np.arange(201) * 0.01
    t_odom = 0.5 + np.arange(25) * 0.05  # 0.5 .. 1.7 s
    t_cmd = 0.25 + np.arange(18) * 0.1  # 0.25 .. 1.95 s
    cmd = 0.01 * np.arange(18.0)  # exactly representable? no: compare with float32
    path = tmp_path / "align.mcap"
    with _Bag(path, "mcap", m) as bag:
        for t in sorted({*t_imu, *t_odom, *t_cmd}):
            if t in t_imu:
                bag.imu(_ns(t), 0.1 * t, -0.2, 0.05)
            if t in t_odom:
                bag.odom("/odom", _ns(t), vx=3.0 + 2.0 * t)
            if t in t_cmd:
                k = int(np.flatnonzero(t_cmd == t)[0])
                bag.drive_cmd(_ns(t), cmd[k])
    d = read_rosbag(path, m, vehicle="f1tenth")
    # the clock: IMU stamps inside every topic's span, 0.5 .. 1.7 s, t from the first tick
    expect_t = t_imu[(t_imu >= 0.5 - 1e-12) & (t_imu <= 1.7 + 1e-12)]
    assert d.n == len(expect_t)
    np.testing.assert_allclose(d.t, expect_t - expect_t[0], atol=1e-9)
    assert d.meta.extra["t_origin_ns"] == _ns(expect_t[0])
    t_abs = d.t + expect_t[0]
    np.testing.assert_allclose(d.col("vx"), 3.0 + 2.0 * t_abs, rtol=0, atol=1e-9)  # linear in t: exact
    np.testing.assert_allclose(d.col("ax"), 0.1 * t_abs, atol=1e-12)
    k = np.searchsorted(t_cmd, t_abs + 1e-9, side="right") - 1  # last command at or before
    np.testing.assert_array_equal(d.col("steer"), 0.5 * cmd.astype(np.float32).astype(float)[k])
    rates = d.meta.extra["source_rates_hz"]
    assert rates["/sensors/imu/raw"] == pytest.approx(100.0)
    assert rates["/odom"] == pytest.approx(20.0)
    assert rates["/drive"] == pytest.approx(10.0)


def test_missing_topic_names_it_and_lists_the_bag(tmp_path, source):
    m = _topic_map()
    path = tmp_path / "run.mcap"
    write_drive_bag(path, "mcap", source.slice_time(0.0, 1.0), m)
    m2 = _topic_map()
    m2["signals"]["vx"] = {"topic": "/vesc/odom", "field": "twist.twist.linear.x"}
    with pytest.raises(ValueError, match=r"/vesc/odom.*topics present: .*/odom \(nav_msgs/msg/Odometry\)"):
        read_rosbag(path, m2)
    m3 = _topic_map()
    m3["signals"]["vx"] = {"topic": "/odom", "field": "twist.twist.linear.q"}
    with pytest.raises(ValueError, match=r"twist.twist.linear.q.*'vx'"):
        read_rosbag(path, m3)
    # an optional entry whose topic is absent is skipped and reported
    m4 = _topic_map()
    m4["extras"]["erpm2"] = {"topic": "/sensors/core2", "field": "state.speed", "optional": True}
    d = read_rosbag(path, m4)
    assert d.meta.extra["entries_skipped"] == ["erpm2 <- /sensors/core2"]


def test_topic_map_errors():
    with pytest.raises(ValueError, match="'t'"):
        load_topic_map({"signals": {"t": {"topic": "/a", "field": "x"}}})
    with pytest.raises(ValueError, match="unit 'deg' measures angle"):
        load_topic_map({"signals": {"ax": {"topic": "/a", "field": "x", "unit": "deg"}}})
    with pytest.raises(ValueError, match="unknown key"):
        load_topic_map({"signals": {"ax": {"topic": "/a", "field": "x", "gain": 2}}})
    with pytest.raises(ValueError, match="scale must be non-zero"):
        load_topic_map({"signals": {"ax": {"topic": "/a", "field": "x", "scale": 0}}})
    m = load_topic_map({"signals": {"yaw_rate": {"topic": "/a", "field": "w", "unit": "deg/s"}}})
    assert m["signals"]["yaw_rate"]["factor"] == pytest.approx(math.pi / 180)
    assert m["clock"] == "/a"


@pytest.mark.parametrize("name", ["run.mcap", "run.bag"])
def test_f1tenth_export_reads_back_with_the_shipped_map(tmp_path, source, name):
    from roadgrip.io.rosbag import write_f1tenth_bag

    write_f1tenth_bag(source, tmp_path / name)
    got = read_drive(tmp_path / name)  # format detected; topic map defaults to f1tenth
    src = source.data
    assert got.n == source.n
    assert list(got.data.columns) == ["t", "ax", "ay", "yaw_rate", "steer", "vx", "x", "y", "psi", "vx_motor"]
    for c in ("ax", "ay", "yaw_rate", "vx", "x", "y"):
        np.testing.assert_array_equal(got.col(c), src[c].to_numpy(float), err_msg=c)
    np.testing.assert_array_equal(got.col("steer"), src["steer"].to_numpy(np.float32).astype(float))
    np.testing.assert_allclose(np.angle(np.exp(1j * (got.col("psi") - src["psi"]))), 0.0, atol=1e-12)
    np.testing.assert_allclose(got.data["vx_motor"], src["vx"], rtol=1e-12)
    assert got.meta.extra["topics_unused"] == []


def test_gap_longer_than_max_gap_is_not_bridged(tmp_path):
    m = _topic_map(signals={
        "ax": {"topic": "/sensors/imu/raw", "field": "linear_acceleration.x"},
        "vx": {"topic": "/odom", "field": "twist.twist.linear.x"},
    }, extras={}, max_gap=0.25)
    t_imu = np.arange(201) * 0.01
    t_odom = np.array([t for t in np.arange(41) * 0.05 if not 0.9 < t < 1.3])  # silent 0.9-1.3 s
    path = tmp_path / "gap.mcap"
    with _Bag(path, "mcap", m) as bag:
        for t in sorted({*t_imu, *t_odom}):
            if t in t_imu:
                bag.imu(_ns(t), 0.0, 0.0, 0.0)
            if t in t_odom:
                bag.odom("/odom", _ns(t), vx=2.0)
    d = read_rosbag(path, m, vehicle="f1tenth")
    t = d.t + 0.0  # the IMU starts the clock at 0
    assert not ((t > 0.9 + 1e-9) & (t < 1.3 - 1e-9)).any()
    assert d.n == 201 - 39  # the 39 ticks strictly inside the gap
    np.testing.assert_array_equal(d.col("vx"), 2.0)


@pytest.mark.parametrize("stamp", ["header", "bag"])
def test_servo_command_without_header_and_stamp_choice(tmp_path, stamp):
    """The servo command (std_msgs/msg/Float64, no header) on its receive time, inverted to
    the road-wheel angle with the F1TENTH servo map; IMU headers 5 ms before their receive time."""
    gain, offset = -1.2135, 0.5304  # servo = gain * steer + offset
    m = _topic_map(signals={
        "ax": {"topic": "/sensors/imu/raw", "field": "linear_acceleration.x"},
        "steer": {"topic": "/sensors/servo_position_command", "field": "data",
                  "scale": 1.0 / gain, "offset": -offset / gain},
    }, extras={}, stamp=stamp)
    t = np.arange(101) * 0.01
    steer = 0.3 * np.sin(2.0 * t)
    latency = 5_000_000  # [ns]
    path = tmp_path / "servo.mcap"
    with _Bag(path, "mcap", m) as bag:
        for k, tk in enumerate(t):
            ns = _ns(tk)
            msg = bag.T["sensor_msgs/msg/Imu"](
                header=bag.header(ns - latency), orientation=bag.T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0),
                orientation_covariance=np.zeros(9), angular_velocity=bag.vec(), angular_velocity_covariance=np.zeros(9),
                linear_acceleration=bag.vec(tk), linear_acceleration_covariance=np.zeros(9))
            bag.write("/sensors/imu/raw", "sensor_msgs/msg/Imu", ns, msg)
            bag.write("/sensors/servo_position_command", "std_msgs/msg/Float64", ns,
                      bag.T["std_msgs/msg/Float64"](data=gain * steer[k] + offset))
    d = read_rosbag(path, m, vehicle="f1tenth")
    if stamp == "bag":  # both on receive times: every sample, exact
        assert d.n == len(t) and d.meta.extra["t_origin_ns"] == _ns(0.0)
        np.testing.assert_allclose(d.col("steer"), steer, rtol=0, atol=1e-12)
    else:  # IMU clock 5 ms early: the servo (receive time) interpolated onto it, first tick dropped
        assert d.n == len(t) - 1 and d.meta.extra["t_origin_ns"] == _ns(0.01) - latency
        t_clock = t[1:] - 0.005
        np.testing.assert_allclose(d.col("steer"), np.interp(t_clock, t, steer), rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.col("ax"), t[-d.n:], atol=1e-12)
