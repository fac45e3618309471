"""The classifiers on the random multi-body vehicle family (issue 29): ``random:100`` to
``random:119``, realistic sensors, each calibrated with ``roadgrip calibrate --label high``
on the dry first minute of its own ``dry-gravel-dry`` seed 10 and scored on seed 0 against
the simulator's truth (:func:`roadgrip.evaluate.classification.surface_change_scores`).

The issue's criterion: gravel flagged within 1.0 s of the first sample on gravel at true
utilisation >= 0.6 and no false switch, on at least 18 of the 20. What holds and is
asserted here: the one-dry-minute calibration holds on the 15 two-wheel-drive cars and
refuses the five all-wheel-drive ones, saying why (no free-rolling wheel: the traction
slips have no speed reference, and the braking slips against a speed coasting on the
accelerometer do not hold the label); on every car where it holds the slip map meets the
criterion, and the bRLS on all but one (``random:111``: a 'low' claimed late in a 0.5 g
stop on the dry asphalt after the gravel). The honesty rule (:mod:`roadgrip.evaluate.honesty`)
holds on all but one calibrated car for each (the bRLS's ``random:111``; the slip map's
``random:108``, whose 'low' outlives the return to dry asphalt by 0.33 s past the rule's
10 s, until the first acceleration there).
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


@pytest.fixture(scope="module")
def family():
    """Per vehicle: None where the calibration fails, else per method (scores, honest)."""
    out = {}
    for vehicle in FAMILY:
        dry = _mb(vehicle, 10).slice_time(0.0, 60.0)
        try:
            cal = calibrate([(dry, "high")])
        except ValueError as e:
            out[vehicle] = None
            assert dry.vehicle.drive == "awd" and "all-wheel driven" in str(e), (vehicle, str(e))
            continue
        test = _mb(vehicle, 0)
        runs = {}
        for method in METHODS:
            res = run_estimator(method, test, {"calibration": cal})
            runs[method] = (surface_change_scores(test, res.table["grip_class"].to_numpy()),
                            score_result(res, test))
        out[vehicle] = runs
    for vehicle, runs in out.items():
        for method, (s, h) in (runs or {}).items():
            print(f"{vehicle} {method:7s}: delays {np.round(s.delays, 2)}, false switches "
                  f"{s.false_switches}, honest {h.honest} (wrong {h.wrong:.4f})")
        if runs is None:
            print(f"{vehicle}: the one-dry-minute calibration fails")
    return out


def _meets(scores) -> bool:
    return scores.delays[0] <= 1.0 and scores.false_switches == 0


def test_one_dry_minute_calibrates_every_two_wheel_drive_car(family):
    refused = [v for v, r in family.items() if r is None]
    assert sum(r is not None for r in family.values()) >= 15, refused  # the refusals are all-wheel drives


def test_slip_map_detects_gravel_on_every_car_it_is_calibrated_for(family):
    for vehicle, runs in family.items():
        if runs is not None:
            assert _meets(runs["slipmap"][0]), (vehicle, runs["slipmap"][0])


def test_brls_detects_gravel_on_all_calibrated_cars_but_one(family):
    misses = [v for v, runs in family.items() if runs is not None and not _meets(runs["brls"][0])]
    assert len(misses) <= 1, misses


@pytest.mark.parametrize(("method", "dishonest"), [("slipmap", 1), ("brls", 1)])
def test_classifiers_honest_on_the_calibrated_cars(family, method, dishonest):
    honest = {v: runs[method][1].honest for v, runs in family.items() if runs is not None}
    assert sum(honest.values()) >= len(honest) - dishonest, (method, honest)
