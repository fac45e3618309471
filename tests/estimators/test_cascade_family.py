"""The cascade on the random multi-body vehicle family (issue 29): ``random:100`` to
``random:119`` with realistic sensors (latencies, scale and bias errors, the steering's
offset, ratio and compliance, the rolling radius) on ``figure-eight`` seed 0, the preset
vehicle description, the honesty rule of :func:`roadgrip.evaluate.honesty.score_result`.

These sensors leave the slip angles 0.01-0.07 rad off, differently at each lateral
acceleration (``docs/validation-cascade.md``). The kinematic check against the pose
(:func:`roadgrip.estimators.cascade.kernel.pose_slip_error`) measures that error at the
lateral acceleration driven; it follows a change only over its 2 s window. The accelerometer
and the gyro come on separate messages with independent 0-150 ms latencies, which put the
latency's difference times each change of ``a_y`` into ``v_y`` at once (0.02 rad of slip angle
at ``random:115``'s first corner exit): the cascade is told so, ``accel_latency_std`` the
spread of that difference (:func:`roadgrip.estimators.cascade.kernel.latency_slip_error`).
Asserted: all 20 runs honest, and no confidently wrong 5 m cell on at least 18 (none of the
20 yields a cell with ten observations, so the cells' error and cover are not judged here;
``benchmarks/vehicle_family.py --cascade`` prints them). With each car's fitted vehicle file
(``vehicle fit``), all 20 honest and no cell confidently wrong.
"""

from __future__ import annotations

import pytest

from roadgrip.estimators import run_estimator
from roadgrip.evaluate.honesty import score_result
from roadgrip.evaluate.map_truth import score_map
from roadgrip.mapping import grid_from_estimates
from roadgrip.sim.scenarios import simulate_scenario

pytestmark = pytest.mark.slow

FAMILY = tuple(f"random:{s}" for s in range(100, 120))
UNALIGNED_LATENCY_STD = 0.06
"""Standard deviation [s] of the difference of two independent uniform 0-150 ms latencies,
``0.15 / sqrt(6)``, as ``benchmarks/vehicle_family.py`` states it."""


def _scores(d, accel_latency_std: float):
    """The honesty score of the cascade's run on ``d`` and its 5 m map's score."""
    res = run_estimator("cascade", d, {"accel_latency_std": accel_latency_std})
    return score_result(res, d), score_map(d, grid_from_estimates(res.table, cell=5.0))


def _figure_eight(vehicle: str):
    return simulate_scenario("figure-eight", seed=0, engine="multibody", vehicle=vehicle)


@pytest.fixture(scope="module")
def family():
    """Per vehicle: the honesty score of the cascade's run and its 5 m map's score."""
    return {vehicle: _scores(_figure_eight(vehicle), UNALIGNED_LATENCY_STD) for vehicle in FAMILY}


def test_honest_on_the_whole_family(family):
    dishonest = {v: score.wrong_axle for v, (score, _) in family.items() if not score.honest}
    assert not dishonest, dishonest


def test_no_confidently_wrong_cell_on_at_least_18(family):
    wrong = {v: m.confidently_wrong for v, (_, m) in family.items() if m.confidently_wrong}
    assert len(wrong) <= 2, wrong  # random:109: one cell of two observations, measured


ALIGNED_LATENCY_STD = 0.02
"""``accel_latency_std`` [s] of a drive read with its fitted file: the issue's bound on a
fitted delay's error."""


@pytest.fixture(scope="module")
def family_fitted():
    """As :func:`family`, each drive read with its car's fitted file (``roadgrip vehicle fit``
    on its own ``dry-gravel-dry`` seed 10 at ``--mu 0.6``, as ``benchmarks/vehicle_family.py
    --fit``): its sensors calibrated (delays, the gyro, the pose's delay and heading) and the
    fitted vehicle."""
    from roadgrip.inference.vehicle_identification import fit_vehicle

    out = {}
    for vehicle in FAMILY:
        fit = fit_vehicle(simulate_scenario("dry-gravel-dry", seed=10, engine="multibody", vehicle=vehicle), mu=0.6)
        out[vehicle] = _scores(fit.read(_figure_eight(vehicle)), ALIGNED_LATENCY_STD)
    return out


def test_with_the_fitted_file_honest_and_no_cell_confidently_wrong_on_the_whole_family(family_fitted):
    # before the file carried the gyro's scale and bias and the pose's delay and heading bias,
    # random:117 (gyro bias 5.2 mrad/s) was dishonest: stage 1's v_y 0.15-0.24 m/s low
    dishonest = {v: score.wrong_axle for v, (score, _) in family_fitted.items() if not score.honest}
    assert not dishonest, dishonest
    wrong = {v: m.confidently_wrong for v, (_, m) in family_fitted.items() if m.confidently_wrong}
    assert not wrong, wrong
