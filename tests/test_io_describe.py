"""describe_drive and the nonlinear-excitation measures behind `roadgrip info`."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from rich.console import Console

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.io import describe_drive, nonlinear_fraction, slip_at_fraction_of_peak
from roadgrip.io.describe import linear_yaw_rate
from roadgrip.tire import SURFACES, Burckhardt, LinearTire, MagicFormula
from roadgrip.vehicle import PRESETS, lateral_derivatives, slip_angles, steady_state_linear

SEDAN = PRESETS["sedan"]


@pytest.mark.parametrize(
    "model",
    [MagicFormula(10.0, 1.9, 1.0, 0.97), SURFACES["snow"].lateral, Burckhardt(1.2801, 23.99, 0.52),
     LinearTire(10.0, 0.5)],
    ids=lambda m: type(m).__name__,
)
def test_slip_at_fraction_of_peak(model):
    s80 = slip_at_fraction_of_peak(model, 0.8)
    s_peak, mu_peak = model.peak()
    assert float(model.mu(s80)) == pytest.approx(0.8 * mu_peak, rel=1e-9)
    assert 0 < s80 < s_peak
    grid = np.linspace(0, s80, 1001)[:-1]
    assert np.all(model.mu(grid) < 0.8 * mu_peak)  # the smallest such slip


def test_linear_tire_without_saturation_never_reaches_80_percent_of_an_infinite_peak():
    assert slip_at_fraction_of_peak(LinearTire(10.0), 0.8) == float("inf")


def test_linear_yaw_rate_steady_state_and_transient():
    t = np.arange(0, 20, 0.01)
    vx = np.full_like(t, 20.0)
    steer = np.full_like(t, 0.01)
    r = linear_yaw_rate(t, steer, vx, SEDAN)
    assert r[-1] == pytest.approx(float(steady_state_linear(0.01, 20.0, SEDAN)), rel=1e-6)
    # transient: against RK4 of paper 000 eq. 1 with linear tires and linearised slip
    t, vx = t[:600], vx[:600]
    steer = 0.02 * np.sin(2 * np.pi * 0.5 * t)
    r = linear_yaw_rate(t, steer, vx, SEDAN)
    tf = LinearTire(SEDAN.cornering_stiffness_front / SEDAN.fz_front)
    tr = LinearTire(SEDAN.cornering_stiffness_rear / SEDAN.fz_rear)

    def f(x, d):
        af, ar = slip_angles(20.0, x[0], x[1], d, SEDAN, exact=False, v_eps=0.0)
        return lateral_derivatives(x, np.array([d, 20.0]), tf.mu(af), tr.mu(ar), SEDAN)

    x = np.zeros(2)
    ref = np.zeros_like(t)
    h = 0.002
    for k in range(1, len(t)):
        for j in range(5):
            tt = t[k - 1] + j * h
            d0, dh, d1 = (0.02 * np.sin(2 * np.pi * 0.5 * v) for v in (tt, tt + h / 2, tt + h))
            k1 = f(x, d0)
            k2 = f(x + h / 2 * k1, dh)
            k3 = f(x + h / 2 * k2, dh)
            k4 = f(x + h * k3, d1)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        ref[k] = x[1]
    amp = np.abs(ref).max()
    assert np.abs(r - ref).max() < 0.05 * amp  # implicit Euler at 100 Hz: a few % of amplitude


def _truth_drive(frac_beyond: float, n: int = 1000, seed: int = 0) -> Drive:
    rng = np.random.default_rng(seed)
    snow = SURFACES["snow"]
    a80 = slip_at_fraction_of_peak(snow.lateral, 0.8)
    k = int(frac_beyond * n)
    mag = np.r_[rng.uniform(1.05, 3.0, k) * a80, rng.uniform(0.0, 0.95, n - k) * a80]
    alpha = rng.permutation(mag) * rng.choice([-1.0, 1.0], n)
    df = pd.DataFrame({"t": np.arange(n) * 0.04, "alpha_f_true": alpha, "surface": "snow"})
    truth = {"surfaces": {"snow": {"front": snow.lateral.to_dict(), "rear": snow.lateral.to_dict(),
                                   "front_long": snow.longitudinal.to_dict(),
                                   "rear_long": snow.longitudinal.to_dict(), "mu": 0.3}}}
    return Drive.from_frame(df, PRESETS["suv"], source="test", truth=truth)


@pytest.mark.parametrize("frac", [0.0, 0.17, 0.5])
def test_truth_fraction_is_exact(frac):
    exc = nonlinear_fraction(_truth_drive(frac))
    assert exc[0].method == "truth"
    assert exc[0].fraction == pytest.approx(frac, abs=1e-12)


def test_truth_fraction_per_surface():
    d = _truth_drive(0.3)
    # relabel half of the samples as dry asphalt, whose a80 is far larger than snow's
    surf = np.where(np.arange(d.n) < d.n // 2, "snow", "dry_asphalt")
    dry = SURFACES["dry_asphalt"]
    truth = dict(d.meta.truth)
    truth["surfaces"] = dict(truth["surfaces"]) | {"dry_asphalt": {
        "front": dry.lateral.to_dict(), "rear": dry.lateral.to_dict(),
        "front_long": dry.longitudinal.to_dict(), "rear_long": dry.longitudinal.to_dict(), "mu": 1.0}}
    d2 = Drive.from_frame(d.data.assign(surface=surf), d.vehicle, truth=truth)
    a80_dry = slip_at_fraction_of_peak(dry.lateral, 0.8)
    alpha = np.abs(d.col("alpha_f_true"))
    expected = np.mean(np.where(surf == "snow", alpha > slip_at_fraction_of_peak(SURFACES["snow"].lateral),
                                alpha > a80_dry))
    assert nonlinear_fraction(d2)[0].fraction == pytest.approx(expected)


def test_ay_proxy():
    n = 2000
    t = np.arange(n) * 0.01
    ay = np.where((t > 5) & (t < 9), 0.7 * GRAVITY, 0.2 * GRAVITY)  # 4 s of 20 s above 0.5 g
    d = Drive.from_frame(pd.DataFrame({"t": t, "ay": ay}), SEDAN)
    (e,) = nonlinear_fraction(d)
    assert e.method == "ay"
    assert e.fraction == pytest.approx(0.2, abs=0.005)  # edges softened by the 0.2 s smoothing
    (e,) = nonlinear_fraction(d, mu_peak=0.3)  # 0.2 g is above 50 % of 0.3
    assert e.fraction == 1.0


def test_yaw_proxy_zero_on_linear_model_and_counts_departures():
    t = np.arange(0, 40, 0.01)
    vx = np.full_like(t, 20.0)
    steer = 0.02 * np.sin(2 * np.pi * 0.2 * t)
    r = linear_yaw_rate(t, steer, vx, SEDAN)
    df = pd.DataFrame({"t": t, "yaw_rate": r, "steer": steer, "vx": vx})
    e = {x.method: x for x in nonlinear_fraction(Drive.from_frame(df, SEDAN))}["yaw"]
    assert e.fraction == 0.0
    # the yaw rate saturates at 60 % of the linear one beyond a threshold
    cap = 0.6 * np.abs(r).max()
    r_sat = np.clip(r, -cap, cap)
    sel = (np.abs(r) > 0.1)
    expected = np.mean(np.abs(r_sat[sel] - r[sel]) > 0.25 * np.abs(r[sel]))
    e = {x.method: x for x in nonlinear_fraction(Drive.from_frame(df.assign(yaw_rate=r_sat), SEDAN))}["yaw"]
    assert expected > 0.2
    assert e.fraction == pytest.approx(expected, abs=0.02)


def test_describe_renders_everything(tmp_path):
    d = _truth_drive(0.25)
    d = Drive(d.data.assign(vx=10.0, my_extra=1.5), d.meta)
    console = Console(record=True, width=200)
    console.print(describe_drive(d))
    text = console.export_text()
    assert "duration" in text and "39.96 s" in text
    assert "25.00 Hz" in text and "jitter" in text
    assert "my_extra" in text
    assert "truth" in text and "yes" in text
    assert "25.0%" in text  # truth excitation fraction
    assert "alpha_f_true" in text and "rad" in text
    assert "snow 100%" in text


@pytest.mark.slow
def test_simulated_scenarios_excitation():
    scen = pytest.importorskip("roadgrip.sim.scenarios", reason="simulator not available")
    slalom = nonlinear_fraction(scen.simulate_scenario("snow-slalom", seed=0))[0]
    cruise = nonlinear_fraction(scen.simulate_scenario("straight-cruise", seed=0))[0]
    assert slalom.method == cruise.method == "truth"
    assert slalom.fraction >= 0.15
    assert cruise.fraction < 0.02
