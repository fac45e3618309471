"""``roadgrip vehicle fit`` on the random multi-body vehicle family (issue 29): ``random:100``
to ``random:119`` with realistic sensors, each fitted on its own ``dry-gravel-dry`` seed 10
(the whole 180 s at ``mu=0.6``, fixed before measuring: the dry minute alone leaves the
stiffnesses undetermined even with error-free sensors), against the simulator's truth.

Truths: the front cornering stiffness in series with the steering compliance,
``1/(1/C_f + c)`` (one a steering-angle sensor cannot tell from the other); the rear the
tire's; each delay its sensor's latency minus the gyro's; the steering offset the road-wheel
angle at a zero reading, ``-offset/(1 + ratio_error)``.

The issue's criterion (stiffnesses within 10 %, each delay within 20 ms, the steering offset
within 0.1 deg, on 18 of 20) is not reached on any vehicle. What holds and is asserted: the
accelerometer's and the pose's delays within 20 ms on all 20, the steering offset within 0.1 deg
on at least 15. What does not: the stiffnesses are undetermined on all 20 and the steering
delay comes out 34-67 ms early (the gyro's noise, 0.005 rad/s, differentiated over 0.15 s into
the yaw-acceleration regressor; measured on random:102 and 103: with every channel exact the
steering delay is found within 5 ms and the stiffnesses are determined, front +4 and +7 %, rear
+18 and +3 %; adding white noise of 0.005 rad/s to the exact yaw rate alone leaves them
undetermined and the steering delay 40 ms early), and the speed
delay is off wherever ``a_x`` and ``a_y`` arrive with different latencies (one accelerometer
delay is fitted).
"""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.inference.vehicle_identification import fit_vehicle
from roadgrip.sim.scenarios import simulate_scenario
from roadgrip.sim.vehicle_family import mb_vehicle

pytestmark = pytest.mark.slow

FAMILY = tuple(f"random:{s}" for s in range(100, 120))


def _errors(name: str) -> dict[str, float]:
    """Fitted minus true, NaN where undetermined (stiffnesses relative)."""
    v = mb_vehicle(name)
    vp, ch, st = v.params, v.sensors.channels, v.sensors.steering
    fit = fit_vehicle(simulate_scenario("dry-gravel-dry", seed=10, engine="multibody", vehicle=name), mu=0.6)
    gyro = ch["yaw_rate"].delay
    truth = {"cornering_stiffness_front": 1.0 / (1.0 / vp.cornering_stiffness_front + st.compliance),
             "cornering_stiffness_rear": vp.cornering_stiffness_rear,
             "delay_accelerometer": ch["ay"].delay - gyro, "steer_delay": ch["steer"].delay - gyro,
             "delay_pose": ch["psi"].delay - gyro, "steer_offset": -st.offset / (1.0 + st.ratio_error)}
    out = {}
    for k, true in truth.items():
        fv = fit.values[k]
        val = fv.value if fv.fitted else float("nan")
        out[k] = val / true - 1.0 if k.startswith("cornering") else val - true
    return out


@pytest.fixture(scope="module")
def family():
    out = {name: _errors(name) for name in FAMILY}
    for name, e in out.items():
        print(name, {k: round(float(x), 4) for k, x in e.items()})
    return out


def test_accelerometer_and_pose_delays_within_20_ms_on_all(family):
    for name, e in family.items():
        assert abs(e["delay_accelerometer"]) <= 0.020, (name, e)
        assert abs(e["delay_pose"]) <= 0.020, (name, e)


def test_steering_offset_within_01_deg_on_15(family):
    ok = [n for n, e in family.items() if abs(e["steer_offset"]) <= np.radians(0.1)]
    assert len(ok) >= 15, sorted(set(FAMILY) - set(ok))


def test_what_is_not_reached_yet(family):
    # held so that a change is noticed: stiffnesses undetermined, steering delay early
    for name, e in family.items():
        assert np.isnan(e["cornering_stiffness_front"]) and np.isnan(e["cornering_stiffness_rear"]), name
        assert -0.080 < e["steer_delay"] < -0.025, (name, e["steer_delay"])
