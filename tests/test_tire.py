"""Tire friction models against their analytic properties and published values."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.tire import (
    BURCKHARDT_PUBLISHED_PEAKS,
    SURFACES,
    BrushTire,
    Burckhardt,
    LinearTire,
    MagicFormula,
    brush_force,
    get_surface,
    model_from_dict,
)

MF_CASES = [
    MagicFormula(B=10.0, C=1.9, D=1.0, E=0.97),
    MagicFormula(B=11.0, C=1.45, D=1.0, E=-0.2),
    MagicFormula(B=24.0, C=1.4, D=0.3, E=0.0),
    MagicFormula(B=5.0, C=2.0, D=0.3, E=1.0),
    *(s.lateral for s in SURFACES.values()),
]


@pytest.mark.parametrize("mf", MF_CASES, ids=str)
def test_magic_formula_slope_at_zero_is_bcd(mf):
    h = 1e-6
    fd = (mf.mu(h) - mf.mu(-h)) / (2 * h)
    assert fd == pytest.approx(mf.B * mf.C * mf.D, rel=1e-8)
    assert float(mf.dmu(0.0)) == pytest.approx(mf.B * mf.C * mf.D, rel=1e-12)
    assert mf.slope0() == pytest.approx(mf.B * mf.C * mf.D, rel=1e-12)


@pytest.mark.parametrize("mf", MF_CASES, ids=str)
def test_magic_formula_peak_is_d(mf):
    s = np.linspace(0.0, 1.5, 300001)
    mu = mf.mu(s)
    assert mu.max() == pytest.approx(mf.D, rel=1e-8)
    s_peak, mu_peak = mf.peak()
    assert mu_peak == mf.D
    assert float(mf.mu(s_peak)) == pytest.approx(mf.D, rel=1e-12)
    assert s_peak == pytest.approx(s[np.argmax(mu)], abs=2e-4)
    assert np.allclose(mf.mu(-s), -mu)  # odd


@pytest.mark.parametrize("mf", MF_CASES[:3], ids=str)
def test_magic_formula_derivative_matches_finite_difference(mf):
    s = np.linspace(-0.5, 0.5, 101)
    h = 1e-7
    assert np.allclose(mf.dmu(s), (mf.mu(s + h) - mf.mu(s - h)) / (2 * h), atol=1e-5)


def test_magic_formula_with_peak_scales():
    mf = MF_CASES[1].with_peak(0.4)
    assert mf.peak()[1] == 0.4
    assert float(mf.mu(mf.peak()[0])) == pytest.approx(0.4)


@pytest.mark.parametrize(("mu", "k"), [(1.0, 15.0), (0.3, 8.0), (0.1, 30.0)])
def test_brush_small_slip_slope_saturation_and_continuity(mu, k):
    b = BrushTire(mu_peak=mu, stiffness=k)
    h = 1e-7
    assert float(b.mu(h) - b.mu(-h)) / (2 * h) == pytest.approx(k, rel=1e-5)
    assert b.slope0() == k
    assert float(b.mu(0.0)) == 0.0 and np.isfinite(b.mu(0.0))
    s = np.linspace(-1.5, 1.5, 200001)
    f = b.mu(s)
    assert np.isfinite(f).all()
    assert np.abs(f).max() <= mu * (1 + 1e-12)
    assert f[-1] == pytest.approx(mu) and f[0] == pytest.approx(-mu)
    # saturates exactly at the sliding slip and stays there
    s_sl = b.slip_sliding
    assert s_sl == pytest.approx(np.arctan(3 * mu / k))
    assert float(b.mu(s_sl)) == pytest.approx(mu, rel=1e-9)
    assert np.allclose(f[s > s_sl], mu)
    # continuous: no jump anywhere on a fine grid
    assert np.abs(np.diff(f)).max() < 2 * k * (s[1] - s[0])
    assert b.peak() == (s_sl, mu)


def test_brush_force_scales_with_load():
    s = np.linspace(-0.3, 0.3, 61)
    f1 = brush_force(s, 1.0, 0.8, 12.0)
    f2 = brush_force(s, 4000.0, 0.8, 12.0)
    assert np.allclose(f2, 4000.0 * f1)
    assert np.abs(f2).max() <= 0.8 * 4000.0 * (1 + 1e-12)


@pytest.mark.parametrize("name", sorted(BURCKHARDT_PUBLISHED_PEAKS))
def test_burckhardt_presets_reproduce_published_peaks(name):
    bk = SURFACES[name].burckhardt
    s_pub, mu_pub = BURCKHARDT_PUBLISHED_PEAKS[name]
    s = np.linspace(0.0, 1.0, 1000001)
    mu = bk.mu(s)
    assert mu.max() == pytest.approx(mu_pub, abs=0.005)
    assert s[np.argmax(mu)] == pytest.approx(s_pub, abs=0.005)
    s_peak, mu_peak = bk.peak()
    assert s_peak == pytest.approx(s[np.argmax(mu)], abs=1e-5)
    assert mu_peak == pytest.approx(mu.max(), rel=1e-9)


def test_burckhardt_slope_and_with_peak():
    bk = Burckhardt(1.2801, 23.99, 0.52)
    h = 1e-7
    assert float(bk.mu(h) - bk.mu(-h)) / (2 * h) == pytest.approx(bk.slope0(), rel=1e-5)
    scaled = bk.with_peak(0.6)
    assert scaled.peak()[1] == pytest.approx(0.6)
    assert scaled.peak()[0] == pytest.approx(bk.peak()[0])


def test_linear_tire():
    lt = LinearTire(stiffness=12.0)
    s = np.linspace(-0.2, 0.2, 9)
    assert np.array_equal(lt.mu(s), 12.0 * s)
    assert lt.slope0() == 12.0
    clipped = LinearTire(stiffness=12.0, mu_max=0.5)
    assert clipped.mu(1.0) == 0.5 and clipped.mu(-1.0) == -0.5
    assert clipped.peak() == pytest.approx((0.5 / 12.0, 0.5))


@pytest.mark.parametrize(
    "model",
    [MagicFormula(10.0, 1.9, 1.0, 0.97), BrushTire(0.7, 10.0), Burckhardt(0.857, 33.822, 0.347),
     LinearTire(9.0, 0.8)],
    ids=lambda m: type(m).__name__,
)
def test_dict_round_trip(model):
    assert model_from_dict(model.to_dict()) == model


def test_bad_parameters_and_names():
    with pytest.raises(ValueError, match="B must be positive"):
        MagicFormula(B=-1.0, C=1.5, D=1.0)
    with pytest.raises(ValueError, match="E must be finite and <= 1"):
        MagicFormula(B=1.0, C=1.5, D=1.0, E=2.0)
    with pytest.raises(ValueError, match="unknown tire model 'pacejka96'"):
        model_from_dict({"model": "pacejka96"})
    with pytest.raises(ValueError, match="bad parameters for tire model 'brush'"):
        model_from_dict({"model": "brush", "mu_peak": 1.0})
    with pytest.raises(ValueError, match="unknown surface 'lava'"):
        get_surface("lava")


def test_surface_presets_are_ordered_by_grip():
    order = ["dry_asphalt", "wet_asphalt", "gravel", "snow", "ice"]
    peaks = [SURFACES[n].lateral.peak()[1] for n in order]
    assert peaks == sorted(peaks, reverse=True)
    for n in order:
        assert SURFACES[n].mu_peak == pytest.approx(SURFACES[n].lateral.D)
