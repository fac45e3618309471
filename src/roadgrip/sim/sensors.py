r"""Sensor models applied to the true signals.

Each measured signal is

``y(t_k) = Q(x(t_k - delay) + bias + e_k)``,   ``e_k ~ N(0, noise_std²)`` i.i.d.,

with ``t_k = k / output_rate`` the output clock, ``x`` the true signal at the
internal rate (linearly interpolated at ``t_k - delay``, held at its first value
before ``t = 0``) and ``Q(y) = q round(y / q)`` a uniform quantiser of step ``q``
(none when ``q = 0``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["SensorSpec", "apply_sensor", "apply_sensors", "sensors_to_dict"]


@dataclass(frozen=True)
class SensorSpec:
    """One sensor channel.

    Attributes
    ----------
    noise_std : float
        Standard deviation of the white noise, in the signal's unit.
    bias : float
        Constant offset, in the signal's unit.
    quantization : float
        Quantisation step, in the signal's unit (0: none).
    delay : float
        Transport delay [s], ``>= 0``.
    """

    noise_std: float = 0.0
    bias: float = 0.0
    quantization: float = 0.0
    delay: float = 0.0

    def __post_init__(self) -> None:
        for name in ("noise_std", "quantization", "delay"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"sensor {name} must be finite and >= 0, got {v!r}")
        if not np.isfinite(self.bias):
            raise ValueError(f"sensor bias must be finite, got {self.bias!r}")


def apply_sensor(
    t_true: NDArray[np.float64],
    x_true: NDArray[np.float64],
    t_out: NDArray[np.float64],
    spec: SensorSpec,
    rng: np.random.Generator,
) -> NDArray[np.float64]:
    """Measure one true signal at the output times (module docstring).

    Parameters
    ----------
    t_true, x_true : ndarray, shape (n,)
        True signal on the internal clock.
    t_out : ndarray, shape (m,)
        Output clock [s].
    spec : SensorSpec
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (m,)
    """
    y = np.interp(t_out - spec.delay, t_true, x_true)
    noise = rng.standard_normal(t_out.shape)  # always drawn: streams do not depend on specs
    y = y + spec.bias + spec.noise_std * noise
    if spec.quantization > 0:
        y = spec.quantization * np.round(y / spec.quantization)
    return y


def apply_sensors(
    t_true: NDArray[np.float64],
    signals: dict[str, NDArray[np.float64]],
    t_out: NDArray[np.float64],
    specs: dict[str, SensorSpec],
    rng: np.random.Generator,
) -> dict[str, NDArray[np.float64]]:
    """Measure every signal of ``signals``; channels without a spec are sampled exactly."""
    out = {}
    for name, x in signals.items():
        out[name] = apply_sensor(t_true, x, t_out, specs.get(name, SensorSpec()), rng)
    return out


def sensors_to_dict(specs: dict[str, SensorSpec]) -> dict[str, Any]:
    """JSON form for ``meta.truth['sensors']``."""
    return {k: asdict(v) for k, v in specs.items()}
