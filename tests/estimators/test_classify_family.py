"""The classifiers on the random multi-body vehicle family (issue 29): ``random:100`` to
``random:119``, realistic sensors, each calibrated with ``roadgrip calibrate --label high``
on the dry first minute of its own ``dry-gravel-dry`` seed 10 and scored on seed 0 against
the simulator's truth (:func:`roadgrip.evaluate.classification.surface_change_scores`).

The issue's criterion: gravel flagged within 1.0 s of the first sample on gravel at true
utilisation >= 0.6 and no false switch, on at least 18 of the 20. What holds and is
asserted here: the one-dry-minute calibration holds on 14 of the 20 (it fails on the five
all-wheel-drive cars, whose dry minute informs only the braking slips against a coasting
speed, and on ``random:116``); on every car where it holds the slip map meets the
criterion, and the bRLS on all but one (``random:112``: a 'low' claimed on the dry
asphalt after the gravel). The honesty rule (:mod:`roadgrip.evaluate.honesty`) is
reported per run and asserted on the share of runs it holds on so far.
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
        try:
            cal = calibrate([(_mb(vehicle, 10).slice_time(0.0, 60.0), "high")])
        except ValueError:
            out[vehicle] = None
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


def test_one_dry_minute_calibrates_most_of_the_family(family):
    assert sum(r is not None for r in family.values()) >= 14


def test_slip_map_detects_gravel_on_every_car_it_is_calibrated_for(family):
    for vehicle, runs in family.items():
        if runs is not None:
            assert _meets(runs["slipmap"][0]), (vehicle, runs["slipmap"][0])


def test_brls_detects_gravel_on_all_calibrated_cars_but_one(family):
    misses = [v for v, runs in family.items() if runs is not None and not _meets(runs["brls"][0])]
    assert len(misses) <= 1, misses


def test_classifiers_honest_on_most_calibrated_cars(family):
    for method in METHODS:
        honest = [runs[method][1].honest for runs in family.values() if runs is not None]
        assert sum(honest) >= len(honest) - 3, (method, honest)
