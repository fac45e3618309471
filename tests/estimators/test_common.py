"""The common estimator check over every registered method, and a tiny test-only estimator."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import pytest

from roadgrip import estimators
from roadgrip.estimators.check import CHECKS, check_estimator
from roadgrip.estimators.protocol import (
    DriveInfo,
    Estimator,
    EstimatorConfig,
    Prepared,
    run_by_stepping,
)


# -- a fifth estimator, as docs/architecture.md describes: constant friction, prior band ------
@dataclass(frozen=True)
class ConstantConfig(EstimatorConfig):
    """Prior band of the peak friction [-]."""

    method = "constant"
    lower: float = 0.1
    upper: float = 1.2

    def __post_init__(self) -> None:
        if not 0.0 <= self.lower < self.upper:
            raise ValueError(f"lower must be in [0, upper), got lower={self.lower}, upper={self.upper}")


class ConstantState(NamedTuple):
    lower: float
    upper: float


def _prepare(drive, config: ConstantConfig) -> Prepared:
    return Prepared(DriveInfo.from_drive(drive), drive.t)


def _init(info: DriveInfo, config: ConstantConfig, seed: int) -> ConstantState:
    return ConstantState(config.lower, config.upper)


def _step(state: ConstantState, t: float) -> tuple[ConstantState, dict[str, Any]]:
    mid = 0.5 * (state.lower + state.upper)
    row = {"t": float(t), "grip_class": "unknown", "grip_index": np.nan, "excited": False,
           "peak_observed_front": False, "peak_observed_rear": False}
    for axle in ("front", "rear"):
        row |= {f"mu_{axle}": mid, f"mu_{axle}_lower": state.lower, f"mu_{axle}_upper": state.upper}
    return state, row


def _summary(table) -> dict[str, float]:
    last = table.iloc[-1]
    return {"MostProbable": float(last["mu_front"]), "LowerBound": float(last["mu_front_lower"]),
            "UpperBound": float(last["mu_front_upper"])}


def _run(drive, config=None, seed=0, progress=None):
    return run_by_stepping(CONSTANT, drive, config, seed, progress, summary=_summary)


CONSTANT = Estimator(
    name="constant", paper="-", summary="Constant friction with its prior band (test only).",
    Config=ConstantConfig, prepare=_prepare, init=_init, step=_step, run=_run,
    prior_band=lambda c: (c.lower, c.upper),
)
estimators.register(CONSTANT)


# -- drives ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def drives():
    from roadgrip.sim.scenarios import simulate_scenario

    excited = simulate_scenario("dry-gravel-dry", seed=0, duration=20.0)
    unexcited = simulate_scenario("straight-cruise", seed=0, duration=12.0)
    return excited, unexcited


@pytest.mark.parametrize("check", list(CHECKS))
@pytest.mark.parametrize("method", estimators.names())
def test_common_check(method, check, drives):
    check_estimator(estimators.get(method), *drives, checks=(check,))


def test_check_catches_a_broken_estimator(drives):
    """The check is not vacuous: an estimator whose run disagrees with its step fails it."""
    from dataclasses import replace

    def bad_run(drive, config=None, seed=0, progress=None):
        res = _run(drive, config, seed, progress)
        res.table.loc[res.table.index[-1], "mu_front"] += 0.01
        return res

    with pytest.raises(AssertionError, match="stepping vs run: column mu_front"):
        check_estimator(replace(CONSTANT, run=bad_run), *drives, checks=("stepping",))
    narrow = replace(CONSTANT, prior_band=lambda c: (0.0, 5.0))
    with pytest.raises(AssertionError, match="narrower than 90 % of the prior band"):
        check_estimator(narrow, *drives, checks=("unexcited",))


def test_registry_rejects_unknown_method_by_name():
    with pytest.raises(ValueError, match="no-such-method"):
        estimators.get("no-such-method")
