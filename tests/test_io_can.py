"""CAN frames through a DBC and a signal map: units, quantisation, faults dropped and counted, logs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadgrip.io.can import (
    FAULTS,
    SHIPPED_DBC,
    FrameDecoder,
    FrameEncoder,
    load_signal_map,
    read_can_log,
    xor8,
)
from roadgrip.live.replay import shipped_codec

# the shipped DBC's resolutions, in SI per bit: the half of each bounds the quantisation
LSB = {"t": 1e-3, "ax": 1e-3, "ay": 1e-3, "yaw_rate": 0.01 * math.pi / 180.0, "steer": 1e-4,
       "vx": 0.01 / 3.6, "omega_fl": 0.01, "omega_fr": 0.01, "omega_rl": 0.01, "omega_rr": 0.01}


@pytest.fixture(scope="module")
def codec():
    return shipped_codec()


def _sample(**kw) -> dict[str, float]:
    row = {"t": 1.234, "ax": 0.5, "ay": -2.25, "yaw_rate": 0.3, "steer": 0.05, "vx": 20.0,
           "omega_fl": 66.0, "omega_fr": 66.5, "omega_rl": 65.0, "omega_rr": 65.5}
    row.update(kw)
    return row


def test_a_sample_comes_back_within_half_a_bit_in_si_units(codec):
    enc = FrameEncoder(*codec)
    dec = FrameDecoder(*codec)
    row = _sample(yaw_rate=0.123456, vx=27.777, steer=-0.33333)
    got = {}
    for fid, data in enc.encode_sample(row):
        got.update(dec.decode(fid, data))
    assert set(got) == set(LSB)
    for c, v in row.items():
        assert abs(got[c] - v) <= LSB[c] / 2 * (1 + 1e-9), c
    assert dec.report() == {"accepted": 5, "ignored": 0, **dict.fromkeys(FAULTS, 0)}


def test_units_of_the_dbc_are_converted_once(codec):
    db, m = codec
    enc = FrameEncoder(db, m)
    # 36 km/h and 180 deg/s written in the DBC's units come out as 10 m/s and pi rad/s
    fid, data = enc.encode("RG_Steering", {"VehicleSpeed": 36.0, "RoadWheelAngle": 0.1})
    assert FrameDecoder(db, m).decode(fid, data)["vx"] == pytest.approx(10.0, abs=1e-12)
    fid, data = enc.encode("RG_Inertial", {"YawRate": 180.0})
    assert FrameDecoder(db, m).decode(fid, data)["yaw_rate"] == pytest.approx(math.pi, abs=1e-12)
    # a sign in the map flips the value
    flipped = FrameDecoder(db, {**m, "signals": {**m["signals"], "ay": {"signal": "AccY", "sign": -1}}})
    fid, data = enc.encode("RG_Inertial", {"AccY": 2.0})
    assert flipped.decode(fid, data)["ay"] == pytest.approx(-2.0)


def test_faulty_frames_are_dropped_and_counted_by_reason(codec):
    db, m = codec
    enc, dec = FrameEncoder(db, m), FrameDecoder(db, m)
    fid, good = enc.encode("RG_Inertial", {"AccX": 1.0})
    assert dec.decode(fid, good) is not None
    assert dec.decode(0x555, good) is None  # no such message
    assert dec.decode(fid, good[:7]) is None  # 7 bytes for an 8-byte message
    bad = bytearray(good)
    bad[0] ^= 0x01
    assert dec.decode(fid, bytes(bad)) is None  # checksum no longer matches
    enc.encode("RG_Inertial", {})  # a frame lost on the way
    _, next_one = enc.encode("RG_Inertial", {})
    assert dec.decode(fid, next_one) is None  # the counter jumped by two
    _, resynced = enc.encode("RG_Inertial", {})
    assert dec.decode(fid, resynced) is not None  # and follows again
    # a raw value the type can carry but the DBC's range excludes: AccX 32.767 > 30
    raw = bytearray(enc.encode("RG_Inertial", {})[1])
    raw[0:2] = (0x7FFF).to_bytes(2, "little")
    raw[7] = xor8(fid, raw, 7)
    assert dec.decode(fid, bytes(raw)) is None
    rep = dec.report()
    assert rep["unknown_id"] == 1 and rep["bad_length"] == 1 and rep["checksum"] == 1
    assert rep["counter"] == 1 and rep["out_of_range"] == 1 and rep["accepted"] == 2


def test_the_output_message_is_known_but_fills_no_column(codec):
    db, m = codec
    fid, data = FrameEncoder(db, m).encode("RG_Friction", {"MostProbable": 80.0})
    dec = FrameDecoder(db, m)
    assert dec.decode(fid, data) is None
    assert dec.ignored == 1 and sum(dec.dropped.values()) == 0


@pytest.mark.parametrize(("change", "message"), [
    ({"signals": {"ax": {"signal": "NoSuchSignal"}}}, "signal 'NoSuchSignal' (for 'ax') not found; signals in"),
    ({"signals": {"ax": {"signal": "AccX", "unit": "deg/s"}}}, "measures rate, but 'ax' is a acceleration"),
    ({"signals": {"ax": {"signal": "AccX", "unit": "g"}}}, "the DBC says 'm/s^2', the map 'g'"),
    ({"signals": {"ax": {"signal": "Friction_Counter", "message": "RG_Friction"}}}, "has no unit in the DBC"),
    ({"signals": {"speed": {"signal": "VehicleSpeed"}}}, "'speed' is not a canonical signal"),
    ({"timeout": -1}, "timeout must be a positive number"),
    ({"integrity": "crc32"}, "integrity must be one of"),
])
def test_bad_maps_are_named(codec, change, message):
    db, m = codec
    with pytest.raises(ValueError, match=None) as err:
        FrameDecoder(db, load_signal_map({**m, **change}))
    assert message in str(err.value)


@pytest.mark.parametrize("suffix", [".asc", ".blf"])
def test_a_can_log_reads_back_as_the_drive_within_half_a_bit(tmp_path, suffix):
    import can

    from roadgrip.io import read_drive
    from roadgrip.live.replay import replay_drive
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("dry-gravel-dry", seed=1, duration=5.0)
    db, m = shipped_codec()
    log = tmp_path / f"drive{suffix}"
    with can.Logger(str(log)) as writer:
        sent = replay_drive(drive, writer.on_message_received, FrameEncoder(db, m), speed=float("inf"))
    assert sent == 5 * drive.n
    back = read_drive(log, dbc=SHIPPED_DBC)
    assert back.meta.extra["format"] == "can" and back.n == drive.n
    assert back.meta.extra["frames"]["accepted"] == sent
    for c in LSB:
        err = np.abs(back.col(c) - drive.col(c)).max()
        assert err <= LSB[c] / 2 * (1 + 1e-6) + 1e-12, (c, err)
    with pytest.raises(ValueError, match="needs a DBC"):
        read_drive(log)
    assert read_can_log(log, SHIPPED_DBC).n == drive.n
