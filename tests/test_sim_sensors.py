"""Sensor models: noise level, bias, quantisation step, output rate and delay."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.sim.sensors import SensorSpec, apply_sensor, apply_sensors, sensors_to_dict

T_TRUE = np.arange(0, 200.0 + 1e-9, 1e-3)


def test_noise_std_and_bias():
    rng = np.random.default_rng(0)
    x = np.zeros_like(T_TRUE)
    t_out = np.arange(0, 200.0, 0.01)
    y = apply_sensor(T_TRUE, x, t_out, SensorSpec(noise_std=0.2, bias=-0.05), rng)
    assert y.mean() == pytest.approx(-0.05, abs=3 * 0.2 / np.sqrt(len(y)))
    assert y.std() == pytest.approx(0.2, rel=0.03)


def test_quantisation_step():
    rng = np.random.default_rng(1)
    x = np.sin(T_TRUE)
    t_out = np.arange(0, 100.0, 0.01)
    y = apply_sensor(T_TRUE, x, t_out, SensorSpec(quantization=0.05), rng)
    np.testing.assert_allclose(y / 0.05, np.round(y / 0.05), atol=1e-9)
    assert np.abs(y - np.sin(t_out)).max() <= 0.025 + 1e-12
    assert len(np.unique(np.round(np.diff(np.unique(y)), 9))) == 1  # one step size


def test_output_rate_and_delay():
    rng = np.random.default_rng(2)
    x = 3.0 * T_TRUE  # a ramp: a delay d shows as an offset -3 d
    t_out = np.arange(1.0, 50.0, 1 / 25)
    y = apply_sensor(T_TRUE, x, t_out, SensorSpec(delay=0.04), rng)
    assert len(y) == len(t_out)
    np.testing.assert_allclose(y, 3.0 * (t_out - 0.04), atol=1e-9)


def test_delay_before_start_holds_first_value():
    rng = np.random.default_rng(3)
    y = apply_sensor(T_TRUE, 1.0 + T_TRUE, np.array([0.0, 0.01]), SensorSpec(delay=0.1), rng)
    np.testing.assert_allclose(y, 1.0)


def test_unmodelled_channels_are_exact_and_specs_serialise():
    rng = np.random.default_rng(4)
    out = apply_sensors(T_TRUE, {"a": np.cos(T_TRUE), "b": T_TRUE}, T_TRUE[::10],
                        {"a": SensorSpec(noise_std=0.1)}, rng)
    np.testing.assert_allclose(out["b"], T_TRUE[::10])
    assert np.std(out["a"] - np.cos(T_TRUE[::10])) > 0.05
    d = sensors_to_dict({"a": SensorSpec(noise_std=0.1, delay=0.02)})
    assert d == {"a": {"noise_std": 0.1, "bias": 0.0, "quantization": 0.0, "delay": 0.02, "drift": 0.0,
                       "scale": 1.0, "dropout_rate": 0.0, "dropout_duration": 0.0}}


@pytest.mark.parametrize("field", ["noise_std", "quantization", "delay"])
def test_negative_values_are_rejected_by_name(field):
    with pytest.raises(ValueError, match=field):
        SensorSpec(**{field: -1.0})
