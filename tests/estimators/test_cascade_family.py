"""The cascade on the random multi-body vehicle family (issue 29): ``random:100`` to
``random:119`` with realistic sensors (latencies, scale and bias errors, the steering's
offset, ratio and compliance, the rolling radius) on ``figure-eight`` seed 0, the preset
vehicle description, the honesty rule of :func:`roadgrip.evaluate.honesty.score_result`.

These sensors leave the slip angles 0.01-0.07 rad off, differently at each lateral
acceleration (``docs/validation-cascade.md``). The kinematic check against the pose
(:func:`roadgrip.estimators.cascade.kernel.pose_slip_error`) measures that error at the
lateral acceleration driven and keeps such samples out of the map: 18 of the 20 runs are
honest (11 without it). Asserted: at least 18 honest, and the two known open ones
(``random:106``, ``random:115``: 0.2-0.3 % of the judged samples wrong, in the first hard
corner, where the pose's heading bias of 0.008 rad hides the slip-angle bias from the check)
listed, so that a change in which cars fail is seen.
"""

from __future__ import annotations

import pytest

from roadgrip.estimators import run_estimator
from roadgrip.evaluate.honesty import score_result
from roadgrip.sim.scenarios import simulate_scenario

pytestmark = pytest.mark.slow

FAMILY = tuple(f"random:{s}" for s in range(100, 120))
KNOWN_DISHONEST = {"random:106", "random:115"}
"""Open: bands that exclude the truth on 0.32 % and 0.24 % of the judged samples (limit 0.1 %)."""


@pytest.fixture(scope="module")
def family():
    """Per vehicle: the honesty score of the cascade's run."""
    out = {}
    for vehicle in FAMILY:
        d = simulate_scenario("figure-eight", seed=0, engine="multibody", vehicle=vehicle)
        out[vehicle] = score_result(run_estimator("cascade", d, {}), d)
    return out


def test_honest_on_the_family_but_the_two_known(family):
    dishonest = {v for v, score in family.items() if not score.honest}
    assert len(dishonest) <= 2, sorted(dishonest)
    assert dishonest <= KNOWN_DISHONEST, sorted(dishonest - KNOWN_DISHONEST)
    for v in dishonest:
        assert family[v].wrong_axle < 0.005, (v, family[v].wrong_axle)
