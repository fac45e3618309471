"""The classifiers on the random multi-body vehicle family (issue 29): ``random:100`` to
``random:119``, realistic sensors, each calibrated with ``roadgrip calibrate --label high``
on the dry first minute of its own ``dry-gravel-dry`` seed 10 and scored on seed 0 against
the simulator's truth (:func:`roadgrip.evaluate.classification.surface_change_scores`),
both as logged and read with the car's fitted vehicle file (``roadgrip vehicle fit`` on
seed 10 whole at ``--mu 0.6``, separate from the scored drive; its delays, steering and
accelerometer corrections applied and its vehicle used, as ``--vehicle car.yaml`` does).

The issue's criterion: gravel flagged within 1.0 s of the first sample on gravel at true
utilisation >= 0.6 and no false switch, on at least 18 of the 20; honest on all 20. What
holds and is asserted here (``docs/validation-classification.md``, family section):

* as logged, the one-dry-minute calibration holds on the 15 two-wheel-drive cars and two of
  the five all-wheel-drive ones (``random:105``, ``119``), refusing the others saying why; both
  classifiers meet the criterion on 16 (``random:119``'s only evidence is braking: gravel
  flagged at its first braking there, 10.2 s late); both honest on all 17;
* with the fitted vehicle file (``a_x`` moved by its own delay, the gyro's scale and bias
  corrected), the calibration holds on 18 (three all-wheel drives, ``random:105``, ``106`` and
  ``110``, besides the 15; ``109`` and ``119`` refused, saying why); both classifiers meet the
  criterion on 18 (the slip map on ``random:110`` since the gyro is corrected: before, it never
  flagged the gravel); both honest on all 18. A calibrated 'low' is held until evidence of high grip
  (5 s on an all-wheel drive, :func:`roadgrip.estimators.classify.fit.low_claim_hold`),
  and decided afresh once 8 s old (``redecide_low_s``): ``random:113`` (fitted) and
  ``random:108`` (as logged, slip map) cruise on dry asphalt after the gravel until 9.4 s
  past the change, and their first dry acceleration ends the old 'low' 0.1-0.2 s into it,
  within the rule's 10 s (held, the old estimate's inertia kept it 0.2-1.0 s past). Braking slips
  only at a stop's onset, and on a two-wheel drive only where its traction slips do not
  hold the label.
"""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.estimators import run_estimator
from roadgrip.estimators.classify import calibrate
from roadgrip.evaluate.classification import surface_change_scores
from roadgrip.evaluate.honesty import score_result
from roadgrip.sim.scenarios import simulate_scenario

pytestmark = pytest.mark.slow

FAMILY = tuple(f"random:{s}" for s in range(100, 120))
METHODS = ("brls", "slipmap")


def _mb(vehicle: str, seed: int):
    return simulate_scenario("dry-gravel-dry", seed=seed, engine="multibody", vehicle=vehicle)


def _family(fitted: bool):
    """Per vehicle: None where the calibration fails, else per method (scores, honesty)."""
    from roadgrip.inference.vehicle_identification import fit_vehicle

    out = {}
    for vehicle in FAMILY:
        cal_drive, test = _mb(vehicle, 10), _mb(vehicle, 0)
        if fitted:
            fit = fit_vehicle(cal_drive, mu=0.6)
            cal_drive, test = fit.read(cal_drive), fit.read(test)
        dry = cal_drive.slice_time(0.0, 60.0)
        try:
            cal = calibrate([(dry, "high")])
        except ValueError as e:
            out[vehicle] = None
            assert dry.vehicle.drive == "awd" and "all-wheel driven" in str(e), (vehicle, str(e))
            continue
        assert bool(cal.diagnostics["sensor_calibration"]) == fitted
        runs = {}
        for method in METHODS:
            res = run_estimator(method, test, {"calibration": cal})
            runs[method] = (surface_change_scores(test, res.table["grip_class"].to_numpy()),
                            score_result(res, test))
        out[vehicle] = runs
    for vehicle, runs in out.items():
        for method, (s, h) in (runs or {}).items():
            print(f"{'fitted' if fitted else 'logged'} {vehicle} {method:7s}: delays {np.round(s.delays, 2)}, "
                  f"false switches {s.false_switches}, honest {h.honest} (wrong {h.wrong:.4f})")
        if runs is None:
            print(f"{vehicle}: the one-dry-minute calibration fails")
    return out


@pytest.fixture(scope="module")
def family():
    """The drives as logged."""
    return _family(fitted=False)


@pytest.fixture(scope="module")
def family_fitted():
    """The drives read with each car's fitted vehicle file."""
    return _family(fitted=True)


def _meets(scores) -> bool:
    return scores.delays[0] <= 1.0 and scores.false_switches == 0


def test_one_dry_minute_calibrates_every_two_wheel_drive_car_and_two_all_wheel_drives(family):
    refused = [v for v, r in family.items() if r is None]
    assert len(refused) <= 3, refused  # all-wheel drives (asserted in the fixture)


@pytest.mark.parametrize("method", METHODS)
def test_as_logged_both_detect_gravel_on_16(family, method):
    meets = [v for v, runs in family.items() if runs is not None and _meets(runs[method][0])]
    assert len(meets) >= 16, meets


@pytest.mark.parametrize("method", METHODS)
def test_as_logged_honest_on_every_calibrated_car(family, method):
    dishonest = {v for v, runs in family.items() if runs is not None and not runs[method][1].honest}
    assert not dishonest, dishonest


def test_the_fitted_vehicle_file_calibrates_three_all_wheel_drives_besides(family_fitted):
    refused = [v for v, r in family_fitted.items() if r is None]
    assert len(refused) <= 2, refused  # all-wheel drives (asserted in the fixture)


@pytest.mark.parametrize(("method", "least"), [("brls", 18), ("slipmap", 18)])
def test_with_the_fitted_vehicle_file_both_detect_gravel_on_18(family_fitted, method, least):
    meets = [v for v, runs in family_fitted.items() if runs is not None and _meets(runs[method][0])]
    assert len(meets) >= least, meets


@pytest.mark.parametrize("method", METHODS)
def test_with_the_fitted_vehicle_file_honest_on_every_calibrated_car(family_fitted, method):
    dishonest = {v for v, runs in family_fitted.items() if runs is not None and not runs[method][1].honest}
    assert not dishonest, dishonest
