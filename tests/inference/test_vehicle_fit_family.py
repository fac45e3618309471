"""``roadgrip vehicle fit`` on the random multi-body vehicle family (issue 29): ``random:100``
to ``random:119`` with realistic sensors, each fitted on its own ``dry-gravel-dry`` seed 10
(the whole 180 s at ``mu=0.6``, fixed before measuring: the dry minute alone leaves the
stiffnesses undetermined even with error-free sensors), against the simulator's truth.

Truths (as ``benchmarks/vehicle_family.py --fit`` states them): the front cornering stiffness
in series with the steering compliance, ``1/(1/C_f + c)``; the rear the tire's; each delay its
sensor's latency minus the gyro's (the speed's: the undriven wheels', or the ``vx`` column's on
an all-wheel drive; ``a_x``'s own, a message apart from ``a_y``); the steering offset the road-wheel angle at a zero reading,
``-offset/(1 + ratio_error)``.

The issue's criterion (stiffnesses within 10 %, each delay within 20 ms, the steering offset
within 0.1 deg, on 18 of 20) is reached for every delay (20 of 20) and the offset (19 of 20),
not for the stiffnesses: the rear within 10 % on 19 of 20 (the pose's lateral velocity measures
it again), both on 13 of 20, 13 vehicles passing whole (``docs/vehicle-fit.md``). What is
asserted: those counts, and that every fitted stiffness lies within three of its standard
errors of the truth (the errors are honest where the values miss).

The drives come from the drive cache (``ROADGRIP_DRIVE_CACHE``, by default the repository's
``.cache/drives`` that ``tests/conftest.py`` names); a drive missing there is simulated.
"""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.inference.vehicle_identification import fit_vehicle
from roadgrip.signals import undriven_wheels
from roadgrip.sim.scenarios import simulate_scenario
from roadgrip.sim.vehicle_family import mb_vehicle

pytestmark = pytest.mark.slow

FAMILY = tuple(f"random:{s}" for s in range(100, 120))
DELAYS = ("delay_accelerometer", "delay_accelerometer_x", "steer_delay", "delay_speed", "delay_pose")
STIFFNESS = ("cornering_stiffness_front", "cornering_stiffness_rear")


def _errors(name: str) -> dict[str, tuple[float, float]]:
    """Fitted minus true and the standard error, NaN where undetermined (stiffnesses relative)."""
    v = mb_vehicle(name)
    vp, ch, st = v.params, v.sensors.channels, v.sensors.steering
    fit = fit_vehicle(simulate_scenario("dry-gravel-dry", seed=10, engine="multibody", vehicle=name), mu=0.6)
    gyro = ch["yaw_rate"].delay
    speed = ch["omega_fl"].delay if undriven_wheels(vp.drive).any() else ch["vx"].delay
    truth = {"cornering_stiffness_front": 1.0 / (1.0 / vp.cornering_stiffness_front + st.compliance),
             "cornering_stiffness_rear": vp.cornering_stiffness_rear,
             "delay_accelerometer": ch["ay"].delay - gyro, "steer_delay": ch["steer"].delay - gyro,
             "delay_speed": speed - gyro, "delay_pose": ch["psi"].delay - gyro,
             "delay_accelerometer_x": ch["ax"].delay - gyro,
             "steer_offset": -st.offset / (1.0 + st.ratio_error)}
    out = {}
    for k, true in truth.items():
        fv = fit.values[k]
        val, std = (fv.value, fv.std) if fv.fitted else (float("nan"), float("nan"))
        out[k] = (val / true - 1.0, std / true) if k in STIFFNESS else (val - true, std)
    return out


@pytest.fixture(scope="module")
def family():
    out = {name: _errors(name) for name in FAMILY}
    for name, e in out.items():
        print(name, {k: round(float(x[0]), 4) for k, x in e.items()})
    return out


def _stiff_ok(e) -> bool:
    return all(abs(e[k][0]) <= 0.10 for k in STIFFNESS)


def test_every_delay_within_20_ms_on_all(family):
    for name, e in family.items():
        for k in DELAYS:
            assert abs(e[k][0]) <= 0.020, (name, k, e[k])


def test_steering_offset_within_01_deg_on_19(family):
    ok = [n for n, e in family.items() if abs(e["steer_offset"][0]) <= np.radians(0.1)]
    assert len(ok) >= 19, sorted(set(FAMILY) - set(ok))


def test_stiffnesses_within_10_percent_on_13_and_honest_on_all(family):
    ok = [n for n, e in family.items() if _stiff_ok(e)]
    assert len(ok) >= 13, sorted(set(FAMILY) - set(ok))
    rear = [n for n, e in family.items() if abs(e["cornering_stiffness_rear"][0]) <= 0.10]
    assert len(rear) >= 19, sorted(set(FAMILY) - set(rear))
    for name, e in family.items():
        for k in STIFFNESS:
            err, std = e[k]
            assert np.isfinite(err) and abs(err) <= 3.0 * std, (name, k, err, std)


def test_whole_criterion_on_13(family):
    ok = [n for n, e in family.items() if _stiff_ok(e) and abs(e["steer_offset"][0]) <= np.radians(0.1)
          and all(abs(e[k][0]) <= 0.020 for k in DELAYS)]
    assert len(ok) >= 13, sorted(set(FAMILY) - set(ok))
