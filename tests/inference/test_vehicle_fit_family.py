"""``roadgrip vehicle fit`` on the random multi-body vehicle family (issue 29): ``random:100``
to ``random:119`` with realistic sensors, each fitted on its own drive (seed 10), against the
simulator's truth (:func:`roadgrip.sim.vehicle_family.fit_truth`, as
``benchmarks/vehicle_family.py --fit`` uses them).

On the identification drive ``vehicle-id`` (``mu=1.0``; turning at 8-20 m/s) the issue's
criterion (stiffnesses within 10 %, each delay within 20 ms, the steering offset within
0.1 deg, on 18 of 20) is met: 19 of 20. On ``dry-gravel-dry`` (the whole 180 s at
``mu=0.6``; all turning at 11-12 m/s, where the steering's scale trades against the
understeer) every delay (20 of 20) and the offset (20 of 20; random:100 at 0.098 deg) pass,
the stiffnesses do not: the rear within 10 % on 18 of 20 (the pose's lateral velocity
measures it again), both on 14 of 20, as the fit's own standard errors (median 10.1 % at the
front) lead one to expect (``docs/vehicle-fit.md``). What is asserted: those counts, that
every stiffness fitted on ``dry-gravel-dry`` lies within three of its standard errors of the
truth (the errors are honest where the values miss), and the gyro's scale and bias and the
pose's heading bias (the truth: the sensors' bias at the drive's middle, their drift
included) on all 20.

The drives come from the drive cache (``ROADGRIP_DRIVE_CACHE``, by default the repository's
``.cache/drives`` that ``tests/conftest.py`` names); a drive missing there is simulated.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from roadgrip.inference.vehicle_identification import fit_vehicle
from roadgrip.sim.scenarios import simulate_scenario
from roadgrip.sim.vehicle_family import fit_truth, mb_vehicle

pytestmark = pytest.mark.slow

FAMILY = tuple(f"random:{s}" for s in range(100, 120))
DELAYS = ("delay_accelerometer", "delay_accelerometer_x", "steer_delay", "delay_speed", "delay_pose")
STIFFNESS = ("cornering_stiffness_front", "cornering_stiffness_rear")
RELATIVE = (*STIFFNESS, "yaw_rate_scale")
FIT_DRIVES = {"dry-gravel-dry": (0.6, 180.0), "vehicle-id": (1.0, 225.0)}
"""Each fit drive's ``mu`` and length [s]."""


@functools.cache
def _fit(name: str, scenario: str):
    drive = simulate_scenario(scenario, seed=10, engine="multibody", vehicle=name)
    return fit_vehicle(drive, mu=FIT_DRIVES[scenario][0])


def _errors(name: str, scenario: str = "dry-gravel-dry") -> dict[str, tuple[float, float]]:
    """Fitted minus true and the standard error, NaN where undetermined (stiffnesses and the
    gyro's scale relative), the car fitted on ``scenario`` seed 10."""
    fit = _fit(name, scenario)
    out = {}
    for k, true in fit_truth(mb_vehicle(name), FIT_DRIVES[scenario][1]).items():
        fv = fit.values[k]
        val, std = (fv.value, fv.std) if fv.fitted else (float("nan"), float("nan"))
        out[k] = (val / true - 1.0, std / true) if k in RELATIVE else (val - true, std)
    return out


@pytest.fixture(scope="module")
def family():
    out = {name: _errors(name) for name in FAMILY}
    for name, e in out.items():
        print(name, {k: round(float(x[0]), 4) for k, x in e.items()})
    return out


@pytest.fixture(scope="module")
def identification():
    """Each car fitted on its own ``vehicle-id`` drive instead."""
    out = {name: _errors(name, "vehicle-id") for name in FAMILY}
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


def test_stiffnesses_within_10_percent_on_14_and_honest_on_all(family):
    ok = [n for n, e in family.items() if _stiff_ok(e)]
    assert len(ok) >= 14, sorted(set(FAMILY) - set(ok))
    # the rear misses on random:102 (+10.7 %) and random:114 (-10.9 %)
    rear = [n for n, e in family.items() if abs(e["cornering_stiffness_rear"][0]) <= 0.10]
    assert len(rear) >= 18, sorted(set(FAMILY) - set(rear))
    for name, e in family.items():
        for k in STIFFNESS:
            err, std = e[k]
            assert np.isfinite(err) and abs(err) <= 3.0 * std, (name, k, err, std)


def _whole(e) -> bool:
    return (_stiff_ok(e) and abs(e["steer_offset"][0]) <= np.radians(0.1)
            and all(abs(e[k][0]) <= 0.020 for k in DELAYS))


def test_whole_criterion_on_14(family):
    ok = [n for n, e in family.items() if _whole(e)]
    assert len(ok) >= 14, sorted(set(FAMILY) - set(ok))


def test_gyro_and_pose_heading_on_all(family):
    # the gyro's scale within 0.5 %, its bias within 1 mrad/s, the pose's heading bias within
    # 1.5 mrad (v_x times it is the pose's v_y error: 0.02 m/s at 12 m/s), each within four
    # standard errors plus the drift's share
    for name, e in family.items():
        assert abs(e["yaw_rate_scale"][0]) <= 0.005, (name, e["yaw_rate_scale"])
        assert abs(e["yaw_rate_bias"][0]) <= 0.001, (name, e["yaw_rate_bias"])
        assert abs(e["pose_heading_bias"][0]) <= 0.0015, (name, e["pose_heading_bias"])


def test_identification_drive_pins_the_front_axle_and_the_steering_scale(identification):
    """Fitted on the ``vehicle-id`` drive (seed 10, ``mu=1.0``: dry only) instead, turning at
    8-20 m/s, the steering's scale is told from the understeer, and with it the front axle.
    Measured (``docs/vehicle-fit.md``): the front within 5.9 % on all 20, standard errors at
    most 2.9 % (median 2.1 %; 10.1 % on ``dry-gravel-dry``, where all turning is at 11-12 m/s), the
    steering scale's median 0.18 % (2.8 %)."""
    scale = []
    for name, e in identification.items():
        fit = _fit(name, "vehicle-id")
        assert fit.values["cornering_stiffness_front"].fitted, (name, fit.values["cornering_stiffness_front"].note)
        scale.append(fit.values["steer_scale"].std / fit.values["steer_scale"].value)
        assert "one speed" not in fit.values["steer_scale"].note, fit.values["steer_scale"].note
        err, std = e["cornering_stiffness_front"]
        assert abs(err) <= 0.08 and std <= 0.04 and abs(err) <= 3.0 * std, (name, err, std)
    assert np.median(scale) <= 0.005, scale


def test_identification_drive_meets_the_criterion_on_18(identification):
    """The issue's whole criterion on the ``vehicle-id`` fits. Measured: 19 of 20; every delay
    within 10 ms and the offset within 0.04 deg on all 20 (with the pose's logger holds filled:
    before, ``a_x``'s delay of the all-wheel drives ``105`` and ``106`` was undetermined and
    ``a_y``'s, kept for it, 37-70 ms off; and the roll's lag taken off the accelerometer's
    delay). The miss is the rear of ``random:112`` (+11 %): the files' yaw inertia is not the
    engine's (``docs/vehicle-fit.md``)."""
    for name, e in identification.items():
        for k in DELAYS:
            assert abs(e[k][0]) <= 0.020, (name, k, e[k])
        assert abs(e["steer_offset"][0]) <= np.radians(0.1), (name, e["steer_offset"])
    ok = [n for n, e in identification.items() if _whole(e)]
    assert len(ok) >= 18, sorted(set(FAMILY) - set(ok))
