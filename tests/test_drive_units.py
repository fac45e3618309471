"""Units and signs from kinematic consistency: valid drives pass, wrong units are named.

Two generated corpora of kinematically exact drives (single-track kinematics with
understeer, noisy sensors): valid drives with standstill, reversing, constant (held),
saturated and dropout segments, with and without a pose and wheel speeds, on a sedan
and a 1:10 car, must never be refused; the same drives with one channel in a wrong unit
or with a flipped sign (g, deg/s, degrees, km/h, rpm, time in ms; every sign) must be
refused naming that channel in at least 95 % of cases.
"""

from __future__ import annotations

import math
import os
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive, DriveValidationError
from roadgrip.drive_units import pair_ratios, unit_findings
from roadgrip.vehicle import PRESETS

_SCALE = int(os.environ.get("ROADGRIP_FUZZ_EXAMPLES", "0"))
WHEELS = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")


def _smooth_noise(rng, n: int, dt: float, corr: float) -> np.ndarray:
    """Unit-RMS noise smoothed over ``corr`` seconds."""
    k = max(int(corr / dt / 2), 1)
    g = np.exp(-0.5 * (np.arange(-3 * k, 3 * k + 1) / k) ** 2)
    z = np.convolve(rng.standard_normal(n + 6 * k), g, mode="valid")[:n]
    return z / max(float(np.std(z)), 1e-12)


def kinematic_drive(seed: int, *, vehicle: str = "sedan", duration: float = 60.0, dt: float = 0.02,
                    pose: bool = True, wheels: bool = True, segments: tuple[str, ...] = ()
                    ) -> pd.DataFrame:
    """A drive that obeys the kinematics exactly, plus sensor noise.

    ``segments`` (each a few seconds at a random place): ``'standstill'``, ``'reversing'``,
    ``'constant'`` (a channel held at one value), ``'saturated'`` (an accelerometer clipped),
    ``'dropout'`` (a channel reading 0).
    """
    rng = np.random.default_rng(seed)
    veh = PRESETS[vehicle]
    small = veh.wheelbase < 1.0
    n = int(duration / dt)
    t = np.arange(n) * dt
    v_lo, v_hi = (1.5, 5.0) if small else (6.0, 25.0)
    v = v_lo + (v_hi - v_lo) * 0.5 * (1 + np.tanh(_smooth_noise(rng, n, dt, 8.0)))
    for kind in segments:
        if kind in ("standstill", "reversing"):
            a = int(rng.integers(0, n // 2))
            b = min(n, a + int(rng.uniform(3.0, 10.0) / dt))
            w = np.zeros(n)
            w[a:b] = 1.0
            w = np.convolve(w, np.ones(int(1.5 / dt)) / int(1.5 / dt), mode="same")
            target = 0.0 if kind == "standstill" else -0.5 * v_lo - 1.0
            v = (1 - w) * v + w * target
    ay_max = (0.5 if small else 0.45) * GRAVITY
    delta = 0.08 * _smooth_noise(rng, n, dt, 1.5) * (0.3 if not small else 2.0)
    K = 0.002  # understeer [rad/(m/s²)]
    kappa = delta / (veh.wheelbase + K * v**2)
    kappa = np.clip(kappa, -ay_max / np.maximum(v**2, 1e-6), ay_max / np.maximum(v**2, 1e-6))
    delta = kappa * (veh.wheelbase + K * v**2)
    r = v * kappa
    ay = v * r
    ax = np.gradient(v, t)
    psi = np.cumsum(r) * dt
    x = np.cumsum(v * np.cos(psi)) * dt
    y = np.cumsum(v * np.sin(psi)) * dt
    scale = 0.3 if small else 1.0
    df = pd.DataFrame({
        "t": t, "ax": ax + 0.05 * rng.standard_normal(n), "ay": ay + 0.05 * rng.standard_normal(n),
        "yaw_rate": r + 0.002 * rng.standard_normal(n), "steer": delta + 0.0005 * rng.standard_normal(n),
        "vx": v + 0.03 * scale * rng.standard_normal(n),
    })
    if wheels:
        for c in WHEELS:
            df[c] = np.abs(v) / veh.wheel_radius + 0.05 * rng.standard_normal(n)
    if pose:
        df["x"] = x + 0.02 * scale * rng.standard_normal(n)
        df["y"] = y + 0.02 * scale * rng.standard_normal(n)
        df["psi"] = np.angle(np.exp(1j * (psi + 0.003 * rng.standard_normal(n))))
    for kind in segments:
        a = int(rng.integers(0, n - 10))
        b = min(n, a + int(rng.uniform(1.0, 15.0) / dt))
        chan = str(rng.choice([c for c in df.columns if c not in ("t", "x", "y", "psi")]))
        if kind == "constant":
            df.loc[a:b, chan] = float(df[chan].iloc[a])
        elif kind == "dropout":
            df.loc[a:b, chan] = 0.0
        elif kind == "saturated":
            c = str(rng.choice(["ax", "ay"]))
            lim = float(rng.uniform(0.3, 0.9)) * float(np.max(np.abs(df[c])))
            df[c] = np.clip(df[c], -lim, lim)
    return df


MISTAKES = {
    "ay in g": ("ay", 1 / GRAVITY), "ax in g": ("ax", 1 / GRAVITY),
    "yaw_rate in deg/s": ("yaw_rate", 180 / math.pi), "steer in degrees": ("steer", 180 / math.pi),
    "vx in km/h": ("vx", 3.6), "wheels in rpm": ("omega", 60 / (2 * math.pi)),
    "psi in degrees": ("psi", 180 / math.pi), "t in ms": ("t", 1000.0),
    "ay flipped": ("ay", -1.0), "ax flipped": ("ax", -1.0), "yaw_rate flipped": ("yaw_rate", -1.0),
    "steer flipped": ("steer", -1.0), "vx flipped": ("vx", -1.0), "psi flipped": ("psi", -1.0),
}  # fmt: skip


def _mistaken(df: pd.DataFrame, column: str, factor: float) -> pd.DataFrame:
    df = df.copy()
    cols = WHEELS if column == "omega" else (column,)
    for c in cols:
        if column == "psi" and factor != -1.0:
            df[c] = np.rad2deg(df[c])
        else:
            df[c] = df[c] * factor
    return df


def _settings(default: int) -> settings:
    return settings(max_examples=max(default, int(_SCALE * 0.02)) if _SCALE else default,
                    derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow])


@_settings(25)
@given(st.integers(0, 10**6), st.sampled_from(["sedan", "f1tenth", "suv"]), st.booleans(),
       st.booleans(), st.sampled_from([0.01, 0.02, 0.05]),
       st.lists(st.sampled_from(["standstill", "reversing", "constant", "saturated", "dropout"]),
                max_size=4))
def test_valid_drives_are_never_refused(seed, vehicle, pose, wheels, dt, segments):
    df = kinematic_drive(seed, vehicle=vehicle, pose=pose, wheels=wheels, dt=dt,
                         segments=tuple(segments), duration=40.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        Drive.from_frame(df, PRESETS[vehicle], source="valid")
    event("accepted")


@pytest.mark.parametrize("mistake", sorted(MISTAKES))
def test_wrong_unit_or_sign_is_named(mistake):
    """Each mistake over 8 drives (both cars, with and without pose/wheels where the
    mistake is visible without them): refused naming the column in >= 95 % overall; here
    per mistake at least 7 of 8."""
    column, factor = MISTAKES[mistake]
    named = 0
    cases = 0
    for seed in range(8):
        vehicle = ("sedan", "f1tenth")[seed % 2]
        pose = column == "psi" or seed % 4 < 3
        df = _mistaken(kinematic_drive(seed, vehicle=vehicle, pose=pose), column, factor)
        cases += 1
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            try:
                Drive.from_frame(df, PRESETS[vehicle], source="mistaken")
            except DriveValidationError as exc:
                name = "omega_*" if column == "omega" else column
                named += f"'{name}'" in str(exc) or f"{name} " in str(exc)
    assert named >= cases - 1, (mistake, named, cases)


def test_pair_ratios_are_one_on_exact_kinematics():
    df = kinematic_drive(3, pose=True, wheels=True)
    v = PRESETS["sedan"]
    got = {p.pair: p for p in pair_ratios(df, v.wheelbase, v.wheel_radius, (True, True, False, False))}
    for pair in ("A", "R", "V", "W"):
        assert got[pair].conclusive and got[pair].ratio == pytest.approx(1.0, abs=0.05), got[pair]
    assert got["S"].conclusive and 0.5 < got["S"].ratio <= 1.05  # understeer lowers it
    assert unit_findings(df, v.wheelbase, v.wheel_radius) == []


def test_short_or_quiet_drive_is_unverified_not_refused():
    df = kinematic_drive(4, duration=1.0)
    df["ay"] = df["ay"] / GRAVITY  # one second says nothing conclusive
    assert [f for f in unit_findings(df) if f.status == "wrong"] == []
    quiet = kinematic_drive(5)
    quiet[["ay", "yaw_rate", "steer"]] = 0.0
    quiet["ay"] = quiet["ay"] / GRAVITY
    assert unit_findings(quiet, 2.7) == []
