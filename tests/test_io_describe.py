"""describe_drive and the nonlinear-excitation measures behind `roadgrip info`."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from rich.console import Console

from roadgrip.cli.info import render
from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.io import describe_drive, nonlinear_fraction, slip_at_fraction_of_peak
from roadgrip.io.describe import format_text, linear_yaw_rate
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
    console.print(render(describe_drive(d)))
    text = console.export_text()
    assert "duration" in text and "39.96 s" in text
    assert "25.00 Hz" in text and "jitter" in text
    assert "my_extra" in text
    assert "truth" in text and "yes" in text
    assert "25.0%" in text  # truth excitation fraction
    assert "alpha_f_true" in text and "rad" in text
    assert "snow 100%" in text
    plain = format_text(describe_drive(d))  # the same tables as plain text
    assert "39.96 s" in plain and "25.0%" in plain and "snow 100%" in plain
    assert "│" not in plain


@pytest.mark.slow
def test_simulated_scenarios_excitation():
    from roadgrip.sim import scenarios as scen

    slalom = nonlinear_fraction(scen.simulate_scenario("snow-slalom", seed=0))[0]
    cruise = nonlinear_fraction(scen.simulate_scenario("straight-cruise", seed=0))[0]
    assert slalom.method == cruise.method == "truth"
    assert slalom.fraction >= 0.15
    assert cruise.fraction < 0.02


# -- friction utilisation, and drives whose truth is binned --------------------------------
def _binned_truth_drive(util_columns: bool) -> Drive:
    """Ten samples; front utilisation given or computed, rear always computed from forces.

    Front: 0.1 0.2 0.55 0.6 0.7 0.81 0.9 0.95 0.3 0.4 -> 6/10 above 0.5, 3/10 above 0.8.
    Rear (mu 0.5, Fz 1000 N, so |F| / 500 N): 1.0, 0.4, 0.8 (not above), 0.9, 0.2, ... and
    one lifted sample (Fz = 0), left out.
    """
    u_f = np.array([0.1, 0.2, 0.55, 0.6, 0.7, 0.81, 0.9, 0.95, 0.3, 0.4])
    fzf = np.full(10, 2000.0)
    mu = np.full(10, 0.5)
    # front forces that give u_f: |F| = u mu Fz, split 3:4 between x and y
    ff = u_f * mu * fzf
    fxr = np.array([300.0, 0.0, 240.0, 0.0, 100.0, 0.0, 0.0, 0.0, 0.0, 50.0])
    fyr = np.array([400.0, 200.0, 320.0, 450.0, 0.0, 260.0, 280.0, 420.0, 350.0, 0.0])
    fzr = np.array([1000.0] * 9 + [0.0])
    df = pd.DataFrame({"t": np.arange(10) * 0.1, "alpha_f_true": 0.0, "alpha_r_true": 0.0,
                       "Fxf_true": 0.6 * ff, "Fyf_true": 0.8 * ff, "Fzf_true": fzf,
                       "Fxr_true": fxr, "Fyr_true": fyr, "Fzr_true": fzr, "mu_true": mu,
                       "surface": "ice"})
    if util_columns:
        # the column wins over the forces: make the forces disagree to show it
        df["util_f_true"] = u_f
        df["Fxf_true"] = 0.0
    truth = {"model": "multibody", "truth_curve": "binned", "surfaces": {"ice": {"mu": 0.5}}}
    return Drive.from_frame(df, SEDAN, source="sim:test", truth=truth, check_units=False)


@pytest.mark.parametrize("util_columns", [True, False])
def test_utilisation_shares_from_columns_or_forces(util_columns):
    from roadgrip.io.describe import utilisation_shares

    front, rear = utilisation_shares(_binned_truth_drive(util_columns))
    assert front.source == ("column" if util_columns else "computed") and rear.source == "computed"
    assert front.above == pytest.approx({0.5: 0.6, 0.8: 0.3})
    assert front.defined == 1.0
    # rear |F| / 500 N over the nine loaded samples: 1.0 0.4 0.8 0.9 0.2 0.52 0.56 0.84 0.7
    assert rear.above == pytest.approx({0.5: 7 / 9, 0.8: 3 / 9})  # 0.8 itself is not above
    assert rear.defined == pytest.approx(0.9)


def test_no_utilisation_without_the_truth_columns():
    from roadgrip.io.describe import utilisation_shares

    assert utilisation_shares(_truth_drive(0.2)) == []


def test_binned_truth_excitation_is_the_front_utilisation():
    exc = nonlinear_fraction(_binned_truth_drive(True))
    assert exc[0].method == "truth"
    assert exc[0].fraction == pytest.approx(0.3)  # 0.81, 0.9, 0.95
    assert "utilisation" in exc[0].detail and "no parametric tire curve" in exc[0].detail
    # neither a parametric curve nor a utilisation: skipped, with the reason
    d = _binned_truth_drive(False)
    bare = Drive.from_frame(d.data.drop(columns=["mu_true"]), SEDAN, truth=d.meta.truth,
                            check_units=False)
    e = nonlinear_fraction(bare)[0]
    assert e.method == "truth" and np.isnan(e.fraction) and e.detail.startswith("skipped:")


def test_describe_reports_utilisation_on_a_binned_truth_drive():
    console = Console(record=True, width=220)
    console.print(render(describe_drive(_binned_truth_drive(False))))
    text = console.export_text()
    assert "friction utilisation" in text and "time > 50%" in text and "time > 80%" in text
    front = next(ln for ln in text.splitlines() if ln.startswith("│ front"))
    assert "60.0%" in front and "30.0%" in front and "hypot(Fxf, Fyf)" in front
    rear = next(ln for ln in text.splitlines() if ln.startswith("│ rear"))
    assert "77.8%" in rear and "33.3%" in rear and "defined at 90.0%" in rear
    assert "skipped" not in text and "30.0%" in text
