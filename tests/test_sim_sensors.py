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


def test_drift_scale_and_dropouts_as_documented():
    rng = np.random.default_rng(5)
    t_out = np.arange(0.0, 10.0, 0.01)
    x = np.sin(T_TRUE)
    spec = SensorSpec(drift=0.02, scale=1.1, bias=0.3)
    y = apply_sensor(T_TRUE, x, t_out, spec, rng, dropouts=[(-1.0, 0.5), (2.0, 2.255)])
    want = 1.1 * np.sin(t_out) + 0.3 + 0.02 * t_out
    held = (t_out >= 2.0) & (t_out < 2.255)
    start = t_out < 0.5
    start[0] = False  # the first sample is always received
    np.testing.assert_allclose(y[~held & ~start], want[~held & ~start], atol=1e-12)
    np.testing.assert_allclose(y[held], want[np.searchsorted(t_out, 2.0) - 1], atol=1e-12)
    np.testing.assert_allclose(y[start], want[0], atol=1e-12)


def test_dropout_intervals_follow_their_rate_and_length():
    from roadgrip.sim.sensors import dropout_intervals

    iv = dropout_intervals(SensorSpec(dropout_rate=0.5, dropout_duration=0.2), 2000.0, np.random.default_rng(6))
    assert len(iv) == pytest.approx(1000, abs=4 * np.sqrt(1000))
    assert all(t1 - t0 == pytest.approx(0.2) for t0, t1 in iv) and all(0 <= t0 <= 2000.0 for t0, _ in iv)
    assert dropout_intervals(SensorSpec(), 100.0, np.random.default_rng(6)) == []


@pytest.mark.parametrize("kwargs", [{"scale": 0.0}, {"scale": np.nan}, {"drift": np.inf},
                                    {"dropout_rate": -0.1}, {"dropout_duration": -1.0}])
def test_bad_error_specs_are_refused_by_name(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        SensorSpec(**kwargs)
