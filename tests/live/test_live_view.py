"""The Foxglove live view: a WebSocket client receives the friction trace and the learned curve."""

from __future__ import annotations

import itertools
import json
import math
import struct
import time

import numpy as np
import pytest

from roadgrip.io.can import FrameEncoder
from roadgrip.live.assembler import Row
from roadgrip.live.replay import quantised
from roadgrip.live.runner import LiveEstimator
from roadgrip.live.sinks import FoxgloveSink

websockets = pytest.importorskip("websockets.sync.client")


def _json(ws, timeout=2.0):
    while True:
        m = ws.recv(timeout=timeout)
        if isinstance(m, str):
            return json.loads(m)


def test_a_websocket_client_receives_the_trace_and_the_curve(codec):
    from roadgrip.sim.scenarios import simulate_scenario

    drive = quantised(simulate_scenario("f1tenth-patches", seed=1, duration=6.0), FrameEncoder(*codec))
    cols = list(drive.data.columns)
    est = LiveEstimator("gpssm", drive.vehicle, cols, {"particles": 64}, warmup=0.5)
    sink = FoxgloveSink(est, port=0, curve_period=2.0, n_alpha=13)
    try:
        with websockets.connect(f"ws://127.0.0.1:{sink.port}", subprotocols=["foxglove.sdk.v1"]) as ws:
            assert _json(ws)["op"] == "serverInfo"
            topics = {}
            while len(topics) < 2:
                msg = _json(ws)
                if msg["op"] == "advertise":
                    topics.update({c["topic"]: c["id"] for c in msg["channels"]})
            assert set(topics) == {"/roadgrip/friction", "/roadgrip/curve"}
            subs = {1: "/roadgrip/friction", 2: "/roadgrip/curve"}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": k, "channelId": topics[v]} for k, v in subs.items()]}))
            time.sleep(0.3)
            data = drive.data.to_numpy(float)
            written = []
            for k in range(0, drive.n, 25):
                rows = [Row(float(r[0]), dict(zip(cols, map(float, r), strict=True)), (), 0.0) for r in data[k:k + 25]]
                out = est.feed(rows)
                sink.write(out)
                written.extend(out)
            got: dict[str, list] = {"/roadgrip/friction": [], "/roadgrip/curve": []}
            deadline = time.monotonic() + 10.0
            while len(got["/roadgrip/friction"]) < len(written) and time.monotonic() < deadline:
                m = ws.recv(timeout=5.0)
                if isinstance(m, bytes) and m[0] == 0x01:  # message data: op, subscription, time, payload
                    sub, stamp = struct.unpack_from("<IQ", m, 1)
                    got[subs[sub]].append((stamp, json.loads(m[13:])))
    finally:
        sink.close()
    trace = [p for _, p in got["/roadgrip/friction"]]
    assert [p["t"] for p in trace] == [r.t for r in written]
    assert [p["grip_class"] for p in trace] == [r.grip_class for r in written]
    assert [p["reason"] for p in trace] == [r.reason for r in written]
    for p, r in zip(trace, written, strict=True):  # withheld values arrive as null
        assert (p["lower"] is None) == math.isnan(r.lower)
    # one curve every two seconds of drive after the warm-up, each a band around its mean
    curves = [p for _, p in got["/roadgrip/curve"]]
    assert len(curves) >= 2 and all(b["t"] - a["t"] >= 2.0 for a, b in itertools.pairwise(curves))
    for c in curves:
        alpha = np.array(c["alpha_deg"])
        assert alpha[0] == pytest.approx(-12.0) and alpha[-1] == pytest.approx(12.0)
        for axle in ("front", "rear"):
            lo, mean, up = (np.array(c[axle][k]) for k in ("lower", "mean", "upper"))
            assert len(mean) == len(alpha) and (lo <= mean + 1e-12).all() and (mean <= up + 1e-12).all()
            assert (up - lo).max() > 0
