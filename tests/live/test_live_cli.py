"""roadgrip replay and roadgrip live from the command line; the CAN and UDP sinks; a bus
that goes away."""

from __future__ import annotations

import json
import math
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from roadgrip.io.can import FrameDecoder, FrameEncoder, xor8
from roadgrip.live.runner import LiveRow
from roadgrip.live.sinks import CanSink, UdpSink


def _roadgrip(*args: str) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).parent / "roadgrip"
    env = {"COLUMNS": "200", "PATH": "/usr/bin:/bin", "TERM": "dumb"}
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=120, env=env)


@pytest.fixture(scope="module")
def drive_file(tmp_path_factory):
    from roadgrip.sim.scenarios import simulate_scenario

    path = tmp_path_factory.mktemp("live") / "drive.parquet"
    drive = simulate_scenario("dry-gravel-dry", seed=2, duration=8.0)
    drive.save(path)
    return drive, path


def test_replay_into_a_log_and_live_from_it_write_a_vss_line_per_sample(drive_file, tmp_path):
    drive, path = drive_file
    log, vss = tmp_path / "drive.blf", tmp_path / "friction.jsonl"
    res = _roadgrip("replay", str(path), "--log", str(log))
    assert res.returncode == 0, res.stderr
    assert f"{5 * drive.n} frames of {drive.n} samples" in res.stderr
    res = _roadgrip("live", "--log", str(log), "--method", "brls", "--vss", str(vss))
    assert res.returncode == 0, res.stderr
    assert f"{drive.n} rows from {5 * drive.n} frames ({5 * drive.n} accepted, dropped: none)" in res.stderr
    assert "ended: end of log" in res.stderr
    lines = [json.loads(s) for s in vss.read_text().splitlines()]
    assert len(lines) == drive.n
    assert np.abs(np.array([x["t"] for x in lines]) - drive.t).max() <= 5e-4  # the clock signal's ms
    assert {x["roadgrip.reason"] for x in lines[:100]} == {"warming_up"}
    assert {x["roadgrip.class"] for x in lines} <= {"high", "low", "unknown"}


def test_live_refuses_what_it_cannot_do_in_one_line(tmp_path):
    res = _roadgrip("live")
    assert res.returncode == 2 and "give a bus (--interface, --channel) or a CAN log (--log)" in res.stderr
    res = _roadgrip("live", "--log", str(tmp_path / "none.blf"))
    assert res.returncode == 2 and "--log" in res.stderr
    res = _roadgrip("live", "--interface", "no-such-interface", "--channel", "x")
    assert res.returncode == 2 and "cannot open CAN interface 'no-such-interface'" in res.stderr


def _row(**kw) -> LiveRow:
    base = {"t": 1.0, "most_probable": 81.3, "lower": 70.0, "upper": float("nan"), "grip_class": "high",
            "mu_front": float("nan"), "mu_rear": float("nan"), "reason": "ok", "detail": ""}
    return LiveRow(**{**base, **kw})


def test_the_friction_message_carries_the_row_to_half_a_percent(codec):
    from roadgrip.live.replay import open_bus

    db, m = codec
    tx, rx = open_bus("virtual", "cli-can-out"), open_bus("virtual", "cli-can-out")
    try:
        sink = CanSink(tx, FrameEncoder(db, m), m["output"])
        sink.write([_row(), _row(t=1.01, reason="signal_timeout", grip_class="unknown", most_probable=math.nan,
                                  lower=math.nan)])
        got = [rx.recv(1.0) for _ in range(2)]
    finally:
        tx.shutdown()
        rx.shutdown()
    msg = db.get_message_by_name("RG_Friction")
    first, second = (msg.decode(g.data, decode_choices=False) for g in got)
    assert abs(first["MostProbable"] - 81.3) <= 0.25 and first["LowerBound"] == 70.0
    assert (first["MostProbableValid"], first["LowerBoundValid"], first["UpperBoundValid"]) == (1, 1, 0)
    assert first["GripClass"] == 2 and first["Reason"] == 0
    assert second["MostProbableValid"] == second["LowerBoundValid"] == 0
    assert second["GripClass"] == 0 and second["Reason"] == 2
    # counter and checksum per the map's rule
    assert second["Friction_Counter"] == (first["Friction_Counter"] + 1) % 16
    assert all(g.data[7] == xor8(g.arbitration_id, g.data, 7) for g in got)


def test_udp_lines_reach_a_listener():
    server = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    server.bind(("127.0.0.1", 0))
    server.settimeout(2.0)
    sink = UdpSink("127.0.0.1", server.getsockname()[1])
    try:
        sink.write([_row(), _row(t=1.01)])
        got = [json.loads(server.recv(4096)) for _ in range(2)]
    finally:
        sink.close()
        server.close()
    assert [g["t"] for g in got] == [1.0, 1.01]
    assert got[0]["Vehicle.ADAS.ESC.RoadFriction.MostProbable"] == 81.3
    assert "Vehicle.ADAS.ESC.RoadFriction.UpperBound" not in got[0]


class _Failing:
    """A bus that delivers some frames and then goes away."""

    def __init__(self, frames, fail_after):
        self.frames, self.fail_after, self.i = list(frames), fail_after, 0

    def recv(self, timeout=None):
        import can

        if self.i >= self.fail_after:
            raise can.CanOperationError("the bus went away")
        self.i += 1
        return self.frames[self.i - 1] if self.i <= len(self.frames) else None


@pytest.mark.parametrize("reconnect", [0, 1])
def test_a_bus_that_goes_away_ends_with_its_reason_or_reconnects(drive_file, codec, tmp_path, reconnect, monkeypatch):
    import can

    from roadgrip.live.assembler import RowAssembler
    from roadgrip.live.loop import run_live
    from roadgrip.live.replay import LogSource, replay_drive
    from roadgrip.live.runner import LiveEstimator
    from roadgrip.live.sinks import ListSink

    drive, _ = drive_file
    db, m = codec
    frames: list = []
    replay_drive(drive, frames.append, FrameEncoder(db, m), speed=float("inf"))
    log = tmp_path / "rest.asc"
    with can.Logger(str(log)) as writer:
        for f in frames[2000:]:
            writer.on_message_received(f)
    monkeypatch.setattr("time.sleep", lambda s: None)
    decoder = FrameDecoder(db, m)
    sink = ListSink()
    stats = run_live(_Failing(frames, 2000), RowAssembler(decoder), LiveEstimator("brls", drive.vehicle, decoder.columns),
                     [sink], reconnect=reconnect, open_source=lambda: LogSource(log))
    if reconnect:
        assert stats.reconnects == 1 and stats.ended == "end of log" and stats.rows == drive.n
    else:
        assert stats.ended == "source failed: the bus went away" and stats.rows == 400


def test_rows_the_estimator_refuses_end_the_loop_with_its_words(drive_file, codec):
    from roadgrip.live.assembler import RowAssembler
    from roadgrip.live.loop import run_live
    from roadgrip.live.runner import LiveEstimator
    from roadgrip.live.sinks import ListSink

    drive, _ = drive_file
    db, m = codec
    frames: list = []
    from roadgrip.live.replay import replay_drive

    replay_drive(drive, frames.append, FrameEncoder(db, m), speed=float("inf"))

    class Refusing(LiveEstimator):
        def feed(self, rows):
            if rows[-1].t > 2.0:
                raise ValueError("sample time does not follow")
            return super().feed(rows)

    decoder = FrameDecoder(db, m)
    stats = run_live(_Failing(frames, len(frames) + 1), RowAssembler(decoder),
                     Refusing("brls", drive.vehicle, decoder.columns), [ListSink()], max_batch=1)
    assert stats.ended.startswith("estimator stopped at t = 2.010 s: sample time does not follow")
    assert stats.rows == 201


@pytest.mark.parametrize("speed", [1.0, 4.0])
def test_a_log_source_hands_out_frames_when_their_time_has_come(tmp_path, speed):
    import time

    import can

    from roadgrip.live.replay import LogSource

    log = tmp_path / "paced.asc"
    with can.Logger(str(log)) as writer:
        for k in range(21):  # 0.2 s of frames
            writer.on_message_received(can.Message(timestamp=100.0 + 0.01 * k, arbitration_id=0x100, data=b"\x00" * 8))
    src = LogSource(log, speed)
    t0 = time.monotonic()
    got = []
    while not src.at_end:
        m = src.recv(0.05)
        if m is not None:
            got.append(time.monotonic() - t0)
    assert len(got) == 21
    assert got[-1] >= 0.2 / speed * 0.95  # not before its time
    assert got[-1] <= 0.2 / speed + 0.5  # nor long after (a loaded machine)
    unpaced = LogSource(log)  # the default: every frame at once
    t0 = time.monotonic()
    assert sum(unpaced.recv(0.05) is not None for _ in range(21)) == 21
    assert time.monotonic() - t0 < 0.15  # paced at 1, the 0.2 s of frames would take 0.2 s
