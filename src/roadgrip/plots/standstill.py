"""The speed below which an estimator takes no friction information from the slip angles.

Near standstill a slip angle is a ratio of two small speeds: at rest the front slip angle
equals the steering angle, and at walking pace a little lateral velocity gives tens of
degrees. The estimators leave those samples out (the GP-SSM filter below
``GPSSMConfig.min_speed``, the Kalman cascade below ``CascadeConfig.v_min``), and the
figures that show slip angles mask them with the same threshold, read from the run.
"""

from __future__ import annotations

from typing import Any

__all__ = ["SPEED_OPTION", "min_speed"]

SPEED_OPTION: dict[str, str] = {"gpssm": "min_speed", "cascade": "v_min"}
"""Method -> name of its ``Config`` option that holds the threshold [m/s]."""


def min_speed(result: Any) -> float:
    """The threshold [m/s] that ``result``'s run used: its ``meta['config']`` value, else the
    method's default.

    Parameters
    ----------
    result : EstimateResult
        A run of a method in :data:`SPEED_OPTION`.

    Examples
    --------
    >>> from roadgrip.estimators import EstimateResult
    >>> import pandas as pd
    >>> min_speed(EstimateResult("cascade", pd.DataFrame(), {"config": {"v_min": 2.0}}))
    2.0
    >>> min_speed(EstimateResult("gpssm", pd.DataFrame(), {}))
    0.5
    """
    from roadgrip.estimators import get

    if result.method not in SPEED_OPTION:
        raise ValueError(f"no standstill threshold for method {result.method!r}; "
                         f"known for {', '.join(SPEED_OPTION)}")
    option = SPEED_OPTION[result.method]
    value = (result.meta or {}).get("config", {}).get(option)
    return float(getattr(get(result.method).Config, option) if value is None else value)
